import math

import numpy as np
import pytest

from sat_agent.config import SatParams
from sat_agent.ospa import ospa
from sat_agent.tracking_overlap import incremental_overlap_score, OverlapMonitor

PARAMS = SatParams()     # window 5 steps, Q_Th = 10, c = 10, a = 10
TARGETS = np.array([[50.0, 50.0], [53.0, 48.0]])
NEAR = (49.0, 50.0)      # own pose
OTHER = (55.0, 52.0)     # neighbour pose: squares overlap


def observe_steps(monitor, steps, own_targets=TARGETS, other_targets=TARGETS,
                  own_pose=NEAR, other_pose=OTHER, neighbour=2):
    return [monitor.observe(k, own_pose, own_targets, neighbour, other_pose, other_targets)
            for k in steps]


def test_incremental_score_is_order_2_ospa_and_needs_non_empty_sets():
    x, y = [[0.0, 0.0]], [[3.0, 4.0], [40.0, 0.0]]
    assert incremental_overlap_score(x, y, 10.0) == ospa(x, y, 10.0, 2).distance
    assert incremental_overlap_score(x, y, 10.0) == pytest.approx(math.sqrt(62.5))
    with pytest.raises(ValueError):
        incremental_overlap_score(np.zeros((0, 2)), y, 10.0)


def test_same_targets_in_overlapping_squares_over_the_window_is_an_overlap():
    monitor = OverlapMonitor(PARAMS)
    for k in range(1, 5):
        observe_steps(monitor, [k])
        assert not monitor.overlapping(2)         # window not full yet
    observe_steps(monitor, [5])
    assert monitor.overlapping(2)
    assert monitor.cumulative_score(2) == 0.0
    assert OverlapMonitor.leaver(1, 2) == OverlapMonitor.leaver(2, 1) == 2


def test_small_estimation_differences_stay_below_the_threshold():
    monitor = OverlapMonitor(PARAMS)
    scores = observe_steps(monitor, range(1, 6), other_targets=TARGETS + [0.0, 1.5])
    assert scores[-1] == pytest.approx(5 * 1.5)       # Delta L = 1.5 m each step
    assert monitor.overlapping(2)
    noisier = OverlapMonitor(PARAMS)
    observe_steps(noisier, range(1, 6), other_targets=TARGETS + [0.0, 2.5])
    assert noisier.cumulative_score(2) == pytest.approx(12.5)
    assert not noisier.overlapping(2)


def test_squares_that_do_not_intersect_never_overlap():
    monitor = OverlapMonitor(PARAMS)
    scores = observe_steps(monitor, range(1, 20), other_pose=(60.5, 50.0))
    assert all(math.isinf(q) for q in scores)
    assert not monitor.overlapping(2)


def test_different_targets_never_overlap():
    far = OverlapMonitor(PARAMS)
    observe_steps(far, range(1, 20), other_targets=TARGETS + [0.0, 20.0])
    assert far.cumulative_score(2) == pytest.approx(5 * 10.0)      # every pair cut off at c
    assert not far.overlapping(2)
    subset = OverlapMonitor(PARAMS)
    observe_steps(subset, range(1, 20), other_targets=TARGETS[:1])
    assert subset.cumulative_score(2) == pytest.approx(5 * math.sqrt(50.0))
    assert not subset.overlapping(2)


def test_an_empty_set_scores_infinity():
    monitor = OverlapMonitor(PARAMS)
    observe_steps(monitor, range(1, 10), other_targets=np.zeros((0, 2)))
    assert math.isinf(monitor.cumulative_score(2))
    assert not monitor.overlapping(2)


def test_a_gap_in_the_steps_restarts_the_window():
    monitor = OverlapMonitor(PARAMS)
    observe_steps(monitor, [1, 2, 3, 4])
    observe_steps(monitor, [6])                   # step 5 missing
    assert not monitor.overlapping(2)
    observe_steps(monitor, [7, 8, 9])
    assert not monitor.overlapping(2)
    observe_steps(monitor, [10])
    assert monitor.overlapping(2)


def test_an_infinite_score_blocks_the_window_until_it_slides_out():
    monitor = OverlapMonitor(PARAMS)
    observe_steps(monitor, [1], other_pose=(80.0, 80.0))
    observe_steps(monitor, [2, 3, 4, 5])
    assert not monitor.overlapping(2)
    observe_steps(monitor, [6])
    assert monitor.overlapping(2)


def test_a_repeated_step_replaces_its_score():
    monitor = OverlapMonitor(PARAMS)
    observe_steps(monitor, [1, 2, 3, 4, 5], other_targets=TARGETS + [0.0, 20.0])
    assert not monitor.overlapping(2)
    observe_steps(monitor, [5])
    assert monitor.cumulative_score(2) == pytest.approx(40.0)


def test_neighbours_are_scored_independently_and_reset_forgets():
    monitor = OverlapMonitor(PARAMS)
    observe_steps(monitor, range(1, 6), neighbour=2)
    observe_steps(monitor, range(1, 6), neighbour=3, other_targets=TARGETS + [0.0, 20.0])
    assert monitor.overlapping(2) and not monitor.overlapping(3)
    monitor.reset(2)
    assert not monitor.overlapping(2)
    assert math.isinf(monitor.cumulative_score(2))
    assert not monitor.overlapping(7)             # never observed
