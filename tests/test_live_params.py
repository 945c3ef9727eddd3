"""Live parameters through rclpy's parameter service client, against running nodes.

``ros2 param set`` of a read-only parameter is refused by rclpy; of a live one with a bad value,
refused with the schema's reason (the parameter, the value, what is allowed); of a live one with
a good value, applied: ``get`` shows it and the node behaves by it (world_sim's radio links,
an agent's views). A node started without ``live_parameters:=true`` refuses every change: its
live parameters are read-only too.
``ros2 param describe`` shows each parameter's description, range and read-only flag.
"""

from pathlib import Path
import re
import time

from geometry_msgs.msg import PoseStamped
import pytest
import rclpy
from rclpy.parameter import Parameter, parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from ros_harness import (executable, PARAMS, ros_node, scaled, spin_until, started, wait_for_text,
                         wait_matched, write_scenario)

from sat_agent.config import SatParams
from sat_agent.node_params import AgentNodeParams, LIVE_SWITCH
from sat_agent.parameter_schema import leaves
from sat_agent.ros.qos import WORLD
from sat_agent.topic_names import VIEW_PREFIX
from sat_msgs.msg import RadioTraffic

# Bounds (scaled by SAT_TEST_TIMEOUT_SCALE): a node's start-up, a parameter service's answer.
START_S = 60.0
ANSWER_S = 30.0
# An unanswered request is sent again after this: Fast DDS drops a service's response if the
# server has not matched the client's response reader within 100 ms ("client will not receive
# response"), which a loaded machine exceeds (CI lost a first describe so). Every request here
# is idempotent: describe, get, list, or set of one value.
RESEND_S = 5.0
# Steps watched after a change.
WATCH_STEPS = 4


def call(node, send, what: str):
    """Return the answer to send()'s request (send returns its future), sent again if unanswered.

    An answer to any of the copies counts.
    """
    futures = []
    deadline = time.monotonic() + scaled(ANSWER_S)
    while time.monotonic() < deadline:
        futures.append(send())
        resend_at = min(deadline, time.monotonic() + scaled(RESEND_S))
        while time.monotonic() < resend_at:
            answered = [future for future in futures if future.done()]
            if answered:
                return answered[0].result()
            rclpy.spin_once(node, timeout_sec=0.1)
    raise AssertionError(f'{what}: no answer to {len(futures)} requests in '
                         f'{scaled(ANSWER_S):g} s (SAT_TEST_TIMEOUT_SCALE scales it)')


def services(node, name: str) -> AsyncParameterClient:
    """Return a parameter client of node name once its services are up."""
    client = AsyncParameterClient(node, name)
    assert client.wait_for_services(timeout_sec=scaled(START_S)), f'{name} parameter services'
    return client


def set_one(node, client, name, value):
    """Set one parameter; return its SetParametersResult."""
    return call(node, lambda: client.set_parameters([Parameter(name, value=value)]),
                f'set {name}').results[0]


def assert_refused(node, client, name, value, reason: str):
    """Set one parameter and check it is refused with reason in the answer."""
    result = set_one(node, client, name, value)
    assert not result.successful and reason in result.reason, result.reason


def change_step(log: Path, node_name: str, name: str, processes) -> int:
    """Return the step a node's log says a live change of name holds from (ros_params.py).

    From the node's own log, not a topic: what the test last received of any topic may be
    steps behind the node (DDS orders nothing across topics and the test may lag).
    """
    pattern = re.compile(rf'live change (at|after) step (\d+): {re.escape(name)} = ')
    wait_for_text(log, f': {name} = ', ANSWER_S, f"{node_name}'s log line of the change",
                  processes)
    where, step = pattern.search(log.read_text(encoding='utf-8')).groups()
    return int(step) + (where == 'after')


def get_one(node, client, name):
    """Get one parameter's value (rclpy's Parameter value)."""
    answer = call(node, lambda: client.get_parameters([name]), f'get {name}')
    return parameter_value_to_python(answer.values[0])


@pytest.mark.ros
@pytest.mark.timeout(180)
def test_agent_parameters_are_described_refused_with_a_reason_or_applied(tmp_path):
    command = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_1',
               '--params-file', str(PARAMS), '-p', 'agent_id:=1', '-p', f'{LIVE_SWITCH}:=true']
    with ros_node('param_test_client') as node, started(command, tmp_path / 'agent.log') as agent:
        client = services(node, '/agent_1/agent')
        described = call(node, lambda: client.describe_parameters(
            ['sensor.p_detect', 'search.investigate_steps', 'search.policy']),
            'describe').descriptors
        p_detect, budget, policy = described
        assert 'p_D' in p_detect.description and p_detect.read_only
        assert (p_detect.floating_point_range[0].from_value,
                p_detect.floating_point_range[0].to_value) == (0.0, 1.0)
        assert '(0, 1]' in p_detect.additional_constraints
        assert not budget.read_only and budget.integer_range[0].from_value == 1
        assert "'thompson'" in policy.additional_constraints and policy.read_only
        names = {name for schema in (SatParams, AgentNodeParams)
                 for name, _, _ in leaves(schema)}
        listed = call(node, client.list_parameters, 'list').result.names
        assert names <= set(listed)

        assert_refused(node, client, 'sensor.p_detect', 5.0, 'read-only')
        assert get_one(node, client, 'sensor.p_detect') == 0.99

        # Outside the descriptor's range: rclpy refuses first, naming the range.
        assert_refused(node, client, 'search.investigate_steps', 0,
                       'search.investigate_steps out of range. Min: 1, Max: 10000, value: 0')
        # At an open end, or of the wrong type: the schema refuses (the on-set callback).
        assert_refused(node, client, 'report_wait_timeout', 0.0,
                       "'report_wait_timeout' = 0.0: allowed range is (0, 86400]")
        assert_refused(node, client, 'view_rate', 'hello',
                       "'view_rate' = 'hello': must be a number")
        assert get_one(node, client, 'search.investigate_steps') == 4

        applied = set_one(node, client, 'search.investigate_steps', 7)
        assert applied.successful, applied.reason
        assert get_one(node, client, 'search.investigate_steps') == 7
        applied = set_one(node, client, 'view_rate', 2)     # an int for a float is fine
        assert applied.successful, applied.reason
        # Outside the schemas: rclpy's clock switch (a robot agent's check of its scans' stamps
        # reads the clock) and the roster stay as started, live parameters or not.
        assert_refused(node, client, 'use_sim_time', True, "'use_sim_time' is read-only")
        assert_refused(node, client, 'agent_ids', [1, 2, 3], "'agent_ids' is read-only")
        assert agent.poll() is None, (tmp_path / 'agent.log').read_text()


