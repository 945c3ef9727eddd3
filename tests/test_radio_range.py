"""Range gating over real DDS: world_sim in its own process, two scripted agents in this one.

The agents fly head-on along y = 50 (4 m per step each, so the gap shrinks by 8 m a step), meet
and separate again. Every report must reach the other agent exactly for the steps at which the
two were within C_R = 50 m (true positions from /world/truth), and never otherwise.
"""

from array import array
import time

import numpy as np
import pytest
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import executable, PARAMS, started, write_scenario

from sat_agent.config import SatParams
from sat_agent.density_codec import encode_density
from sat_msgs.msg import (AgentMode, ControlCommand, GroundTruth, MeasurementSet,
                          MultiTargetEstimate, SearchDensity, WorldStep)

pytestmark = pytest.mark.ros
RELIABLE = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)
WORLD = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.TRANSIENT_LOCAL)
KINDS = (('search_density', SearchDensity), ('estimate', MultiTargetEstimate),
         ('mode', AgentMode))
EAST, WEST = 9, 13          # 2 * Delta_R along 0 and pi (Eqn. controlVectors ordering)
STEPS = 20


class ScriptedAgents:
    """Both agents in one node: answer every scan with three reports and a fixed move."""

    def __init__(self, node):
        self.node = node
        self.truth = {}
        self.received = {1: set(), 2: set()}
        self.finished = False
        self.pubs = {}
        for i, action in ((1, EAST), (2, WEST)):
            ns = f'/agent_{i}'
            self.pubs[i] = {kind: node.create_publisher(cls, f'{ns}/radio/out/{kind}', RELIABLE)
                            for kind, cls in KINDS}
            self.pubs[i]['cmd'] = node.create_publisher(ControlCommand, f'{ns}/cmd', RELIABLE)
            node.create_subscription(MeasurementSet, f'{ns}/measurements',
                                     lambda m, i=i, a=action: self.on_scan(i, a, m), RELIABLE)
            for kind, cls in KINDS:
                node.create_subscription(
                    cls, f'{ns}/radio/in/{kind}',
                    lambda m, i=i, kind=kind: self.received[i].add((m.agent_id, m.step, kind)),
                    RELIABLE)
        node.create_subscription(GroundTruth, '/world/truth', self.on_truth, WORLD)
        node.create_subscription(WorldStep, '/world/step',
                                 lambda m: setattr(self, 'finished', m.finished), WORLD)

    def on_truth(self, msg):
        self.truth[msg.step] = {a.id: np.array([a.position.x, a.position.y]) for a in msg.agents}

    def on_scan(self, agent_id, action, msg):
        size = 100 * 100
        for kind, cls in KINDS:
            out = cls(agent_id=agent_id, step=msg.step)
            if kind == 'search_density':
                out.grid.resolution, out.grid.width, out.grid.height = 1.0, 100, 100
                out.values_zlib = array('B', encode_density(np.zeros(size)))
            self.pubs[agent_id][kind].publish(out)
        self.pubs[agent_id]['cmd'].publish(
            ControlCommand(agent_id=agent_id, step=msg.step, action_index=action))


@pytest.mark.timeout(180)
def test_reports_flow_exactly_while_agents_are_within_range(tmp_path):
    scenario = write_scenario(tmp_path / 'head_on.yaml', name='head_on', seed=3, steps=STEPS,
                              truth_process_noise=0.0,
                              agents=[{'id': 1, 'start': [10.0, 50.0]},
                                      {'id': 2, 'start': [90.0, 50.0]}])
    command = [executable('sat_world_sim', 'world_sim'), '--ros-args', '--params-file',
               str(PARAMS), '-p', f'scenario:={scenario}', '-p', 'observers:=0']
    rclpy.init()
    node = rclpy.create_node('scripted_agents')
    agents = ScriptedAgents(node)
    try:
        with started(command, tmp_path / 'world_sim.log') as world:
            deadline = time.monotonic() + 120
            while not agents.finished and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.05)
                assert world.poll() in (None, 0), (tmp_path / 'world_sim.log').read_text()
            # Let the last forwards arrive (there are none after the last step by design).
            end = time.monotonic() + 0.5
            while time.monotonic() < end:
                rclpy.spin_once(node, timeout_sec=0.05)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert agents.finished, 'world_sim did not finish the run'
    comm_range = SatParams().cooperation.comm_range
    in_range = {k for k, poses in agents.truth.items()
                if np.hypot(*(poses[1] - poses[2])) <= comm_range}
    # Gap 80 - 8 (k - 1): within 50 m for k = 5 .. 17, and the world moved the agents as told.
    assert in_range == set(range(5, 18))
    # A report of step k is read at k + 1, so the run's last step sends nothing anyone reads.
    expected_steps = in_range - {STEPS}
    for receiver, sender in ((1, 2), (2, 1)):
        got = agents.received[receiver]
        assert {s for (a, s, _) in got if a == sender} == expected_steps
        assert got == {(sender, k, kind) for k in expected_steps for kind, _ in KINDS}
        assert all(a == sender for (a, _, _) in got), 'a report came back to its own sender'
