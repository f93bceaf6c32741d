"""
Service calls, action goals and xs commands through real nodes: recorded once, read, not replayed.

Another participant (as another process would be) runs a px100_control_msgs/ComputeIK server on
the contract's ``compute_ik`` and a std_srvs/Trigger server ``reset`` (both with service
introspection on, as rosbag2 needs), a stand-in for the FollowJointTrajectory action server
that publishes what the real one does (its goal/cancel/result service events, feedback,
status), and an Interbotix JointGroupCommand publisher. Two in-process recorders run: the
robot's view (the default set) and ``-a``. Each request and each response is in both bags
exactly once with its payload (read with rosbags, which also checks every type hash against the
stored definitions, and with mcap); inspect counts the calls; replay re-sends none of them.
"""
import threading
import time

from bag_ros_support import RawListener, wait_until
from px100_control.bag.calls import event_info, format_calls, summarise_calls
from px100_control.bag.reader import BagReader
import pytest

pytestmark = pytest.mark.ros
NS = '/px100_calls'
IK_EV = NS + '/compute_ik/_service_event'
RESET_EV = NS + '/reset/_service_event'
ACTION = NS + '/arm_controller/follow_joint_trajectory'
GOAL_EV = ACTION + '/_action/send_goal/_service_event'
CANCEL_EV = ACTION + '/_action/cancel_goal/_service_event'
RESULT_EV = ACTION + '/_action/get_result/_service_event'
FEEDBACK = ACTION + '/_action/feedback'
STATUS = ACTION + '/_action/status'
GROUP = NS + '/commands/joint_group'
CHATTER = NS + '/chatter'
#: messages each bag must hold per topic
EXPECTED = {IK_EV: 6, RESET_EV: 4, GOAL_EV: 4, CANCEL_EV: 2, RESULT_EV: 4, FEEDBACK: 3,
            STATUS: 1, GROUP: 3, CHATTER: 2}


