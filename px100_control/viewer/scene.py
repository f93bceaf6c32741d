"""
Draw a :class:`~px100_control.viewer.state.ViewerState` in the browser with viser.

viser serves its own web client (bundled in the wheel, works offline) over HTTP + websocket.
The robot comes from its URDF text through viser's URDF support (yourdfpy); world bodies,
trail, trajectory path, IK target and a status panel are viser scene nodes and GUI elements.
The scene root is the robot's base frame, +z up; units m, rad.

Controls (absent in read-only mode) report the user's actions through ``actions``, a callable
``actions(name, **values)``; the adapter turns them into ROS messages. Names: ``joint_goal``
(positions: dict joint -> rad/m), ``ee_target`` (position xyz [m], quat_xyzw or None = free),
and ``home``, ``sleep``, ``gripper_open``, ``gripper_close``, ``reset_scene``, ``torque_on``,
``torque_off``. They run in viser's threads: the adapter must hand them to its own thread.

Cost: :meth:`ViewerScene.render` does nothing while no browser is connected (no kinematics,
no messages); a browser that connects gets everything redrawn. A render sends one atomic batch
and flushes it (no wait for viser's next send window).

Safety: viser's Share button (a public tunnel through share.viser.studio) is hidden and the
server refuses share requests from any page, so the page is reachable only where it is bound.
The page's handlers run through ``guard`` (a :class:`~px100_control.viewer.guard.Guard`): a
fault is reported, never raised into viser's threads.
"""
import io
import sys
import threading
import time
from typing import Callable, Dict, Optional, Sequence, Tuple

import numpy as np

from px100_control.viewer.guard import Guard
from px100_control.viewer.robot import UrdfRobot
from px100_control.viewer.state import markdown_literal, ViewerState

#: buttons of the controls panel: (action name, label)
BUTTONS = (('home', 'Home'), ('sleep', 'Sleep'), ('gripper_open', 'Open gripper'),
           ('gripper_close', 'Close gripper'), ('reset_scene', 'Reset scene'),
           ('torque_on', 'Torque on'), ('torque_off', 'Torque off'))
#: seconds after the user's last slider or gizmo input before they follow the robot again
FOLLOW_DELAY = 1.5
#: joint slider step [rad or m]; the value box (3 rem wide in viser) shows what fits: '-1.88'
SLIDER_STEP = 0.01


def _on_step(value: float) -> float:
    """Return value rounded to the slider step (the box shows every digit it is sent)."""
    return round(round(float(value) / SLIDER_STEP) * SLIDER_STEP, 6)


def _wxyz(quat_xyzw: Sequence[float]) -> Tuple[float, float, float, float]:
    x, y, z, w = (float(v) for v in quat_xyzw)
    return (w, x, y, z)


def _rgb255(rgba: Sequence[float]) -> Tuple[int, int, int]:
    return tuple(int(round(255 * min(1.0, max(0.0, float(c))))) for c in rgba[:3])


def _refuse_share_url(*args, **kwargs) -> None:
    """Stand in for ViserServer.request_share_url: no public tunnel, ever (returns None)."""
    return None


def disable_sharing(server) -> None:
    """
    Hide viser's Share button and make the server refuse share-URL requests.

    The page's Share button would open a public tunnel (share.viser.studio) to this server,
    around its bind address and read-only rule. The client->server ShareUrlRequest and
    ShareUrlDisconnect handlers are removed (a page that sends one anyway gets nothing) and
    request_share_url returns None.
    """
    from viser import _messages  # optional: viser is loaded with the scene
    server.gui.configure_theme(show_share_button=False)
    websock = server._websock_server       # viser 1.1.1 (pinned): where client messages land
    for message in (_messages.ShareUrlRequest, _messages.ShareUrlDisconnect):
        try:
            websock.unregister_handler(message)
        except AssertionError:             # not registered: nothing to refuse
            pass
    server.request_share_url = _refuse_share_url


def _drawn_urdf(urdf_xml: str):
    """Return the yourdfpy URDF with visual meshes and scene graph that viser draws."""
    import yourdfpy  # optional: with trimesh ~0.5 s to import, loaded with a URDF
    try:
        return yourdfpy.URDF.load(io.BytesIO(urdf_xml.encode('utf-8')), build_scene_graph=True,
                                  build_collision_scene_graph=False, load_meshes=True,
                                  load_collision_meshes=False)
    except Exception as exc:  # noqa: B902 - yourdfpy/lxml raise many kinds
        raise ValueError(f'robot_description is not a usable URDF: {exc}') from None


