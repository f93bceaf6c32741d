"""
The interface packages this project builds are the upstream types: same RIHS01 type hashes.

The generated hashes are read from each package's installed type description (``share/<pkg>/
<msg|srv|action>/<Name>.json``, found through the ament index, so a user's own apt-installed
packages are checked the same way); the expected ones are in upstream_type_hashes.yaml.
"""
import json
import os

from ament_index_python.packages import get_package_share_directory
import pytest
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
with open(os.path.join(HERE, 'upstream_type_hashes.yaml')) as f:
    EXPECTED = yaml.safe_load(f)


def _generated_hash(type_name: str) -> str:
    """Return the RIHS01 hash the installed package gives ``pkg/kind/Name[_Part]``."""
    pkg, kind, name = type_name.split('/')
    base = name
    for suffix in ('_Request', '_Response', '_Goal', '_Result', '_Feedback'):
        if kind in ('srv', 'action') and name.endswith(suffix):
            base = name[:-len(suffix)]
    path = os.path.join(get_package_share_directory(pkg), kind, base + '.json')
    with open(path) as f:
        hashes = {h['type_name']: h['hash_string'] for h in json.load(f)['type_hashes']}
    return hashes[type_name]


@pytest.mark.parametrize('type_name', sorted(EXPECTED))
def test_type_hash_matches_upstream(type_name):
    assert _generated_hash(type_name) == EXPECTED[type_name], type_name


def test_expected_hashes_agree_with_an_independent_store():
    """The file's tf2_msgs entries are what rosbags' own Jazzy store computes."""
    typesys = pytest.importorskip('rosbags.typesys')
    store = typesys.get_typestore(typesys.Stores.ROS2_JAZZY)
    for name in ('tf2_msgs/msg/TFMessage', 'tf2_msgs/msg/TF2Error'):
        assert store.hash_rihs01(name) == EXPECTED[name]


def test_every_interface_built_here_is_covered():
    """Each upstream package in interfaces/ has each of its types in the expected file."""
    root = os.path.dirname(os.path.dirname(HERE))
    for pkg in ('interbotix_xs_msgs', 'interbotix_perception_msgs', 'control_msgs', 'tf2_msgs'):
        for kind in ('msg', 'srv', 'action'):
            folder = os.path.join(root, 'interfaces', pkg, kind)
            for fname in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
                stem = fname.rsplit('.', 1)[0]
                parts = {'msg': [''], 'srv': ['_Request', '_Response'],
                         'action': ['_Goal', '_Result', '_Feedback']}[kind]
                for part in parts:
                    assert f'{pkg}/{kind}/{stem}{part}' in EXPECTED, (pkg, fname)
