"""
The architecture, checked on the source with ast (so it also holds on a machine without ROS).

- The pure layers (wire, kinematics, models, control, sim, bag, viewer, perception) import no
  rclpy, *_msgs package or builtin_interfaces.
- Layer order of the packages, lowest first: errors/paths/parameters (the parameter schemas:
  data the engines check against and the nodes declare), wire, kinematics, models, then
  control / bag / tools / perception (the camera model and the cloud filter), then sim (the
  simulated plant: it runs control's PID, servo and gripper models, and renders the camera) /
  viewer (it plays bags), then ros, then client. A module imports only from its own package or
  from a package of a strictly lower rank (two packages of one rank do not import each other).
- No import cycles, between modules nor between packages.
- Imports sit at the top of a module (project, standard library, third-party and ROS alike);
  one inside a function must say why on its line (``# optional: why``): an optional dependency
  or one that is slow to import, loaded when used.
- One place for rclpy's and mcap_ros2's private APIs (wire/private_api.py).
- Thin nodes: a node module (ros/*_node.py) has at most 350 lines, each of its callbacks at
  most 20 (the logic lives in the pure layers and in ros/ helper modules).
"""
import ast
import functools
import os
import re

import pytest

ROOT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                    'px100_control')
PURE = ('wire', 'models', 'kinematics', 'control', 'sim', 'bag', 'viewer', 'perception')
#: top-level modules that are pure too
PURE_MODULES = ('errors.py', 'paths.py', 'parameters.py')
#: layer rank of each top-level package (or module) of px100_control: a module imports its own
#: package or packages of a strictly lower rank
LAYERS = {'errors': 0, 'paths': 0, 'parameters': 0, '__init__': 0, 'wire': 1, 'kinematics': 2,
          'models': 3, 'control': 4, 'bag': 4, 'tools': 4, 'perception': 4, 'sim': 5,
          'viewer': 5, 'ros': 6, 'client': 7, 'entry_points': 8}


def _forbidden(module: str) -> bool:
    top = module.split('.')[0]
    return (top in ('rclpy', 'builtin_interfaces', 'rosidl_runtime_py', 'rosbag2_py')
            or top.endswith('_msgs') or top.endswith('_srvs'))


def _pure_files():
    for name in PURE_MODULES:
        yield os.path.join(ROOT, name)
    for pkg in PURE:
        folder = os.path.join(ROOT, pkg)
        for dirpath, _, files in os.walk(folder):
            for f in sorted(files):
                if f.endswith('.py'):
                    yield os.path.join(dirpath, f)


@functools.lru_cache(maxsize=None)
def _parsed(path: str):
    """Return (text, lines, tree, {child: parent}) of a source file (parsed once per run)."""
    with open(path, encoding='utf-8') as f:
        text = f.read()
    tree = ast.parse(text, filename=path)
    parents = {child: node for node in ast.walk(tree) for child in ast.iter_child_nodes(node)}
    return text, text.split('\n'), tree, parents


def _imports(path):
    tree = _parsed(path)[2]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield node.lineno, alias.name
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            yield node.lineno, node.module
        elif isinstance(node, ast.Call) and getattr(node.func, 'id', '') == '__import__' and (
                node.args and isinstance(node.args[0], ast.Constant)):
            yield node.lineno, str(node.args[0].value)


def test_pure_layers_exist():
    """The scan covers real packages (a renamed folder must not make the test vacuous)."""
    files = list(_pure_files())
    assert any('/kinematics/' in f for f in files) and any('/models/' in f for f in files)
    assert len(files) >= 10


@pytest.mark.parametrize('path', list(_pure_files()),
                         ids=lambda p: os.path.relpath(p, ROOT))
def test_no_ros_imports(path):
    """No module of the pure layers imports rclpy, *_msgs or builtin_interfaces."""
    bad = [f'line {n}: {m}' for n, m in _imports(path) if _forbidden(m)]
    assert not bad, f'{os.path.relpath(path, ROOT)} imports ROS: {bad}'


def test_detector_catches_ros_imports(tmp_path):
    """The import scanner flags every forbidden form (guards against a test that cannot fail)."""
    src = tmp_path / 'bad.py'
    src.write_text('import rclpy\nfrom sensor_msgs.msg import JointState\n'
                   'from builtin_interfaces.msg import Time\nimport numpy\n'
                   "x = __import__('std_msgs.msg')\n")
    found = [m for _, m in _imports(str(src)) if _forbidden(m)]
    assert found == ['rclpy', 'sensor_msgs.msg', 'builtin_interfaces.msg', 'std_msgs.msg']


# ---------------------------------------------------------------------------------------------
# layer order, cycles, imports at the top
# ---------------------------------------------------------------------------------------------

