"""
The pure layers import no ROS.

models, kinematics, control, sim, bag and viewer must not import rclpy, any *_msgs package or
builtin_interfaces (checked on the source with ast, so it also holds on a machine without ROS).
"""
import ast
import os

import pytest

ROOT = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))),
                    'px100_control')
PURE = ('models', 'kinematics', 'control', 'bag', 'sim', 'viewer')


def _forbidden(module: str) -> bool:
    top = module.split('.')[0]
    return (top in ('rclpy', 'builtin_interfaces', 'rosidl_runtime_py', 'rosbag2_py')
            or top.endswith('_msgs') or top.endswith('_srvs'))


def _pure_files():
    for pkg in PURE:
        folder = os.path.join(ROOT, pkg)
        for dirpath, _, files in os.walk(folder):
            for f in sorted(files):
                if f.endswith('.py'):
                    yield os.path.join(dirpath, f)


def _imports(path):
    with open(path, encoding='utf-8') as f:
        tree = ast.parse(f.read(), filename=path)
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
