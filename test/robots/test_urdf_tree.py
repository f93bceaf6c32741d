"""
The URDF tree cache (px100_control/models/urdf_tree.py): what yourdfpy parses, without yourdfpy.

Every registered robot's URDF gives the same joints and inertials from yourdfpy, from a cold
cache and from a warm one; a process with a warm cache imports neither yourdfpy nor trimesh; a
broken, foreign or unwritable cache costs only the parse; a URDF yourdfpy refuses is refused and
nothing is stored.
"""
import json
import os
import subprocess
import sys

import numpy as np
from px100_control.errors import RobotModelError
from px100_control.models.registry import available_robots, load_robot
from px100_control.models.urdf_chain import load_urdf
from px100_control.models.urdf_tree import cache_key, load_urdf_tree
import pytest
from tiers import robots


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """Point the cache at an empty folder; clear the in-process memo before and after."""
    monkeypatch.setenv('PX100_CACHE_DIR', str(tmp_path / 'cache'))
    load_urdf_tree.cache_clear()
    yield tmp_path / 'cache'
    load_urdf_tree.cache_clear()


def _same(a, b):
    """Assert two values of a joint/link field are equal (arrays exactly)."""
    if a is None or b is None:
        assert a is None and b is None
    elif isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        np.testing.assert_array_equal(np.asarray(a, float), np.asarray(b, float))
    else:
        assert a == b and type(a) is type(b), (a, b)


def _assert_tree_is(tree, urdf):
    """Assert a UrdfTree holds every field this package reads from the yourdfpy URDF."""
    assert tree.robot.name == urdf.robot.name
    assert [j.name for j in tree.robot.joints] == [j.name for j in urdf.robot.joints]
    for ours, theirs in zip(tree.robot.joints, urdf.robot.joints):
        for field in ('type', 'parent', 'child', 'origin', 'axis'):
            _same(getattr(ours, field), getattr(theirs, field))
        for part, fields in (('limit', ('effort', 'velocity', 'lower', 'upper')),
                             ('dynamics', ('damping', 'friction')),
                             ('mimic', ('joint', 'multiplier', 'offset'))):
            a, b = getattr(ours, part), getattr(theirs, part)
            assert (a is None) == (b is None), (ours.name, part)
            for field in fields if a is not None else ():
                _same(getattr(a, field), getattr(b, field))
    assert [k.name for k in tree.robot.links] == [k.name for k in urdf.robot.links]
    for ours, theirs in zip(tree.robot.links, urdf.robot.links):
        assert (ours.inertial is None) == (theirs.inertial is None), ours.name
        if ours.inertial is not None:
            for field in ('origin', 'mass', 'inertia'):
                _same(getattr(ours.inertial, field), getattr(theirs.inertial, field))


@pytest.mark.parametrize('name', robots(available_robots()))
def test_cold_and_warm_trees_equal_yourdfpy(name, cache):
    """Parsed (and stored), then read back in a fresh memo: both equal yourdfpy's fields."""
    xml = load_robot(name).urdf_xml
    urdf = load_urdf(xml)
    cold = load_urdf_tree(xml)
    _assert_tree_is(cold, urdf)
    assert (cache / 'urdf' / f'{cache_key(xml)}.json').is_file()
    load_urdf_tree.cache_clear()
    warm = load_urdf_tree(xml)
    assert warm is not cold
    _assert_tree_is(warm, urdf)


def test_arrays_of_a_shared_tree_are_read_only(cache):
    """A caller cannot change the tree every other caller gets."""
    joint = load_urdf_tree(load_robot('px100').urdf_xml).robot.joints[1]
    with pytest.raises(ValueError):
        joint.origin[0, 3] = 1.0


_LOAD = ('import sys; from px100_control.models.registry import load_robot; '
         "load_robot('px100'); print(sorted(m for m in ('yourdfpy', 'trimesh') "
         'if m in sys.modules))')


def test_a_warm_cache_spares_a_process_yourdfpy(tmp_path):
    """The first process parses (imports yourdfpy) and stores; the next imports neither."""
    env = dict(os.environ, PX100_CACHE_DIR=str(tmp_path / 'cache'))
    runs = [subprocess.run([sys.executable, '-c', _LOAD], env=env, capture_output=True,
                           text=True, timeout=120) for _ in range(2)]
    for run in runs:
        assert run.returncode == 0, run.stderr
    assert runs[0].stdout.split() == ["['trimesh',", "'yourdfpy']"]
    assert runs[1].stdout.strip() == '[]'


@pytest.mark.parametrize('content', ['{"key": "another", "urdf": {}}', '{not json', '[]',
                                     '{"key": "KEY", "urdf": {"name": "x"}}'])
def test_a_broken_or_foreign_cache_file_is_parsed_again_and_replaced(cache, content):
    """Garbage, another key or a truncated layout: the URDF is parsed and the file rewritten."""
    xml = load_robot('px100').urdf_xml
    path = cache / 'urdf' / f'{cache_key(xml)}.json'
    path.parent.mkdir(parents=True)
    path.write_text(content.replace('KEY', cache_key(xml)))
    _assert_tree_is(load_urdf_tree(xml), load_urdf(xml))
    assert json.loads(path.read_text())['key'] == cache_key(xml)


def test_an_unwritable_or_disabled_cache_only_costs_the_parse(tmp_path, monkeypatch):
    """A cache 'folder' that is a file, and PX100_CACHE_DIR='' (off): trees, no files."""
    xml = load_robot('px100').urdf_xml
    blocker = tmp_path / 'a_file'
    blocker.write_text('')
    for value in (str(blocker), ''):
        monkeypatch.setenv('PX100_CACHE_DIR', value)
        load_urdf_tree.cache_clear()
        _assert_tree_is(load_urdf_tree(xml), load_urdf(xml))
    assert sorted(os.listdir(tmp_path)) == ['a_file']
    load_urdf_tree.cache_clear()


def test_a_urdf_yourdfpy_refuses_is_refused_and_not_stored(cache):
    """The parse error names the problem as before; no cache file appears."""
    with pytest.raises(RobotModelError, match='cannot parse URDF'):
        load_urdf_tree('<robot name="x"><joint name="j" type="revolute"></robot>')
    assert not (cache / 'urdf').exists() or not os.listdir(cache / 'urdf')


def test_another_urdf_text_has_another_key():
    """One character of the text changes the file it is stored in."""
    xml = load_robot('px100').urdf_xml
    assert cache_key(xml) != cache_key(xml.replace('0.04225', '0.04226'))
