"""
Hypothesis strategies of hostile inputs for every topic and service of the px100 nodes.

Each strategy draws ROS messages (real ``*_msgs`` objects, ready to publish) that mix valid
values with the classes of nonsense users send: NaN, +-inf, huge and empty arrays, mismatched
lengths, unknown and duplicate joint names, zero and non-unit quaternions, out-of-limit values,
negative / far-future / denormalised times (nanosec >= 1e9) and unknown frames. Valid inputs stay
in the mix (about a third) so the nodes are also busy doing real work while being fuzzed.
Units: rad, m, s, as on the wire.
"""
import array
from functools import lru_cache
import math

from action_msgs.msg import GoalInfo
from action_msgs.srv import CancelGoal
from builtin_interfaces.msg import Duration, Time
from geometry_msgs.msg import Pose, PoseArray, PoseStamped
from hypothesis import strategies as st
from rcl_interfaces.msg import Parameter, ParameterType, ParameterValue
from sensor_msgs.msg import JointState
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

INT32_MIN, INT32_MAX = -2 ** 31, 2 ** 31 - 1
UINT32_MAX = 2 ** 32 - 1
#: size of a "huge" array; a huge goal repeats a point (itself possibly with huge arrays) as
#: many times, so one goal sample can reach 800 MB
HUGE = (1_000, 10_000)
#: a huge input is drawn about once in RARE (they cost far more than the others to send)
RARE = 15

# -- scalars ---------------------------------------------------------------------------------

NASTY_FLOATS = (math.nan, -math.nan, math.inf, -math.inf, 0.0, -0.0, 1e308, -1e308, 5e-324,
                1e-300, 1e12, -1e12, 2 ** 53 + 1.0)


@lru_cache(maxsize=None)
def nasty_floats():
    """Return floats from the edge classes: NaN, +-inf, +-0, subnormal, huge."""
    return st.sampled_from(NASTY_FLOATS)


@lru_cache(maxsize=None)
def any_floats():
    """Return any float64 at all, nasty ones often."""
    return st.one_of(nasty_floats(), st.floats(allow_nan=True, allow_infinity=True),
                     st.floats(-10.0, 10.0))


@lru_cache(maxsize=None)
def joint_values(lower, upper):
    """Return a value for a joint with limits [lower, upper]: inside, on, just off, far off."""
    span = upper - lower
    return st.one_of(
        st.floats(lower, upper),
        st.sampled_from((lower, upper, lower - 1e-9, upper + 1e-9, lower - 1e-3, upper + 1e-3,
                         lower - span, upper + span)),
        any_floats())


@lru_cache(maxsize=None)
def times():
    """Return a builtin_interfaces/Time: zero, now-ish, negative, far-future, nanosec >= 1e9."""
    return st.builds(
        Time,
        sec=st.one_of(st.sampled_from((0, 1, -1, INT32_MIN, INT32_MAX, 1_700_000_000)),
                      st.integers(INT32_MIN, INT32_MAX)),
        nanosec=st.one_of(st.sampled_from((0, 1, 999_999_999, 1_000_000_000, UINT32_MAX)),
                          st.integers(0, UINT32_MAX)))


@lru_cache(maxsize=None)
def durations():
    """Return a builtin_interfaces/Duration: zero, small, negative, huge, non-normalised."""
    return st.builds(
        Duration,
        sec=st.one_of(st.integers(0, 5), st.sampled_from((-1, -100, INT32_MIN, INT32_MAX,
                                                          1_000_000)),
                      st.integers(INT32_MIN, INT32_MAX)),
        nanosec=st.one_of(st.integers(0, 999_999_999),
                          st.sampled_from((1_000_000_000, UINT32_MAX))))


@lru_cache(maxsize=None)
def frames(robot_name='px100'):
    """Return frame ids: empty, the base frame (both spellings), other robots', nonsense."""
    return st.one_of(
        st.sampled_from(('', f'{robot_name}/base_link', 'base_link', f'/{robot_name}/base_link',
                         'world', 'map', f'{robot_name}/ee_gripper_link', 'other/base_link',
                         ' ', '\x00', 'ü' * 50, 'a' * 5000)),
        st.text(max_size=40))


