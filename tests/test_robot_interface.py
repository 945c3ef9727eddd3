"""The robot-facing interface: an agent driven only through standard-typed topics, no world_sim.

A scripted drone publishes its pose (geometry_msgs/PoseStamped) and each scan's detections
(sensor_msgs/PointCloud2) to an agent process started with ``input_source:=robot``, and flies
to the goal (geometry_msgs/PoseStamped) the agent answers with. A target stands still near the
start: the agent must find it and report it on its standard views. Input it cannot use (no
pose yet, an unknown frame, a malformed cloud) is dropped and counted on /diagnostics.
"""

import json
import math

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseArray, PoseStamped
import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import executable, PARAMS, ros_node, spin_until, started
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import String

from sat_agent.config import load_params_file
from sat_agent.ros import readiness
from sat_agent.ros.msg_conversions import header, InvalidMessage
from sat_agent.ros.robot_input import detections_from_msg, pose_from_msg, RobotPose
from sat_agent.stamps import agent_frame, MAP_FRAME

AGENT = 4
TARGET = np.array([53.0, 52.0])
START = np.array([50.0, 50.0])
STEPS = 12
DT = load_params_file(PARAMS).motion.dt
RELIABLE = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def cloud(points, frame: str, step: int, dtype=np.float32) -> PointCloud2:
    """Return a PointCloud2 of (N, 2) points with x, y, z fields, as a detector driver would."""
    xyz = np.zeros((len(points), 3), dtype=dtype)
    xyz[:, :2] = np.asarray(points, dtype=float).reshape(-1, 2)
    kind = PointField.FLOAT32 if dtype == np.float32 else PointField.FLOAT64
    size = np.dtype(dtype).itemsize
    fields = [PointField(name=n, offset=i * size, datatype=kind, count=1)
              for i, n in enumerate('xyz')]
    msg = PointCloud2(header=header(step, DT, frame), height=1, width=len(points),
                      fields=fields, is_bigendian=False, point_step=3 * size,
                      row_step=3 * size * len(points), is_dense=True)
    msg.data = xyz.tobytes()
    return msg


def pose(xy, step: int, yaw: float = 0.0, frame: str = MAP_FRAME) -> PoseStamped:
    msg = PoseStamped(header=header(step, DT, frame))
    msg.pose.position.x, msg.pose.position.y = float(xy[0]), float(xy[1])
    msg.pose.orientation.z, msg.pose.orientation.w = math.sin(yaw / 2), math.cos(yaw / 2)
    return msg


def test_points_in_map_and_in_the_agents_rotated_frame_give_the_same_range_and_bearing():
    drone = RobotPose(np.array([10.0, 20.0]), math.pi / 2)
    in_map = np.array([[13.0, 24.0], [10.0, 15.0]])
    # Heading +y: the agent frame's x is the map's y, its y the map's -x.
    in_agent = np.array([[4.0, -3.0], [-5.0, 0.0]])
    expected = np.array([[5.0, math.atan2(4, 3)], [5.0, -math.pi / 2]])
    for points, frame in ((in_map, MAP_FRAME), (in_agent, agent_frame(AGENT))):
        z = detections_from_msg(cloud(points, frame, 3, np.float64), drone, AGENT)
        assert np.allclose(z, expected)
    assert detections_from_msg(cloud([], MAP_FRAME, 3), drone, AGENT).shape == (0, 2)


def test_a_yawed_pose_and_bad_input_are_read_or_refused_with_a_reason():
    assert pose_from_msg(pose((1.0, 2.0), 1, yaw=0.3)).yaw == pytest.approx(0.3)
    drone = RobotPose(np.zeros(2), 0.0)
    bad = {'unknown_frame': lambda: detections_from_msg(cloud([[1, 1]], 'camera', 1), drone,
                                                        AGENT),
           'bad_layout': lambda: detections_from_msg(_truncated(), drone, AGENT),
           'non_finite': lambda: detections_from_msg(cloud([[math.nan, 1]], MAP_FRAME, 1),
                                                     drone, AGENT)}
    for reason, read in bad.items():
        with pytest.raises(InvalidMessage) as error:
            read()
        assert error.value.reason == reason
    with pytest.raises(InvalidMessage, match='unknown_frame'):
        pose_from_msg(pose((1.0, 2.0), 1, frame='odom'))


def _truncated() -> PointCloud2:
    msg = cloud([[1, 1], [2, 2]], MAP_FRAME, 1)
    msg.data = bytes(msg.data)[:-4]
    return msg


