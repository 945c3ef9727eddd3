"""The swarm as separate OS processes over DDS.

First contact, the paper's run, determinism, overlap resolution and a killed agent. Every process
is started here and stopped by its pid.
"""

import json
import os
import signal
import time

import numpy as np
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_harness import (announce, executable, PARAMS, REPO, ros_node, run_swarm, scaled,
                         spin_until, started, wait_exit, write_scenario)

from sat_agent.config import load_params_file
from sat_msgs.msg import AgentStatus, GroundTruth, SearchDensity, WorldStep
from sat_world_sim.inprocess_swarm import run_swarm as run_inprocess
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.records import density_values
from sat_world_sim.scenario import load_scenario

pytestmark = pytest.mark.ros
RELIABLE = QoSProfile(depth=300, reliability=ReliabilityPolicy.RELIABLE)
WORLD = QoSProfile(depth=300, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.TRANSIENT_LOCAL)
PAPER = REPO / 'config' / 'scenarios' / 'paper.yaml'


def world_command(scenario, *params):
    args = [executable('sat_world_sim', 'world_sim'), '--ros-args', '--params-file', str(PARAMS),
            '-p', f'scenario:={scenario}']
    for param in params:
        args += ['-p', param]
    return args


def agent_command(agent_id):
    return [executable('sat_agent', 'agent'), '--ros-args', '-r', f'__ns:=/agent_{agent_id}',
            '--params-file', str(PARAMS), '-p', f'agent_id:={agent_id}']


class Observer:
    """Records /world/step and /world/truth, every agent's status and the densities they send."""

    def __init__(self, node, agent_ids):
        self.steps, self.finished = [], False
        self.truth = {}          # step -> GroundTruth
        self.status = {}         # (agent, step) -> AgentStatus
        self.density = {}        # (agent, step) -> (ny, nx) values sent
        subscriptions = [node.create_subscription(WorldStep, '/world/step', self.on_step, WORLD),
                         node.create_subscription(
                             GroundTruth, '/world/truth',
                             lambda m: self.truth.__setitem__(m.step, m), WORLD)]
        for i in agent_ids:
            subscriptions.append(node.create_subscription(
                AgentStatus, f'/agent_{i}/status',
                lambda m, i=i: self.status.__setitem__((i, m.step), m), RELIABLE))
            subscriptions.append(node.create_subscription(
                SearchDensity, f'/agent_{i}/radio/out/search_density',
                lambda m, i=i: self.density.__setitem__(
                    (i, m.step), density_values(m)),
                RELIABLE))
        # world_sim starts step 1 once this observer says it sees every topic.
        self.ready = announce(node, subscriptions)

    def on_step(self, msg):
        self.steps.append((time.monotonic(), msg.step))
        self.finished = self.finished or msg.finished


@pytest.fixture
def watcher():
    with ros_node('swarm_test_observer') as node:
        yield node


