from conftest import REPO_ROOT
import numpy as np
import pytest

from sat_agent.config import load_params_file
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.metrics import compute_metrics, MetricsConfig, StepRecord
from sat_world_sim.ospa_breakdown import coasted_tracks, false_sources, ospa_without
from sat_world_sim.ospa_breakdown import ospa_regimes, regime, REGIMES, report_sources
from sat_world_sim.ospa_breakdown import SOURCES, what_if_estimates, what_if_ospa
from sat_world_sim.random_scenarios import random_scenario

CONFIG = MetricsConfig()
PERSISTENT = load_params_file(REPO_ROOT / 'config' / 'persistent.yaml')


def record(step, truth, estimates):
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    return StepRecord(step=step, truth_ids=np.arange(len(truth)), truth_positions=truth,
                      agent_poses={1: np.zeros(2)}, modes={1: 'SEARCH'},
                      estimates={a: np.asarray(e, float).reshape(-1, 2)
                                 for a, e in estimates.items()})


def test_each_what_if_changes_only_what_it_names():
    truth = np.array([[0.0, 0.0], [50.0, 50.0], [80.0, 10.0]])
    # One estimate 2 m off the first target, one 4 m off the second, one false (30 m away).
    estimate = np.array([[2.0, 0.0], [50.0, 54.0], [30.0, 30.0]])
    detected = np.array([True, True, True])
    reported, kept, localised, found = what_if_estimates(truth, estimate, detected, CONFIG)
    np.testing.assert_array_equal(reported, estimate)
    np.testing.assert_array_equal(kept, estimate[:2])
    np.testing.assert_array_equal(localised, truth[:2])
    # The third target was found before and no estimate is within 5 m of it now.
    np.testing.assert_array_equal(found, truth)
    _, _, _, found = what_if_estimates(truth, estimate, np.array([True, True, False]), CONFIG)
    np.testing.assert_array_equal(found, truth[:2])


def test_an_estimate_beyond_the_detection_radius_is_kept_but_not_localised():
    truth = np.array([[0.0, 0.0]])
    _, kept, localised, found = what_if_estimates(truth, np.array([[8.0, 0.0]]),
                                                  np.array([True]), CONFIG)
    np.testing.assert_array_equal(kept, [[8.0, 0.0]])
    np.testing.assert_array_equal(localised, [[8.0, 0.0]])
    # Not tracked (8 m > 5 m), so the found target is added beside the estimate.
    np.testing.assert_array_equal(found, [[8.0, 0.0], [0.0, 0.0]])


def test_what_if_estimates_of_empty_sets():
    for truth, estimate in (([], []), ([[1.0, 1.0]], []), ([], [[1.0, 1.0]])):
        sets = what_if_estimates(np.reshape(truth, (-1, 2)), np.reshape(estimate, (-1, 2)),
                                 np.ones(len(truth), bool), CONFIG)
        assert sets[0].shape == (len(estimate), 2)
        assert len(sets[1]) == len(sets[2]) == 0
        assert len(sets[3]) == len(truth)


def test_what_if_ospa_of_a_hand_checked_run():
    # Step 1: the target estimated 5 m off (OSPA 5; localised 0). Step 2: only a false
    # estimate 70 m away (OSPA c = 10 with or without it); the target was found at step 1, so
    # keeping it scores 0.
    records = [record(1, [[0.0, 0.0]], {1: [[3.0, 4.0]]}),
               record(2, [[0.0, 0.0]], {1: [[50.0, 50.0]]})]
    result = what_if_ospa(records)
    assert result['reported'] == pytest.approx(compute_metrics(records, '', 0)['summary'][
        'mean_ospa'])
    assert result == pytest.approx({'reported': 7.5, 'without false': 7.5,
                                    'and localised': 5.0, 'and kept after detection': 0.0})


def test_report_sources_sorts_the_false_reports():
    truth = np.array([[0.0, 0.0], [60.0, 60.0]])
    own = np.array([[1.0, 1.0], [30.0, 0.0]])
    coasted = np.array([[2.0, 0.0], [90.0, 90.0], [0.0, 90.0], [40.0, 0.0]])
    sources = report_sources(truth, [7, 8], own, coasted, [7, 8, 9, None], CONFIG)
    assert sources == [None, SOURCES[0], None, 'coasted, target alive',
                       'coasted, target died', 'coasted, no target']


