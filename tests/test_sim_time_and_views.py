"""Sim time, frames and the standard views (RViz2/Foxglove) next to Rerun.

Unit checks of the stamps and of the view messages, then the bag of the paper run (the
bring-up `make run` uses): /clock and the standard views are recorded, every header carries
its step's sim time k dt and a frame. An agent under use_sim_time stamps what reads its clock
with /clock, and its timers keep running while the sim clock stands still.
"""

from pathlib import Path

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import pytest
from ros_harness import (executable, PARAMS, ros_node, run_swarm, spin_until, started,
                         wait_matched, write_scenario)
from rosbags.highlevel import AnyReader
from rosgraph_msgs.msg import Clock

from sat_agent.config import load_params_file
from sat_agent.ros import views
from sat_agent.ros.msg_conversions import header
from sat_agent.search_density import Lattice
from sat_agent.stamps import step_at, step_time, views_due
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate
from sat_agent.topic_names import AGENT_VIEWS
from sat_world_sim.bag_types import sat_typestore

DT = load_params_file(PARAMS).motion.dt
STANDARD = {'rosgraph_msgs/msg/Clock', 'nav_msgs/msg/OccupancyGrid', 'nav_msgs/msg/Path',
            'visualization_msgs/msg/MarkerArray', 'geometry_msgs/msg/PoseStamped',
            'geometry_msgs/msg/PoseArray'}


@pytest.mark.parametrize('dt', [1.0, 0.1, 0.25, 2.0])
def test_step_k_is_at_k_dt_and_a_stamp_gives_its_step_back(dt):
    for step in (1, 7, 199, 10 ** 6):
        sec, nanosec = step_time(step, dt)
        assert sec + nanosec * 1e-9 == pytest.approx(step * dt)
        assert 0 <= nanosec < 10 ** 9
        assert step_at(sec, nanosec, dt) == step
        # A stamp a little off the grid (a real detector's clock) still gives the step.
        assert step_at(sec, nanosec + int(0.3 * dt * 1e9), dt) == step


def test_views_are_decimated_by_their_rate_in_sim_time():
    def published(rate, dt, steps=20):
        last, out = None, []
        for k in range(1, steps + 1):
            if views_due(k, last, dt, rate):
                last = k
                out.append(k)
        return out

    assert published(1.0, 1.0) == list(range(1, 21))
    assert published(0.2, 1.0) == [1, 5, 10, 15, 20]
    assert published(1.0, 0.1) == [1, 10, 20]
    assert published(0.0, 1.0) == []


def test_the_occupancy_grid_is_the_density_on_the_lattice():
    lattice = Lattice(spacing=2.0, nx=3, ny=2)
    values = np.array([[0.0, 0.5, 1.0], [0.25, 1.0, 0.999]], dtype=np.float32)
    grid = views.occupancy_grid(values, lattice, header(4, DT))
    assert (grid.info.width, grid.info.height, grid.info.resolution) == (3, 2, 2.0)
    assert (grid.info.origin.position.x, grid.info.origin.position.y) == (0.0, 0.0)
    # Row-major from the origin, 100 = never searched, 0 = just searched.
    assert list(grid.data) == [100, 50, 0, 75, 0, 0]
    assert grid.header.frame_id == 'map' and grid.header.stamp.sec == 4


def test_estimate_markers_are_two_sigma_ellipses_with_ids_after_a_delete_all():
    covariance = np.zeros((4, 4))
    covariance[0, 0], covariance[2, 2] = 4.0, 1.0       # sigma_x 2 m, sigma_y 1 m
    estimate = MultiTargetEstimate((
        TargetEstimate(np.array([10.0, 20.0]), np.array([0.0, 1.0]), covariance, 0.9),
        TargetEstimate(np.array([30.0, 40.0]), np.zeros(2), np.eye(4), 1.1)), 2.0)
    markers = views.estimate_markers(3, estimate, header(9, DT)).markers
    assert markers[0].action == markers[0].DELETEALL
    ellipses = [m for m in markers if m.type == m.CYLINDER]
    labels = [m for m in markers if m.type == m.TEXT_VIEW_FACING]
    assert [m.id for m in ellipses] == [0, 1] and [m.id for m in labels] == [0, 1]
    # The rotated cylinder spans 2 sigma either side along x (2 m) and y (1 m).
    first = ellipses[0]
    yaw = 2.0 * np.arctan2(first.pose.orientation.z, first.pose.orientation.w)
    half = np.array([first.scale.x, first.scale.y]) / 2.0
    extent_x = np.hypot(half[0] * np.cos(yaw), half[1] * np.sin(yaw))
    extent_y = np.hypot(half[0] * np.sin(yaw), half[1] * np.cos(yaw))
    assert (extent_x, extent_y) == pytest.approx((4.0, 2.0))
    assert (first.pose.position.x, first.pose.position.y) == (10.0, 20.0)
    assert labels[0].text.startswith('3.0') and labels[1].text.startswith('3.1')
    poses = views.estimate_poses(estimate, header(9, DT)).poses
    # Heading along the velocity: +y is a quarter turn.
    assert poses[0].orientation.z == pytest.approx(np.sin(np.pi / 4))


