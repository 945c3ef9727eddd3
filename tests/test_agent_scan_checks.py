"""An agent node's checks of a scan, run in the test process against its real subscriptions.

A scan is taken only if it is this agent's, of a new step and of finite, in-range content. A
signed scan refused by those checks must not advance the world's replay counter, or a key
holder's bad scan sent with the next counter would make the genuine scan it races a replay.
A scan signed for another run under the same key is refused. A robot's scans are unsigned: one
stamped far ahead of the agent's clock must not lock out the genuine ones that follow.
"""

import math

from geometry_msgs.msg import Point, PoseStamped
import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from ros_harness import ros_node
from sensor_msgs.msg import PointCloud2, PointField

from sat_agent.message_auth import MonotonicCounter, run_key, Signer, WORLD_SENDER
from sat_agent.ros.agent_node import AgentNode
from sat_agent.stamps import MAP_FRAME
from sat_msgs.msg import MeasurementSet, RangeBearing

pytestmark = pytest.mark.ros
AGENT = 1
CHANNEL = f'/agent_{AGENT}/measurements'


def subscription(node, topic: str):
    """Return the node's subscription to topic (its callback takes what DDS would deliver)."""
    return next(s for s in node.subscriptions if s.topic_name == topic)


def scan(step: int, agent_id: int = AGENT, bearing: float = 0.5) -> MeasurementSet:
    return MeasurementSet(agent_id=agent_id, step=step, agent_position=Point(x=50.0, y=50.0),
                          detections=[RangeBearing(range=3.0, bearing=bearing)])


def signed(key: bytes, counter: int, msg: MeasurementSet) -> bytes:
    """Return msg as world_sim sends it: signed by the world with this counter."""
    return Signer(key, WORLD_SENDER, MonotonicCounter(lambda: counter)).sign(
        CHANNEL, serialize_message(msg), msg.step)


@pytest.fixture
def key_file(tmp_path):
    path = tmp_path / 'swarm.key'
    path.write_bytes(bytes(range(32)))
    path.chmod(0o600)
    return path


def test_a_signed_scan_refused_for_its_content_does_not_block_the_genuine_one(key_file):
    key = key_file.read_bytes()
    with ros_node('scan_checks'):
        agent = AgentNode(namespace=f'/agent_{AGENT}', parameter_overrides=[
            Parameter('agent_id', value=AGENT), Parameter('auth_key_file', value=str(key_file)),
            Parameter('agent_ids', value=[AGENT, 2])])
        try:
            deliver = subscription(agent, CHANNEL).callback
            deliver(signed(key, 10, scan(1)))
            assert agent.last_step == 1
            # A key holder's scans of step 2, each with a counter above the genuine one's and
            # arriving first: another agent's, a repeat of step 1, NaN and out-of-range content.
            bombs = [scan(2, agent_id=2), scan(1), scan(2, bearing=math.nan),
                     scan(2, bearing=4.0)]
            for counter, bomb in enumerate(bombs, start=12):
                deliver(signed(key, counter, bomb))
            assert dict(agent.guard.dropped) == {'wrong_agent_id': 1, 'stale_step': 1,
                                                 'non_finite': 1, 'out_of_range': 1}
            assert agent.last_step == 1
            deliver(signed(key, 11, scan(2)))
            assert agent.last_step == 2 and agent.guard.accepted['measurements'] == 2
            # Taken, it moved the counter: sent again, it is a replay.
            deliver(signed(key, 11, scan(3)))
            assert agent.guard.dropped['replayed'] == 1 and agent.last_step == 2
        finally:
            agent.destroy_node()


def test_a_scan_of_another_run_under_the_same_key_is_refused(key_file):
    # A key file reused across runs: the agent of run 'mission-b' gets run 'mission-a''s
    # recorded scan of the same step first.
    key = key_file.read_bytes()
    with ros_node('scan_of_another_run'):
        agent = AgentNode(namespace=f'/agent_{AGENT}', parameter_overrides=[
            Parameter('agent_id', value=AGENT), Parameter('auth_key_file', value=str(key_file)),
            Parameter('auth_run_id', value='mission-b'), Parameter('agent_ids', value=[AGENT])])
        try:
            deliver = subscription(agent, CHANNEL).callback
            deliver(signed(run_key(key, 'mission-a'), 10, scan(1, bearing=1.0)))
            deliver(signed(key, 11, scan(1, bearing=1.0)))    # nor one signed with the key itself
            assert agent.guard.dropped == {'bad_signature': 2} and agent.last_step == 0
            deliver(signed(run_key(key, 'mission-b'), 5, scan(1)))
            assert agent.last_step == 1 and agent.guard.accepted['measurements'] == 1
        finally:
            agent.destroy_node()


def robot_scan(stamp_ns: int) -> PointCloud2:
    """Return an empty scan (it saw nothing) stamped stamp_ns, in the map frame."""
    fields = [PointField(name=name, offset=4 * i, datatype=PointField.FLOAT32, count=1)
              for i, name in enumerate('xy')]
    msg = PointCloud2(height=1, width=0, fields=fields, point_step=8, is_dense=True)
    msg.header.frame_id = MAP_FRAME
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(stamp_ns, 10 ** 9)
    return msg


def test_a_robot_scan_stamped_far_ahead_of_the_agents_clock_does_not_lock_it_out():
    with ros_node('robot_scan_checks'):
        agent = AgentNode(namespace=f'/agent_{AGENT}', parameter_overrides=[
            Parameter('agent_id', value=AGENT), Parameter('input_source', value='robot')])
        try:
            dt_ns = round(agent.dt * 10 ** 9)
            pose = PoseStamped()
            pose.header.frame_id = MAP_FRAME
            pose.pose.position.x = pose.pose.position.y = 50.0
            pose.pose.orientation.w = 1.0
            agent.on_robot_pose(pose)
            now = agent.get_clock().now().nanoseconds
            # A forged first scan an hour ahead of the clock, then the drone's genuine ones.
            agent.on_detections(robot_scan(now + 3600 * 10 ** 9))
            assert agent.guard.dropped == {'future_step': 1} and agent.last_step == 0
            for k in range(1, 3):
                agent.on_detections(robot_scan(now + (k - 3) * dt_ns))
            assert agent.guard.accepted['robot/detections'] == 2
            # 5 steps ahead is too many (the README allows 2; the test takes well under 2 s).
            agent.on_detections(robot_scan(now + 5 * dt_ns))
            assert agent.guard.dropped == {'future_step': 2}
            # Within the drift the README allows (and a /clock a step late) it is taken.
            agent.on_detections(robot_scan(now + 2 * dt_ns))
            assert agent.guard.accepted['robot/detections'] == 3
            assert agent.guard.dropped == {'future_step': 2}
        finally:
            agent.destroy_node()