def test_ospa_without_a_source_drops_its_reports_from_every_agent():
    truth = np.array([[0.0, 0.0]])
    reports = {1: (np.array([[1.0, 0.0], [50.0, 50.0]]), [None, SOURCES[0]]),
               2: (np.array([[60.0, 0.0]]), [SOURCES[1]])}
    # Three reports, one target 1 m from one of them: ((1 + 2 c^2) / 3)^(1/2).
    assert ospa_without(truth, reports, None, CONFIG) == pytest.approx(np.sqrt(201 / 3))
    assert ospa_without(truth, reports, SOURCES[0], CONFIG) == pytest.approx(np.sqrt(101 / 2))
    assert ospa_without(truth, reports, SOURCES[1], CONFIG) == pytest.approx(np.sqrt(101 / 2))
    assert ospa_without(truth, reports, SOURCES[3], CONFIG) == pytest.approx(np.sqrt(201 / 3))


def test_the_coasted_rows_are_those_of_the_coasted_tracks_in_order():
    # Seed 14: within 60 steps an agent coasts two tracks at once, so their order is checked too.
    scenario = random_scenario(14, 4, 60)
    swarm = InProcessSwarm(scenario, PERSISTENT)
    most = 0
    for _ in range(scenario.steps):
        record = swarm.step()
        for agent_id, output in swarm.last_outputs.items():
            tracks = coasted_tracks(swarm.agents[agent_id].coasting.tracks, record.step)
            predicted = np.array([t.predict(record.step) for t in tracks]).reshape(-1, 2)
            np.testing.assert_allclose(predicted, output.coasted)
            most = max(most, len(tracks))
    assert most >= 2


def test_false_sources_scores_the_metrics_ospa_and_what_each_source_costs():
    # Seed 14: in 60 steps a coasted track's fit drifts more than c from its live target.
    scenario = random_scenario(14, 4, 60)
    found = false_sources(InProcessSwarm(scenario, PERSISTENT), scenario.steps)
    metrics = compute_metrics(found.records, scenario.name, scenario.seed)['summary']
    assert found.mean_ospa == pytest.approx(metrics['mean_ospa'])
    assert what_if_ospa(found.records)['reported'] == pytest.approx(metrics['mean_ospa'])
    assert found.counts['coasted, target alive'] > 0
    for source in SOURCES:
        if found.counts[source]:
            # A false report costs c^p only where the reports outnumber the targets.
            assert found.mean_ospa_without[source] <= found.mean_ospa + 1e-12
        else:
            assert found.mean_ospa_without[source] == pytest.approx(found.mean_ospa)


def test_regime_names_how_the_reports_compare_with_the_targets():
    assert [regime(n, m) for n, m in ((3, 0), (3, 1), (3, 3), (3, 4), (0, 2), (0, 0))] == list(
        REGIMES)


def test_ospa_regimes_split_the_mean_ospa_and_a_false_report_costs_only_beyond_the_targets():
    far = [[90.0, 90.0]]
    records = [record(1, [[0.0, 0.0], [50.0, 50.0]], {1: far}),         # fewer: OSPA c
               record(2, [[0.0, 0.0]], {1: [[3.0, 4.0]] + far}),        # more: (25 + c^2) / 2
               record(3, [], {}),                                       # neither: 0
               record(4, [[0.0, 0.0]], {})]                             # no report: c
    split = ospa_regimes(records)
    assert split['fewer reports than targets'] == pytest.approx((0.25, 10.0 / 4))
    assert split['more reports than targets'] == pytest.approx((0.25, np.sqrt(125 / 2) / 4))
    assert split['neither'] == (0.25, 0.0)
    assert split['targets, no report'] == pytest.approx((0.25, 10.0 / 4))
    assert split['as many'] == split['reports, no target'] == (0.0, 0.0)
    assert sum(part for _, part in split.values()) == pytest.approx(
        compute_metrics(records, '', 0)['summary']['mean_ospa'])
    # The false report of step 1 costs nothing: without it the step still scores c.
    assert ospa_regimes(records[:1])['fewer reports than targets'][1] == pytest.approx(
        ospa_regimes([record(1, [[0.0, 0.0], [50.0, 50.0]], {})])['targets, no report'][1])