@pytest.mark.timeout(240)
def test_first_contact_fuses_densities_and_both_adopt_one_joint_plan(tmp_path, watcher):
    observer = Observer(watcher, (1, 2))
    world = world_command(PAPER, 'steps:=60', 'observers:=1')
    with started(world, tmp_path / 'world.log') as w, \
            started(agent_command(1), tmp_path / 'a1.log') as a1, \
            started(agent_command(2), tmp_path / 'a2.log') as a2:
        spin_until(watcher, lambda: observer.finished, 180, 'the 60-step run finishing',
                   (w, a1, a2))
        # Other topics than /world/step: their last step may come after it. Each writer
        # delivers in order, so its step 60 comes after all its earlier ones.
        last = [(i, 60) for i in (1, 2)]
        spin_until(watcher,
                   lambda: all(k in observer.status and k in observer.density for k in last),
                   30, "both agents' status and density of step 60", (a1, a2))
    joint = sorted(k for k in range(1, 61)
                   if all(list(observer.status[(i, k)].group) == [1, 2] for i in (1, 2)))
    assert joint, 'the agents never planned together'
    contact = joint[0]
    # Both switched at the same step, each on its own, from the reports of step contact - 1.
    for i in (1, 2):
        assert list(observer.status[(i, contact - 1)].group) == [i]
    plans = [{(round(p.x, 6), round(p.y, 6)) for p in observer.status[(i, contact)].plan[:-1]}
             for i in (1, 2)]
    assert plans[0] and plans[1] and not plans[0] & plans[1], 'joint walks share nodes'
    # Fusion: what each sends at `contact` covers what the other sent at contact - 1, predicted
    # to `contact` (outside the sender's square decayed by J; float32 on the wire).
    decay = load_params_file(PARAMS).search.decay
    for i, j in ((1, 2), (2, 1)):
        assert np.all(observer.density[(i, contact)]
                      >= decay * observer.density[(j, contact - 1)] - 1e-6)


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_paper_scenario_runs_through_the_ros_graph(paper_run):
    run_dir, code, metrics, output = paper_run
    assert code == 0, output[-3000:]
    steps = metrics['steps']
    assert [s['step'] for s in steps] == list(range(1, 201))
    assert [(t['id'], t['born'], t['died']) for t in metrics['targets']] == [
        (1, 104, 179), (2, 144, 182)]
    assert all(set(s['modes']) == {'1', '2'} for s in steps)
    assert steps[-1]['searched_pct'] > steps[0]['searched_pct'] > 0
    assert metrics['radio']['1']['messages'] > 0 and metrics['radio']['2']['bytes'] > 0
    plots = sorted(p.name for p in (run_dir / 'plots').glob('*.png'))
    assert plots == ['cardinality.png', 'ospa.png', 'searched.png', 'trajectories.png']
    assert (run_dir / 'run.rrd').is_file() and (run_dir / 'bag' / 'metadata.yaml').is_file()


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_paper_scenario_figures_through_the_ros_graph(paper_run):
    _, code, metrics, output = paper_run
    assert code == 0, output[-3000:]
    steps = metrics['steps']
    searched_103 = max(s['searched_pct'] for s in steps if s['step'] <= 103)
    assert searched_103 >= 65.0
    # Coverage keeps growing while an agent tracks.
    tracking = [s for s in steps if s['tracking']]
    assert tracking and tracking[-1]['searched_pct'] > tracking[0]['searched_pct']
    for target in metrics['targets']:
        assert target['detection_delay'] is not None and target['detection_delay'] <= 10, target
    # One tracks while the other searches.
    assert any(sorted(s['modes'].values()) == ['SEARCH', 'TRACK'] for s in tracking)


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_paper_scenario_mean_ospa_while_tracking_through_the_ros_graph(paper_run):
    _, code, metrics, output = paper_run
    assert code == 0, output[-3000:]
    tracking = [s['ospa'] for s in metrics['steps'] if s['tracking']]
    assert tracking and np.mean(tracking) <= 3.0


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_lock_step_runs_with_one_seed_give_identical_metrics(tmp_path):
    texts = []
    for name in ('a', 'b'):
        code, metrics, output = run_swarm(tmp_path / name, PAPER, '--steps', '120', '--seed', '5')
        assert code == 0, output[-3000:]
        texts.append((tmp_path / name / 'metrics.json').read_text())
    assert texts[0] == texts[1]
    assert json.loads(texts[0])['seed'] == 5


def inprocess_metrics(scenario, params=PARAMS):
    """metrics.json of the in-process swarm for the same files, as read back from JSON."""
    run = run_inprocess(load_scenario(scenario), load_params_file(params))
    return json.loads(json.dumps(compute_metrics(run.records, run.scenario.name,
                                                 run.scenario.seed)))


@pytest.mark.slow
@pytest.mark.timeout(600)
def test_the_ros_paper_run_gives_the_in_process_metrics(paper_run):
    _, code, metrics, output = paper_run
    assert code == 0, output[-3000:]
    # Every step's OSPA, counts, coverage and modes, every target, overlap event and radio
    # count: the lock-step graph is the in-process loop with real transport.
    assert metrics == inprocess_metrics(PAPER)


