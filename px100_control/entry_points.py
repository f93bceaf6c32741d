"""
The executables' entry points (setup.py's console_scripts): a stop signal during start-up is quiet.

Python turns SIGINT into KeyboardInterrupt wherever the main thread is, and a node installs its
own stop handlers (:func:`px100_control.ros.common.install_stop_signals`) only once its module is
imported: Ctrl-C, or ``ros2 launch``'s SIGINT to the process group, landing while numpy, rclpy
or MuJoCo were still being imported printed a KeyboardInterrupt traceback (bringup's camera
process, stopped right after bringup said it was up). Here SIGINT and SIGTERM end the process
with status 0 and no traceback until the executable installs its handlers (during the imports
once they are done): nothing exists yet to tear down. The one-shot tools (``inspect``,
``bag_reindex``) get Python's default handlers back once imported, so an interrupted run still
fails as an interrupted run.
"""
import importlib
import signal

#: executable -> 'module:function': what setup.py installs (lib/px100_control/<name>)
TARGETS = {
    'sim_driver': 'px100_control.ros.sim_driver_node:main',
    'ik_service': 'px100_control.ros.ik_service_node:main',
    'trajectory_server': 'px100_control.ros.trajectory_server_node:main',
    'state_publisher': 'px100_control.ros.state_publisher_node:main',
    'bringup': 'px100_control.ros.bringup:main',
    'record': 'px100_control.ros.recorder_node:main',
    'replay': 'px100_control.ros.replayer_node:main',
    'inspect': 'px100_control.bag.inspect_cli:main',
    'bag_reindex': 'px100_control.bag.reindex:main',
    'viewer': 'px100_control.ros.viewer_node:main',
    'pc_filter': 'px100_control.ros.pc_filter_node:main',
    'camera': 'px100_control.ros.camera_node:main',
}
#: tools that end by themselves: Python's own SIGINT handling once their module is imported
ONE_SHOT = ('inspect', 'bag_reindex')
_STOP = (signal.SIGINT, signal.SIGTERM)
#: stop signals received while the executable's module was being imported
_RECEIVED = []


def _note(signum, frame):
    _RECEIVED.append(signum)


def _exit_quietly(signum, frame):
    raise SystemExit(0)


def run(name: str):
    """
    Import the executable's module with quiet stop signals, then call its main.

    During the import a signal is only noted (an exception raised inside a C extension's
    initialisation, MuJoCo's, became "ImportError: initialization failed" with a traceback);
    the process then ends with status 0 once the import is done. From then until the
    executable installs its own handlers a signal raises SystemExit(0).
    """
    previous = {sig: signal.signal(sig, _note) for sig in _STOP}
    module, function = TARGETS[name].split(':')
    main = getattr(importlib.import_module(module), function)
    if _RECEIVED:
        raise SystemExit(0)
    for sig, handler in previous.items():
        signal.signal(sig, handler if name in ONE_SHOT else _exit_quietly)
    return main()


def sim_driver():
    """Run ``sim_driver``."""
    return run('sim_driver')


def ik_service():
    """Run ``ik_service``."""
    return run('ik_service')


def trajectory_server():
    """Run ``trajectory_server``."""
    return run('trajectory_server')


def state_publisher():
    """Run ``state_publisher``."""
    return run('state_publisher')


def bringup():
    """Run ``bringup``."""
    return run('bringup')


def record():
    """Run ``record``."""
    return run('record')


def replay():
    """Run ``replay``."""
    return run('replay')


def inspect():
    """Run ``inspect``."""
    return run('inspect')


def bag_reindex():
    """Run ``bag_reindex``."""
    return run('bag_reindex')


def viewer():
    """Run ``viewer``."""
    return run('viewer')


def pc_filter():
    """Run ``pc_filter``."""
    return run('pc_filter')


def camera():
    """Run ``camera``."""
    return run('camera')
