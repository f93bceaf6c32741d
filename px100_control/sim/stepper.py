"""
The sim_driver's time keeping: an ArmSimulator advanced in fixed steps to a target time.

No ROS: the node clock's "now" [ns] is an argument, wall time [s] comes from a callable, and
what is due at a sample (publish the state, publish ``/clock``) is handed to callbacks. The
physics advances by the elapsed time in chunks (no dependence on timer precision). Two modes,
chosen at start:

- following a clock (``master`` False): the physics catches up to the clock's now, at most
  one publish period plus MAX_CHUNK at a time; further behind (a starved process),
  the rest of the time is dropped (``start_ns`` moves on) instead of falling further behind. A
  ``control_rate`` whose physics would need over MAX_PHYSICS_LOAD of a core is refused (the
  step cost is measured while running: about 44 us on a 2-core test machine, so ~18 kHz);
- owning the clock (``master`` True): simulated time advances from 0 at ``rtf`` x wall time (0
  or inf: as fast as possible, CHUNK_BUDGET of wall time per tick, ticks back to back); the
  node publishes it on ``/clock`` so nodes started with ``use_sim_time:=true`` follow it.

Times: ``sim_ns`` simulated time integrated so far [ns]; ``start_ns`` the node clock at
simulated time 0 [ns] (following a clock).
"""
import math
import time
from typing import Callable, Optional

#: physics chunk timer in clock-master mode [Hz]
TICK_RATE = 100.0
#: most simulated time one chunk may integrate before the driver drops time [s]
MAX_CHUNK = 0.5
#: wall-time budget of one chunk in clock-master mode [s]
CHUNK_BUDGET = 0.008
#: most of a CPU core the physics may need to follow the clock at a requested control_rate
MAX_PHYSICS_LOAD = 0.8


def period_ns(rate: float) -> int:
    """Return the period [ns] of a rate [Hz]."""
    return int(round(1e9 / rate))