class Robot:
    """The servers, the action stand-in and the command publisher, in a context of their own."""

    def __init__(self):
        import rclpy
        from action_msgs.msg import GoalStatusArray
        from action_msgs.srv import CancelGoal
        from control_msgs.action import FollowJointTrajectory
        from interbotix_xs_msgs.msg import JointGroupCommand
        from px100_control.ros.common import make_executor
        from px100_control_msgs.srv import ComputeIK
        from rclpy.qos import (DurabilityPolicy, qos_profile_system_default, QoSProfile,
                               ReliabilityPolicy)
        from rclpy.service_introspection import ServiceIntrospectionState
        from std_msgs.msg import String
        from std_srvs.srv import Trigger
        self.context = rclpy.Context()
        rclpy.init(context=self.context)
        self.node = node = rclpy.node.Node('fake_driver', namespace=NS, context=self.context)
        self.ComputeIK, self.Trigger, self.FJT = ComputeIK, Trigger, FollowJointTrajectory
        self.CancelGoal, self.GoalStatusArray = CancelGoal, GoalStatusArray
        self.JointGroupCommand, self.String = JointGroupCommand, String
        for srv, name, cb in ((ComputeIK, 'compute_ik', self._ik),
                              (Trigger, 'reset', self._reset)):
            server = node.create_service(srv, name, cb)
            server.configure_introspection(node.get_clock(), qos_profile_system_default,
                                           ServiceIntrospectionState.CONTENTS)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                             reliability=ReliabilityPolicy.RELIABLE)
        impl = FollowJointTrajectory.Impl
        self.pubs = {
            GOAL_EV: node.create_publisher(impl.SendGoalService.Event, GOAL_EV,
                                           qos_profile_system_default),
            CANCEL_EV: node.create_publisher(CancelGoal.Event, CANCEL_EV,
                                             qos_profile_system_default),
            RESULT_EV: node.create_publisher(impl.GetResultService.Event, RESULT_EV,
                                             qos_profile_system_default),
            FEEDBACK: node.create_publisher(impl.FeedbackMessage, FEEDBACK, 10),
            STATUS: node.create_publisher(GoalStatusArray, STATUS, latched),
            GROUP: node.create_publisher(JointGroupCommand, GROUP, 10),
            CHATTER: node.create_publisher(String, CHATTER, 10),
        }
        self.executor = make_executor(context=self.context, kind='single')
        self.executor.add_node(node)
        self._thread = threading.Thread(target=self._spin, daemon=True)
        self._thread.start()

    def _spin(self):
        try:
            while self.context.ok():
                self.executor.spin_once(timeout_sec=0.05)
        except Exception:  # noqa: B902 - shut down under the executor
            pass

    def _ik(self, request, response):
        response.success = True
        response.message = f'ok {request.target.pose.position.x:.1f}'
        response.solution.position = [request.target.pose.position.x]
        return response

    def _reset(self, request, response):
        response.success, response.message = True, 'reset'
        return response

    def event(self, topic, event_type, seq, request=None, response=None):
        """Publish one service event of the action stand-in (client gid 7...)."""
        msg = self.pubs[topic].msg_type()
        msg.info.event_type, msg.info.sequence_number = event_type, seq
        msg.info.client_gid = [7] * 16
        msg.info.stamp = self.node.get_clock().now().to_msg()
        if request is not None:
            msg.request.append(request)
        if response is not None:
            msg.response.append(response)
        self.pubs[topic].publish(msg)

    def drive_action(self):
        """Two goals (the second cancelled), their results, feedback and status."""
        impl = self.FJT.Impl
        for seq in (1, 2):
            goal = impl.SendGoalService.Request()
            goal.goal_id.uuid = [seq] * 16
            goal.goal.trajectory.joint_names = ['waist']
            self.event(GOAL_EV, 1, seq, request=goal)
            self.event(GOAL_EV, 2, seq, response=impl.SendGoalService.Response(accepted=True))
            fb = impl.FeedbackMessage()
            fb.goal_id.uuid = [seq] * 16
            fb.feedback.joint_names = ['waist']
            fb.feedback.actual.positions = [0.1 * seq]
            self.pubs[FEEDBACK].publish(fb)
        self.pubs[FEEDBACK].publish(fb)
        cancel = self.CancelGoal.Request()
        cancel.goal_info.goal_id.uuid = [2] * 16
        self.event(CANCEL_EV, 1, 3, request=cancel)
        self.event(CANCEL_EV, 2, 3, response=self.CancelGoal.Response(return_code=0))
        for seq, code in ((4, 0), (5, -1)):
            req = impl.GetResultService.Request()
            req.goal_id.uuid = [seq - 3] * 16
            self.event(RESULT_EV, 1, seq, request=req)
            res = impl.GetResultService.Response(status=4 if code == 0 else 5)
            res.result.error_code = code
            self.event(RESULT_EV, 2, seq, response=res)
        self.pubs[STATUS].publish(self.GoalStatusArray())

    def close(self):
        """Stop spinning, destroy the node (its participant leaves the graph), shut down."""
        self.executor.shutdown(timeout_sec=2.0)
        self.node.destroy_node()
        self.context.try_shutdown()
        self._thread.join(timeout=5.0)


def _call(node, client, request, timeout=20.0):
    """Call a service from a spun node; return the response."""
    assert client.wait_for_service(timeout_sec=timeout), f'{client.srv_name} never appeared'
    future = client.call_async(request)
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    assert done.wait(timeout), f'no reply from {client.srv_name}'
    return future.result()


def _events_by_type(bag, topic):
    """Return [(event type, decoded event)] of one topic, read with rosbags."""
    from pathlib import Path

    from rosbags.highlevel import AnyReader
    with AnyReader([Path(bag)]) as reader:
        conns = [c for c in reader.connections if c.topic == topic]
        return [(m.info.event_type, m) for m in
                (reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns))]


