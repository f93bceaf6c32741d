"""
An overall time bound for a benchmark run: past it the run fails, naming where it was.

``with bounded('bench_ik_service', 300):`` starts a watchdog process beside the benchmark;
``stage('null service, 8 clients')`` notes where the run is (sent to the watchdog as a line).
If the run has not left the ``with`` block after its bound, the watchdog prints::

    [bench_ik_service] FAILED: still running after its bound of 300 s, at: null service,
    8 clients (for 251 s); stopping it and its child processes (its thread stacks follow)

makes the benchmark dump every thread's Python stack (faulthandler, SIGUSR1), stops the
benchmark's child processes (SIGINT, then SIGKILL after 3 s) and the benchmark (SIGTERM, then
SIGKILL after 3 s). The exit status is then that of a killed process (143 or 137).

A process, not a thread: a benchmark hung inside a C extension that holds the GIL (a DDS call)
stops every Python thread of its own, but not another process. The watchdog ends with the
benchmark: it reads the stage lines from a pipe and sees its end as the run's end.

Usage: ``python benchmarks/bound.py --watch PID SECONDS NAME`` is the watchdog itself (started by
:func:`bounded`); benchmarks call :func:`add_argument`, :func:`bounded`, :func:`stage` and
:func:`log`. Each benchmark states its bounds in ``BOUND_S`` (--quick, full) [s].
"""
import argparse
import contextlib
import faulthandler
import os
import select
import signal
import subprocess
import sys
import time

#: the pipe to the watchdog of this process's bounded run, if any
_PIPE = []


def add_argument(parser: argparse.ArgumentParser, quick_s: float, full_s: float) -> None:
    """Add ``--bound SECONDS`` (default: quick_s with --quick, else full_s)."""
    parser.add_argument('--bound', type=float, default=None, metavar='SECONDS',
                        help=f'fail if the run takes longer (default {quick_s:.0f} s with '
                             f'--quick, {full_s:.0f} s without)')
    parser.set_defaults(bound_quick_s=quick_s, bound_full_s=full_s)


def seconds(options, quick: bool) -> float:
    """Return the bound of a run from parsed options (see :func:`add_argument`)."""
    if options.bound is not None:
        return options.bound
    return options.bound_quick_s if quick else options.bound_full_s


def stage(text: str) -> None:
    """Note where the bounded run is now (a no-op outside :func:`bounded`)."""
    if not _PIPE:
        return
    try:
        os.write(_PIPE[-1], (' '.join(text.split()) + '\n').encode())
    except OSError:
        pass                                    # the watchdog is gone: nothing to tell


def log(text: str) -> None:
    """Print a progress line and note it as the stage (a ``log`` for the benchmarks' run())."""
    print(text, flush=True)
    stage(text)


@contextlib.contextmanager
def bounded(name: str, bound_s: float):
    """Run the block under a watchdog that stops this process after ``bound_s`` seconds."""
    faulthandler.register(signal.SIGUSR1, all_threads=True, chain=False)
    watchdog = subprocess.Popen(
        [sys.executable, os.path.abspath(__file__), '--watch', str(os.getpid()),
         str(bound_s), name], stdin=subprocess.PIPE, start_new_session=True)
    _PIPE.append(watchdog.stdin.fileno())
    stage('start')
    try:
        yield
    finally:
        stage('DONE')
        _PIPE.pop()
        watchdog.stdin.close()
        try:
            watchdog.wait(5.0)
        except subprocess.TimeoutExpired:
            watchdog.kill()


def _descendants(pid: int) -> list:
    """Return the process ids below ``pid`` (children first), from /proc."""
    parents = {}
    for entry in os.listdir('/proc'):
        if entry.isdigit():
            try:
                with open(f'/proc/{entry}/stat', 'rb') as f:
                    parents[int(entry)] = int(f.read().rsplit(b')', 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                continue
    out, todo = [], [pid]
    while todo:
        kids = [p for p, pp in parents.items() if pp == todo[0]]
        out += kids
        todo = todo[1:] + kids
    return out


def _alive(pid: int) -> bool:
    """Return whether a process runs (a zombie, ended but not yet reaped, does not)."""
    try:
        with open(f'/proc/{pid}/stat', 'rb') as f:
            return f.read().rsplit(b')', 1)[1].split()[0] != b'Z'
    except (OSError, IndexError):
        return False


def _stop(pids, first: int, wait_s: float) -> None:
    """Send ``first`` to pids, then SIGKILL to those still alive after wait_s."""
    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, first)
    deadline = time.monotonic() + wait_s
    while time.monotonic() < deadline and any(_alive(p) for p in pids):
        time.sleep(0.1)
    for pid in pids:
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def watch(pid: int, bound_s: float, name: str) -> int:
    """Watch benchmark ``pid``: its stage lines on stdin, and stop it past ``bound_s``."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)    # a Ctrl-C is the benchmark's to handle
    deadline = time.monotonic() + bound_s
    where, since, buf = 'start', time.monotonic(), b''
    while True:
        left = deadline - time.monotonic()
        if left <= 0:
            break
        ready, _, _ = select.select([sys.stdin.buffer], [], [], min(left, 1.0))
        if ready:
            chunk = os.read(sys.stdin.fileno(), 4096)
            if not chunk:
                return 0                            # the benchmark ended (pipe closed)
            buf += chunk
            *lines, buf = buf.split(b'\n')
            for line in lines:
                if line.strip() == b'DONE':
                    return 0
                where, since = line.decode(errors='replace'), time.monotonic()
        elif not _alive(pid):
            return 0
    sys.stderr.write(f'[{name}] FAILED: still running after its bound of {bound_s:.0f} s, at: '
                     f'{where} (for {time.monotonic() - since:.0f} s); stopping it and its '
                     'child processes (its thread stacks follow)\n')
    sys.stderr.flush()
    children = [p for p in _descendants(pid) if p != os.getpid()]    # not this watchdog
    with contextlib.suppress(OSError):
        os.kill(pid, signal.SIGUSR1)                # faulthandler: every thread's stack
    time.sleep(1.0)
    _stop(children, signal.SIGINT, 3.0)
    _stop([pid], signal.SIGTERM, 3.0)
    return 1


def main(argv=None) -> int:
    """Run the watchdog (``--watch PID SECONDS NAME``)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--watch', nargs=3, metavar=('PID', 'SECONDS', 'NAME'), required=True)
    pid, bound_s, name = parser.parse_args(argv).watch
    return watch(int(pid), float(bound_s), name)


if __name__ == '__main__':
    sys.exit(main())
