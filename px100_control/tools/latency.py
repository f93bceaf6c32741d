"""
How long a stamped sample waited in this process before its callback ran.

``lag = (this node's clock when the callback runs) - (the sample's header stamp)`` is transport
time + clock offset between the hosts + time spent queued here. The smallest lag over the last
``window_s`` seconds is taken as transport + offset (samples that did not wait); the excess of
a lag over it is how long that sample sat queued while this process was stalled. A node stalled
for a second then reads samples a second old: it must not take them for fresh ones. Times in
nanoseconds; no rclpy.
"""
from collections import deque


class QueueDelay:
    """
    Sliding minimum of lags; :meth:`update` returns a sample's excess over it [ns].

    :param window_s: how long a small lag is remembered as the floor [s]
    :param reset_after_s: an excess larger than this is a clock change (the stamps' clock or
        ours jumped, or the publisher restarted on another clock), not a queue: the floor
        restarts from this sample and the excess is 0 [s]
    """

    def __init__(self, window_s: float = 10.0, reset_after_s: float = 10.0):
        if not (window_s > 0 and reset_after_s > 0):
            raise ValueError(f'window_s and reset_after_s must be > 0, got {window_s}, '
                             f'{reset_after_s}')
        self.window_ns = int(window_s * 1e9)
        self.reset_after_ns = int(reset_after_s * 1e9)
        self._floor = deque()   # (steady ns, lag ns), lags increasing from the left

    def update(self, steady_ns: int, lag_ns: int) -> int:
        """Add the lag of a sample read at ``steady_ns``; return how long it waited [ns]."""
        floor = self._floor
        while floor and floor[-1][1] >= lag_ns:
            floor.pop()
        floor.append((steady_ns, lag_ns))
        while floor[0][0] < steady_ns - self.window_ns:
            floor.popleft()
        excess = lag_ns - floor[0][1]
        if excess > self.reset_after_ns:
            floor.clear()
            floor.append((steady_ns, lag_ns))
            return 0
        return excess

    def reset(self) -> None:
        """Forget the floor (e.g. a new publisher)."""
        self._floor.clear()