def _module_name(path: str) -> str:
    rel = os.path.relpath(path, os.path.dirname(ROOT))[:-3].replace(os.sep, '.')
    return rel[:-len('.__init__')] if rel.endswith('.__init__') else rel


def _project_imports(path: str):
    """Yield (line, imported module, inside a function, marked optional) of project imports."""
    _, lines, tree, parents = _parsed(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            # 'from pkg import module' imports the module pkg.module
            names = [f'{node.module}.{a.name}' for a in node.names] + [node.module]
        else:
            continue
        names = [n for n in names if n.split('.')[0] == 'px100_control']
        if not names:
            continue
        p, inside = parents.get(node), False
        while p is not None and not inside:
            inside = isinstance(p, (ast.FunctionDef, ast.AsyncFunctionDef))
            p = parents.get(p)
        marked = '# optional' in lines[node.lineno - 1]
        for name in names:
            yield node.lineno, name, inside, marked


def _graph(files):
    """Return {module: {(imported module, line, inside a function, marked)}} of the package."""
    known = {_module_name(f) for f in files}
    graph = {}
    for f in files:
        edges = set()
        for line, name, inside, marked in _project_imports(f):
            while name not in known and '.' in name:
                name = name.rsplit('.', 1)[0]          # 'pkg.module.Class' -> 'pkg.module'
            if name in known:
                edges.add((name, line, inside, marked))
        graph[_module_name(f)] = edges
    return graph


def _layer(module: str) -> str:
    parts = module.split('.')
    return parts[1] if len(parts) > 1 else '__init__'


def _upward(graph):
    """Return ['a (layer) -> b (layer), line n'] of imports of a package of no lower rank."""
    bad = []
    for module, edges in graph.items():
        for target, line, _, _ in edges:
            here, there = _layer(module), _layer(target)
            if here != there and LAYERS[there] >= LAYERS[here]:
                bad.append(f'{module} ({here}) -> {target} ({there}), line {line}')
    return sorted(bad)


def _package_graph(graph):
    """Return {package: {imported package: ['a -> b, line n', ...]}} (packages = layers)."""
    out = {}
    for module, edges in graph.items():
        deps = out.setdefault(_layer(module), {})
        for target, line, _, _ in edges:
            if _layer(target) != _layer(module):
                deps.setdefault(_layer(target), []).append(f'{module} -> {target}, line {line}')
    return {pkg: {dep: sorted(why) for dep, why in deps.items()} for pkg, deps in out.items()}


def _package_cycles(graph):
    """Return one text per package cycle: its packages and the imports that close it."""
    packages = _package_graph(graph)
    as_edges = {pkg: {(dep,) for dep in deps} for pkg, deps in packages.items()}
    out = []
    for comp in _cycles(as_edges):
        more = {1: ''}
        imports = [f'{pkg} -> {dep}: {why[0]}' + more.get(len(why), f' (+{len(why) - 1} more)')
                   for pkg in sorted(comp) for dep, why in sorted(packages[pkg].items())
                   if dep in comp]
        out.append(f'packages {sorted(comp)} import each other:\n  ' + '\n  '.join(imports))
    return out


def _cycles(graph):
    """Return the strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w, *_ in graph.get(v, ()):
            if w == v:
                continue
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = set()
            while True:
                w = stack.pop()
                on.discard(w)
                comp.add(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(comp)
    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def _all_files():
    for dirpath, _, files in os.walk(ROOT):
        for f in sorted(files):
            if f.endswith('.py'):
                yield os.path.join(dirpath, f)


@functools.lru_cache(maxsize=None)
def _package_tree_graph():
    """Return _graph of every module of the package (built once per run)."""
    return _graph(list(_all_files()))


def test_every_package_has_a_layer():
    assert {_layer(_module_name(f)) for f in _all_files()} <= set(LAYERS)


def test_layer_order():
    """No module imports a package of its rank or higher (models from kinematics, sim from ros)."""
    bad = _upward(_package_tree_graph())
    assert not bad, 'imports from the same or a higher layer:\n' + '\n'.join(bad)


def test_no_package_cycles():
    """No two packages import each other, even through modules that form no module cycle."""
    cycles = _package_cycles(_package_tree_graph())
    assert not cycles, '\n'.join(cycles)


def test_no_import_cycles():
    """No cycle among the modules (function-level imports count)."""
    cycles = _cycles(_package_tree_graph())
    assert not cycles, cycles


#: function-level imports in code that the parameter-schema change moves out of ros/common.py
#: and ros/parameter_schema.py: (module, function, imported module). The test fails once one is
#: gone (then delete it here).
PENDING_LAZY = set()
_OPTIONAL = re.compile(r'#\s*optional:\s*\S')


def _function_imports(path: str):
    """Yield (line, function, imported module, marked '# optional: why') of function imports."""
    _, lines, tree, parents = _parsed(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            names = ['.' * node.level + (node.module or '')]
        else:
            continue
        func = parents.get(node)
        while func is not None and not isinstance(func, (ast.FunctionDef, ast.AsyncFunctionDef)):
            func = parents.get(func)
        if func is None:
            continue                            # module level (also in try / if blocks)
        marked = bool(_OPTIONAL.search(lines[node.lineno - 1]))
        for name in names:
            yield node.lineno, func.name, name, marked


def _unmarked_imports(files):
    """Return (['module: line n in f() imports m'], the PENDING_LAZY entries seen)."""
    bad, seen = set(), set()
    for f in files:
        module = _module_name(f)
        for line, func, name, marked in _function_imports(f):
            if (module, func, name) in PENDING_LAZY:
                seen.add((module, func, name))
            elif not marked:
                bad.add(f'{module}: line {line} in {func}() imports {name}')
    return sorted(bad), seen


def test_imports_at_the_top():
    """An import inside a function (any module: project, stdlib, ROS) says '# optional: why'."""
    bad, seen = _unmarked_imports(list(_all_files()))
    assert not bad, 'function-level imports (move to the top or mark # optional: why):\n' \
        + '\n'.join(bad)
    assert seen == PENDING_LAZY, f'gone, delete from PENDING_LAZY: {PENDING_LAZY - seen}'


def test_private_apis_in_one_module():
    """Use rclpy's take_message and mcap_ros2._dynamic only in wire/private_api.py."""
    bad = []
    for f in _all_files():
        if f.endswith(os.path.join('wire', 'private_api.py')):
            continue
        bad += [os.path.relpath(f, ROOT) for word in ('take_message', 'mcap_ros2._dynamic')
                if word in _parsed(f)[0]]
    assert not bad, bad


def test_checks_catch_an_upward_import_a_cycle_and_a_hidden_import(tmp_path):
    """The checks flag what they are for (a test that cannot fail proves nothing)."""
    pkg = tmp_path / 'px100_control'
    (pkg / 'kinematics').mkdir(parents=True)
    (pkg / 'models').mkdir()
    (pkg / 'kinematics' / 'a.py').write_text(
        'def f():\n    from px100_control.models import b\n    return b\n')
    (pkg / 'models' / 'b.py').write_text('from px100_control.kinematics import a\n')
    global ROOT
    saved, ROOT = ROOT, str(pkg)
    try:
        files = [str(pkg / 'kinematics' / 'a.py'), str(pkg / 'models' / 'b.py')]
        graph = _graph(files)
        assert _upward(graph) == ['px100_control.kinematics.a (kinematics) -> '
                                  'px100_control.models.b (models), line 2']
        assert _cycles(graph) == [{'px100_control.kinematics.a', 'px100_control.models.b'}]
        assert [e for e in graph['px100_control.kinematics.a'] if e[2] and not e[3]]
    finally:
        ROOT = saved


def test_checks_catch_packages_that_import_each_other(tmp_path):
    """control.a -> sim.b and sim.c -> control.d: no module cycle, but a package cycle."""
    pkg = tmp_path / 'px100_control'
    for folder in ('control', 'sim'):
        (pkg / folder).mkdir(parents=True)
    (pkg / 'control' / 'a.py').write_text('from px100_control.sim import b\n')
    (pkg / 'sim' / 'b.py').write_text('X = 1\n')
    (pkg / 'sim' / 'c.py').write_text('\n\nfrom px100_control.control.d import Y\n')
    (pkg / 'control' / 'd.py').write_text('Y = 2\n')
    global ROOT
    saved, ROOT = ROOT, str(pkg)
    try:
        graph = _graph([str(p) for p in sorted(pkg.rglob('*.py'))])
        assert _cycles(graph) == []
        assert _package_cycles(graph) == [
            "packages ['control', 'sim'] import each other:\n"
            '  control -> sim: px100_control.control.a -> px100_control.sim.b, line 1\n'
            '  sim -> control: px100_control.sim.c -> px100_control.control.d, line 3']
        assert _upward(graph) == ['px100_control.control.a (control) -> '
                                  'px100_control.sim.b (sim), line 1']
        saved_layers = dict(LAYERS)
        LAYERS['sim'] = LAYERS['control']       # same rank: the import is refused either way
        try:
            assert len(_upward(graph)) == 2
        finally:
            LAYERS.update(saved_layers)
    finally:
        ROOT = saved


def test_import_check_catches_unmarked_function_imports(tmp_path):
    """Stdlib, third-party and project imports in functions need '# optional: why'."""
    path = tmp_path / 'm.py'
    path.write_text('import os\n\n\n'
                    'def f():\n'
                    '    import json\n'
                    '    from rclpy.node import Node\n'
                    '    import yaml  # optional\n'
                    '    import viser  # optional: slow to import\n'
                    '    from px100_control.models import registry  # optional: cycle\n\n\n'
                    'class C:\n'
                    '    def g(self):\n'
                    '        def h():\n'
                    '            from . import sibling\n')
    assert [(line, func, name, marked) for line, func, name, marked
            in _function_imports(str(path)) if not marked] == [
        (5, 'f', 'json', False), (6, 'f', 'rclpy.node', False), (7, 'f', 'yaml', False),
        (15, 'h', '.', False)]
    bad, _ = _unmarked_imports([str(path)])
    assert len(bad) == 4 and not any('viser' in b or 'registry' in b for b in bad)


# ---------------------------------------------------------------------------------------------
# thin nodes: module size and callback length
# ---------------------------------------------------------------------------------------------

MAX_NODE_LINES = 350
MAX_CALLBACK_LINES = 20
#: calls that register a callback (rclpy entities, parameter callbacks, futures, signals,
#: threads)
REGISTERING = ('create_subscription', 'create_timer', 'create_wall_timer', 'create_service',
               'add_on_set_parameters_callback', 'add_pre_set_parameters_callback',
               'add_post_set_parameters_callback', 'add_done_callback', 'signal', 'Thread',
               'ActionServer')


def _node_files():
    folder = os.path.join(ROOT, 'ros')
    return sorted(os.path.join(folder, f) for f in os.listdir(folder) if f.endswith('_node.py'))


def _callback_names(tree) -> set:
    """Return the names of the functions a module registers as callbacks, and its on_* ones."""
    names = set()
    for node in ast.walk(tree):
        func = getattr(node, 'func', None)
        if not isinstance(node, ast.Call) or (
                getattr(func, 'attr', None) or getattr(func, 'id', None)) not in REGISTERING:
            continue
        for arg in list(node.args) + [k.value for k in node.keywords]:
            if isinstance(arg, ast.Lambda):          # lambda: self._x(...): _x is the callback
                arg = arg.body.func if isinstance(arg.body, ast.Call) else arg.body
            if isinstance(arg, ast.Attribute):
                names.add(arg.attr)
            elif isinstance(arg, ast.Name):
                names.add(arg.id)
    defs = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    return names | {d.name for d in defs if d.name.lstrip('_').startswith('on_')}


def _too_long(path: str) -> list:
    """Return what makes a node module too long: its line count, callbacks over the limit."""
    text, _, tree, _ = _parsed(path)
    bad = []
    if len(text.splitlines()) > MAX_NODE_LINES:
        bad.append(f'{len(text.splitlines())} lines')
    callbacks = _callback_names(tree)
    for d in ast.walk(tree):
        if isinstance(d, (ast.FunctionDef, ast.AsyncFunctionDef)) and d.name in callbacks:
            length = d.end_lineno - d.lineno + 1
            if length > MAX_CALLBACK_LINES:
                bad.append(f'callback {d.name}: {length} lines')
    return bad


@pytest.mark.parametrize('path', _node_files(), ids=os.path.basename)
def test_nodes_are_thin(path):
    """A node module has at most 350 lines, each callback at most 20 (def line to last line)."""
    bad = _too_long(path)
    assert not bad, f'{os.path.basename(path)}: ' + ', '.join(bad)


def test_callbacks_are_short_everywhere():
    """Outside the nodes too (viewer page events, client timers, threads): <= 20 lines each."""
    bad = {os.path.relpath(f, ROOT): [b for b in _too_long(f) if b.startswith('callback')]
           for f in _all_files()}
    assert not {f: b for f, b in bad.items() if b}, bad


def test_thin_node_check_finds_long_callbacks(tmp_path):
    """Registered methods, lambda targets and on_* handlers are measured; helpers are not."""
    src = tmp_path / 'x_node.py'
    body = '\n'.join(['        x = 1'] * 20)
    src.write_text(
        'class N:\n'
        '    def __init__(self):\n'
        '        self.create_timer(1.0, self._tick)\n'
        '        self.create_subscription(int, "t", lambda m: self._got(m), 1)\n'
        f'    def _tick(self):\n{body}\n'
        f'    def _got(self, m):\n{body}\n'
        f'    def _on_thing(self):\n{body}\n'
        f'    def _helper(self):\n{body}\n')
    assert _too_long(str(src)) == ['callback _tick: 21 lines', 'callback _got: 21 lines',
                                   'callback _on_thing: 21 lines']
