"""
Run the viewer's callbacks so that a fault is reported, never raised.

The viewer may share a process and an executor with sim_driver and the other nodes (``bringup
--viewer``, the client's in-process bringup, the demo's ``--viewer``): an exception escaping one
of its callbacks (viser, yourdfpy or our own code) would stop the executor and every node in it.
:class:`Guard` wraps each callback once, where it is registered; a fault is handed to ``report``
as one line (callback, exception type, message, the line that raised it), the same line at
most once per ``repeat_period`` seconds of ``clock``.
"""
import functools
import math
import os
import time
import traceback
from typing import Callable, Dict


class Guard:
    """
    Wrap callbacks: an Exception becomes a report; KeyboardInterrupt and SystemExit pass.

    :param report: callable(text) given each fault's line (e.g. a logger's error)
    :param repeat_period: seconds before the same fault line is reported again
    :param clock: callable() -> seconds, for repeat_period
    """

    def __init__(self, report: Callable[[str], None], repeat_period: float = 10.0,
                 clock: Callable[[], float] = time.monotonic):
        self.report = report
        self.repeat_period = float(repeat_period)
        self.clock = clock
        self.faults = 0
        self.last = ''
        self._reported: Dict[str, float] = {}

    def wrap(self, fn: Callable, where: str = '') -> Callable:
        """Return fn guarded: its exceptions are reported under where (default its name)."""
        name = where or getattr(fn, '__name__', repr(fn)).lstrip('_')

        @functools.wraps(fn)
        def guarded(*args, **kwargs):
            try:
                return fn(*args, **kwargs)
            except Exception as exc:  # noqa: B902 - any fault is reported, none escapes
                self.fault(name, exc)
                return None
        return guarded

    def call(self, where: str, fn: Callable, *args, **kwargs):
        """Call fn with the arguments, guarded; return its result (None after a fault)."""
        return self.wrap(fn, where)(*args, **kwargs)

    def fault(self, where: str, exc: BaseException) -> str:
        """Count and report one fault, each line at most once per repeat_period; return it."""
        frames = traceback.extract_tb(exc.__traceback__)
        at = f' (at {os.path.basename(frames[-1].filename)}:{frames[-1].lineno})' \
            if frames else ''
        text = f'{where} failed: {type(exc).__name__}: {exc}{at}'
        self.faults += 1
        self.last = text
        now = self.clock()
        if now - self._reported.get(text, -math.inf) >= self.repeat_period:
            self._reported[text] = now
            if len(self._reported) > 1000:
                self._reported = {text: now}
            try:
                self.report(text)
            except Exception:  # noqa: B902 - a failing report must not raise either
                pass
        return text