@lru_cache(maxsize=None)
def headers_kw(robot_name='px100'):
    """Return (stamp, frame_id) pairs as a tuple strategy."""
    return st.tuples(times(), frames(robot_name))


def rarely(rare, common, one_in=RARE):
    """Return ``rare`` about once in ``one_in`` draws, else ``common`` (shrinks to common)."""
    return st.integers(1, one_in).flatmap(lambda k: rare if k == one_in else common)


@lru_cache(maxsize=None)
def huge_floats():
    """Return a huge float64 array (array.array: the message setters take it without a copy)."""
    return st.builds(lambda n, v: array.array('d', [v]) * n, st.integers(*HUGE), any_floats())


# -- names -----------------------------------------------------------------------------------

@lru_cache(maxsize=None)
def joint_name_lists(known, max_size=10):
    """
    Return lists of joint names: known subsets, permutations, unknown and duplicate names.

    :param known: (tuple) the names the node knows (arm + gripper + fingers)
    """
    known = list(known)
    unknown = st.one_of(st.sampled_from(('', ' ', 'Waist', 'waist ', 'joint1', 'gripper_2',
                                         'px100/waist', '\x00', 'w' * 1000)),
                        st.text(max_size=20))
    name = st.one_of(st.sampled_from(known), unknown)
    valid = st.permutations(known).flatmap(
        lambda p: st.integers(0, len(p)).map(lambda k: list(p[:k])))
    return rarely(st.builds(lambda n: [known[0]] * n, st.integers(*HUGE)), st.one_of(
        valid,
        st.lists(name, max_size=max_size),
        valid.filter(bool).map(lambda names: names + names[:1])))  # duplicate


def _value_strategy(name, limits):
    lim = limits.get(name) if isinstance(name, str) else None
    return joint_values(*lim) if lim is not None else any_floats()


@lru_cache(maxsize=None)
def mismatched_values(n):
    """Return a values list of a length different from n (or any length)."""
    return rarely(huge_floats(),
                  st.lists(any_floats(), max_size=n + 3).filter(lambda v: len(v) != n))


_VECTOR_KINDS = st.sampled_from(('match', 'match', 'empty', 'mismatch'))
_VECTOR_KINDS_NONEMPTY = st.sampled_from(('match', 'match', 'mismatch'))


@st.composite
def _vector(draw, names, limits, optional=True):
    """Draw a value array for names: matched, empty (optional) or mismatched in length."""
    choice = draw(_VECTOR_KINDS if optional else _VECTOR_KINDS_NONEMPTY)
    if choice == 'match':
        if len(names) >= 50:
            return array.array('d', [draw(any_floats())]) * len(names)
        return [draw(_value_strategy(n, limits)) for n in names]
    if choice == 'empty':
        return []
    return draw(mismatched_values(len(names)))


# -- messages --------------------------------------------------------------------------------

@st.composite
def joint_states(draw, known, limits, velocity_limits, robot_name='px100'):
    """
    Return sensor_msgs/JointState setpoints: position and/or velocity and/or effort by name.

    :param known: every joint name the driver knows
    :param limits: {name: (lower, upper)} position limits
    :param velocity_limits: {name: (-v, v)}
    """
    names = draw(joint_name_lists(tuple(known)))
    stamp, frame = draw(headers_kw(robot_name))
    msg = JointState()
    msg.header.stamp, msg.header.frame_id = stamp, frame
    msg.name = names
    msg.position = draw(_vector(names, limits))
    msg.velocity = draw(_vector(names, velocity_limits))
    msg.effort = draw(_vector(names, {}, optional=True))
    return msg


