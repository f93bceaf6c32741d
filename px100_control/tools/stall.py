"""
Notice when a node's callbacks stop running on time, and say what ran long meanwhile.

A periodic check (a steady-clock timer) calls :meth:`StallMeter.check`; callbacks report how
long they or their slow parts took with :meth:`StallMeter.note`. When the check comes more
than ``warn_after`` seconds after the previous one, the node was not scheduled for that long:
the returned :class:`Stall` says how long, which noted part took longest since the last check
(a publish blocked in the middleware, a long callback) and how often each ran (parts that ran
at their usual rate meanwhile mean the process ran and only the check was not called), so a
late reaction in a log names its cause. Times are ``time.monotonic_ns`` (steady); no rclpy.
"""
from dataclasses import dataclass, field
import time
from typing import Dict, Optional


@dataclass
class Stall:
    """One late check: ``gap_s`` since the previous one [s], expected ``period_s`` [s]."""

    gap_s: float
    period_s: float
    longest: Dict[str, float]   # part -> its longest single duration since the last check [s]
    counts: Dict[str, int] = field(default_factory=dict)   # part -> times noted meanwhile

    def describe(self) -> str:
        """Return the stall in words, the longest parts first."""
        parts = sorted(self.longest.items(), key=lambda kv: -kv[1])[:3]
        what = ', '.join(f'{name} {s:.3f} s (x{self.counts.get(name, 1)})' for name, s in parts) \
            or 'no noted part ran'
        return (f'not scheduled for {self.gap_s:.2f} s (checks every {self.period_s:g} s); '
                f'longest since the previous check: {what}')


class StallMeter:
    """
    Measure the gaps between periodic checks and the longest noted parts in between.

    :param period_s: how often :meth:`check` is meant to run [s]
    :param warn_after_s: a gap longer than this is a stall [s]
    """

    def __init__(self, period_s: float, warn_after_s: float):
        if not (period_s > 0 and warn_after_s > period_s):
            raise ValueError(f'need 0 < period_s < warn_after_s, got {period_s}, '
                             f'{warn_after_s}')
        self.period_s = float(period_s)
        self.warn_after_ns = int(warn_after_s * 1e9)
        self._last_check_ns: Optional[int] = None
        self._longest: Dict[str, int] = {}
        self._counts: Dict[str, int] = {}
        self.stalls = 0          # stalls seen since start
        self.worst_gap_s = 0.0   # longest gap seen since start [s]

    def note(self, part: str, duration_ns: int) -> None:
        """Record that ``part`` took ``duration_ns`` once (the longest and a count are kept)."""
        self._counts[part] = self._counts.get(part, 0) + 1
        if duration_ns > self._longest.get(part, -1):
            self._longest[part] = duration_ns

    def check(self, now_ns: Optional[int] = None) -> Optional[Stall]:
        """Close the interval since the previous check; return a :class:`Stall` if it was late."""
        now_ns = time.monotonic_ns() if now_ns is None else now_ns
        last, self._last_check_ns = self._last_check_ns, now_ns
        longest, self._longest = self._longest, {}
        counts, self._counts = self._counts, {}
        if last is None:
            return None
        gap_ns = now_ns - last
        self.worst_gap_s = max(self.worst_gap_s, gap_ns * 1e-9)
        if gap_ns <= self.warn_after_ns:
            return None
        self.stalls += 1
        return Stall(gap_ns * 1e-9, self.period_s,
                     {k: v * 1e-9 for k, v in longest.items()}, counts)
