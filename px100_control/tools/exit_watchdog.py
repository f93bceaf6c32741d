"""
A native watchdog that ends the process with status 0 if its teardown hangs.

Fast DDS 2.14 (the Jazzy wheels) can deadlock while it destroys a DDS participant: the main
thread spins in ``DomainParticipant::set_listener`` holding Python's GIL while a discovery
thread waits (docs/guide.md, known limits). Nothing written in Python can run then, so the
watchdog is a POSIX timer whose expiry glibc hands to a thread of its own (``SIGEV_THREAD``):
at ``bound_s`` it calls ``perror`` with a line that names the hang, then
``_exit(status)``.
The process has done its work by then (bags closed, nodes gone from the graph); only the
participant's own teardown is cut short, as SIGKILL would cut it, but with the status the
process was about to return (0 for a clean stop). Linux with glibc only; elsewhere
:func:`exit_watchdog` arms nothing.
"""
import contextlib
import ctypes
import ctypes.util
import sys
from typing import Iterator, Optional

#: the line written to stderr when the watchdog fires (perror appends ': Success')
MESSAGE = (b'[px100_control] the DDS participant teardown hung (a Fast DDS 2.14 deadlock); '
           b'exiting with the stop status')
_CLOCK_MONOTONIC = 1
_SIGEV_THREAD = 2
#: the line first, the exit this much later [s] (the line's thread must get to run)
_EXIT_AFTER_LINE_S = 0.1


class _SigevThread(ctypes.Structure):
    _fields_ = [('function', ctypes.c_void_p), ('attribute', ctypes.c_void_p)]


class _SigEvent(ctypes.Structure):
    """Linux ``struct sigevent`` (64 bytes): value, signo, notify, the thread fields."""

    _fields_ = [('value', ctypes.c_void_p), ('signo', ctypes.c_int), ('notify', ctypes.c_int),
                ('thread', _SigevThread), ('pad', ctypes.c_byte * 32)]


class _Timespec(ctypes.Structure):
    _fields_ = [('sec', ctypes.c_long), ('nsec', ctypes.c_long)]


class _ITimerSpec(ctypes.Structure):
    _fields_ = [('interval', _Timespec), ('value', _Timespec)]


_LINE = ctypes.create_string_buffer(MESSAGE)


def _libc():
    """Return (libc, timer functions' library) or None where POSIX timers are not reachable."""
    if not sys.platform.startswith('linux') or ctypes.sizeof(_SigEvent) != 64:
        return None
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        timers = libc if hasattr(libc, 'timer_create') else \
            ctypes.CDLL(ctypes.util.find_library('rt') or 'librt.so.1', use_errno=True)
        return libc, timers
    except (OSError, AttributeError):
        return None


def _arm(timers, function: int, value: Optional[int], after_s: float):
    """Arm a one-shot CLOCK_MONOTONIC timer calling ``function(value)``; return its id."""
    event = _SigEvent(value=value, notify=_SIGEV_THREAD, thread=_SigevThread(function, None))
    timer = ctypes.c_void_p()
    if timers.timer_create(_CLOCK_MONOTONIC, ctypes.byref(event), ctypes.byref(timer)) != 0:
        raise OSError(ctypes.get_errno(), 'timer_create failed')
    sec = int(after_s)
    spec = _ITimerSpec(value=_Timespec(sec, int((after_s - sec) * 1e9)))
    if timers.timer_settime(timer, 0, ctypes.byref(spec), None) != 0:
        timers.timer_delete(timer)
        raise OSError(ctypes.get_errno(), 'timer_settime failed')
    return timer


@contextlib.contextmanager
def exit_watchdog(bound_s: float, status: int = 0) -> Iterator[bool]:
    """
    Within the block, a hang longer than ``bound_s`` [s] ends the process with ``status``.

    Yields True when the watchdog is armed (False where it cannot be: not Linux/glibc).
    Python's own stdout and stderr are flushed first: ``_exit`` skips every buffer.
    """
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, OSError, ValueError):
            pass
    libs = _libc()
    armed = []
    if libs is not None:
        libc, timers = libs
        try:
            armed.append(_arm(timers, ctypes.cast(libc.perror, ctypes.c_void_p).value,
                              ctypes.addressof(_LINE), bound_s))
            armed.append(_arm(timers, ctypes.cast(libc._exit, ctypes.c_void_p).value,
                              int(status) or None, bound_s + _EXIT_AFTER_LINE_S))
        except OSError:
            pass
    try:
        yield len(armed) == 2
    finally:
        if libs is not None:
            for timer in armed:
                libs[1].timer_delete(timer)