@lru_cache(maxsize=None)
def quaternions():
    """Return (x, y, z, w): unit, zero (orientation free), non-unit, NaN."""
    unit = st.tuples(*[st.floats(-1.0, 1.0)] * 4).filter(
        lambda q: sum(c * c for c in q) > 1e-6).map(
        lambda q: tuple(c / math.sqrt(sum(k * k for k in q)) for c in q))
    return st.one_of(
        st.just((0.0, 0.0, 0.0, 1.0)), unit, st.just((0.0, 0.0, 0.0, 0.0)),
        st.tuples(st.floats(0.0, 1e-3), st.just(0.0), st.just(0.0), st.floats(0.0, 1e-3)),
        unit.flatmap(lambda q: st.floats(0.01, 100.0).map(lambda s: tuple(c * s for c in q))),
        st.tuples(*[any_floats()] * 4))


@lru_cache(maxsize=None)
def positions(reach=0.35):
    """Return (x, y, z) [m]: reachable-ish, out of reach, NaN/inf."""
    return st.one_of(
        st.tuples(st.floats(-reach, reach), st.floats(-reach, reach), st.floats(-0.1, reach)),
        st.tuples(st.floats(0.05, 0.3), st.just(0.0), st.floats(0.0, 0.3)),
        st.tuples(any_floats(), any_floats(), any_floats()))


@lru_cache(maxsize=None)
def poses():
    """Return geometry_msgs/Pose values from positions() and quaternions()."""
    def build(p, q):
        pose = Pose()
        pose.position.x, pose.position.y, pose.position.z = p
        pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = q
        return pose
    return st.builds(build, positions(), quaternions())


@st.composite
def pose_stampeds(draw, robot_name='px100'):
    """Return geometry_msgs/PoseStamped IK requests."""
    msg = PoseStamped()
    msg.header.stamp, msg.header.frame_id = draw(headers_kw(robot_name))
    msg.pose = draw(poses())
    return msg


@st.composite
def pose_arrays(draw, robot_name='px100', huge=(200, 2_000)):
    """Return geometry_msgs/PoseArray path requests: empty, short, long, nasty."""
    msg = PoseArray()
    msg.header.stamp, msg.header.frame_id = draw(headers_kw(robot_name))
    msg.poses = draw(rarely(st.builds(lambda n, p: [p] * n, st.integers(*huge), poses()),
                            st.lists(poses(), max_size=8)))
    return msg


@st.composite
def trajectory_points(draw, names, limits, velocity_limits, count):
    """Return count JointTrajectoryPoints: increasing times usually, broken ones sometimes."""
    times_kind = draw(st.sampled_from(('increasing', 'increasing', 'random', 'equal',
                                       'decreasing')))
    t = 0.0
    points = []
    for i in range(count):
        p = JointTrajectoryPoint()
        p.positions = draw(_vector(names, limits, optional=False))
        p.velocities = draw(_vector(names, velocity_limits))
        p.accelerations = draw(st.one_of(st.just([]), _vector(names, {})))
        if draw(st.integers(0, 9)) == 0:
            p.effort = draw(_vector(names, {}))
        if times_kind == 'increasing':
            t += draw(st.floats(0.05, 2.0))
            p.time_from_start = Duration(sec=int(t), nanosec=int((t % 1.0) * 1e9))
        elif times_kind == 'equal':
            p.time_from_start = Duration(sec=1, nanosec=0)
        elif times_kind == 'decreasing':
            p.time_from_start = Duration(sec=count - i, nanosec=0)
        else:
            p.time_from_start = draw(durations())
        points.append(p)
    return points


@st.composite
def joint_trajectories(draw, arm, limits, velocity_limits, robot_name='px100'):
    """
    Return trajectory_msgs/JointTrajectory goals.

    :param arm: the arm joint names (goals may name a subset of them)
    """
    names = draw(joint_name_lists(tuple(arm), max_size=6))
    msg = JointTrajectory()
    msg.header.stamp, msg.header.frame_id = draw(headers_kw(robot_name))
    msg.joint_names = names
    count = draw(st.one_of(st.integers(0, 4), st.just(0), st.integers(5, 12)))
    msg.points = draw(trajectory_points(names, limits, velocity_limits, count))
    if count and draw(st.integers(1, RARE)) == RARE:   # a huge goal: one point many times
        msg.points = msg.points[:1] * draw(st.integers(*HUGE))
    return msg