class Drone:
    """The scripted robot: pose and detections out, goals, views and the agent's counters in."""

    def __init__(self, node):
        ns = f'/agent_{AGENT}'
        self.node = node
        self.pose_pub = node.create_publisher(PoseStamped, f'{ns}/robot/pose', RELIABLE)
        self.scan_pub = node.create_publisher(PointCloud2, f'{ns}/robot/detections', RELIABLE)
        self.goals, self.estimates, self.counters = {}, {}, None
        self.goal_readers = 0     # the agent's view: readers its robot/goal writer matched
        node.create_subscription(PoseStamped, f'{ns}/robot/goal', self.on_goal, RELIABLE)
        node.create_subscription(PoseArray, f'{ns}/view/estimate_poses',
                                 lambda m: self.estimates.__setitem__(m.header.stamp.sec, m),
                                 LATCHED)
        node.create_subscription(DiagnosticArray, '/diagnostics', self.on_diagnostics, 10)
        node.create_subscription(String, readiness.TOPIC, self.on_announcement, readiness.QOS)

    def on_goal(self, msg):
        self.goals[round(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)] = msg

    def on_diagnostics(self, msg):
        for status in msg.status:
            if status.hardware_id == f'agent_{AGENT}':
                self.counters = {kv.key: int(kv.value) for kv in status.values}

    def on_announcement(self, msg):
        writes = json.loads(msg.data)['writes']
        self.goal_readers = writes.get(f'/agent_{AGENT}/robot/goal', self.goal_readers)

    def count(self, key: str) -> int:
        return (self.counters or {}).get(key, 0)


@pytest.mark.ros
@pytest.mark.timeout(180)
def test_an_agent_driven_only_by_pose_and_detections_finds_the_target_and_sends_goals(tmp_path):
    command = [executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{AGENT}',
               '--params-file', str(PARAMS), '-p', f'agent_id:={AGENT}',
               '-p', 'input_source:=robot', '-p', 'diagnostics_period:=0.2']
    with ros_node('scripted_drone') as node:
        drone = Drone(node)
        with started(command, tmp_path / 'agent.log') as agent:
            def wait(done, what):
                spin_until(node, done, 30, what, (agent,))
            # Matched both ways: the drone's writers the agent's readers, the agent's goal
            # writer the drone's reader (its announcement), and its /diagnostics.
            spin_until(node, lambda: drone.pose_pub.get_subscription_count() > 0
                       and drone.scan_pub.get_subscription_count() > 0
                       and drone.goal_readers > 0 and drone.counters is not None, 60,
                       "the drone's topics matched both ways and the agent's diagnostics",
                       (agent,))
            # A scan before any pose, and one in a frame without TF, are refused.
            drone.scan_pub.publish(cloud([[1.0, 1.0]], MAP_FRAME, 1))
            wait(lambda: drone.count('dropped.no_pose'), 'the scan before any pose dropped')
            position = START.copy()
            for step in range(1, STEPS + 1):
                drone.pose_pub.publish(pose(position, step))
                # DDS does not order the two topics: the scan goes once the pose is taken.
                wait(lambda: drone.count('accepted.robot/pose') == step,
                     f'the pose of step {step} accepted')
                frame = MAP_FRAME if step != 5 else 'camera'
                drone.scan_pub.publish(cloud([TARGET], frame, step))
                if step == 5:
                    wait(lambda: drone.count('dropped.unknown_frame'),
                         'the scan in an unknown frame dropped')
                    continue
                wait(lambda: step in drone.goals, f'the goal of step {step}')
                goal = drone.goals[step]
                target = np.array([goal.pose.position.x, goal.pose.position.y])
                assert goal.header.frame_id == MAP_FRAME
                assert np.linalg.norm(target - position) <= 4.0 + 1e-9   # N_R * Delta_R
                position = target       # the drone flies to its goal
            wait(lambda: STEPS in drone.estimates, f'the estimates of step {STEPS}')
            wait(lambda: drone.count('accepted.robot/detections') == STEPS - 1,
                 'the counters of every scan')
    assert sorted(drone.goals) == [s for s in range(1, STEPS + 1) if s != 5]
    found = [[p.position.x, p.position.y] for p in drone.estimates[STEPS].poses]
    assert len(found) == 1 and np.linalg.norm(np.array(found[0]) - TARGET) < 1.5
    assert drone.counters['accepted.robot/detections'] == STEPS - 1
    assert drone.counters['accepted.robot/pose'] == STEPS
