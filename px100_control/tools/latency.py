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
A floor set while the two clocks disagreed (a node following ``/clock`` that had not read the
latest time yet: its clock behind the stamps) would make every later sample look queued by
that much: an excess that lasts, every sample for ``lasting_s`` of reading time, is a changed
clock relation, not a queue (a stalled node reads its queue in one burst, and a keep-last queue
holds a fraction of a second), so the floor restarts from it. Times in nanoseconds; no rclpy.
"""
from collections import deque


class QueueDelay:
    """
    Sliding minimum of lags; :meth:`update` returns a sample's excess over it [ns].

    :param window_s: how long a small lag is remembered as the floor [s]
    :param max_wait_s: a longer excess is another clock (or a bad stamp), not a queue [s]
    :param below_s: a lag this far below the floor is an outlier (or a clock change) [s]
    :param lasting_s: an excess of at least ``lasting_excess_s`` in every sample read over this
        long is a changed clock relation: the floor restarts [s]
    :param lasting_excess_s: see ``lasting_s`` [s]
    """

    def __init__(self, window_s: float = 5.0, max_wait_s: float = 10.0, below_s: float = 1.0,
                 lasting_s: float = 0.25, lasting_excess_s: float = 0.2):
        if not (window_s > 0 and max_wait_s > 0 and below_s > 0 and lasting_s > 0 and
                lasting_excess_s > 0):
            raise ValueError('window_s, max_wait_s, below_s, lasting_s and lasting_excess_s '
                             f'must be > 0, got {window_s}, {max_wait_s}, {below_s}, '
                             f'{lasting_s}, {lasting_excess_s}')
        self.window_ns = int(window_s * 1e9)
        self.max_wait_ns = int(max_wait_s * 1e9)
        self.below_ns = int(below_s * 1e9)
        self.lasting_ns = int(lasting_s * 1e9)
        self.lasting_excess_ns = int(lasting_excess_s * 1e9)
        self._floor = deque()   # (steady ns, lag ns), lags increasing from the left
        self._late_since = None  # steady ns of the first sample of the current run of excesses

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
        if excess < self.lasting_excess_ns:
            self._late_since = None
        elif self._late_since is None:
            self._late_since = steady_ns
        elif steady_ns - self._late_since >= self.lasting_ns:
            floor.clear()                       # the clocks moved: this lag is the new floor
            floor.append((steady_ns, lag_ns))
            self._late_since = None
            return 0
        return excess if excess <= self.max_wait_ns else 0
