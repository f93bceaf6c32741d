"""
The sim_driver's physics thread: it paces the physics chunks and the publishing.

On wall time the thread sleeps to each sample time itself: inside rclpy's multi-threaded
executor a 100 Hz timer whose callback integrates and publishes (1-2 ms) fired late and in
pairs (periods 1.5 ms / 18.5 ms), and a timer that only woke a thread fired every 20 ms.
Following the system clock, each sample is integrated up to its nominal time and stamped with
it (after a stall the missed samples follow at once, each with its own state, up to CATCH_UP
late); with its own clock, ticks of TICK_RATE advance simulated time. Following ``/clock``
(use_sim_time), ROS timers on the node clock wake it. As fast as possible (real_time_factor 0 or
inf) the ticks run back to back: between two ticks the thread lets the callbacks that wait for
the node's :class:`YieldingLock` (setpoints, services, parameters) go first, and otherwise
takes it straight back.
"""
import threading
import time

from px100_control.sim.stepper import period_ns, TICK_RATE

#: below this publish_rate [Hz] an extra timer advances the physics in follow-clock mode
#: (setpoints and service calls also catch the physics up to "now" before they apply)
FOLLOW_TICK_RATE = 20.0
#: following the system clock, samples missed by a stall up to this long are still published
#: (each integrated to and stamped with its own time) [s]; longer stalls drop them
CATCH_UP = 2.0
#: as fast as possible: the pause [s] while callbacks wait for the lock, and its longest sum
YIELD_PAUSE, YIELD_MAX = 0.0002, 0.05


class YieldingLock:
    """
    A mutual-exclusion lock (``with lock:``) that counts the threads waiting for it.

    The physics thread, running as fast as possible, looks at ``waiting`` between ticks and
    lets them have the lock first (a plain Lock goes straight back to the thread that released
    it while the woken waiter is still being scheduled).
    """

    def __init__(self):
        self._lock = threading.Lock()
        self._count = threading.Lock()
        #: threads blocked in ``with lock:``
        self.waiting = 0

    def __enter__(self):
        with self._count:
            self.waiting += 1
        self._lock.acquire()
        with self._count:
            self.waiting -= 1
        return self

    def __exit__(self, *exc_info):
        self._lock.release()


