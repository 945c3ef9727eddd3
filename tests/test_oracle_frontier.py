import csv
from pathlib import Path
import runpy

import pytest

from sat_agent.config import load_params_file
from sat_world_sim.evaluate import METRICS, run_one, RUNS_CSV
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.oracle_sweep import run_oracle_sweep
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import CONFIG_COLUMNS, default_cell, ORACLE_TRACK
from sat_world_sim.study_design import ORACLE_TRACK_LABEL, PERSISTENT_LABEL, PERSISTENT_PROFILE
from sat_world_sim.study_design import scenario_for

REPO = Path(__file__).resolve().parents[1]
FRONTIER = runpy.run_path(str(REPO / 'scripts' / 'oracle_frontier.py'))


def write_rows(path: Path, cells_values) -> None:
    """Write an evaluation.csv with one row per (cell, seed, {metric: value})."""
    with open(path, 'w', newline='') as stream:
        writer = csv.DictWriter(stream, fieldnames=CONFIG_COLUMNS + ('seed',) + METRICS,
                                restval='')
        writer.writeheader()
        for cell, seed, values in cells_values:
            writer.writerow(dict(cell.columns(), seed=seed, **values))


def test_the_frontier_without_a_limit_is_the_evaluation_cell_and_the_paired_lines(
        tmp_path, capsys):
    oracle = default_cell('random', ORACLE_TRACK_LABEL, policy=ORACLE_TRACK, planner='none')
    persistent = default_cell('random', PERSISTENT_LABEL, profile=PERSISTENT_PROFILE)
    paper = load_scenario(REPO / 'config' / 'scenarios' / 'paper.yaml')
    params = oracle.params(load_params_file(REPO / 'config' / 'paper.yaml'))
    rows = [run_one(oracle, seed, params, paper)['row'] for seed in (1, 2)]
    point = FRONTIER['frontier_point']('random', (1, 2), None)
    for name in ('detected_share', 'tracked_share', 'mean_ospa'):
        assert point[name] == pytest.approx(sum(r[name] for r in rows) / 2)
    # Persistent 0.1 below the oracle on every seed and metric: the paired difference is -0.1.
    csv_path = tmp_path / RUNS_CSV
    write_rows(csv_path, [(oracle, r['seed'], {m: r[m] for m in METRICS}) for r in rows]
               + [(persistent, r['seed'], {m: r[m] - 0.1 for m in METRICS}) for r in rows])
    assert FRONTIER['main'](['--seeds', '2', '--limits', '0', 'none', '--csv',
                             str(csv_path)]) == 0
    out = capsys.readouterr().out
    assert '| 0 | ' in out and '| none (until it dies) | ' in out
    assert f'{100 * point["tracked_share"]:.1f}' in out
    assert out.count('difference -0.100 [-0.100, -0.100]') == 3


def test_the_frontier_refuses_a_negative_limit_and_says_when_rows_are_missing(tmp_path, capsys):
    with pytest.raises(SystemExit):
        FRONTIER['main'](['--limits', '-1'])
    assert 'must be >= 0 or none' in capsys.readouterr().err
    lines = FRONTIER['persistent_against_the_oracle']('random', tmp_path / 'none.csv')
    assert lines == [f'{tmp_path / "none.csv"}: no {PERSISTENT_LABEL} or {ORACLE_TRACK_LABEL} '
                     f'({ORACLE_TRACK}) rows at random']


def test_the_frontier_passes_followers_and_dispatch_to_the_oracle(tmp_path, capsys):
    # One follower, dispatched: run_oracle_sweep's figures for the same seeds.
    cell = default_cell('random', ORACLE_TRACK_LABEL, policy=ORACLE_TRACK, planner='none')
    params = cell.params(load_params_file(REPO / 'config' / 'paper.yaml'))
    paper = load_scenario(REPO / 'config' / 'scenarios' / 'paper.yaml')
    tracked = []
    for seed in (1, 2):
        scenario = scenario_for(cell, seed, params, paper)
        run = run_oracle_sweep(scenario, params, follow=True, followers=1, dispatch=True)
        tracked.append(compute_metrics(run.records, scenario.name, seed)['summary']
                       ['tracked_share'])
    point = FRONTIER['frontier_point']('random', (1, 2), None, 1, True)
    assert point['tracked_share'] == pytest.approx(sum(tracked) / 2)
    assert point != FRONTIER['frontier_point']('random', (1, 2), None)
    assert FRONTIER['main'](['--seeds', '2', '--limits', 'none', '--followers', '1',
                             '--dispatch', '--csv', str(tmp_path / RUNS_CSV)]) == 0
    out = capsys.readouterr().out
    assert 'followers: 1, dispatched to any target seen' in out
    assert f'| none (until it dies) | {100 * point["detected_share"]:.1f} | ' in out
    with pytest.raises(SystemExit):
        FRONTIER['main'](['--followers', '-1'])
    assert '--followers -1: must be >= 0' in capsys.readouterr().err
    with pytest.raises(SystemExit):
        FRONTIER['main'](['--seeds', '1', '--limits', 'none', '--followers', '5'])
    assert 'followers = 5 for a team of 4: must be 0 to 4' in capsys.readouterr().err


def test_the_frontier_passes_coast_and_coasting_even_the_sweep_tracks(tmp_path, capsys):
    cell = default_cell('random', ORACLE_TRACK_LABEL, policy=ORACLE_TRACK, planner='none')
    params = cell.params(load_params_file(REPO / 'config' / 'paper.yaml'))
    paper = load_scenario(REPO / 'config' / 'scenarios' / 'paper.yaml')
    scenario = scenario_for(cell, 1, params, paper)
    run = run_oracle_sweep(scenario, params, follow=True, follow_limit=10, coast=True)
    coasted = FRONTIER['frontier_point']('random', (1,), 10, coast=True)
    assert coasted['tracked_share'] == pytest.approx(
        compute_metrics(run.records, scenario.name, 1)['summary']['tracked_share'])
    assert coasted['tracked_share'] > FRONTIER['frontier_point']('random', (1,), 10)[
        'tracked_share']
    # With --coast the limit 0 row is the coasting sweep, not the plain one.
    assert FRONTIER['main'](['--seeds', '1', '--limits', '0', '--coast',
                             '--csv', str(tmp_path / RUNS_CSV)]) == 0
    out = capsys.readouterr().out
    sweep = FRONTIER['frontier_point']('random', (1,), 0, coast=True)
    assert 'coasting what they saw' in out
    assert f'| 0 | {100 * sweep["detected_share"]:.1f} | {100 * sweep["tracked_share"]:.1f} |' \
        in out


def test_the_frontier_rides_the_tour_and_keeps_the_strips_floors(tmp_path, capsys):
    assert FRONTIER['main'](['--seeds', '2', '--limits', '0', '--tour',
                             '--csv', str(tmp_path / RUNS_CSV)]) == 0
    out = capsys.readouterr().out
    tour = FRONTIER['frontier_point']('random', (1, 2), 0, tour=True)
    strips = FRONTIER['frontier_point']('random', (1, 2), 0)
    assert tour != strips
    assert 'riding one tour' in out
    # The floor is a share of the strips' sweep (issue 8's ceiling), the row the tour's.
    assert f'detected >= {0.9 * strips["detected_share"]:.1%}' in out
    assert f'| 0 | {100 * tour["detected_share"]:.1f} | {100 * tour["tracked_share"]:.1f} |' \
        in out