class Stepper:
    """
    Advance ``sim`` (an ArmSimulator: ``step()``, ``dt`` [s]) in steps of ``dt_ns``.

    :param control_rate: physics rate [Hz]
    :param publish_rate: joint_states rate [Hz] (own clock: samples every 1/rate of sim time)
    :param clock_rate: ``/clock`` rate [Hz] of simulated time (own clock)
    :param rtf: real-time factor (own clock; 0 or inf: as fast as possible)
    :param master: True: own the clock; False: follow the clock given to :meth:`advance_to`
    :param warn: callable(text) for the "fell behind" warning
    :param wall: callable() -> monotonic wall time [s]
    """

    def __init__(self, sim, control_rate: float, publish_rate: float, clock_rate: float,
                 rtf: float, master: bool, warn: Optional[Callable[[str], None]] = None,
                 wall: Callable[[], float] = time.monotonic):
        self.sim = sim
        self.dt_ns = period_ns(control_rate)
        self.publish_rate = float(publish_rate)
        self.clock_rate = float(clock_rate)
        self.rtf = float(rtf)
        self.master = bool(master)
        self.sim_ns = 0
        self.start_ns = 0
        #: wall seconds of one physics step (fastest chunk seen; None until measured)
        self.step_cost: Optional[float] = None
        self.achieved_rtf = math.nan
        self._warn = warn or (lambda text: None)
        self._wall = wall
        self.wall_anchor = wall()
        self.sim_anchor_ns = 0
        self.next_pub_ns = period_ns(self.publish_rate)
        self.next_clock_ns = period_ns(self.clock_rate)
        #: callable() run before each physics step while set (e.g. a servo profile that moves
        #: the setpoints every step); None: the plain loop
        self.before_step: Optional[Callable[[], None]] = None

    @property
    def fast(self) -> bool:
        """Return True when owning the clock as fast as possible (rtf 0 or inf)."""
        return self.master and (self.rtf == 0.0 or math.isinf(self.rtf))

    @property
    def stamp_ns(self) -> int:
        """Return the stamp [ns] of the current state (simulated time when owning the clock)."""
        return self.sim_ns if self.master else self.start_ns + self.sim_ns

    def advance(self, steps: int) -> None:
        """Integrate ``steps`` physics steps; measure the step cost on chunks of 5 or more."""
        step = self.sim.step
        hook = self.before_step
        t0 = time.perf_counter()
        if hook is None:
            for _ in range(steps):
                step()
        else:
            for _ in range(steps):
                hook()
                step()
        self.sim_ns += steps * self.dt_ns
        if steps >= 5:   # the fastest chunk seen: what this machine needs per step, unloaded
            cost = (time.perf_counter() - t0) / steps
            if self.step_cost is None or cost < self.step_cost:
                self.step_cost = cost

    @property
    def max_chunk_s(self) -> float:
        """Return the most simulated time [s] one catch-up integrates: a period + MAX_CHUNK."""
        return 1.0 / self.publish_rate + MAX_CHUNK

    def capped_steps(self, behind_ns: int) -> int:
        """
        Return the physics steps to integrate ``behind_ns`` of simulated time.

        At most :attr:`max_chunk_s`: one publish period (between two samples that much is
        normally pending: publish_rate goes down to 0.1 Hz) plus MAX_CHUNK of lateness (a
        sample timer late by a few ms at 1 Hz dropped simulated time). Further behind (a
        starved process, or a control_rate this machine cannot integrate in real time), the
        rest of the time is dropped (``start_ns`` moves on): lateness and the time a caller's
        lock is held stay bounded.
        """
        steps = behind_ns // self.dt_ns
        max_steps = int(self.max_chunk_s * 1e9 // self.dt_ns)
        if steps > max_steps:
            self._warn(f'simulation fell {behind_ns * 1e-9:.3f} s behind the clock; '
                       'skipping ahead')
            self.start_ns += (steps - max_steps) * self.dt_ns
            steps = max_steps
        return int(steps)

    def advance_to(self, now_ns: int) -> None:
        """Follow the clock: integrate up to its ``now_ns`` [ns] (the first call sets 0)."""
        if self.start_ns == 0 and self.sim_ns == 0:
            self.start_ns = now_ns   # use_sim_time: the first /clock message sets the origin
        target = now_ns - self.start_ns
        if target < self.sim_ns:     # the clock jumped back (e.g. /clock restarted)
            self.start_ns = now_ns - self.sim_ns
            return
        self.advance(self.capped_steps(target - self.sim_ns))

    def advance_to_sample(self, stamp_ns: int) -> int:
        """
        Integrate up to the sample time ``stamp_ns`` [ns] (clock time); return the state's stamp.

        That is the nominal sample time, or later when a command already made the physics catch
        up beyond it.
        """
        steps = self.capped_steps(stamp_ns - self.start_ns - self.sim_ns)
        if steps > 0:
            self.advance(steps)
        return self.start_ns + self.sim_ns

    def set_control_rate(self, rate: float) -> None:
        """Change the physics rate [Hz] (the step of ``sim`` too)."""
        self.sim.dt = 1.0 / rate
        self.dt_ns = period_ns(rate)

    def set_rtf(self, rtf: float) -> None:
        """Change the real-time factor from now on (own clock)."""
        self.rtf = float(rtf)
        self.wall_anchor = self._wall()
        self.sim_anchor_ns = self.sim_ns

    def load_error(self, rate: float) -> Optional[str]:
        """Return why the physics could not follow the clock at ``rate`` [Hz], or None."""
        cost = self.step_cost
        if cost is None or self.master or rate * cost <= MAX_PHYSICS_LOAD:
            return None
        return (f'control_rate {rate:g} Hz: one physics step takes {cost * 1e6:.0f} us here, '
                'so the simulation could not keep up with the clock (at most '
                f'{MAX_PHYSICS_LOAD / cost:.0f} Hz on this machine)')

    def master_tick(self, on_clock: Callable[[int], None],
                    on_sample: Callable[[int], None]) -> None:
        """
        Own clock: advance simulated time to ``rtf`` x the wall time since the anchor.

        Calls ``on_clock(sim_ns)`` at every ``/clock`` period and ``on_sample(sim_ns)`` at every
        publish period of simulated time; stops after the tick's wall-time budget.
        """
        wall0 = self._wall()
        fast = self.fast
        target = (math.inf if fast
                  else self.sim_anchor_ns + (wall0 - self.wall_anchor) * self.rtf * 1e9)
        start_ns = self.sim_ns
        budget_end = wall0 + (CHUNK_BUDGET if fast else 0.8 / TICK_RATE)
        while self.sim_ns + self.dt_ns <= target:
            self._master_chunk(target, fast, on_clock, on_sample)
            if self._wall() > budget_end:
                break
        wall1 = self._wall()
        if not fast and self.sim_ns + 2 * self.dt_ns < target:
            # cannot keep up: re-anchor so the debt does not grow without bound
            self.wall_anchor, self.sim_anchor_ns = wall1, self.sim_ns
        if wall1 > wall0:
            self.achieved_rtf = (self.sim_ns - start_ns) * 1e-9 / (wall1 - wall0)

    def _master_chunk(self, target: float, fast: bool, on_clock, on_sample) -> None:
        """
        Integrate up to the next event (at most 50 steps) and hand out what is due.

        As fast as possible the chunk runs to the next state sample: ``/clock`` carries only a
        time, so its ticks passed on the way are handed out after the chunk, each with the
        stamp it would have had (the first step at or after it). Longer runs of steps are
        cheaper (measured in the driver: 38 us per step in chunks of 4, 23 us in a loop).
        """
        next_event = self.next_pub_ns if fast else min(self.next_pub_ns, self.next_clock_ns)
        steps = max(1, (next_event - self.sim_ns) // self.dt_ns)
        if not fast:
            steps = min(steps, int((target - self.sim_ns) // self.dt_ns))
        self.advance(int(min(steps, 50)))
        while self.sim_ns >= self.next_clock_ns:
            stamp = min(-(-self.next_clock_ns // self.dt_ns) * self.dt_ns, self.sim_ns)
            on_clock(stamp)
            self.next_clock_ns = _next_due(self.next_clock_ns, stamp,
                                           period_ns(self.clock_rate))
        if self.sim_ns >= self.next_pub_ns:
            on_sample(self.sim_ns)
            self.next_pub_ns = _next_due(self.next_pub_ns, self.sim_ns,
                                         period_ns(self.publish_rate))


def _next_due(due_ns: int, now_ns: int, period: int) -> int:
    """Return the next due time [ns] after ``now_ns`` on the grid ``due_ns`` + k * period."""
    return due_ns + period * max(1, (now_ns - due_ns) // period + 1)
