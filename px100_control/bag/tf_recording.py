"""
The /tf (and, failing a published one, the robot_description) a recorder adds to its bag.

Pure (no rclpy): the recorder hands over the raw bytes of ``joint_states``, ``world/markers``
and ``robot_description`` as it records them; the decoding is injected (the ROS side passes
rclpy's deserializer, a test a plain function), so the clock and the middleware stay outside.

- ``joint_states`` become ``/tf`` through the URDF: the published robot_description once one is
  usable, else the robot model's URDF with links prefixed ``<robot_name>/``. The model is
  parsed in a background thread (a few seconds at start-up); joint states arriving meanwhile
  wait in a backlog (at most TF_BACKLOG) and get their /tf when it is ready or at close.
- ``world/markers`` become the objects' frames ``<robot_name>/objects/<name>``, children of the
  markers' frame ``<robot_name>/base_link``.
- Both at most one /tf message per ``period_ns`` of log time each; stamps are the messages'
  header stamps (their log time [ns since the epoch] when zero). Translations [m], quaternions
  (x, y, z, w).
- A live /tf wins: ``live()`` (injected; the recorder asks the graph whether /tf has a
  publisher, e.g. robot_state_publisher) is asked before each computed /tf is written; once it
  says yes, no /tf is computed any more (the backlog is dropped) and the recorder records the
  live /tf and /tf_static as they are, so the bag never holds the same frames from two
  sources. Graphs without a /tf publisher (older bringups) keep the computed /tf.
"""
import threading
import time
from typing import Callable, List, Optional, Tuple

from px100_control.bag.recording import DESCRIPTION_QOS, TF_QOS, TF_TOPIC
from px100_control.bag.tf import description_tree, encode_tf_message, TF_TYPE, TfTree
from px100_control.bag.world import object_tf_entries, WorldMarker
from px100_control.bag.writer import BagWriter
from px100_control.errors import BagError, Px100Error
from px100_control.models.registry import load_robot
from px100_control.models.urdf_prefix import prefix_urdf
from px100_control.models.urdf_writer import urdf_from_model
from px100_control.wire.cdr import string_message

#: joint states kept for /tf while the URDF is being parsed at start-up
TF_BACKLOG = 20000
#: without a published robot_description, the model's is written this long [s] after the
#: first joint_states
DESCRIPTION_WAIT_S = 1.5

#: decode(bytes) -> ({joint name: position [rad or m]}, header stamp [ns])
JointStateDecoder = Callable[[bytes], Tuple[dict, int]]
#: decode(bytes) -> (markers, stamp of the first marker [ns])
MarkerDecoder = Callable[[bytes], Tuple[List[WorldMarker], int]]


