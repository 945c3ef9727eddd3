import json
import math

import numpy as np
import pytest

from sat_world_sim.metrics import compute_metrics, MetricsConfig, StepRecord, swarm_estimate
from sat_world_sim.metrics import write_metrics
from sat_world_sim.plots import write_plots


def record(step, truth, poses, estimates, modes, searched=0.0, ids=None, **extra):
    truth = np.asarray(truth, dtype=float).reshape(-1, 2)
    return StepRecord(step=step,
                      truth_ids=np.asarray(ids if ids is not None else range(len(truth)), int),
                      truth_positions=truth,
                      agent_poses={a: np.asarray(p, float) for a, p in poses.items()},
                      modes=modes,
                      estimates={a: np.asarray(e, float).reshape(-1, 2)
                                 for a, e in estimates.items()},
                      searched_fraction=searched, **extra)


def small_run():
    """Hand-checked run: target 0 born at 2, enters agent 1's square at 3, found at 4."""
    poses = {1: (10.0, 10.0), 2: (80.0, 80.0)}
    return [
        record(1, [], poses, {1: [], 2: []}, {1: 'SEARCH', 2: 'SEARCH'}, 0.02,
               radio_messages={1: 1, 2: 1}, radio_bytes={1: 100, 2: 120}),
        record(2, [[30.0, 10.0]], poses, {1: [], 2: []}, {1: 'SEARCH', 2: 'SEARCH'}, 0.03,
               ids=[0]),
        record(3, [[14.0, 10.0]], poses, {1: [], 2: [[70.0, 70.0]]},
               {1: 'SEARCH', 2: 'SEARCH'}, 0.04, ids=[0],
               radio_messages={1: 1}, radio_bytes={1: 100}),
        record(4, [[13.0, 10.0]], poses, {1: [[13.0, 13.0]], 2: []},
               {1: 'TRACK', 2: 'SEARCH'}, 0.05, ids=[0],
               overlap_events=[{'step': 4, 'agent': 2, 'left_for': 1}]),
        record(5, [], poses, {1: [[12.0, 10.0]], 2: []}, {1: 'TRACK', 2: 'SEARCH'}, 0.05),
    ]


def test_per_step_ospa_counts_and_modes_are_hand_checked():
    metrics = compute_metrics(small_run(), 'tiny', 9)
    steps = metrics['steps']
    assert [s['step'] for s in steps] == [1, 2, 3, 4, 5]
    # 1: both empty. 2: one true, none estimated: c. 3: assignment (14,10)-(70,70) is cut off
    # at c = 10, so c. 4: 3 m error. 5: nothing true, one estimate: c.
    assert [s['ospa'] for s in steps] == pytest.approx([0.0, 10.0, 10.0, 3.0, 10.0])
    assert [s['ospa_card'] for s in steps] == pytest.approx([0.0, 10.0, 0.0, 0.0, 10.0])
    assert [s['ospa_loc'] for s in steps] == pytest.approx([0.0, 0.0, 10.0, 3.0, 0.0])
    assert [s['n_true'] for s in steps] == [0, 1, 1, 1, 0]
    assert [s['n_est'] for s in steps] == [0, 0, 1, 1, 1]
    assert [s['searched_pct'] for s in steps] == pytest.approx([2.0, 3.0, 4.0, 5.0, 5.0])
    assert [s['tracking'] for s in steps] == [False, False, False, True, True]
    assert steps[3]['modes'] == {'1': 'TRACK', '2': 'SEARCH'}
    assert metrics['summary']['mean_ospa_tracking'] == pytest.approx(6.5)
    assert metrics['summary']['tracking_steps'] == 2


def test_target_first_in_view_first_detected_and_delay():
    (target,) = compute_metrics(small_run(), 'tiny', 9)['targets']
    assert target == {'id': 0, 'born': 2, 'died': 4, 'first_in_view': 3, 'first_detected': 4,
                      'detection_delay': 1, 'time_to_detection': 2}


def test_radio_totals_overlap_events_and_json_round_trip(tmp_path):
    metrics = compute_metrics(small_run(), 'tiny', 9)
    assert metrics['radio'] == {'1': {'messages': 2, 'bytes': 200},
                                '2': {'messages': 1, 'bytes': 120}}
    assert metrics['overlap_events'] == [{'step': 4, 'agent': 2, 'left_for': 1}]
    path = tmp_path / 'metrics.json'
    write_metrics(metrics, path)
    assert json.loads(path.read_text()) == metrics
    # Deterministic: the same records give byte-identical files.
    write_metrics(compute_metrics(small_run(), 'tiny', 9), tmp_path / 'again.json')
    assert (tmp_path / 'again.json').read_bytes() == path.read_bytes()


