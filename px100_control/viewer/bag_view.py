"""
Play a recorded bag in the viewer's page, with a time slider (no ROS graph needed).

The bag is read with :mod:`px100_control.bag.reader`: ``robot_description`` (the URDF drawn),
``joint_states``, ``world/markers`` and ``world/held_object`` of one robot namespace, and the
goals (path and target), goal statuses, IK targets and errors the live viewer shows, from the
action's and ``compute_ik``'s events or an older bag's topics
(:mod:`px100_control.viewer.bag_calls`). The page is read-only; a slider picks the time [s from
the bag's start], a Play checkbox runs it at the chosen speed. The trail shows the end effector
over the last ``trail_s`` seconds.
"""
import bisect
from dataclasses import dataclass, field
import sys
import time
from typing import Callable, List, Optional, Tuple

from px100_control.bag.reader import BagReader
from px100_control.errors import BagError
from px100_control.viewer.bag_calls import CallTimeline
from px100_control.viewer.scene import ViewerScene
from px100_control.viewer.state import ViewerState


@dataclass
class BagTimeline:
    """What a bag holds for the viewer; times are seconds from the bag's first message."""

    path: str
    namespace: str
    urdf_xml: str
    duration: float
    joint_times: List[float] = field(default_factory=list)
    joint_samples: List[Tuple[tuple, tuple, float]] = field(default_factory=list)
    marker_times: List[float] = field(default_factory=list)
    marker_sets: List[list] = field(default_factory=list)
    held_times: List[float] = field(default_factory=list)
    held_names: List[str] = field(default_factory=list)
    calls: CallTimeline = field(default_factory=CallTimeline)

    def index(self, times: List[float], t: float) -> int:
        """Return the index of the last sample at or before t (-1 if none)."""
        return bisect.bisect_right(times, t) - 1

    def joints_at(self, t: float) -> dict:
        """Return the recorded joints {name: value} at time t [s] (the first sample before)."""
        names, positions, _ = self.joint_samples[max(0, self.index(self.joint_times, t))]
        return dict(zip(names, positions))


def _find_topic(topics, name: str, namespace: Optional[str]) -> Optional[str]:
    wanted = f'/{namespace.strip("/")}/{name}' if namespace else None
    if wanted:
        return wanted if wanted in topics else None
    matches = sorted(t for t in topics if t == '/' + name or t.endswith('/' + name))
    return matches[0] if matches else None


def _decodable(bag: BagReader, topic: str) -> bool:
    """Return True if the bag holds a usable definition of the topic's type."""
    try:
        bag.decoder(bag.topics[topic])
        return True
    except BagError:
        return False


def _decoded(bag: BagReader, raw):
    try:
        return bag.decode(raw)
    except BagError:
        return None


def load_bag(path: str, namespace: Optional[str] = None) -> BagTimeline:
    """
    Read what the viewer needs from a bag.

    :param namespace: robot namespace ('px100'); None = the first joint_states topic's
    :raises BagError: unreadable bag, or no joint_states / robot_description in it
    """
    with BagReader(path) as bag:
        js = _find_topic(bag.topics, 'joint_states', namespace)
        if js is None:
            raise BagError(f'{path}: no joint_states topic to view '
                           f'(topics: {", ".join(sorted(bag.topics)) or "none"})')
        ns = js[:-len('joint_states')].rstrip('/')
        desc = f'{ns}/robot_description'
        markers, held = f'{ns}/world/markers', f'{ns}/world/held_object'
        if desc not in bag.topics:
            raise BagError(f'{path}: no {desc} in the bag: the viewer draws the recorded URDF')
        calls = {t: k for t, k in CallTimeline.topics(ns, bag.topics).items()
                 if _decodable(bag, t)}
        wanted = [t for t in (js, desc, markers, held) if t in bag.topics] + list(calls)
        timeline = BagTimeline(path=path, namespace=ns.strip('/'), urdf_xml='', duration=0.0)
        t0 = None
        for raw in bag.iter_raw(wanted):
            t0 = raw.log_time_ns if t0 is None else t0
            t = (raw.log_time_ns - t0) * 1e-9
            timeline.duration = max(timeline.duration, t)
            if raw.topic in calls:      # a message that cannot be decoded is left out
                msg = _decoded(bag, raw)
                if msg is not None:
                    timeline.calls.add(calls[raw.topic], t, msg)
                continue
            msg = bag.decode(raw)
            if raw.topic == js:
                timeline.joint_times.append(t)
                stamp = float(msg.header.stamp.sec) + 1e-9 * float(msg.header.stamp.nanosec)
                timeline.joint_samples.append((tuple(msg.name), tuple(msg.position), stamp))
            elif raw.topic == desc and not timeline.urdf_xml:
                timeline.urdf_xml = str(msg.data)
            elif raw.topic == markers:
                timeline.marker_times.append(t)
                timeline.marker_sets.append(list(msg.markers))
            elif raw.topic == held:
                timeline.held_times.append(t)
                timeline.held_names.append(str(msg.data))
    timeline.calls.finish()
    if not timeline.joint_samples:
        raise BagError(f'{path}: {js} has no messages')
    if not timeline.urdf_xml:
        raise BagError(f'{path}: {desc} has no message')
    return timeline