class TfRecording:
    """
    Write /tf from joint states and world markers into a bag (see the module docstring).

    :param bag: the bag being written
    :param robot_name: frame prefix ``<robot_name>/`` ('' for none)
    :param model_name: registered robot model whose URDF serves when none is published
    :param period_ns: shortest log-time gap between two /tf messages of one source [ns]
    :param decode_joint_state: see JointStateDecoder (raises on a malformed message)
    :param decode_markers: see MarkerDecoder (raises on a malformed message)
    :param decode_string: decode(bytes) -> str of a std_msgs/String
    :param encode_string: encode(str) -> bytes of a std_msgs/String (the model's
        robot_description when none is published)
    :param log: log(level 'info' | 'warning', text)
    :param prefix: the robot's topics start with it (``/px100/``): ``<prefix>joint_states``,
        ``<prefix>world/markers``, ``<prefix>robot_description``
    :param enabled: write /tf at all (False: only the description fallback)
    :param live: live() -> True when the graph has a /tf publisher of its own (then this
        stops writing /tf for good)
    """

    def __init__(self, bag: BagWriter, robot_name: str, model_name: str, period_ns: int,
                 decode_joint_state: JointStateDecoder, decode_markers: MarkerDecoder,
                 decode_string: Callable[[bytes], str], log: Callable[[str, str], None],
                 prefix: str, enabled: bool = True,
                 encode_string: Callable[[str], bytes] = string_message,
                 live: Callable[[], bool] = lambda: False):
        self.bag, self.robot_name, self.model_name = bag, robot_name, model_name
        self.js_topic = prefix + 'joint_states'
        self.markers_topic = prefix + 'world/markers'
        self.description_topic = prefix + 'robot_description'
        self.period_ns = int(period_ns)
        self._decode_js, self._decode_markers = decode_joint_state, decode_markers
        self._decode_string, self._log = decode_string, log
        self._encode_string = encode_string
        #: False once it is known that no /tf can be written (no URDF)
        self.enabled = bool(enabled)
        self.tree: Optional[TfTree] = None
        self.model_tree: Optional[TfTree] = None
        self.model_urdf: Optional[str] = None
        self.model_ready = threading.Event()
        self.backlog: List[tuple] = []
        self.description_seen = False
        #: monotonic time [s] of the first joint_states
        self.first_js_at: Optional[float] = None
        self._last_tf_ns = 0
        self._last_object_tf_ns = 0
        self._live = live
        #: True once a live /tf publisher was seen (this writes no /tf since)
        self.live_seen = False

    # -- URDF sources ---------------------------------------------------------------------------
    def load_model(self) -> None:
        """Load the robot model's URDF and its tf tree (run it in a background thread)."""
        try:
            model = load_robot(self.model_name)
            urdf = model.urdf_xml or urdf_from_model(model)
            self.model_urdf = urdf
            self.model_tree = TfTree(urdf, f'{self.robot_name}/' if self.robot_name else '')
        except Exception as exc:  # no URDF for this model: record without /tf
            self._log('warning', f'robot model {self.model_name}: no URDF for /tf ({exc})')
        finally:
            self.model_ready.set()

    def start_loading(self) -> None:
        """Load the model in a daemon thread: recording starts at once."""
        threading.Thread(target=self.load_model, name='px100_recorder_model',
                         daemon=True).start()

    def description(self, data: bytes) -> None:
        """Take a recorded robot_description: /tf uses it once parsed (in a thread)."""
        self.description_seen = True
        if not self.enabled:
            return
        try:
            urdf = self._decode_string(data)
        except Exception:  # not a String after all: /tf keeps using the robot model
            return
        # parsing a URDF can take a while (yourdfpy): never in the executor's thread
        threading.Thread(target=self.use_description, args=(urdf,), daemon=True,
                         name='px100_recorder_urdf').start()

    def use_description(self, urdf: str) -> None:
        """Build the /tf tree from a published robot_description."""
        try:
            tree = description_tree(urdf, self.robot_name)
        except Px100Error as exc:
            self._log('warning', f'robot_description is not a usable URDF ({exc}); '
                                 '/tf uses the robot model')
            return
        self.tree = tree

    # -- /tf ----------------------------------------------------------------------------------
    def take(self, topic: str, data: bytes, log_ns: int, now: float,
             description: bool = True) -> None:
        """
        Use one recorded message (log time [ns], monotonic ``now`` [s]).

        joint_states and world/markers give /tf; a robot_description gives its URDF (unless
        ``description`` is False).
        """
        if topic == self.js_topic and self.enabled:
            self.joint_states(data, log_ns, now)
        elif topic == self.markers_topic and self.enabled:
            self.markers(data, log_ns)
        elif description and topic == self.description_topic:
            self.description(data)

    def _live_now(self) -> bool:
        """Return True (and stop computing /tf for good) once the graph has a /tf publisher."""
        try:
            live = bool(self._live())
        except Exception as exc:  # the graph cannot be asked (shutting down): go on as before
            self._log('debug', f'/tf publishers cannot be counted ({exc})')
            return False
        if live:
            self.enabled, self.live_seen, self.backlog = False, True, []
            self._log('info', '/tf has a live publisher: recording it; no /tf is computed '
                              'from joint_states any more')
        return live

    def joint_states(self, data: bytes, log_ns: int, now: float) -> None:
        """Write /tf of one recorded JointState (log time [ns], monotonic ``now`` [s])."""
        if self.first_js_at is None:
            self.first_js_at = now
        if self.tree is None:
            if not self.model_ready.is_set():
                # the URDF is still being parsed (first seconds): /tf of these joint states is
                # written as soon as it is ready
                if len(self.backlog) < TF_BACKLOG:
                    self.backlog.append((data, log_ns))
                return
            if self.model_tree is None:
                self.enabled = False
                return
            self.tree = self.model_tree
        self._write_backlog()
        self._write_joint_tf(data, log_ns)

    def _write_backlog(self) -> None:
        backlog, self.backlog = self.backlog, []
        for data, log_ns in backlog:
            self._write_joint_tf(data, log_ns)

    def _decoded(self, decode, data: bytes, last_ns: int, log_ns: int):
        """Return decode(data) when a /tf is due ``period_ns`` after ``last_ns``, else None."""
        if log_ns - last_ns < self.period_ns:
            return None
        try:
            return decode(data)
        except Exception:  # a malformed message: recorded as is, no /tf from it
            return None

    def _write_joint_tf(self, data: bytes, log_ns: int) -> None:
        decoded = self._decoded(self._decode_js, data, self._last_tf_ns, log_ns)
        if decoded is not None and self._write(self.tree.tf_entries(decoded[0]), decoded[1],
                                               log_ns):
            self._last_tf_ns = log_ns

    def markers(self, data: bytes, log_ns: int) -> None:
        """Write the objects' /tf frames of one recorded world/markers MarkerArray."""
        decoded = self._decoded(self._decode_markers, data, self._last_object_tf_ns, log_ns)
        entries = object_tf_entries(decoded[0], self.robot_name) if decoded else []
        if entries and self._write(entries, decoded[1], log_ns):
            self._last_object_tf_ns = log_ns

    def _write(self, entries, stamp_ns: int, log_ns: int) -> bool:
        if self.live_seen or self._live_now():
            return False
        try:
            if not self.bag.has_topic(TF_TOPIC):
                self.bag.add_topic(TF_TOPIC, TF_TYPE, [TF_QOS])
            self.bag.write(TF_TOPIC, encode_tf_message(entries, stamp_ns or log_ns), log_ns)
        except BagError:
            return False
        return True

    def flush_backlog(self, timeout_s: float = 5.0) -> None:
        """At close: wait (a little) for the URDF, then write /tf of the waiting joint states."""
        if not (self.enabled and self.backlog):
            return
        if self.tree is None:
            self.model_ready.wait(timeout_s)
            self.tree = self.tree or self.model_tree
        if self.tree is not None:
            self._write_backlog()

    # -- robot_description fallback -----------------------------------------------------------
    def description_due(self, now: float) -> bool:
        """Return True when none was published and the model's should be written now."""
        return (not self.description_seen and self.first_js_at is not None
                and now - self.first_js_at > DESCRIPTION_WAIT_S and self.model_ready.is_set())

    def write_model_description(self) -> None:
        """Write the model's URDF (links prefixed ``<robot_name>/``) as robot_description."""
        topic = self.description_topic
        urdf = self.model_urdf
        if urdf is None:
            return
        if self.robot_name:
            urdf = prefix_urdf(urdf, self.robot_name)
        try:
            if not self.bag.has_topic(topic):
                self.bag.add_topic(topic, 'std_msgs/msg/String', [DESCRIPTION_QOS])
            self.bag.write(topic, self._encode_string(urdf), self.bag.start_ns or time.time_ns())
            self._log('info', f'no robot_description published: wrote the '
                              f'{self.model_name} model URDF to {topic}')
        except BagError:
            pass
        self.description_seen = True