class ViewerScene:
    """
    The page: a viser server drawing a ViewerState, with optional controls.

    :param host/port: where viser listens (127.0.0.1 unless asked otherwise); when the port is
        busy viser takes the next free one: :attr:`port` is the one bound
    :param read_only: no sliders, buttons or gizmo at all
    :param actions: callable(name, **values) for the user's actions (see the module doc)
    :param guard: wraps the page's handlers (default: faults printed to stderr)
    :param server: an existing viser server to draw into (then host/port are unused)

    The joint sliders are the arm joints of the loaded URDF (:meth:`load_robot`), with its
    limits.
    """

    def __init__(self, host: str = '127.0.0.1', port: int = 8080, read_only: bool = True,
                 actions: Optional[Callable] = None, title: str = 'px100_control',
                 server=None, guard: Optional[Guard] = None):
        import viser  # optional: ~1 s to import, loaded with the scene
        self.server = server or viser.ViserServer(host=host, port=port, label=title,
                                                  verbose=False)
        disable_sharing(self.server)
        self.host = str(host)
        self.guard = guard or Guard(lambda text: print(f'viewer: {text}', file=sys.stderr))
        self.read_only = bool(read_only)
        self.actions = actions or (lambda name, **values: None)
        self._lock = threading.RLock()
        self._drawn: Dict[str, int] = {}
        self._urdf_vis = None
        self._moving = None
        self._posed: Dict[str, float] = {}
        self.kin: Optional[UrdfRobot] = None
        self._bodies: Dict = {}
        self._handles: Dict = {}
        self._redraw = False
        self._last_user_input = -1e9
        self._dragging = False
        self.server.initial_camera.position = (0.26, -0.30, 0.22)
        self.server.initial_camera.look_at = (0.12, 0.0, 0.08)
        self.server.scene.add_grid('/grid', width=1.0, height=1.0, cell_size=0.05,
                                   section_size=0.25)
        self.status = self.server.gui.add_markdown('state t = 0.000000 s', order=0)
        self.sliders = {}
        self.buttons = {}
        self.gizmo = None
        self.orientation_box = None
        self._joints_folder = None
        if not self.read_only:
            self._add_controls()
        self.server.on_client_connect(self.guard.wrap(self._on_connect))

    @property
    def port(self) -> int:
        """Return the TCP port the page is served on (the one bound, not the one asked)."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """Return the page's address, http://host:port with the bound port."""
        return f'http://{self.host}:{self.port}'

    # -- controls ----------------------------------------------------------------------------
    def _add_controls(self) -> None:
        gui, wrap = self.server.gui, self.guard.wrap
        self._joints_folder = gui.add_folder('Joints', order=1)
        with gui.add_folder('Actions', order=2):
            for action, label in BUTTONS:
                b = gui.add_button(label)
                b.on_click(wrap(lambda event, a=action: self._user(a), f'{action} button'))
                self.buttons[action] = b
            self.orientation_box = gui.add_checkbox(
                'Gizmo orientation', False,
                hint='rotate the gizmo and send its orientation to IK (off: position only, '
                     'orientation free)')
        self.gizmo = self.server.scene.add_transform_controls(
            '/ee_target_gizmo', scale=0.1, line_width=3.0, depth_test=False,
            disable_rotations=True)
        self.gizmo.on_update(wrap(self._on_gizmo))
        self.orientation_box.on_update(wrap(self._on_orientation_box))

    def _set_sliders(self, arm) -> None:
        """Replace the joint sliders by one per arm joint of the URDF, within its limits."""
        for s in self.sliders.values():
            s.remove()
        self.sliders = {}
        if self._joints_folder is None:
            return
        with self._joints_folder:
            for name, lo, hi in zip(arm.joint_names, arm.lower, arm.upper):
                s = self.server.gui.add_slider(
                    name, min=lo, max=hi, step=SLIDER_STEP,
                    initial_value=_on_step(min(max(0.0, lo), hi)),
                    marks=((lo, f'{lo:.2f}'), (hi, f'{hi:.2f}')))
                s.on_update(self.guard.wrap(self._on_slider))
                self.sliders[name] = s

    def show_button(self, action: str, visible: bool) -> None:
        """Show or hide one action button (no effect on a read-only page)."""
        if action in self.buttons:
            self.buttons[action].visible = bool(visible)

    def _now(self) -> float:
        return time.monotonic()

    def _user(self, action: str, **values) -> None:
        self._last_user_input = self._now()
        self.actions(action, **values)

    def _on_slider(self, event) -> None:
        if event.client is None:      # set by the server (following the robot)
            return
        self._user('joint_goal', positions={n: float(s.value) for n, s in self.sliders.items()})

    def _on_gizmo(self, event) -> None:
        if event.client is None:
            return
        self._dragging = event.phase != 'end'
        w, x, y, z = (float(v) for v in event.target.wxyz)
        quat = (x, y, z, w) if self.orientation_box is not None and \
            self.orientation_box.value else None
        self._user('ee_target', position=tuple(float(v) for v in event.target.position),
                   quat_xyzw=quat)

    def _on_orientation_box(self, event) -> None:
        self.gizmo.disable_rotations = not self.orientation_box.value

    def _on_connect(self, client) -> None:
        # no lock here: viser may call this while it holds its own locks, which render()
        # takes after self._lock
        self._redraw = True            # everything is redrawn at the next render

    # -- drawing -----------------------------------------------------------------------------
    def has_clients(self) -> bool:
        """Return True while at least one browser is connected."""
        return bool(self.server.get_clients())

    def attach(self, state: ViewerState) -> None:
        """Let state compute end-effector poses through this scene's robot kinematics."""
        state.fk = lambda q: self.kin.ee_pose(q) if self.kin is not None else None

    def render(self, state: ViewerState, now: float, force: bool = False) -> bool:
        """
        Send what changed in state since the last render; return True if anything was sent.

        Nothing happens while no browser is connected (unless force): the trail grows only
        here, one end-effector pose per drawn state. now [s] decides when the controls follow
        the robot again after the user's last input.
        """
        if not force and not self.has_clients():
            return False
        with self._lock:
            if self._redraw:
                self._redraw = False
                self._drawn.clear()
            state.update_trail()
            changed = [p for p in state.PARTS if self._drawn.get(p) != state.version[p]]
            if not changed:
                return False
            with self.server.atomic():
                for part in changed:
                    getattr(self, '_draw_' + part)(state, now)
                    self._drawn[part] = state.version[part]
            self.server.flush()        # send now, not at viser's next window
        return True

    def load_robot(self, state: ViewerState) -> None:
        """
        (Re)load the robot of state.urdf_xml and its joint sliders.

        A URDF that cannot be used is reported in state.robot_error (the page says why).
        """
        from viser.extras import ViserUrdf  # optional: viser is loaded with the scene
        with self._lock:
            if self._urdf_vis is not None:
                self._urdf_vis.remove()
                self._urdf_vis, self._moving = None, None
            try:
                self.kin = UrdfRobot(state.urdf_xml)
                drawn = _drawn_urdf(state.urdf_xml)
                self._urdf_vis = ViserUrdf(self.server, drawn, root_node_name='/robot')
                state.robot_error = ''
            except ValueError as exc:
                self.kin = None
                state.robot_error = str(exc)
            else:
                self._place_frames(drawn)
                self._set_sliders(self.kin.arm)
            state.version['status'] += 1
            self._drawn.pop('joints', None)

    def _place_frames(self, drawn) -> None:
        """Pose every link frame once at q = 0; keep the moving ones for :meth:`_pose_robot`."""
        self._urdf_vis.update_cfg(dict.fromkeys(drawn.actuated_joint_names, 0.0))
        joints = getattr(self._urdf_vis, '_joint_map_values', None)   # viser 1.1.1's
        frames = getattr(self._urdf_vis, '_joint_frames', None)
        if joints is not None and frames is not None and len(joints) == len(frames):
            self._moving = [(j.name, f) for j, f in zip(joints, frames)
                            if j.name in self.kin.joints]
            self._posed = {}

    def _pose_robot(self, joints: Dict[str, float]) -> None:
        """Move the drawn robot's moving links to joints (only those frames are sent)."""
        if self._moving is None:
            self._urdf_vis.update_cfg({n: v for n, v in joints.items()
                                       if n in self.kin.actuated})
            return
        for name, frame in self._moving:
            value = self.kin.value(name, joints)
            if value is None or abs(value - self._posed.get(name, float('nan'))) < 1e-6:
                continue        # unknown or unchanged (nan: never posed) -> nothing to send
            self._posed[name] = value
            xyz, wxyz = self.kin.local_pose(name, value)
            if self.kin.joints[name].kind == 'prismatic':
                frame.position = xyz
            else:           # a rotation about the joint's origin: the position never changes
                frame.wxyz = wxyz

    def _draw_robot(self, state: ViewerState, now: float) -> None:
        if state.urdf_xml and (self.kin is None or self._urdf_vis is None) and \
                not state.robot_error:
            self.load_robot(state)

    def _draw_joints(self, state: ViewerState, now: float) -> None:
        if self._urdf_vis is None or not state.joints:
            return
        self._pose_robot(state.joints)
        following = now - self._last_user_input > FOLLOW_DELAY and not self._dragging
        if not following:
            return
        for name, slider in self.sliders.items():
            v = state.joints.get(name)
            if v is not None and abs(v - slider.value) > 0.005:
                slider.value = _on_step(min(max(v, slider.min), slider.max))
        if self.gizmo is not None:
            pose = state.ee_pose()
            if pose is not None and np.linalg.norm(np.subtract(pose[0], self.gizmo.position)) \
                    > 0.002:
                self.gizmo.position = pose[0]
                self.gizmo.wxyz = _wxyz(pose[1])

    def _draw_world(self, state: ViewerState, now: float) -> None:
        scene = self.server.scene
        seen = set()
        for key, body in state.bodies.items():
            node = f'/world/{body.ns}/{body.name}'
            seen.add(node)
            old = self._bodies.get(node)
            shape_key = (body.shape, body.size, body.rgba, body.name == state.held)
            if old is None or old[0] != shape_key:
                if old is not None:
                    old[1].remove()
                color = _rgb255(body.rgba)
                opacity = body.rgba[3] if body.rgba[3] < 1.0 else None
                kw = {'position': body.position, 'wxyz': _wxyz(body.quat_xyzw)}
                if body.shape == 'box':
                    h = scene.add_box(node, color=color, dimensions=body.size,
                                      opacity=opacity, **kw)
                elif body.shape == 'cylinder':
                    h = scene.add_cylinder(node, radius=body.size[0], height=body.size[1],
                                           color=color, opacity=opacity, **kw)
                else:
                    h = scene.add_icosphere(node, radius=body.size[0], color=color,
                                            opacity=opacity, **kw)
                self._bodies[node] = (shape_key, h)
            else:
                h = old[1]
                h.position = body.position
                h.wxyz = _wxyz(body.quat_xyzw)
        for node in [n for n in self._bodies if n not in seen]:
            self._bodies.pop(node)[1].remove()
        self._remove('/world/held_label')
        held = [b for b in state.bodies.values() if state.held and b.name == state.held]
        if held:
            x, y, z = held[0].position
            self._handles['/world/held_label'] = scene.add_label(
                '/world/held_label', f'held: {held[0].name}', position=(x, y, z + 0.04))

    def _remove(self, name: str) -> None:
        handle = self._handles.pop(name, None)
        if handle is not None:
            handle.remove()

    def _lines(self, name: str, points, color, thickness: float) -> None:
        if len(points) < 2:
            self._remove(name)
            return
        pts = np.asarray(points, dtype=np.float32)
        segments = np.stack([pts[:-1], pts[1:]], axis=1)
        handle = self._handles.get(name)
        if handle is None:
            self._handles[name] = self.server.scene.add_line_segments(
                name, segments, colors=color, thickness=thickness, thickness_units='screen')
        else:       # update in place: the page keeps its node instead of rebuilding it
            handle.colors = np.tile(np.asarray(color, dtype=np.uint8), (len(segments), 2, 1))
            handle.points = segments

    def _draw_trail(self, state: ViewerState, now: float) -> None:
        self._lines('/trail', list(state.trail.points), (255, 140, 0), 2.0)

    def _draw_path(self, state: ViewerState, now: float) -> None:
        self._lines('/trajectory/path', state.path, (30, 110, 255), 3.0)
        self._remove('/trajectory/target')
        if state.path and state.target is not None:
            self._handles['/trajectory/target'] = self.server.scene.add_icosphere(
                '/trajectory/target', radius=0.008, color=(30, 110, 255),
                position=state.target)

    def _draw_ik(self, state: ViewerState, now: float) -> None:
        self._remove('/ik_target')
        if state.ik_target is None:
            return
        xyz, quat = state.ik_target
        if any(quat):
            self._handles['/ik_target'] = self.server.scene.add_frame(
                '/ik_target', axes_length=0.04, axes_radius=0.002, position=xyz,
                wxyz=_wxyz(quat))
        else:
            self._handles['/ik_target'] = self.server.scene.add_icosphere(
                '/ik_target', radius=0.007, color=(200, 0, 200), position=xyz)

    def _draw_status(self, state: ViewerState, now: float) -> None:
        lines = (markdown_literal(line) for line in state.status_lines())
        self.status.content = '  \n'.join(lines)    # '  \n': a Markdown line break

    def close(self) -> None:
        """Stop the web server."""
        self.server.stop()