def state_at(timeline: BagTimeline, state: ViewerState, t: float, trail_s: float = 10.0,
             trail_step_s: float = 0.05) -> None:
    """Set state to the bag at time t [s]: joints, world, held object, trail, goals and IK."""
    if state.urdf_xml != timeline.urdf_xml:
        state.set_robot(timeline.urdf_xml)
    k = max(0, timeline.index(timeline.joint_times, t))
    names, positions, stamp = timeline.joint_samples[k]
    state.trail.clear()
    if state.fk is not None:
        t_from = max(0.0, t - trail_s)
        j = max(0, timeline.index(timeline.joint_times, t_from))
        next_t = -1.0
        for i in range(j, k + 1):
            ti = timeline.joint_times[i]
            if ti >= next_t:
                n, p, _ = timeline.joint_samples[i]
                pose = state.fk(dict(zip(n, p)))
                if pose is not None:
                    state.trail.add(pose[0])
                next_t = ti + trail_step_s
        state.version['trail'] += 1
    state.set_joints(names, positions, stamp)
    m = timeline.index(timeline.marker_times, t)
    state.bodies = {}
    if m >= 0:
        state.set_markers(timeline.marker_sets[m])
    state.version['world'] += 1
    h = timeline.index(timeline.held_times, t)
    state.set_held(timeline.held_names[h] if h >= 0 else '')
    timeline.calls.apply(state, t, timeline.joints_at)


def serve_bag(path: str, host: str = '127.0.0.1', port: int = 8080,
              namespace: Optional[str] = None, rate: float = 30.0,
              stop_after: Optional[float] = None,
              stop: Optional[Callable[[], bool]] = None) -> int:
    """
    Serve a bag's page until Ctrl-C, ``stop()`` returns True or stop_after [s]; return the status.

    A bag the viewer cannot use: one error line and status 1.
    """
    try:
        timeline = load_bag(path, namespace)
    except BagError as exc:
        print(f'viewer: {exc}', file=sys.stderr)
        return 1
    scene = ViewerScene(host=host, port=port, read_only=True,
                        title=f'{timeline.namespace or "bag"}: {path}')
    state = ViewerState()
    scene.attach(state)
    state.set_robot(timeline.urdf_xml)
    scene.load_robot(state)
    gui = scene.server.gui
    slider = gui.add_slider('time [s]', min=0.0, max=max(timeline.duration, 1e-3), step=0.01,
                            initial_value=0.0, order=-2)
    play = gui.add_checkbox('Play', False, order=-1)
    speed = gui.add_slider('speed', min=0.1, max=4.0, step=0.1, initial_value=1.0, order=-1)
    if scene.port != int(port):
        print(f'viewer: port {port} is busy: serving on {scene.port}', file=sys.stderr)
    print(f'viewer: {path} ({timeline.duration:.1f} s) on {scene.url}', flush=True)
    start = time.monotonic()
    last_t, last = None, time.monotonic()
    try:
        while (stop_after is None or time.monotonic() - start < stop_after) and not (
                stop is not None and stop()):
            now = time.monotonic()
            if play.value:
                t = slider.value + (now - last) * speed.value
                if t >= timeline.duration:
                    t, play.value = timeline.duration, False
                slider.value = round(t, 2)
            last = now
            if slider.value != last_t:
                last_t = slider.value
                state_at(timeline, state, float(slider.value))
            scene.render(state, now)
            time.sleep(1.0 / rate)
    except KeyboardInterrupt:
        pass
    finally:
        scene.close()
    return 0