def test_calls_goals_and_commands_are_recorded_once(rclpy_context, spin_node, tmp_path,
                                                    capsys):
    """Both recorders hold each request and response once; inspect counts; replay holds."""
    from geometry_msgs.msg import Pose
    from px100_control.ros.recorder import Recorder
    robot = Robot()
    try:
        caller = spin_node(__import__('rclpy').node.Node('caller', context=rclpy_context))
        ik = caller.create_client(robot.ComputeIK, NS + '/compute_ik')
        reset = caller.create_client(robot.Trigger, NS + '/reset')
        view, every = str(tmp_path / 'view'), str(tmp_path / 'all')
        rec_view = Recorder(view, robot_name=NS.strip('/'), context=rclpy_context,
                            write_tf=False).start()
        rec_all = Recorder(every, all_topics=True, robot_name='px100_calls_all',
                           context=rclpy_context, write_tf=False).start()
        recs = (rec_view, rec_all)
        # the publishers' side of the match too (reliable, volatile: nothing sent before it)
        assert wait_until(lambda: all(robot.node.count_subscribers(t) >= 2
                                      for t in (IK_EV, RESET_EV, GOAL_EV, GROUP)), 30.0)
        assert wait_until(lambda: all(p.get_subscription_count() >= 2
                                      for p in robot.pubs.values()), 30.0)
        for i in range(3):
            req = robot.ComputeIK.Request()
            req.target.pose = Pose()
            req.target.pose.position.x = 0.1 * (i + 1)
            assert _call(caller, ik, req).message == f'ok {0.1 * (i + 1):.1f}'
            robot.pubs[GROUP].publish(robot.JointGroupCommand(name='arm', cmd=[0.1 * i] * 4))
        assert _call(caller, reset, robot.Trigger.Request()).message == 'reset'
        robot.drive_action()
        robot.pubs[CHATTER].publish(robot.String(data='one'))
        assert _call(caller, reset, robot.Trigger.Request()).success
        robot.pubs[CHATTER].publish(robot.String(data='two'))

        def counts(rec):
            return {t: rec.node.bag.topics[t].message_count if t in rec.node.bag.topics else 0
                    for t in EXPECTED}
        complete = wait_until(lambda: all(counts(r) == EXPECTED for r in recs), 20.0)
        assert complete, [counts(r) for r in recs]
        for rec in recs:
            rec.stop()
    finally:
        robot.close()

    for bag in (view, every):
        ik_events = _events_by_type(bag, IK_EV)
        requests = [m.request[0].target.pose.position.x for t, m in ik_events if t == 1]
        replies = [m.response[0].message for t, m in ik_events if t == 2]
        assert requests == pytest.approx([0.1, 0.2, 0.3]) and len(ik_events) == 6
        assert replies == ['ok 0.1', 'ok 0.2', 'ok 0.3']
        assert [m.info.sequence_number for _, m in ik_events] == [1, 1, 2, 2, 3, 3]
        goals = _events_by_type(bag, GOAL_EV)
        assert [(t, bool(m.request), bool(m.response)) for t, m in goals] == \
            [(1, True, False), (2, False, True)] * 2
        assert [m.request[0].goal.trajectory.joint_names for t, m in goals if t == 1] == \
            [['waist'], ['waist']]
        results = _events_by_type(bag, RESULT_EV)
        assert [m.response[0].result.error_code for t, m in results if t == 2] == [0, -1]
        cancels = _events_by_type(bag, CANCEL_EV)
        assert list(cancels[0][1].request[0].goal_info.goal_id.uuid) == [2] * 16

        from pathlib import Path

        from rosbags.highlevel import AnyReader
        with AnyReader([Path(bag)]) as reader:  # every type hash checked on open
            types = {c.topic: c.msgtype for c in reader.connections}
            conns = [c for c in reader.connections if c.topic == GROUP]
            cmds = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(conns)]
        assert types[GROUP] == 'interbotix_xs_msgs/msg/JointGroupCommand'
        assert types[IK_EV] == 'px100_control_msgs/srv/ComputeIK_Event'
        assert types[FEEDBACK] == 'control_msgs/action/FollowJointTrajectory_FeedbackMessage'
        assert [list(c.cmd) for c in cmds] == [[0.0] * 4, [0.1] * 4, [0.2] * 4]
        _check_with_mcap(bag)

    from px100_control.bag import inspect_cli
    assert inspect_cli.main(['--no-plots', every]) == 0
    out = capsys.readouterr().out
    assert f'{NS}/compute_ik' in out and '3 requests, 3 responses' in out, out
    assert f'{NS}/reset' in out and '2 requests, 2 responses' in out, out
    assert ('2 goals, 2 goal replies, 1 cancel, 1 cancel reply, 2 result requests, '
            '2 results, 3 feedback, 1 status') in out, out
    _replay_sends_none_of_them(rclpy_context, spin_node, view)


