"""The OSPA report rule of coasted tracks (beyond_paper/coast_report.py)."""

import numpy as np
import pytest

from sat_agent.beyond_paper.coast_report import expected_squared_distance, report_threshold
from sat_agent.beyond_paper.track_coasting import coast_steps, Track, TrackCoasting
from sat_agent.config import load_params_file

PARAMS = load_params_file('config/persistent.yaml')
FAR = np.array([90.0, 90.0])           # a pose whose square sees none of the tracks
NONE = np.zeros((0, 2))


@pytest.mark.parametrize('spread', [0.5, 3.0, 8.0, 30.0])
def test_the_expected_squared_distance_is_the_rayleigh_mean_cut_at_c(spread):
    errors = np.random.default_rng(7).normal(0.0, spread, (400_000, 2))
    found = np.mean(np.minimum(np.hypot(*errors.T), 10.0) ** 2)
    assert expected_squared_distance(spread, 10.0) == pytest.approx(found, rel=0.01)


def test_the_threshold_is_the_papers_for_an_exact_fit_and_tends_to_one_as_it_drifts():
    assert expected_squared_distance(0.0, 10.0) == 0.0
    assert expected_squared_distance(np.inf, 10.0) == 100.0
    assert report_threshold(0.5, 0.0, 10.0) == 0.5
    assert report_threshold(0.3, 0.0, 10.0) == pytest.approx(0.3)
    assert report_threshold(0.5, np.inf, 10.0) == pytest.approx(1.0)
    thresholds = [report_threshold(0.5, s, 10.0) for s in (0.5, 2.0, 5.0, 20.0)]
    assert np.all(np.diff(thresholds) > 0) and thresholds[0] < 0.502
    # The rule it stands for: reporting lowers a E + (1 - a) c^2 below a c^2 exactly there.
    a, e = report_threshold(0.5, 5.0, 10.0), expected_squared_distance(5.0, 10.0)
    assert a * e + (1 - a) * 100.0 == pytest.approx(a * 100.0)


def _coasted_steps(report, positions):
    """Return how many steps after its last estimate a track of these estimates is reported."""
    coasting = TrackCoasting(PARAMS.with_overrides({'phd.coast_report': report}))
    coasting.tracks = [Track(list(range(1, len(positions) + 1)),
                             [np.asarray(p, float) for p in positions], np.zeros(2),
                             length=len(positions))]
    last = len(positions)
    for k in range(last + 1, last + 200):
        if len(coasting.update(k, FAR, [], NONE, NONE).coasted) == 0:
            return k - 1 - last
    return 200


def test_a_noisy_fit_is_reported_for_shorter_than_an_exact_one_and_survival_ignores_both():
    rng = np.random.default_rng(3)
    steps = np.arange(1, 21)[:, None]
    exact = 30.0 + 0.1 * steps * np.array([1.0, 0.5])
    noisy = exact + rng.normal(0.0, 1.0, exact.shape)
    horizon = coast_steps(PARAMS)
    assert _coasted_steps('survival', exact) == _coasted_steps('survival', noisy) == horizon
    # A straight line without residuals has no drift: the paper's horizon.
    assert _coasted_steps('ospa', exact) == horizon
    # A noisy fit drifts: its reports stop earlier, when the drift's expected cost says so.
    shorter = _coasted_steps('ospa', noisy)
    assert shorter < horizon
    track = Track(list(range(1, 21)), list(noisy), np.zeros(2))
    for t, reported in ((shorter, True), (shorter + 1, False)):
        threshold = report_threshold(0.5, track.drift_spread(20 + t), 10.0)
        assert (PARAMS.motion.p_survival ** t >= threshold) is reported