@lru_cache(maxsize=None)
def uuids():
    """Return 16-byte goal ids: zero, random, all 0xff."""
    return st.one_of(st.just(bytes(16)), st.binary(min_size=16, max_size=16),
                     st.just(b'\xff' * 16))


@st.composite
def cancel_requests(draw, known_stamps=()):
    """
    Return action_msgs/CancelGoal requests: cancel all, by stamp, by UUID, unknown goals.

    :param known_stamps: stamps of goals sent earlier (Time), to cancel real goals sometimes
    """
    req = CancelGoal.Request()
    info = GoalInfo()
    kind = draw(st.sampled_from(('all', 'stamp', 'uuid', 'both', 'known')))
    if kind in ('stamp', 'both'):
        info.stamp = draw(times())
    if kind in ('uuid', 'both'):
        info.goal_id.uuid = list(draw(uuids()))
    if kind == 'known' and known_stamps:
        info.stamp = draw(st.sampled_from(list(known_stamps)))
    req.goal_info = info
    return req


def setbool_requests():
    """Return std_srvs/SetBool requests (torque on/off)."""
    return st.builds(lambda b: SetBool.Request(data=b), st.booleans())


def trigger_requests():
    """Return std_srvs/Trigger requests (there is nothing to vary but the timing)."""
    return st.just(None).map(lambda _: Trigger.Request())


def _param_value(kind, value):
    v = ParameterValue(type=kind)
    if kind == ParameterType.PARAMETER_DOUBLE:
        v.double_value = value
    elif kind == ParameterType.PARAMETER_INTEGER:
        v.integer_value = value
    elif kind == ParameterType.PARAMETER_STRING:
        v.string_value = value
    elif kind == ParameterType.PARAMETER_BOOL:
        v.bool_value = value
    elif kind == ParameterType.PARAMETER_DOUBLE_ARRAY:
        v.double_array_value = value
    elif kind == ParameterType.PARAMETER_INTEGER_ARRAY:
        v.integer_array_value = value
    elif kind == ParameterType.PARAMETER_STRING_ARRAY:
        v.string_array_value = value
    return v


@lru_cache(maxsize=None)
def parameter_values():
    """Return rcl_interfaces ParameterValues of every type, with nonsense numbers."""
    T = ParameterType
    gain = st.one_of(nasty_floats(), st.floats(-1e6, 1e6), st.floats(0.0, 100.0))
    return st.one_of(
        gain.map(lambda x: _param_value(T.PARAMETER_DOUBLE, x)),
        st.integers(-2 ** 63, 2 ** 63 - 1).map(lambda x: _param_value(T.PARAMETER_INTEGER, x)),
        st.text(max_size=20).map(lambda x: _param_value(T.PARAMETER_STRING, x)),
        st.booleans().map(lambda x: _param_value(T.PARAMETER_BOOL, x)),
        st.lists(gain, max_size=8).map(lambda x: _param_value(T.PARAMETER_DOUBLE_ARRAY, x)),
        st.lists(st.integers(-10 ** 6, 10 ** 6), max_size=8).map(
            lambda x: _param_value(T.PARAMETER_INTEGER_ARRAY, x)),
        st.lists(st.text(max_size=8), max_size=4).map(
            lambda x: _param_value(T.PARAMETER_STRING_ARRAY, x)),
        st.just(ParameterValue(type=T.PARAMETER_NOT_SET)))


def parameter_sets(names):
    """
    Return lists of rcl_interfaces/Parameter: the node's own names with nonsense values.

    :param names: the parameter names the node declares (unknown names are added)
    """
    names = sorted(set(names) - {'use_sim_time'})  # true would stop the clock: legal, not fuzz
    name = st.one_of(st.sampled_from(names) if names else st.nothing(),
                     st.sampled_from(('kp', 'gains.nope', '', 'a' * 300)),
                     st.text(max_size=12))
    param = st.builds(lambda n, v: Parameter(name=n, value=v), name, parameter_values())
    return st.lists(param, min_size=1, max_size=4)