def test_a_target_never_seen_has_no_delay_and_a_live_one_no_death():
    records = [record(k, [[90.0, 90.0]], {1: (10.0, 10.0)}, {1: []}, {1: 'SEARCH'})
               for k in (1, 2, 3)]
    (target,) = compute_metrics(records, 's', 1)['targets']
    # Never detected: the time to detection is censored at the 3 steps it was alive.
    assert target == {'id': 0, 'born': 1, 'died': None, 'first_in_view': None,
                      'first_detected': None, 'detection_delay': None, 'time_to_detection': 3}


def test_evaluation_summary_of_the_hand_checked_run():
    summary = compute_metrics(small_run(), 'tiny', 9)['summary']
    # OSPA parts per step: loc (0, 0, 10, 3, 0), card (0, 10, 0, 0, 10).
    assert summary['mean_ospa_loc'] == pytest.approx(13.0 / 5)
    assert summary['mean_ospa_card'] == pytest.approx(20.0 / 5)
    assert summary['targets_to_detect'] == 1 and summary['detected_share'] == 1.0
    assert summary['mean_time_to_detection'] == 2
    # The target is alive at steps 2-4 and tracked (estimate within 5 m) at step 4 only.
    assert summary['tracked_share'] == pytest.approx(1.0 / 3)
    assert summary['duplicate_tracking_steps'] == 0
    # 3 messages and 320 bytes from 2 agents over 5 steps.
    assert summary['radio_msgs_per_agent_step'] == pytest.approx(0.3)
    assert summary['bytes_per_agent_step'] == pytest.approx(32.0)


def test_false_tracks_are_estimates_assigned_to_no_target():
    metrics = compute_metrics(small_run(), 'tiny', 9)
    # Step 3: agent 2's (70, 70) is 50 m from the only target; step 5: agent 1 reports a
    # target after it died. Step 4's estimate is 3 m from the target: a true track.
    assert [s['n_false'] for s in metrics['steps']] == [0, 0, 1, 0, 1]
    assert metrics['summary']['false_track_steps'] == 2
    # Two estimates near one target from one agent: one is assigned, the other is false.
    two = compute_metrics([record(1, [[50.0, 50.0]], {1: (50.0, 50.0)},
                                  {1: [[50.0, 51.0], [51.0, 50.0]]}, {1: 'TRACK'})], 's', 1)
    assert two['steps'][0]['n_false'] == 1 and two['steps'][0]['n_tracked'] == 1


def test_detectable_share_counts_targets_that_were_ever_in_a_square():
    assert compute_metrics(small_run(), 'tiny', 9)['summary']['detectable_share'] == 1.0
    # Target 0 passes the agent's square at step 2, never detected; target 1 stays far.
    records = [record(k, [[10.0 + 20 * (k - 2) ** 2, 10.0], [90.0, 90.0]], {1: (10.0, 10.0)},
                      {1: []}, {1: 'SEARCH'}, ids=[0, 1]) for k in (1, 2, 3)]
    summary = compute_metrics(records, 's', 1)['summary']
    assert summary['detectable_share'] == 0.5 and summary['detected_share'] == 0.0


def test_an_estimate_near_a_target_no_square_has_held_is_a_false_track():
    # Target 0 walks east at y = 50; agent 1's square (x in [45, 55]) first holds it at step
    # 3. Agent 2, far away, reports a point 2 m from it at every step (a coasted report of
    # something else): no detection and no tracked step before step 3, a false track instead.
    records = [record(k, [[36.0 + 3 * k, 50.0]], {1: (50.0, 50.0), 2: (90.0, 90.0)},
                      {1: [], 2: [[38.0 + 3 * k, 50.0]]}, {1: 'SEARCH', 2: 'TRACK'})
               for k in (1, 2, 3, 4)]
    metrics = compute_metrics(records, 'unit', 0)
    (target,) = metrics['targets']
    assert target['first_in_view'] == 3 and target['first_detected'] == 3
    assert target['detection_delay'] == 0 and target['time_to_detection'] == 2
    assert [s['n_tracked'] for s in metrics['steps']] == [0, 0, 1, 1]
    assert [s['n_false'] for s in metrics['steps']] == [1, 1, 0, 0]
    # The OSPA is the set distance either way: 2 m at every step.
    assert [s['ospa'] for s in metrics['steps']] == pytest.approx([2.0] * 4)
    # A target never in a square is never detected, however close a report passes.
    never = compute_metrics([record(k, [[80.0, 20.0]], {1: (10.0, 10.0)},
                                    {1: [[81.0, 20.0]]}, {1: 'TRACK'}) for k in (1, 2)],
                            'unit', 0)
    assert never['targets'][0]['first_detected'] is None
    assert never['summary']['detected_share'] == 0.0
    assert never['summary']['tracked_share'] == 0.0
    assert never['summary']['false_track_steps'] == 2