class PhysicsThread:
    """
    The physics thread of a sim_driver node and the ROS timers that wake it (use_sim_time).

    :param node: the node (clock, logger, context, timers)
    :param stepper: the node's :class:`px100_control.sim.stepper.Stepper`
    :param lock: the node's lock, held while the physics advances and publishes
    :param use_sim_time: the node follows ``/clock``
    :param group: callback group of the timers
    :param publish: callables ``state(stamp_ns)`` (publish the simulator's state, stamped) and
        ``clock(stamp_ns)`` (publish ``/clock``), called with the lock held
    :param outbox: the :class:`~px100_control.ros.sim_messages.Outbox` those callables publish
        through: batched while the physics runs as fast as possible, flushed after each tick
    """

    def __init__(self, node, stepper, lock, use_sim_time: bool, group, publish: dict, outbox):
        self._node = node
        self._stepper = stepper
        self._lock = lock
        self._use_sim_time = bool(use_sim_time)
        self._group = group
        self._publish = publish
        self._outbox = outbox
        self._jobs = set()
        self._cv = threading.Condition()
        self._stopping = False
        self._timers = []
        self._next = 0            # the next tick [s, monotonic] or sample [ns, node clock]
        self._period = 0          # the sample period [ns] (following the system clock)
        self._thread = threading.Thread(target=self._loop, daemon=True,
                                        name='sim_driver_physics')

    def catch_up(self) -> None:
        """Following a clock: integrate up to now (call with the lock held), e.g. a command's."""
        if not self._stepper.master:
            self._stepper.advance_to(self._node.get_clock().now().nanoseconds)

    def _follow_tick(self) -> None:
        with self._lock:
            self.catch_up()

    def _publish_tick(self) -> None:
        with self._lock:
            now = self._node.get_clock().now().nanoseconds
            self._stepper.advance_to(now)
            self._publish['state'](now)

    def _sample(self, stamp_ns: int) -> None:
        """Integrate up to the sample time stamp_ns (node clock) and publish the state there."""
        with self._lock:
            self._publish['state'](self._stepper.advance_to_sample(stamp_ns))

    def _master_tick(self) -> None:
        with self._lock:
            outbox = self._outbox
            outbox.enabled = self._stepper.fast
            try:
                self._stepper.master_tick(self._publish['clock'], self._publish['state'])
            finally:
                outbox.enabled = False
                outbox.flush()

    def start(self) -> None:
        """Start the thread and the timers."""
        self._thread.start()
        self.retime()

    def retime(self) -> None:
        """
        Create or retime the ROS timers: only when following ``/clock`` (use_sim_time).

        On wall time the thread paces itself; a timer would only wake it.
        """
        if self._stepper.master or not self._use_sim_time:
            with self._cv:
                self._cv.notify()           # a new publish_rate applies at once
            return
        # timers are created once and retimed, never destroyed while spinning (rclpy 7.1's
        # EventsExecutor fails when an entity is destroyed under it)
        period = period_ns(self._stepper.publish_rate)
        if not self._timers:
            self._timers = [
                self._node.create_timer(period * 1e-9, lambda: self._wake('publish'),
                                        callback_group=self._group),
                self._node.create_timer(1.0 / FOLLOW_TICK_RATE, lambda: self._wake('follow'),
                                        callback_group=self._group)]
        elif self._timers[0].timer_period_ns != period:
            self._timers[0].timer_period_ns = period
            self._timers[0].reset()
        follow = self._timers[1]
        if self._stepper.publish_rate < FOLLOW_TICK_RATE:
            if follow.is_canceled():
                follow.reset()
        else:
            follow.cancel()

    def stop(self) -> None:
        """Stop the thread (the node then only answers services and parameters)."""
        with self._cv:
            self._stopping = True
            self._cv.notify()
        if self._thread.is_alive() and threading.current_thread() is not self._thread:
            self._thread.join(timeout=5.0)

    def _wake(self, job: str) -> None:
        with self._cv:
            self._jobs.add(job)
            self._cv.notify()

    def _loop(self) -> None:
        try:
            if self._stepper.master:
                self._paced()
            elif not self._use_sim_time:
                self._paced_follow()
            else:
                self._woken()
        except Exception as exc:  # pragma: no cover - reported, the node keeps its services
            self._node.get_logger().fatal(f'physics thread stopped: {exc!r}')

    def _wait_until(self, due) -> bool:
        """Sleep until ``due()`` (seconds left, asked on every wake-up) is <= 0; False: stop."""
        with self._cv:
            while not self._stopping:
                remaining = due()
                if remaining <= 0.0:
                    break
                self._cv.wait(remaining)
            return not self._stopping

    def _paced(self) -> None:
        """Own clock: run the master tick every 1 / TICK_RATE of wall time (or back to back)."""
        period = 1.0 / TICK_RATE
        self._next = time.monotonic() + period
        while self._wait_until(lambda: self._next - time.monotonic()):
            self._run(self._master_tick)
            now = time.monotonic()
            if self._stepper.fast:                          # as fast as possible
                self._next = now
                self._let_waiters_in()
                continue
            self._next += period
            if now - self._next > period:                   # fell behind: skip, do not burst
                self._next = now + period

    def _let_waiters_in(self) -> None:
        """Pause while callbacks wait for the lock (at most YIELD_MAX)."""
        end = time.monotonic() + YIELD_MAX
        while getattr(self._lock, 'waiting', 0) and not self._stopping and \
                time.monotonic() < end:
            time.sleep(YIELD_PAUSE)

    def _follow_due(self) -> float:
        """Return the seconds to the next sample; a changed publish_rate restarts the period."""
        now = self._node.get_clock().now().nanoseconds
        if period_ns(self._stepper.publish_rate) != self._period:
            self._period = period_ns(self._stepper.publish_rate)
            self._next = now + self._period
        return (self._next - now) * 1e-9

    def _paced_follow(self) -> None:
        """Publish at publish_rate on the node clock (wall time), sleeping to each sample."""
        clock = self._node.get_clock()
        self._period = period_ns(self._stepper.publish_rate)
        self._next = clock.now().nanoseconds + self._period
        while self._wait_until(self._follow_due):
            late = clock.now().nanoseconds - self._next
            if late > CATCH_UP * 1e9:
                # starved for longer than a chunk: drop the missed samples, do not burst
                self._node.get_logger().warning(f'publishing {late * 1e-9:.3f} s late; skipping '
                                                'the missed samples', throttle_duration_sec=5.0)
                self._next += (late // self._period) * self._period
            stamp = self._next
            self._run(lambda: self._sample(stamp))
            self._next += self._period

    def _woken(self) -> None:
        """Following ``/clock``: run the jobs the ROS timers ask for."""
        while True:
            with self._cv:
                while not self._jobs and not self._stopping:
                    self._cv.wait()
                if self._stopping:
                    return
                jobs, self._jobs = self._jobs, set()
            for job, work in (('follow', self._follow_tick), ('publish', self._publish_tick)):
                if job in jobs:
                    self._run(work)

    def _run(self, work) -> None:
        try:
            work()
        except Exception as exc:   # keep simulating; say why once a second
            if not self._node.context.ok():          # shutting down (SIGINT): stop quietly
                with self._cv:
                    self._stopping = True
                return
            self._node.get_logger().error(f'physics step failed: {exc!r}',
                                          throttle_duration_sec=1.0)