def _check_with_mcap(bag):
    """Read every message with mcap; decode with mcap-ros2-support the types it can name."""
    import glob

    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    path = glob.glob(bag + '/*.mcap')[0]
    seen = {}
    with open(path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message in reader.iter_messages():
            seen.setdefault(channel.topic, []).append((schema, message.data))
    for topic, n in EXPECTED.items():
        assert len(seen[topic]) == n, topic
    for topic in (IK_EV, RESET_EV, GOAL_EV, CANCEL_EV, RESULT_EV):
        schema = seen[topic][0][0]
        assert schema.encoding == 'ros2idl' and schema.name.endswith('_Event')
        infos = [event_info(data) for _, data in seen[topic]]
        assert sorted(i.event_type for i in infos) == sorted([1, 2] * (len(infos) // 2))
    factory = DecoderFactory()
    for topic in (GROUP, STATUS, CHATTER):
        schema, data = seen[topic][0]
        assert schema.encoding == 'ros2msg'
        decoded = factory.decoder_for('cdr', schema)(data)
        if topic == GROUP:
            assert decoded.name == 'arm' and list(decoded.cmd) == [0.0] * 4
    with BagReader(bag) as reader:
        names = {s.name: s for s in summarise_calls(reader)}
        assert names[ACTION].counts == {'goal': (2, 2), 'cancel': (1, 1), 'result': (2, 2)}
        assert format_calls(names.values()).count('\n') == len(names) == 3


def _replay_sends_none_of_them(rclpy_context, spin_node, bag):
    """Replay publishes the plain topic only: no call, no action topic, no xs command."""
    from interbotix_xs_msgs.msg import JointGroupCommand
    from px100_control.ros.replayer_node import ReplayerNode
    from std_msgs.msg import String
    from std_srvs.srv import Trigger
    listener = spin_node(RawListener([(CHATTER, String), (GROUP, JointGroupCommand),
                                      (RESET_EV, Trigger.Event)], context=rclpy_context))
    replayer = ReplayerNode(bag, context=rclpy_context, progress=False,
                            wait_for_subscribers=20.0)
    assert sorted(replayer.publishers_by_topic) == [CHATTER], replayer.publishers_by_topic
    assert set(replayer.not_replayed) == set(EXPECTED) - {CHATTER}
    spin_node(replayer).start()
    assert replayer.done.wait(30.0) and not replayer.error
    assert wait_until(lambda: listener.count(CHATTER) == 2, 10.0)
    time.sleep(0.2)  # anything else sent would be here by now (the chatter came after it)
    assert listener.count(GROUP) == 0 and listener.count(RESET_EV) == 0


def test_a_live_tf_publisher_replaces_the_computed_tf(rclpy_context, spin_node, tmp_path):
    """Computed /tf while the graph has no /tf publisher; only the live one once it appears."""
    import rclpy
    from bag_ros_support import FakeRobot
    from geometry_msgs.msg import TransformStamped
    from px100_control.ros.recorder import Recorder
    from tf2_msgs.msg import TFMessage
    other = rclpy.Context()
    rclpy.init(context=other)
    fake = FakeRobot('fake_tf_robot', context=other)
    try:
        bag = str(tmp_path / 'tf')
        with Recorder(bag, robot_name='px100', context=rclpy_context) as rec:
            assert fake.wait_for_subscribers([fake.js], 30.0)
            assert rec.node.tf.model_ready.wait(60.0)
            topics = rec.node.bag.topics

            def count(topic):
                return topics[topic].message_count if topic in topics else 0
            for seq in range(5):
                fake.js.publish(fake.joint_state(seq))
                time.sleep(0.005)
            # computed /tf (at most tf_rate: bunched joint states may share one)
            assert wait_until(lambda: count('/px100/joint_states') == 5 and count('/tf'), 20.0)
            computed = count('/tf')
            live = fake.create_publisher(TFMessage, '/tf', 100)
            # both sides: the recorder's graph shows the publisher (its data is taken after that)
            assert wait_until(lambda: live.get_subscription_count() >= 1
                              and rec.node.count_publishers('/tf') >= 1, 30.0)
            for seq in range(5, 10):
                fake.js.publish(fake.joint_state(seq))
                live.publish(TFMessage(transforms=[TransformStamped(child_frame_id=f'live{seq}')]))
                time.sleep(0.005)
            assert wait_until(lambda: count('/px100/joint_states') == 10
                              and count('/tf') >= computed + 5, 20.0), {
                t: r.message_count for t, r in topics.items()}
            assert rec.node.tf.live_seen
    finally:
        fake.destroy_node()         # its participant leaves the graph: no stray /px100 node
        other.try_shutdown()
    with BagReader(bag) as reader:
        frames = [[t.child_frame_id for t in reader.decode(m).transforms]
                  for m in reader.iter_raw(['/tf'])]
    assert len(frames) == computed + 5, frames
    assert all('px100/ee_gripper_link' in f for f in frames[:computed])
    assert frames[computed:] == [[f'live{seq}'] for seq in range(5, 10)]
