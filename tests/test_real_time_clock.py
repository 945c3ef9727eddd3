"""The real-time clock through the ROS graph: steps on time, radio in range only, every step kept.

In the real-time clock world_sim forwards each report as it arrives (not in one burst at the
next step), so this checks that the range gate still holds on that path and that agents in
range hear each other every step.
"""

from collections import defaultdict

import pytest
from ros_harness import run_swarm, scaled, write_scenario

from sat_msgs.msg import WorldStep
from sat_world_sim.bag_replay import deserialized

pytestmark = pytest.mark.ros
STEPS = 8
PERIOD_S = 1.0


@pytest.mark.timeout(300)
def test_real_time_run_keeps_the_range_gate_and_every_step(tmp_path):
    # Agents 1 and 2 are 20 m apart and stay within C_R = 50 m for 8 steps of at most 4 m;
    # agent 3 is ~110 m away from both.
    scenario = write_scenario(
        tmp_path / 'rt.yaml', name='real_time', seed=2, steps=STEPS, truth_process_noise=0.0,
        agents=[{'id': 1, 'start': [10.0, 10.0]}, {'id': 2, 'start': [30.0, 10.0]},
                {'id': 3, 'start': [95.0, 95.0]}])
    run_dir = tmp_path / 'run'
    # A report later than its step's period is dropped (stale), by design: the period leaves
    # an agent's step (first one included: its core is built then) room on a loaded machine.
    code, metrics, output = run_swarm(run_dir, scenario, '--clock', 'real_time', '--period',
                                      str(scaled(PERIOD_S)), '--quiet', timeout=240)
    assert code == 0, output[-3000:]
    assert [s['step'] for s in metrics['steps']] == list(range(1, STEPS + 1))
    assert isinstance(metrics['late_commands'], int)

    senders = defaultdict(set)      # receiver -> {(sender, step)} of forwarded densities
    clocks = set()
    for topic, msg in deserialized(run_dir / 'bag'):
        if topic.endswith('/radio/in/search_density'):
            senders[int(topic.split('/')[1][len('agent_'):])].add((msg.agent_id, msg.step))
        elif topic == '/world/step':
            clocks.add(msg.clock)
    assert clocks == {WorldStep.CLOCK_REAL_TIME}
    assert {sender for sender, _ in senders[1]} == {2}
    assert {sender for sender, _ in senders[2]} == {1}
    assert not senders[3]
    # Reports of every step but the last (sent after the world's final step) were forwarded.
    assert {step for _, step in senders[1]} >= set(range(1, STEPS))
