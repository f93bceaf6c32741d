"""
Start this package's executables the way ``ros2 run`` resolves them, and stop them cleanly.

``ros2 run px100_control <name>`` looks the package up in the ament index (its prefix) and runs
``<prefix>/lib/px100_control/<name>``; :func:`executable_path` does exactly that. Processes are
stopped with SIGINT and waited for (SIGKILL only as a last resort, and then reported).
"""
import os
import signal
import subprocess
import tempfile
import time
from typing import List, Optional, Sequence

from ament_index_python.packages import get_package_prefix, PackageNotFoundError

PACKAGE = 'px100_control'


def executable_path(name: str, package: str = PACKAGE) -> str:
    """
    Return ``<package prefix>/lib/<package>/<name>`` as ros2cli resolves it.

    :raises FileNotFoundError: the package is not in the ament index or has no such executable
    """
    try:
        prefix = get_package_prefix(package)
    except PackageNotFoundError as exc:
        raise FileNotFoundError(f"package '{package}' is not in the ament index "
                                f"(AMENT_PREFIX_PATH={os.environ.get('AMENT_PREFIX_PATH')}); "
                                'build it and source install/setup.bash') from exc
    path = os.path.join(prefix, 'lib', package, name)
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        raise FileNotFoundError(f"no executable '{name}' in {os.path.dirname(path)}")
    return path


class NodeProcess:
    """
    One executable of this package running as a child process (output kept in a log file).

    Use as a context manager, or call :meth:`stop`; stop sends SIGINT and waits.
    """

    def __init__(self, name: str, args: Sequence[str] = (), env: Optional[dict] = None,
                 package: str = PACKAGE):
        self.name = name
        self.cmd: List[str] = [executable_path(name, package), *args]
        self.log = tempfile.NamedTemporaryFile(prefix=f'px100_{name}_', suffix='.log',
                                               delete=False)
        self.proc = subprocess.Popen(self.cmd, stdout=self.log, stderr=subprocess.STDOUT,
                                     env=env if env is not None else os.environ.copy())
        self.returncode: Optional[int] = None
        self.killed = False

    @property
    def pid(self) -> int:
        """Return the child's process id."""
        return self.proc.pid

    def alive(self) -> bool:
        """Return True while the process runs."""
        return self.proc.poll() is None

    def output(self) -> str:
        """Return everything the process printed so far (also after stop())."""
        if not self.log.closed:
            self.log.flush()
        with open(self.log.name, encoding='utf-8', errors='replace') as f:
            return f.read()

    def signal(self, sig: int) -> None:
        """Send a signal to the process if it still runs."""
        if self.alive():
            self.proc.send_signal(sig)

    def stop(self, timeout: float = 10.0) -> int:
        """Send SIGINT, wait up to timeout [s]; SIGKILL (and mark killed) if it will not stop."""
        if self.alive():
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout)
            except subprocess.TimeoutExpired:
                self.killed = True
                self.proc.kill()
                self.proc.wait(5.0)
        self.returncode = self.proc.returncode
        self.log.close()
        return self.returncode

    def wait_for_output(self, text: str, timeout: float = 10.0) -> bool:
        """Return True once ``text`` appears in the output, False on timeout or exit."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            if text in self.output():
                return True
            if not self.alive():
                return text in self.output()
            time.sleep(0.05)
        return False

    def __enter__(self):
        """Context manager support."""
        return self

    def __exit__(self, *exc):
        """Stop the process on exit."""
        self.stop()