@pytest.mark.ros
@pytest.mark.timeout(300)
def test_live_changes_cut_the_radio_links_and_stop_an_agents_views(tmp_path):
    scenario = write_scenario(tmp_path / 'pair.yaml', name='pair', seed=3, steps=400,
                              agents=[{'id': 1, 'start': [40.0, 50.0]},
                                      {'id': 2, 'start': [50.0, 50.0]}])
    common = ['--params-file', str(PARAMS), '-p', 'seed:=3']
    live = ['-p', f'{LIVE_SWITCH}:=true']
    world = [executable('sat_world_sim', 'world_sim'), '--ros-args', *common, *live,
             '-p', f'scenario:={scenario}', '-p', 'clock:=real_time', '-p', 'period:=0.3']
    # Agent 2 keeps the default: its live parameters are read-only.
    agents = [[executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{i}',
               *common, '-p', f'agent_id:={i}', *switch] for i, switch in ((1, live), (2, []))]
    traffic, views = {}, set()
    with ros_node('param_test_client') as node, \
            started(world, tmp_path / 'world.log') as world_sim, \
            started(agents[0], tmp_path / 'agent_1.log') as agent_1, \
            started(agents[1], tmp_path / 'agent_2.log') as agent_2:
        running = (world_sim, agent_1, agent_2)
        node.create_subscription(RadioTraffic, '/world/radio',
                                 lambda m: traffic.__setitem__(m.step, len(m.link_a)), 50)
        view_reader = node.create_subscription(PoseStamped, f'/agent_1/{VIEW_PREFIX}pose',
                                               lambda m: views.add(m.header.stamp.sec), WORLD)
        client = services(node, '/world_sim')
        # 10 m apart at the start, within C_R = 50 m: linked.
        spin_until(node, lambda: any(traffic.values()), START_S, 'a step with a radio link',
                   running)
        # The world's traffic says nothing of the agent's writers: under load this reader can
        # match the view writer seconds later (transient local, so it then gets the history).
        wait_matched(node, [view_reader], START_S,
                     "the test's reader of agent 1's pose view matching the agent's writer")

        assert_refused(node, client, 'cooperation.comm_range', -1.0,
                       'cooperation.comm_range out of range Min: 0.0, Max: inf, value: -1.0')
        assert_refused(node, client, 'radio.loss', 1.0,
                       "'radio.loss' = 1.0: allowed range is [0, 1)")
        assert any(traffic.values())
        assert_refused(node, client, 'radio.delay_steps', 2, 'read-only')

        applied = set_one(node, client, 'cooperation.comm_range', 0.0)
        assert applied.successful, applied.reason
        changed_at = change_step(tmp_path / 'world.log', 'world_sim', 'cooperation.comm_range',
                                 running)
        assert get_one(node, client, 'cooperation.comm_range') == 0.0
        # From the step the change landed in, no pair is within 0 m.
        spin_until(node, lambda: max(traffic) >= changed_at + WATCH_STEPS, START_S,
                   f'{WATCH_STEPS} steps after the change', running)
        assert [k for k in traffic if k < changed_at and traffic[k]], 'no link before the change'
        assert all(traffic[k] == 0 for k in traffic if k >= changed_at)

        # The agent's views (every step at view_rate 1 with dt = 1 s; stamp = step) come after
        # the change too, and stop at view_rate 0.
        agent = services(node, '/agent_1/agent')
        spin_until(node, lambda: views and max(views) > changed_at, START_S,
                   f"agent 1's pose view of a step after {changed_at}", running)
        applied = set_one(node, agent, 'view_rate', 0.0)
        assert applied.successful, applied.reason
        stopped_at = change_step(tmp_path / 'agent_1.log', 'agent 1', 'view_rate', running)
        # Views the agent might still send after the change have had WATCH_STEPS steps to come.
        spin_until(node, lambda: max(traffic) >= stopped_at + WATCH_STEPS, START_S,
                   f'{WATCH_STEPS} steps after view_rate 0', running)
        assert not [k for k in views if k >= stopped_at]

        locked = services(node, '/agent_2/agent')
        for name, value in (('view_rate', 0.0), ('world_timeout', 1e-6)):
            assert_refused(node, locked, name, value, 'read-only')
            described = call(node, lambda: locked.describe_parameters([name]), 'describe')
            assert described.descriptors[0].read_only
        assert get_one(node, locked, 'world_timeout') == 60.0
        assert_refused(node, locked, 'use_sim_time', True,
                       f"'use_sim_time' is read-only while the node runs (started without "
                       f'{LIVE_SWITCH}:=true)')
