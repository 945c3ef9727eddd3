import json
from pathlib import Path

import numpy as np
import pytest

from sat_agent.agent_core import wire_bytes
from sat_agent.config import load_params_file
from sat_world_sim.inprocess_swarm import InProcessSwarm, main, run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.scenario import load_scenario, scenario_from_mapping

CONFIG = Path(__file__).resolve().parent.parent / 'config'
PARAMS = CONFIG / 'paper.yaml'
SEEDS = range(10)


@pytest.fixture(scope='module')
def params():
    return load_params_file(PARAMS)


def single_target_runs_with(params):
    """Run the single-agent find-and-track scenario over 10 seeds: one metrics dict per seed."""
    scenario = load_scenario(CONFIG / 'scenarios' / 'single_target.yaml')
    runs = []
    for seed in SEEDS:
        run = run_swarm(scenario.with_seed(seed), params)
        runs.append(compute_metrics(run.records, scenario.name, seed))
    return runs


@pytest.fixture(scope='module')
def single_target_runs(params):
    return single_target_runs_with(params)


@pytest.fixture(scope='module')
def single_target_runs_tuned():
    """Run the same with config/tuned.yaml (the filter's Q at 0.02 of the paper's)."""
    return single_target_runs_with(load_params_file(CONFIG / 'tuned.yaml'))


@pytest.fixture(scope='module')
def paper_run(params):
    scenario = load_scenario(CONFIG / 'scenarios' / 'paper.yaml')
    run = run_swarm(scenario, params)
    return run, compute_metrics(run.records, scenario.name, scenario.seed)


def tracked_ospa(metrics):
    return [s['ospa'] for s in metrics['steps'] if s['tracking']]


def pooled_ospa_while_tracking(runs):
    """Mean OSPA over every tracked step of the runs, and per run whether it tracked at all."""
    per_run = [tracked_ospa(m) for m in runs]
    return float(np.mean(np.concatenate(per_run))), [bool(t) for t in per_run]


def test_single_agent_loop_detects_the_target_it_passes(single_target_runs):
    targets = [m['targets'][0] for m in single_target_runs]
    assert all(t['born'] == 3 for t in targets)
    # Born in the walk: in view at once, or a few steps later when the agent was looking at a
    # tentative peak elsewhere when it was born.
    assert all(t['first_in_view'] is not None and t['first_in_view'] <= 15 for t in targets)
    delays = [t['detection_delay'] for t in targets]
    detected = [d for d in delays if d is not None and d <= 10]
    # Scan -> filter -> estimate -> metrics: 10 of 10 seeds within 2-6 steps with
    # config/paper.yaml (7 of 10 under the dense reading of the clutter, README "Clutter").
    assert len(detected) >= 9, delays


def test_single_agent_finds_and_tracks_a_moving_target_with_mean_ospa_below_2m(
        single_target_runs):
    mean, tracked = pooled_ospa_while_tracking(single_target_runs)
    assert all(tracked), tracked
    assert mean < 2.0, mean


def test_single_agent_tracks_better_with_the_tuned_process_noise(
        single_target_runs, single_target_runs_tuned):
    # Seeds 0-9: 0.87 m with config/tuned.yaml (Q at 0.02, closer to the near-constant-velocity
    # truth), 1.59 m with the paper's Q.
    tuned, tracked = pooled_ospa_while_tracking(single_target_runs_tuned)
    paper, _ = pooled_ospa_while_tracking(single_target_runs)
    assert all(tracked), tracked
    assert tuned < 0.75 * paper, (tuned, paper)


def test_paper_run_records_every_step_and_both_scripted_targets(paper_run):
    run, metrics = paper_run
    assert [s['step'] for s in metrics['steps']] == list(range(1, 201))
    targets = {t['id']: t for t in metrics['targets']}
    assert (targets[1]['born'], targets[1]['died']) == (104, 179)
    assert (targets[2]['born'], targets[2]['died']) == (144, 182)
    assert [s['n_true'] for s in metrics['steps']][102:105] == [0, 1, 1]
    searched = [s['searched_pct'] for s in metrics['steps']]
    assert all(b >= a for a, b in zip(searched, searched[1:]))
    assert not any(run.records[i].refused_actions for i in range(200))
    json.dumps(metrics)


def paper_figures(run, metrics):
    """Return the four figures the issue asks of the in-process paper run."""
    steps = metrics['steps']
    targets = metrics['targets']
    released = [r.step for r in run.records if 'TRACK' in r.modes.values() and any(
        r.modes[a] == 'SEARCH' and why == 'RELEASED' for a, why in r.replans.items())]
    return {
        'searched_by_103': steps[102]['searched_pct'],
        'detection_delays': [t['detection_delay'] for t in targets],
        'mean_ospa_tracking': metrics['summary']['mean_ospa_tracking'],
        'released_steps': released,
    }


