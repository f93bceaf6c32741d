"""
How long a stamped sample waited in this process before its callback ran.

``lag = (this node's clock when the callback runs) - (the sample's header stamp)`` is transport
time + clock offset between the hosts + time spent queued here. The smallest lag over the last
``window_s`` seconds is taken as transport + offset (samples that did not wait); the excess of
a lag over it is how long that sample sat queued while this process was stalled. A node stalled
for a second then reads samples a second old: it must not take them for fresh ones.

One bad stamp must not move the floor: a lag far below it (a stamp from the future) or an
excess beyond ``max_wait_s`` (a stamp from the distant past) counts as no wait and leaves the
floor alone; a lasting clock change becomes the floor once the old one has left the window.
Times in nanoseconds; no rclpy.
"""
from collections import deque


class QueueDelay:
    """
    Sliding minimum of lags; :meth:`update` returns a sample's excess over it [ns].

    :param window_s: how long a small lag is remembered as the floor [s]
    :param max_wait_s: a longer excess is another clock (or a bad stamp), not a queue [s]
    :param below_s: a lag this far below the floor is an outlier (or a clock change) [s]
    """

    def __init__(self, window_s: float = 5.0, max_wait_s: float = 10.0, below_s: float = 1.0):
        if not (window_s > 0 and max_wait_s > 0 and below_s > 0):
            raise ValueError(f'window_s, max_wait_s and below_s must be > 0, got {window_s}, '
                             f'{max_wait_s}, {below_s}')
        self.window_ns = int(window_s * 1e9)
        self.max_wait_ns = int(max_wait_s * 1e9)
        self.below_ns = int(below_s * 1e9)
        self._floor = deque()   # (steady ns, lag ns), lags increasing from the left

    def update(self, steady_ns: int, lag_ns: int) -> int:
        """Add the lag of a sample read at ``steady_ns``; return how long it waited [ns]."""
        floor = self._floor
        while floor and floor[0][0] < steady_ns - self.window_ns:
            floor.popleft()
        if floor and lag_ns < floor[0][1] - self.below_ns:
            return 0
        while floor and floor[-1][1] >= lag_ns:
            floor.pop()
        floor.append((steady_ns, lag_ns))
        excess = lag_ns - floor[0][1]
        return excess if excess <= self.max_wait_ns else 0