def test_the_plan_path_holds_the_walk_and_truth_markers_draw_every_square():
    path = views.plan_path([[5.0, 5.0], [15.0, 5.0]], header(2, DT))
    assert [(p.pose.position.x, p.pose.position.y) for p in path.poses] == [
        (5.0, 5.0), (15.0, 5.0)]
    assert all(p.header.stamp.sec == 2 and p.header.frame_id == 'map' for p in path.poses)
    assert views.plan_path(np.zeros((0, 2)), header(2, DT)).poses == []
    markers = views.truth_markers([7], [[40.0, 50.0]], {1: (10.0, 60.0), 2: (60.0, 10.0)},
                                  (100.0, 100.0), 10.0, header(3, DT)).markers
    squares = next(m for m in markers if m.ns == 'world/squares')
    corners = {(p.x, p.y) for p in squares.points}
    assert len(squares.points) == 16 and {(5.0, 55.0), (15.0, 65.0), (65.0, 15.0)} <= corners
    assert {m.text for m in markers if m.type == m.TEXT_VIEW_FACING} == {
        'target 7', 'agent 1', 'agent 2'}


def headers_of(msg):
    """Every std_msgs/Header of a deserialised message, nested messages' included.

    A Marker's optional texture image (sensor_msgs/CompressedImage) is not part of what we
    draw and stays empty, header included.
    """
    found = []
    for name in getattr(msg, '__dataclass_fields__', {}):
        value = getattr(msg, name)
        if name == 'header':
            found.append(value)
        elif name != 'texture':
            for item in value if isinstance(value, list) else [value]:
                found += headers_of(item)
    return found


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(600)
def test_the_run_bag_holds_clock_and_views_with_step_stamps_and_frames(paper_run):
    run_dir, code, _, output = paper_run
    assert code == 0, output[-3000:]
    counts, clock, problems = {}, [], []
    with AnyReader([Path(run_dir) / 'bag'], default_typestore=sat_typestore()) as reader:
        for connection, _, raw in reader.messages():
            msg = reader.deserialize(raw, connection.msgtype)
            counts[connection.msgtype] = counts.get(connection.msgtype, 0) + 1
            if connection.msgtype == 'rosgraph_msgs/msg/Clock':
                clock.append(msg.clock.sec + msg.clock.nanosec * 1e-9)
                continue
            stamps = headers_of(msg)
            step = getattr(msg, 'step', None)
            for stamp in stamps:
                t = stamp.stamp.sec + stamp.stamp.nanosec * 1e-9
                if t <= 0 or not stamp.frame_id or (step is not None and t != step * DT):
                    problems.append((connection.topic, step, t, stamp.frame_id))
            if not stamps:
                problems.append((connection.topic, 'no header'))
    assert problems == []
    assert STANDARD <= set(counts)
    assert clock == [k * DT for k in range(1, 201)]
    # One view of each kind per agent and step at the default rate (1 per second of sim time);
    # the plan when it changed (a node visited, a new plan, TRACK).
    assert counts['nav_msgs/msg/OccupancyGrid'] == 2 * 200
    assert 2 * 5 <= counts['nav_msgs/msg/Path'] < 2 * 200
    assert counts['geometry_msgs/msg/PoseStamped'] == 2 * 2 * 200    # goal and pose
    assert set(AGENT_VIEWS.values()) <= set(counts)


@pytest.mark.ros
@pytest.mark.timeout(300)
def test_the_real_time_clock_publishes_the_same_sim_time(tmp_path):
    scenario = write_scenario(
        tmp_path / 'rt.yaml', name='real_time_clock', seed=2, steps=6, truth_process_noise=0.0,
        agents=[{'id': 1, 'start': [10.0, 10.0]}])
    code, _, output = run_swarm(tmp_path / 'run', scenario, '--clock', 'real_time', '--period',
                                '0.3', '--view', 'none', '--quiet', timeout=240)
    assert code == 0, output[-3000:]
    with AnyReader([tmp_path / 'run' / 'bag'], default_typestore=sat_typestore()) as reader:
        clock = [reader.deserialize(raw, c.msgtype).clock.sec
                 for c, _, raw in reader.messages() if c.topic == '/clock']
        grids = [reader.deserialize(raw, c.msgtype).header.stamp.sec
                 for c, _, raw in reader.messages() if c.topic == '/agent_1/view/search_density']
    assert clock == [1, 2, 3, 4, 5, 6]
    # A late agent may miss a step in real time; whatever it publishes is stamped on /clock.
    assert grids and set(grids) <= set(clock)


@pytest.mark.ros
@pytest.mark.timeout(120)
def test_an_agent_on_sim_time_reads_clock_and_its_timers_run_while_the_clock_stands(tmp_path):
    command = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_5',
               '--params-file', str(PARAMS), '-p', 'agent_id:=5', '-p', 'use_sim_time:=true',
               '-p', 'diagnostics_period:=0.2']
    with ros_node('sim_clock') as node:
        clock = node.create_publisher(Clock, '/clock', 10)
        stamps = []
        node.create_subscription(
            DiagnosticArray, '/diagnostics',
            lambda m: stamps.extend(m.header.stamp.sec for s in m.status
                                    if s.hardware_id == 'agent_5'), 10)
        with started(command, tmp_path / 'agent.log') as agent:
            # rclpy reads /clock best effort, keep last 1: a sample sent before the agent's
            # reader matched this writer is lost, so the test is a clock source that keeps
            # publishing the time (standing at 42 s), as a simulator does.
            wait_matched(node, [clock], 60, "the test's /clock writer matching the agent")
            node.create_timer(0.1, lambda: clock.publish(Clock(clock=step_time_msg(42))))
            spin_until(node, lambda: stamps and stamps[-1] == 42, 60,
                       'a diagnostics message stamped with the published sim time', (agent,))
            # The clock stands at 42 s: the diagnostics timer (steady) still fires.
            seen = len(stamps)
            spin_until(node, lambda: len(stamps) - seen >= 4, 30,
                       'four more diagnostics while the sim clock stands', (agent,))
    assert stamps[seen - 1] == 42 and set(stamps[seen:]) == {42}


def step_time_msg(step: int):
    return header(step, DT).stamp