def test_paper_run_searches_65_percent_of_the_area_by_step_103(paper_run):
    assert paper_figures(*paper_run)['searched_by_103'] >= 65.0


def test_paper_run_detects_each_target_within_10_steps_of_entering_a_square(paper_run):
    delays = paper_figures(*paper_run)['detection_delays']
    assert all(d is not None and 0 <= d <= 10 for d in delays), delays


def test_paper_run_mean_ospa_while_some_agent_tracks_is_at_most_3m(paper_run):
    value = paper_figures(*paper_run)['mean_ospa_tracking']
    assert value is not None and value <= 3.0


def test_paper_run_one_agent_tracks_while_the_other_searches_its_released_nodes(paper_run):
    assert paper_figures(*paper_run)['released_steps']


def test_radio_carries_reports_only_between_agents_in_range(params):
    scenario = load_scenario(CONFIG / 'scenarios' / 'paper.yaml')
    swarm = InProcessSwarm(scenario, params)
    first = swarm.step()
    # (10, 60) and (60, 10) are 70.7 m apart: nothing is sent to anyone at k = 1.
    assert first.radio_messages == {1: 0, 2: 0}
    assert swarm.inbox(1) == [] and swarm.inbox(2) == []
    close = scenario_from_mapping({'seed': 1, 'steps': 3, 'agents': [
        {'id': 1, 'start': [10.0, 10.0]}, {'id': 2, 'start': [40.0, 10.0]},
        {'id': 3, 'start': [95.0, 95.0]}]})
    swarm = InProcessSwarm(close, params)
    record = swarm.step()
    # One report a step: three messages (density, estimate, mode) to the one neighbour.
    assert record.radio_messages == {1: 3, 2: 3, 3: 0}
    # The bytes are the compressed density as sent plus the estimate and mode messages.
    report = swarm.last_outputs[1].report
    assert record.radio_bytes[1] == report.nbytes and record.radio_bytes[3] == 0
    assert report.nbytes - len(report.encoded_search_values) == \
        wire_bytes('search_density', 0) + wire_bytes('estimate', len(report.estimate.targets)) \
        + wire_bytes('mode')
    # One square seen so far: the 40 kB float32 density shrinks below 1 kB.
    assert len(report.encoded_search_values) < 1_000
    assert [r.agent_id for r in swarm.inbox(1)] == [2]
    assert [r.agent_id for r in swarm.inbox(2)] == [1]
    assert swarm.inbox(3) == []
    assert all(r.step == 1 for r in swarm.inbox(1))


def test_same_seed_same_metrics_and_cli_writes_the_run_directory(tmp_path, capsys):
    scenario = str(CONFIG / 'scenarios' / 'single_target.yaml')
    out = tmp_path / 'run'
    assert main(['--scenario', scenario, '--params', str(PARAMS), '--out', str(out),
                 '--seed', '3', '--steps', '12']) == 0
    assert capsys.readouterr().out.strip().splitlines()[-1] == str(out)
    metrics = json.loads((out / 'metrics.json').read_text())
    assert metrics['seed'] == 3 and len(metrics['steps']) == 12
    assert sorted(p.name for p in (out / 'plots').iterdir()) == [
        'cardinality.png', 'ospa.png', 'searched.png', 'trajectories.png']
    again = tmp_path / 'again'
    main(['--scenario', scenario, '--params', str(PARAMS), '--out', str(again), '--seed', '3',
          '--steps', '12'])
    assert (again / 'metrics.json').read_bytes() == (out / 'metrics.json').read_bytes()


def test_an_a_a_run_meets_the_same_truth_with_other_filter_draws(params):
    """phd.filter_stream (an A/A trial): the same truth and first poses, other particles."""
    scenario = load_scenario(CONFIG / 'scenarios' / 'single_target.yaml').with_seed(3)
    runs = [run_swarm(scenario, params.with_overrides({'phd.filter_stream': stream}), steps=30)
            for stream in (0, 1)]
    steps = list(zip(*(run.records for run in runs)))
    for a, b in steps:
        np.testing.assert_array_equal(a.truth_ids, b.truth_ids)
        np.testing.assert_array_equal(a.truth_positions, b.truth_positions)
    first_a, first_b = steps[0]
    assert all(np.array_equal(first_a.agent_poses[agent], pose)
               for agent, pose in first_b.agent_poses.items())
    assert any(not np.array_equal(a.agent_poses[1], b.agent_poses[1])
               or a.estimates[1].shape != b.estimates[1].shape
               or not np.allclose(a.estimates[1], b.estimates[1])
               for a, b in steps)


def test_cli_refuses_a_bad_scenario_with_a_clear_message(tmp_path, capsys):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('seed: 1\nsteps: 10\nagents: [{id: 1, start: [500, 1]}]\n')
    assert main(['--scenario', str(bad), '--params', str(PARAMS), '--out',
                 str(tmp_path / 'r')]) == 2
    assert "'agents[0].start[0]' = 500" in capsys.readouterr().err
