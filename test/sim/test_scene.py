"""Scene files: the default scene loads; every kind of bad file is refused naming the field."""
import copy
import math

from px100_control.errors import InvalidInputError
from px100_control.models.registry import load_robot
from px100_control.perception.camera import CameraSpec
from px100_control.sim.scene import available_scenes, load_scene, parse_scene, reach_margin
import pytest
import yaml


@pytest.fixture(scope='module')
def px100():
    return load_robot('px100')


@pytest.fixture(scope='module')
def raw():
    scene = load_scene('pick_place')
    with open(scene.path, encoding='utf-8') as f:
        return yaml.safe_load(f)


def test_default_scene_loads_with_objects_in_reach(px100):
    """pick_place: a table, fixtures and three 25-30 mm, 30 g objects the PX100 reaches."""
    assert 'pick_place' in available_scenes()
    scene = load_scene('pick_place', px100)
    kinds = [b.kind for b in scene.bodies]
    assert kinds.count('table') == 1 and kinds.count('fixture') >= 2
    assert len(scene.objects) == 3
    assert len({b.rgba for b in scene.objects}) == 3
    for b in scene.objects:
        assert b.mass == pytest.approx(0.03)
        width = b.size[0] if b.shape == 'box' else 2 * b.size[0]
        assert 0.025 <= width <= 0.030
        assert reach_margin(px100, b.position) > 0.05


def test_every_scene_file_loads(px100):
    """Every file in config/scenes is valid for the PX100."""
    for name in available_scenes():
        assert load_scene(name, px100).bodies


def _mutate(raw, path, value):
    data = copy.deepcopy(raw)
    node = data
    for key in path[:-1]:
        node = node[key]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return data


@pytest.mark.parametrize('path, value, words', [
    (('objects', 0, 'colour'), [1, 0, 0, 1], 'unknown key.*colour'),
    (('lighting',), 'dim', 'unknown key.*lighting'),
    (('objects', 0, 'size'), [0.03, math.nan, 0.03], r'objects\[0\] \(red_cube\).size.*NaN'),
    (('objects', 1, 'mass'), 0.0, r'green_cube\).mass must be positive'),
    (('objects', 1, 'mass'), KeyError, r'green_cube\).mass is missing'),
    (('objects', 2, 'size'), [-0.01, 0.03], r'blue_cylinder\).size must be positive'),
    (('objects', 2, 'size'), [0.01, 0.02, 0.03], r'blue_cylinder\).size needs 2 values'),
    (('objects', 0, 'shape'), 'cone', r'red_cube\).shape must be one of'),
    (('objects', 0, 'rgba'), [1, 0, 0, 2], r'red_cube\).rgba values must be in 0..1'),
    (('objects', 0, 'position'), [0.2, 0.0], r'red_cube\).position needs 3 values'),
    (('objects', 0, 'position'), 'here', r'red_cube\).position must be a list'),
    (('objects', 1, 'name'), 'red_cube', "duplicate body name 'red_cube'"),
    (('objects', 1, 'name'), 'green cube', 'name must be an identifier'),
    (('objects', 1, 'position'), [0.18, -0.055, 0.014], "'red_cube' and 'green_cube' overlap"),
    (('objects', 0, 'position'), [0.12, 0.17, 0.03], "'pedestal' and 'red_cube' overlap"),
    (('fixtures', 0, 'mass'), 1.0, r'pedestal\).mass: a fixture is static'),
    (('table', 'shape'), 'sphere', r"table \(table\).shape must be one of \['box'\]"),
])
def test_bad_scene_is_refused_naming_the_field(raw, px100, path, value, words):
    """Unknown keys, NaN, non-positive sizes/masses, overlaps: InvalidInputError with the field."""
    with pytest.raises(InvalidInputError, match=words):
        parse_scene(_mutate(raw, path, value), 'pick_place.yaml', px100)


def test_object_out_of_reach_is_refused(raw, px100):
    """An object 0.6 m away is refused with its name, the robot and the distance."""
    data = _mutate(raw, ('objects', 0, 'position'), [0.6, 0.0, 0.014])
    with pytest.raises(InvalidInputError, match="'red_cube'.position.*out of reach.*px100"):
        parse_scene(data, 'pick_place.yaml', px100)
    parse_scene(data, 'pick_place.yaml')          # without a robot there is no reach check


def test_unknown_and_broken_files(tmp_path):
    """Unknown scene names, missing paths, invalid YAML and non-mapping files are refused."""
    with pytest.raises(InvalidInputError, match="unknown scene 'no_such_scene'.*pick_place"):
        load_scene('no_such_scene')
    with pytest.raises(InvalidInputError, match='unknown scene'):
        load_scene(str(tmp_path / 'missing.yaml'))
    bad = tmp_path / 'bad.yaml'
    bad.write_text('objects: [\n')
    with pytest.raises(InvalidInputError, match='not valid YAML'):
        load_scene(str(bad))
    bad.write_text('- 1\n- 2\n')
    with pytest.raises(InvalidInputError, match='must be a mapping'):
        load_scene(str(bad))


def test_every_wrong_field_is_named_one_line_each(raw, px100):
    """Three wrong fields in two bodies and an unknown top key: all four named, one per line."""
    data = _mutate(raw, ('objects', 0, 'size'), [0.03, math.nan, 0.03])
    data = _mutate(data, ('objects', 1, 'mass'), 0.0)
    data = _mutate(data, ('objects', 1, 'rgba'), [1, 0, 0, 2])
    data = _mutate(data, ('lighting',), 'dim')
    with pytest.raises(InvalidInputError) as err:
        parse_scene(data, 'pick_place.yaml', px100)
    lines = str(err.value).splitlines()
    assert lines[0] == 'scene pick_place.yaml: 4 problems:', lines
    for words in ("unknown key(s) ['lighting']", 'objects[0] (red_cube).size contains NaN',
                  'objects[1] (green_cube).mass must be positive',
                  'objects[1] (green_cube).rgba values must be in 0..1'):
        assert sum(words in line for line in lines[1:]) == 1, (words, lines)
    assert len(lines) == 5


def test_bad_yaml_is_one_line(tmp_path):
    """A YAML syntax error is named with its line and column, on one line."""
    bad = tmp_path / 'bad.yaml'
    bad.write_text('objects:\n  - {name: a, size: [0.02\n')
    with pytest.raises(InvalidInputError) as err:
        load_scene(str(bad))
    assert len(str(err.value).splitlines()) == 1, str(err.value)
    assert 'not valid YAML at line' in str(err.value)


def test_scene_camera_block(raw, px100):
    """pick_place has the D415 camera; a scene without the block has none; wrong fields named."""
    assert load_scene('pick_place', px100).camera == CameraSpec(fovy=0.743365)
    data = copy.deepcopy(raw)
    del data['camera']
    assert parse_scene(data, 'pick_place.yaml').camera is None
    data['camera'] = {'position': [0.1, math.nan, 0.6], 'width': 8, 'rate': 0.0, 'zoom': 2}
    with pytest.raises(InvalidInputError, match=r"camera: unknown key\(s\) \['zoom'\]"):
        parse_scene(data, 'pick_place.yaml')
    del data['camera']['zoom']
    with pytest.raises(InvalidInputError, match=r'camera: position contains NaN.*width and '
                                                r'height must be 16..4096.*rate must be'):
        parse_scene(data, 'pick_place.yaml')
    data['camera'] = {'width': 640.5}
    with pytest.raises(InvalidInputError, match='width must be an integer'):
        parse_scene(data, 'pick_place.yaml')
