"""The `ros2 run px100_control <name>` contract, resolved the way ros2cli does it."""
import os

from px100_control.tools.processes import executable_path, NodeProcess
import pytest
import yaml

# Every executable of docs/ros_interfaces.md.
CONTRACT_EXECUTABLES = ['sim_driver', 'ik_service', 'trajectory_server', 'state_publisher',
                        'bringup', 'record', 'replay', 'inspect', 'viewer', 'pc_filter',
                        'camera']


def test_package_is_in_the_ament_index():
    """The package prefix resolves and holds package.xml, the URDF and the config."""
    from ament_index_python.packages import get_package_prefix, get_package_share_directory
    prefix = get_package_prefix('px100_control')
    share = get_package_share_directory('px100_control')
    assert share.startswith(prefix)
    for rel in ('package.xml', 'urdf/px100.urdf', 'config/px100.yaml',
                'config/robots/px100.yaml'):
        assert os.path.isfile(os.path.join(share, rel)), rel


@pytest.mark.parametrize('name', CONTRACT_EXECUTABLES)
def test_executable_exists_where_ros2_run_looks(name):
    """lib/px100_control/<name> is an executable file under the package prefix."""
    path = executable_path(name)
    assert os.access(path, os.X_OK)
    assert os.path.basename(os.path.dirname(path)) == 'px100_control'


@pytest.mark.parametrize('name', CONTRACT_EXECUTABLES)
def test_executable_starts_and_answers_help(name):
    """Each executable starts from the install prefix and prints its usage for --help."""
    with NodeProcess(name, ['--help']) as proc:
        proc.proc.wait(30)
        out = proc.output()
    assert proc.proc.returncode == 0, out
    assert 'usage' in out.lower(), out


def test_params_file_is_valid_ros_yaml():
    """config/px100.yaml has the ros__parameters layout --params-file expects."""
    from px100_control.paths import data_path
    with open(data_path('config', 'px100.yaml')) as f:
        params = yaml.safe_load(f)
    assert params['/**']['ros__parameters']['robot_model'] == 'px100'
    for node in ('sim_driver', 'ik_service', 'trajectory_server'):
        assert 'ros__parameters' in params['/**/' + node], node


def test_installed_scripts_are_the_entry_points():
    """The install's console scripts are entry_points.TARGETS, each through its function."""
    from importlib import metadata
    from px100_control import entry_points
    scripts = {e.name: e.value for e in metadata.distribution('px100_control').entry_points
               if e.group == 'console_scripts'}
    assert scripts == {name: f'px100_control.entry_points:{name}'
                       for name in entry_points.TARGETS}
    assert all(callable(getattr(entry_points, name)) for name in entry_points.TARGETS)


def _mapped(pid: int, library: str) -> bool:
    """Return True once the process has mapped a shared library (its imports got that far)."""
    try:
        with open(f'/proc/{pid}/maps', encoding='utf-8') as f:
            return library in f.read()
    except OSError:
        return False


@pytest.mark.parametrize('name,how,library', [
    ('camera', 'SIGINT', '_multiarray_umath'), ('sim_driver', 'SIGTERM', '_multiarray_umath'),
    ('bringup', 'SIGINT', '_multiarray_umath'), ('camera', 'SIGINT', 'mujoco/_specs')])
def test_a_stop_signal_during_start_up_imports_ends_quietly(name, how, library):
    """
    Ctrl-C while the executable still imports (numpy, or MuJoCo's extension, mapped): exit 0.

    CI: ``bringup``'s camera process, stopped with the group right after bringup was up,
    printed a KeyboardInterrupt traceback from inside numpy's import, and, once that raised a
    quiet SystemExit, "ImportError: initialization failed" from inside MuJoCo's extension.
    """
    import signal
    import time
    proc = NodeProcess(name, [])
    try:
        deadline = time.monotonic() + 30.0
        while not _mapped(proc.pid, library) and proc.alive() and time.monotonic() < deadline:
            time.sleep(0.001)
        assert _mapped(proc.pid, library), f'{name} never mapped {library}\n{proc.output()}'
        proc.signal(getattr(signal, how))
        rc = proc.proc.wait(30)
    finally:
        proc.stop()
    out = proc.output()
    assert rc == 0 and 'Traceback' not in out, f'{name}: exit {rc}\n{out[-3000:]}'