def test_two_agents_near_one_target_are_a_duplicate():
    records = [record(k, [[50.0, 50.0]], {1: (50, 50), 2: (52, 50)},
                      {1: [[50.0, 51.0]], 2: [[50.0, 49.0]] if k > 1 else []},
                      {1: 'TRACK', 2: 'TRACK'}) for k in (1, 2, 3)]
    metrics = compute_metrics(records, 's', 1)
    assert [s['n_duplicate'] for s in metrics['steps']] == [0, 1, 1]
    assert [s['n_tracked'] for s in metrics['steps']] == [1, 1, 1]
    assert metrics['summary']['duplicate_tracking_steps'] == 2
    assert metrics['summary']['tracked_share'] == 1.0


def test_an_estimate_of_one_target_does_not_detect_a_second_target_next_to_it():
    # Targets 4 m apart, one agent's single estimate on target 0: within 5 m of both, it is
    # assigned to target 0 only. With a second estimate, on target 1, both are detected.
    truth = [[50.0, 50.0], [54.0, 50.0]]
    one = compute_metrics([record(1, truth, {1: (52.0, 52.0)}, {1: [[50.5, 50.0]]},
                                  {1: 'TRACK'}, ids=[0, 1])], 'unit', 0)
    assert [t['first_detected'] for t in one['targets']] == [1, None]
    assert one['steps'][0]['n_tracked'] == 1
    # Listed in the opposite order, the assignment still pairs each estimate with its target.
    two = compute_metrics([record(1, truth, {1: (52.0, 52.0)},
                                  {1: [[53.0, 50.0], [50.5, 50.0]]}, {1: 'TRACK'}, ids=[0, 1])],
                          'unit', 0)
    assert [t['first_detected'] for t in two['targets']] == [1, 1]
    assert two['steps'][0]['n_tracked'] == 2 and two['steps'][0]['n_duplicate'] == 0


def test_swarm_estimate_merges_duplicates_within_the_merge_distance():
    merged = swarm_estimate({2: np.array([[11.0, 10.0]]),
                             1: np.array([[10.0, 10.0], [40.0, 40.0]])}, merge_distance=3.0)
    np.testing.assert_allclose(merged, [[10.5, 10.0], [40.0, 40.0]])
    apart = swarm_estimate({1: np.array([[10.0, 10.0]]), 2: np.array([[14.0, 10.0]])}, 3.0)
    assert len(apart) == 2
    assert swarm_estimate({}, 3.0).shape == (0, 2)


def test_swarm_estimate_keeps_one_agents_close_estimates_apart():
    # One agent tracking two targets 2 m apart reports two targets; a second agent's estimate
    # of one of them joins the nearer, and only one, of the two.
    own = swarm_estimate({1: np.array([[10.0, 10.0], [12.0, 10.0]])}, merge_distance=3.0)
    np.testing.assert_allclose(own, [[10.0, 10.0], [12.0, 10.0]])
    both = swarm_estimate({1: np.array([[10.0, 10.0], [12.0, 10.0]]),
                           2: np.array([[12.5, 10.0], [10.5, 10.0]])}, merge_distance=3.0)
    np.testing.assert_allclose(both, [[10.25, 10.0], [12.25, 10.0]])


def test_two_agents_on_one_target_count_once():
    records = [record(1, [[50.0, 50.0]], {1: (50, 50), 2: (52, 50)},
                      {1: [[50.0, 51.0]], 2: [[50.0, 49.0]]}, {1: 'TRACK', 2: 'TRACK'})]
    step = compute_metrics(records, 's', 1, MetricsConfig())['steps'][0]
    assert step['n_est'] == 1
    assert step['ospa'] == pytest.approx(0.0)


def test_plots_are_written(tmp_path):
    records = small_run()
    for r in records:
        r.plans = {1: np.array([[20.0, 20.0], [10.0, 10.0]])}
    metrics = compute_metrics(records, 'tiny', 9)
    paths = write_plots(metrics, records, tmp_path / 'plots',
                        final_density=np.linspace(0, 1, 100 * 100).reshape(100, 100))
    assert sorted(p.name for p in paths) == ['cardinality.png', 'ospa.png', 'searched.png',
                                             'trajectories.png']
    for path in paths:
        assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
        assert path.stat().st_size > 5000
    assert not math.isnan(metrics['summary']['mean_ospa'])
