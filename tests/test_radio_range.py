"""Range gating over real DDS: world_sim in its own process, two scripted agents in this one.

The agents fly head-on along y = 50 (4 m per step each, so the gap shrinks by 8 m a step), meet
and separate again. Every report must reach the other agent exactly for the steps at which the
two were within C_R = 50 m (true positions from /world/truth), and never otherwise.
"""

from array import array

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import (announce, executable, PARAMS, ros_node, spin_until, started,
                         write_scenario)

from sat_agent.config import SatParams
from sat_agent.density_codec import encode_density
from sat_msgs.msg import (AgentMode, ControlCommand, GroundTruth, MeasurementSet,
                          MultiTargetEstimate, RadioTraffic, SearchDensity, WorldStep)

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
        self.received = {1: [], 2: []}
        self.traffic = {}        # step -> RadioTraffic
        self.finished = False
        self.pubs = {}
        inputs = []
        for i, action in ((1, EAST), (2, WEST)):
            ns = f'/agent_{i}'
            self.pubs[i] = {kind: node.create_publisher(cls, f'{ns}/radio/out/{kind}', RELIABLE)
                            for kind, cls in KINDS}
            self.pubs[i]['cmd'] = node.create_publisher(ControlCommand, f'{ns}/cmd', RELIABLE)
            inputs.append(node.create_subscription(
                MeasurementSet, f'{ns}/measurements',
                lambda m, i=i, a=action: self.on_scan(i, a, m), RELIABLE))
            for kind, cls in KINDS:
                inputs.append(node.create_subscription(
                    cls, f'{ns}/radio/in/{kind}',
                    lambda m, i=i, kind=kind: self.received[i].append((m.agent_id, m.step, kind)),
                    RELIABLE))
        inputs += [
            node.create_subscription(GroundTruth, '/world/truth', self.on_truth, WORLD),
            node.create_subscription(RadioTraffic, '/world/radio',
                                     lambda m: self.traffic.__setitem__(m.step, m), WORLD),
            node.create_subscription(WorldStep, '/world/step',
                                     lambda m: setattr(self, 'finished', m.finished), WORLD)]
        # world_sim starts once these writers matched its readers and its writers these.
        self.ready = announce(node, inputs, [p for pubs in self.pubs.values()
                                             for p in pubs.values()])

    def forwarded(self, sender, receiver):
        """Messages the world counted from sender to receiver up to the last delivered step.

        Reports of step k are forwarded at the start of k + 1, so those of the final step never
        are; /world/radio counts cumulatively, at the end of each step.
        """
        traffic = self.traffic[STEPS - 1]
        pairs = list(zip(traffic.sender, traffic.receiver))
        return traffic.messages[pairs.index((sender, receiver))] if (sender, receiver) in pairs \
            else 0

    def all_in(self):
        """Whether the run is over and every truth and forwarded message is here."""
        return self.finished and STEPS in self.truth and STEPS - 1 in self.traffic and all(
            len(self.received[receiver]) >= self.forwarded(sender, receiver)
            for receiver, sender in ((1, 2), (2, 1)))

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
    with ros_node('scripted_agents') as node:
        agents = ScriptedAgents(node)
        with started(command, tmp_path / 'world_sim.log') as world:
            # Truth and forwards come on other topics than /world/step: wait until every
            # message the world sent is in.
            spin_until(node, agents.all_in, 120,
                       'the run finishing with every truth and forwarded report received',
                       (world,))
    comm_range = SatParams().cooperation.comm_range
    in_range = {k for k, poses in agents.truth.items()
                if np.hypot(*(poses[1] - poses[2])) <= comm_range}
    # Gap 80 - 8 (k - 1): within 50 m for k = 5 .. 17, and the world moved the agents as told.
    assert in_range == set(range(5, 18))
    # A report of step k is read at k + 1, so the run's last step sends nothing anyone reads.
    expected_steps = in_range - {STEPS}
    for receiver, sender in ((1, 2), (2, 1)):
        assert len(agents.received[receiver]) == agents.forwarded(sender, receiver)
        assert len(set(agents.received[receiver])) == len(agents.received[receiver]), \
            'a report was forwarded twice'
        got = set(agents.received[receiver])
        assert {s for (a, s, _) in got if a == sender} == expected_steps
        assert got == {(sender, k, kind) for k in expected_steps for kind, _ in KINDS}
        assert all(a == sender for (a, _, _) in got), 'a report came back to its own sender'
