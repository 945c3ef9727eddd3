"""The triage oracle: the looks see only candidates near a target, the scans only targets."""

from dataclasses import replace
from pathlib import Path
import runpy

import numpy as np
import pytest

from sat_agent.config import load_params_file
from sat_agent.phd_filter import BirthSpots
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate
from sat_world_sim.evaluate import read_rows
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.random_scenarios import random_scenario
from sat_world_sim.triage_oracle import oracle_triage, real_scans, run_with_oracle_triage
from sat_world_sim.triage_oracle import triaged_look, truth_near
from sat_world_sim.world_model import Scan

SCRIPT = runpy.run_path(str(Path(__file__).resolve().parents[1] / 'scripts' / 'triage_oracle.py'))
TRUTH = np.array([[10.0, 10.0], [50.0, 50.0]])


def peak(x, y):
    return TargetEstimate(np.array([x, y]), np.zeros(2), np.eye(4), 0.5)


def spots(*points):
    points = np.array(points, dtype=float).reshape(-1, 2)
    return BirthSpots(points + 100.0, points, np.linspace(0.3, 0.6, len(points)))


def seen_by(kinds, estimate, birth_spots):
    """Return what the wrapped look receives from the oracle."""
    got = {}

    def look(mode, estimate, cooldown_left, birth_spots):
        got.update(estimate=estimate, spots=birth_spots, args=(mode, cooldown_left))
        return 'looked'

    assert triaged_look(look, lambda: TRUTH, kinds, 3.0)('SEARCH', estimate, 0,
                                                         birth_spots) == 'looked'
    assert got['args'] == ('SEARCH', 0)
    return got['estimate'], got['spots']


def test_truth_near_is_within_the_radius_of_some_target():
    points = np.array([[12.9, 10.0], [13.1, 10.0], [50.0, 47.0], [30.0, 30.0]])
    np.testing.assert_array_equal(truth_near(points, TRUTH, 3.0), [True, False, True, False])
    assert truth_near(points, np.zeros((0, 2)), 3.0).tolist() == [False] * 4
    assert truth_near(np.zeros((0, 2)), TRUTH, 3.0).shape == (0,)


def test_the_looks_see_only_the_candidates_of_their_kinds_near_a_target():
    estimate = MultiTargetEstimate((peak(1.0, 1.0),), 1.0,
                                   tentative=(peak(11.0, 11.0), peak(30.0, 30.0),
                                              peak(49.0, 52.0)),
                                   tentative_streaks=(1, 0, 2))
    births = spots([10.5, 9.0], [20.0, 20.0], [52.0, 50.0], [0.0, 0.0])
    both_estimate, both_spots = seen_by(('spots', 'peaks'), estimate, births)
    assert [p.position.tolist() for p in both_estimate.tentative] == [[11.0, 11.0],
                                                                      [49.0, 52.0]]
    assert both_estimate.tentative_streaks == (1, 2)
    assert both_estimate.targets == estimate.targets      # confirmed targets are not triaged
    np.testing.assert_array_equal(both_spots.positions, [[10.5, 9.0], [52.0, 50.0]])
    np.testing.assert_array_equal(both_spots.measurements, both_spots.positions + 100.0)
    np.testing.assert_allclose(both_spots.masses, [0.3, 0.5])
    peaks_estimate, peaks_spots = seen_by(('peaks',), estimate, births)
    assert len(peaks_estimate.tentative) == 2 and peaks_spots is births
    spots_estimate, spots_spots = seen_by(('spots',), estimate, births)
    assert spots_estimate is estimate and len(spots_spots.positions) == 2
    for kinds in (('targets',), ('scans',)):
        with pytest.raises(ValueError, match=f"kinds \\['{kinds[0]}'\\]"):
            triaged_look(lambda *a: None, lambda: TRUTH, kinds)


def short_run(scenario, params, **oracle):
    run = (run_with_oracle_triage(scenario, params, **oracle) if oracle
           else run_swarm(scenario, params))
    return [(r.agent_poses, r.estimates) for r in run.records]


def assert_same_runs(a, b):
    assert len(a) == len(b)
    for (poses_a, estimates_a), (poses_b, estimates_b) in zip(a, b):
        for agent in poses_a:
            np.testing.assert_array_equal(poses_a[agent], poses_b[agent])
            np.testing.assert_array_equal(estimates_a[agent], estimates_b[agent])


def test_without_triage_the_run_is_the_profiles_bit_for_bit():
    params = load_params_file('config/persistent.yaml')
    scenario = random_scenario(6, 4, 50)
    assert_same_runs(short_run(scenario, params), short_run(scenario, params, kinds=()))


def test_without_targets_the_oracle_never_looks_as_a_profile_without_looks():
    # Clutter seeds spots and peaks; with no target near any, no look is taken, and every
    # random stream is the profile's: the paths are those of additions.investigation off.
    params = load_params_file('config/persistent.yaml')
    scenario = replace(random_scenario(6, 4, 60), targets=(), random_births=None)
    blind = params.with_overrides({'additions.investigation': False})
    oracle = short_run(scenario, params, kinds=('spots', 'peaks'))
    assert_same_runs(short_run(scenario, blind), oracle)
    plain = short_run(scenario, params)
    assert any(not np.array_equal(a[0][i], b[0][i]) for a, b in zip(plain, oracle)
               for i in a[0]), 'the profile looks at the clutter: its paths differ'