@pytest.mark.timeout(300)
def test_a_random_birth_baseline_swarm_gives_the_in_process_metrics(tmp_path):
    # Three agents in range of each other, random births and the random-walk baseline (its own
    # random stream) for 40 steps: the ROS run must draw the same numbers.
    scenario = write_scenario(
        tmp_path / 'births.yaml', name='births', seed=4, steps=40, truth_process_noise=1.0,
        agents=[{'id': 1, 'start': [40.0, 50.0]}, {'id': 2, 'start': [60.0, 50.0]},
                {'id': 3, 'start': [50.0, 40.0]}],
        random_births={'rate': 0.1, 'survival': 0.99, 'speed_std': 0.5},
        targets=[{'id': 1, 'born': 1, 'died': 40, 'start': [45.0, 50.0], 'end': [55.0, 50.0]}])
    params = tmp_path / 'random_walk.yaml'
    params.write_text(PARAMS.read_text().replace('policy: sat', 'policy: random_walk'))
    assert load_params_file(params).search.policy == 'random_walk'
    code, metrics, output = run_swarm(tmp_path / 'run', scenario, '--no-record', '--no-view',
                                      params=params)
    assert code == 0, output[-3000:]
    expected = inprocess_metrics(scenario, params)
    assert len(expected['targets']) > 1 and expected['radio']['3']['messages'] > 0
    assert metrics == expected


@pytest.mark.timeout(300)
def test_two_trackers_on_the_same_target_end_with_one_tracking(tmp_path):
    scenario = write_scenario(
        tmp_path / 'overlap.yaml', name='overlap', seed=2, steps=60, truth_process_noise=1e-4,
        agents=[{'id': 1, 'start': [47.0, 50.0]}, {'id': 2, 'start': [53.0, 50.0]}],
        targets=[{'id': 1, 'born': 1, 'died': 60, 'start': [50.0, 50.0], 'end': [62.0, 50.0]}])
    code, metrics, output = run_swarm(tmp_path / 'run', scenario)
    assert code == 0, output[-3000:]
    steps = metrics['steps']
    both = [s['step'] for s in steps if list(s['modes'].values()) == ['TRACK', 'TRACK']]
    assert both, 'the two agents never tracked together'
    events = metrics['overlap_events']
    assert events and events[0]['agent'] == 2 and events[0]['left_for'] == 1
    resolved = events[0]['step']
    window = 5
    assert resolved - both[0] <= window + 1
    after = [s for s in steps if s['step'] > resolved]
    assert after and all(s['modes'] == {'1': 'TRACK', '2': 'SEARCH'} for s in after[:5])


@pytest.mark.timeout(300)
def test_a_killed_agent_stalls_the_world_at_most_the_timeout(tmp_path, watcher):
    observer = Observer(watcher, ())
    timeout = 3.0
    steps = 80
    run_dir = tmp_path / 'run'
    world = world_command(PAPER, f'steps:={steps}', 'observers:=2', f'agent_timeout:={timeout}')
    metrics = [executable('sat_world_sim', 'metrics'), '--ros-args', '--params-file',
               str(PARAMS), '-p', f'run_dir:={run_dir}', '-p', 'agent_ids:=[1,2]']
    with started(world, tmp_path / 'world.log') as w, \
            started(metrics, tmp_path / 'metrics.log') as m, \
            started(agent_command(1), tmp_path / 'a1.log'), \
            started(agent_command(2), tmp_path / 'a2.log') as a2:
        spin_until(watcher, lambda: observer.steps and observer.steps[-1][1] >= 30, 120,
                   '/world/step reaching step 30', (w, m))
        os.kill(a2.pid, signal.SIGKILL)
        a2.wait()
        spin_until(watcher, lambda: observer.finished and steps in observer.truth, 120,
                   'the run finishing', (w, m))
        assert wait_exit(m, 30, 'metrics writing metrics.json') == 0, \
            (tmp_path / 'metrics.log').read_text()[-3000:]
    # Between two steps the world waited at most the timeout (and the messages' way here).
    gaps = np.diff([t for t, _ in observer.steps])
    assert gaps.max() <= timeout + scaled(1.5), f'world stalled {gaps.max():.1f} s'
    result = json.loads((run_dir / 'metrics.json').read_text())
    assert [s['step'] for s in result['steps']] == list(range(1, steps + 1))
    # Agent 2 reported up to some step, never after: its last report came before the world
    # marked it inactive, one step later (or two, killed between its status and command).
    reported = [s['step'] for s in result['steps'] if '2' in s['modes']]
    assert reported == list(range(1, len(reported) + 1)), 'a dead agent still reported'
    inactive = [k for k, truth in sorted(observer.truth.items())
                if not next(a.active for a in truth.agents if a.id == 2)]
    assert inactive and inactive == list(range(inactive[0], steps + 1)), inactive
    assert len(reported) + 1 <= inactive[0] <= len(reported) + 2