def test_real_scans_keep_only_the_targets_rows():
    z = np.arange(10.0).reshape(5, 2)
    scans = {1: Scan(z, np.array([-1, 3, -1, -1, 7])), 2: Scan(z[:2], np.array([-1, -1]))}
    cleaned = real_scans(lambda: scans)()
    np.testing.assert_array_equal(cleaned[1].measurements, z[[1, 4]])
    np.testing.assert_array_equal(cleaned[1].source_ids, [3, 7])
    assert cleaned[2].measurements.shape == (0, 2) and len(cleaned[2].source_ids) == 0


def test_with_real_scans_the_agents_measure_only_targets():
    params = load_params_file('config/persistent.yaml')
    scenario = random_scenario(6, 4, 60)
    drawn, seen = [], []

    def spy(swarm):
        world_scans = swarm.world.scan_all

        def scan_all():
            scans = world_scans()
            drawn.extend((agent, scan.measurements[scan.source_ids >= 0].copy(),
                          int(np.sum(scan.source_ids < 0))) for agent, scan in scans.items())
            return scans
        swarm.world.scan_all = scan_all
        oracle_triage(swarm, ('scans',))
        for agent_id, agent in swarm.agents.items():
            agent.step = recorded(agent_id, agent.step)

    def recorded(agent_id, step):
        def stepped(k, pose, measurements, inbox):
            seen.append((agent_id, np.array(measurements)))
            return step(k, pose, measurements, inbox)
        return stepped

    run_swarm(scenario, params, prepare=spy)
    assert len(seen) == len(drawn) == 4 * 60
    for (agent, got), (drawn_agent, real, _) in zip(seen, drawn):
        assert agent == drawn_agent
        np.testing.assert_array_equal(got.reshape(-1, 2), real)
    assert sum(len(real) for _, real, _ in drawn) > 0, 'the targets were measured'
    assert sum(clutter for *_, clutter in drawn) > 100, 'the world drew its clutter'


def test_without_targets_real_scans_give_the_run_without_clutter():
    # With no measurement kappa never enters the update, so the filter's clutter model, which
    # sensor.clutter_rate 0 also changes, does not matter: the runs are equal step for step.
    params = load_params_file('config/persistent.yaml')
    scenario = replace(random_scenario(6, 4, 60), targets=(), random_births=None)
    quiet = params.with_overrides({'sensor.clutter_rate': 0.0})
    without_clutter = short_run(scenario, quiet)
    assert_same_runs(without_clutter, short_run(scenario, params, kinds=('scans',)))
    plain = short_run(scenario, params)
    assert any(not np.array_equal(a[1][i], b[1][i]) or not np.array_equal(a[0][i], b[0][i])
               for a, b in zip(plain, without_clutter) for i in a[0]), \
        'the clutter moves the profile: the runs differ'


def timeless(rows):
    """Return the rows without their wall and CPU times, which no two runs share."""
    return [{key: value for key, value in row.items() if not key.endswith('_time_s')}
            for row in rows]


def test_the_script_pairs_the_profile_with_its_oracle(tmp_path, capsys):
    main = SCRIPT['main']
    assert main(['--out', str(tmp_path), '--setting', 'paper_random', '--seeds', '1',
                 '--first-seed', '3', '--jobs', '1', '--kinds', 'peaks']) == 0
    rows = read_rows(tmp_path / 'evaluation.csv')
    assert [r['label'] for r in rows] == ['SAT-PHD persistent',
                                          'SAT-PHD persistent, oracle triage (peaks)']
    assert {r['seed'] for r in rows} == {'3'}
    printed = capsys.readouterr().out
    assert 'oracle triage (peaks) (B) against the profile (A)' in printed
    assert '| paper_random | tracked_share |' in printed
    for bad in (['--kinds', 'spots,targets'], ['--kinds', ','],
                ['--profile', str(tmp_path / 'evaluation.csv'), '--first-seed', '4']):
        with pytest.raises(SystemExit):
            main(['--out', str(tmp_path / 'bad'), '--setting', 'paper_random', '--seeds', '1',
                  *bad])
    # The profile's rows taken from that file pair with a fresh oracle run as before.
    again = tmp_path / 'again'
    assert main(['--out', str(again), '--setting', 'paper_random', '--seeds', '1',
                 '--first-seed', '3', '--jobs', '1', '--kinds', 'peaks',
                 '--profile', str(tmp_path / 'evaluation.csv')]) == 0
    assert timeless(read_rows(again / 'evaluation.csv')) == timeless(rows)
    assert capsys.readouterr().out.split('rows in')[1].split('\n', 1)[1] == \
        printed.split('rows in')[1].split('\n', 1)[1]
