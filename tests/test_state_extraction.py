"""Multi-target state extraction: the paper's n-hat peaks and the per-peak addition.

Most tests are about the peak extraction (beyond_paper/peak_extraction.py), one scan at a time
unless a test passes a memory of the last scan (``extract``).
"""

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.beyond_paper.peak_extraction import PeakExtractor
from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD
from sat_agent.state_extraction import ExtractionMemory, NHatExtractor, within_radius

PARAMS = SatParams()
POSE = np.array([50.0, 50.0])
# A new target on its first scan: the tests of the peaks themselves.
ONE_SCAN = PARAMS.with_overrides({'additions.confirmation': False})
STRICT = SatParams().with_overrides({f'additions.{name}': False for name in (
    'peak_extraction', 'extraction_margin', 'confirmation')})


def extract(phd, pose=POSE, params=ONE_SCAN, extractor=PeakExtractor, **memory):
    """Return the estimate of phd after a last scan that left memory (ExtractionMemory fields)."""
    return extractor(params, ExtractionMemory(**memory)).estimate(phd, pose)[0]


def _cloud(rng, center, mass, count=400, spread=0.5, velocity=(0.0, 0.0)):
    states = np.zeros((count, 4))
    states[:, [0, 2]] = np.asarray(center) + rng.normal(0, spread, (count, 2))
    states[:, [1, 3]] = np.asarray(velocity) + rng.normal(0, 0.1, (count, 2))
    return states, np.full(count, mass / count)


def _phd(*clouds):
    return ParticlePHD(np.vstack([c[0] for c in clouds]), np.concatenate([c[1] for c in clouds]))


def test_no_mass_gives_no_targets():
    rng = np.random.default_rng(0)
    estimate = extract(_phd(_cloud(rng, (52, 50), 0.3)))
    assert estimate.targets == () and estimate.cardinality == pytest.approx(0.3)
    assert extract(ParticlePHD.empty()).targets == ()


def test_mass_outside_the_region_is_not_counted():
    rng = np.random.default_rng(1)
    far = _cloud(rng, (80, 80), 3.0)
    near = _cloud(rng, (53, 48), 1.0)
    estimate = extract(_phd(far, near))
    assert estimate.cardinality == pytest.approx(1.0)
    assert len(estimate.targets) == 1
    np.testing.assert_allclose(estimate.targets[0].position, (53, 48), atol=0.15)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), count=st.integers(1, 4))
def test_well_separated_clusters_give_count_and_positions(seed, count):
    rng = np.random.default_rng(seed)
    corners = np.array([(46.5, 46.5), (53.5, 53.5), (46.5, 53.5), (53.5, 46.5)])[:count]
    velocities = rng.uniform(-1, 1, (count, 2))
    clouds = [_cloud(rng, c, 1.0, velocity=v) for c, v in zip(corners, velocities)]
    estimate = extract(_phd(*clouds))
    assert len(estimate.targets) == count
    found = estimate.positions()
    for corner, velocity in zip(corners, velocities):
        match = np.argmin(np.linalg.norm(found - corner, axis=1))
        assert np.linalg.norm(found[match] - corner) < 0.2
        np.testing.assert_allclose(estimate.targets[match].velocity, velocity, atol=0.05)
        assert estimate.targets[match].weight == pytest.approx(1.0, abs=0.02)


def test_spread_is_the_weighted_covariance():
    rng = np.random.default_rng(2)
    cloud = _cloud(rng, (50, 50), 1.0, count=4000, spread=0.7)
    target = extract(_phd(cloud)).targets[0]
    assert target.covariance.shape == (4, 4)
    np.testing.assert_allclose(np.sqrt(np.diag(target.covariance))[[0, 2]], 0.7, rtol=0.08)
    np.testing.assert_allclose(target.covariance, target.covariance.T)


def test_diffuse_mass_does_not_drag_the_peak():
    rng = np.random.default_rng(3)
    peak = _cloud(rng, (48, 52), 0.9)
    diffuse = (np.column_stack([rng.uniform(40, 60, 2000), np.zeros(2000),
                                rng.uniform(40, 60, 2000), np.zeros(2000)]),
               np.full(2000, 0.3 / 2000))
    estimate = extract(_phd(peak, diffuse))
    assert len(estimate.targets) == 1
    np.testing.assert_allclose(estimate.targets[0].position, (48, 52), atol=0.2)


def test_extraction_is_deterministic_and_order_independent():
    rng = np.random.default_rng(4)
    phd = _phd(_cloud(rng, (46, 46), 1.0), _cloud(rng, (54, 53), 1.2))
    first = extract(phd)
    again = extract(phd)
    order = rng.permutation(len(phd))
    shuffled = extract(ParticlePHD(phd.states[order], phd.weights[order]))
    assert [t.position.tolist() for t in first.targets] == \
        [t.position.tolist() for t in again.targets]
    np.testing.assert_allclose(np.sort(first.positions(), axis=0),
                               np.sort(shuffled.positions(), axis=0), atol=1e-9)


def test_close_targets_still_get_their_count():
    rng = np.random.default_rng(5)
    phd = _phd(_cloud(rng, (50, 50), 1.0, spread=0.3), _cloud(rng, (51.5, 50), 1.0, spread=0.3))
    estimate = extract(phd)
    assert len(estimate.targets) == 2
    xs = np.sort(estimate.positions()[:, 0])
    assert xs[0] < 50.75 < xs[1]


def test_a_target_of_the_last_step_continues_on_a_lighter_peak():
    """Track continuity: 0.3 of mass keeps a target it could not start (round(0.3) = 0)."""
    rng = np.random.default_rng(11)
    cloud = _cloud(rng, (53, 48), 0.3, velocity=(0.5, 0.0))
    assert extract(_phd(cloud)).targets == ()
    expected = np.array([[52.0, 48.5]])     # within phd.continue_gate of the peak
    (target,) = extract(_phd(cloud), expected=expected).targets
    np.testing.assert_allclose(target.position, (53, 48), atol=0.15)
    assert target.weight == pytest.approx(0.3, abs=0.01)
    # Too light, or too far from where the target should be: lost.
    light = _cloud(rng, (53, 48), 0.5 * PARAMS.phd.continue_threshold)
    assert extract(_phd(light), expected=expected).targets == ()
    far = np.array([[53.0 - PARAMS.phd.continue_gate - 1.0, 48.0]])
    assert extract(_phd(cloud), expected=far).targets == ()


def test_a_continued_target_splits_only_at_mass_two():
    rng = np.random.default_rng(12)
    heavy = _cloud(rng, (53, 48), 1.7)
    assert len(extract(_phd(heavy)).targets) == 2
    assert len(extract(_phd(heavy), expected=np.array([[53.0, 48.0]])).targets) == 1


def test_new_targets_need_confirm_scans_in_a_row():
    rng = np.random.default_rng(13)
    cloud = _cloud(rng, (53, 48), 0.8)
    first = extract(_phd(cloud), params=PARAMS)
    assert first.targets == () and first.tentative_streaks == (1,)
    np.testing.assert_allclose(first.tentative[0].position, (53, 48), atol=0.15)
    near = (np.array([[52.0, 48.0]]), np.array(first.tentative_streaks))
    (target,) = extract(_phd(cloud), params=PARAMS, candidates=near[0], streaks=near[1]).targets
    np.testing.assert_allclose(target.position, (53, 48), atol=0.15)
    far = (np.array([[53.0 + PARAMS.phd.confirm_gate + 1.0, 48.0]]), np.array([1]))
    assert extract(_phd(cloud), params=PARAMS, candidates=far[0],
                   streaks=far[1]).targets == ()


def test_light_peaks_in_the_square_are_tentative_not_targets():
    rng = np.random.default_rng(14)
    light = _cloud(rng, (53, 48), PARAMS.phd.tentative_threshold + 0.1)
    faint = _cloud(rng, (46, 53), PARAMS.phd.tentative_threshold - 0.1)
    estimate = extract(_phd(light, faint))
    assert estimate.targets == () and estimate.tentative_streaks == (0,)
    np.testing.assert_allclose(estimate.tentative[0].position, (53, 48), atol=0.15)


def test_mass_mostly_beyond_the_square_starts_no_target_but_continues_one():
    rng = np.random.default_rng(15)
    ghost = _cloud(rng, (57, 50), 1.0)      # in the extraction margin, outside the square
    assert extract(_phd(ghost)).targets == ()
    (target,) = extract(_phd(ghost), expected=np.array([[56.5, 50.0]])).targets
    np.testing.assert_allclose(target.position, (57, 50), atol=0.15)


# --- the switches -----------------------------------------------------------------------------


def test_peak_extraction_switch_counts_per_peak_or_the_papers_n_hat_over_the_square():
    # Two clouds of 0.3 and a diffuse 0.5 in the square: no peak reaches round(mass) = 1, but
    # the square holds round(1.1) = 1 target, the highest peak (the tighter cloud).
    rng = np.random.default_rng(21)
    tight = _cloud(rng, (53, 48), 0.3, spread=0.3)
    loose = _cloud(rng, (46, 53), 0.3, spread=0.8)
    diffuse = (np.column_stack([rng.uniform(45.5, 54.5, 2000), np.zeros(2000),
                                rng.uniform(45.5, 54.5, 2000), np.zeros(2000)]),
               np.full(2000, 0.5 / 2000))
    phd = _phd(tight, loose, diffuse)
    per_peak = extract(phd)
    assert per_peak.targets == () and len(per_peak.tentative) == 2
    paper = ONE_SCAN.with_overrides({'additions.peak_extraction': False})
    (target,) = extract(phd, params=paper, extractor=NHatExtractor).targets
    np.testing.assert_allclose(target.position, (53, 48), atol=0.5)   # diffuse mass drags it
    assert target.weight < 0.5
    # Strict: n_hat = round(1.5) = 2 of three clouds: the two highest peaks.
    clouds = [_cloud(rng, (52, 47), 0.6, spread=0.3), _cloud(rng, (52.5, 52.5), 0.6, spread=0.3),
              _cloud(rng, (47, 50), 0.3, spread=0.3)]
    strict = extract(_phd(*clouds), params=STRICT, extractor=NHatExtractor)
    assert strict.cardinality == pytest.approx(1.5)
    found = strict.positions()
    assert len(found) == 2
    np.testing.assert_allclose(found[np.argsort(found[:, 1])], [(52, 47), (52.5, 52.5)],
                               atol=0.5)


def test_extraction_margin_switch_grows_the_region_beyond_the_square():
    rng = np.random.default_rng(22)
    ghost = _cloud(rng, (57, 50), 1.0)      # 2 m beyond the square's edge
    inside = _cloud(rng, (52, 50), 1.0)
    expected = np.array([[56.5, 50.0]])
    narrow = ONE_SCAN.with_overrides({'additions.extraction_margin': False})
    assert extract(_phd(ghost, inside), expected=expected).cardinality == pytest.approx(2.0)
    assert len(extract(_phd(ghost, inside), expected=expected).targets) == 2
    off = extract(_phd(ghost, inside), params=narrow, expected=expected)
    assert off.cardinality == pytest.approx(1.0, abs=0.02) and len(off.targets) == 1
    np.testing.assert_allclose(off.targets[0].position, (52, 50), atol=0.15)
    # The paper's n_hat counts the margin too when the switch is on.
    paper = STRICT.with_overrides({'additions.extraction_margin': True})
    assert len(extract(_phd(ghost, inside), params=paper, extractor=NHatExtractor).targets) == 2
    assert len(extract(_phd(ghost, inside), params=STRICT, extractor=NHatExtractor).targets) == 1


@pytest.mark.parametrize('extractor', [PeakExtractor, NHatExtractor])
def test_confirmation_switch_takes_confirm_scans_or_the_first_estimate(extractor):
    rng = np.random.default_rng(23)
    phd = _phd(_cloud(rng, (53, 48), 1.0))
    base = PARAMS if extractor is PeakExtractor else STRICT
    on = extractor(base.with_overrides({'additions.confirmation': True}))
    off = extractor(base.with_overrides({'additions.confirmation': False}))
    # Three scans of a standing target: confirmed on the second with the switch on, and it
    # stays a target; a target from the first scan with it off.
    assert [len(on.extract(phd, POSE).targets) for _ in range(3)] == [0, 1, 1]
    assert [len(off.extract(phd, POSE).targets) for _ in range(3)] == [1, 1, 1]


@pytest.mark.parametrize('extractor', [PeakExtractor, NHatExtractor])
def test_a_heavy_peak_is_a_target_on_its_first_scan(extractor):
    rng = np.random.default_rng(24)
    heavy, light = _phd(_cloud(rng, (53, 48), 0.9)), _phd(_cloud(rng, (53, 48), 0.7))
    base = PARAMS if extractor is PeakExtractor else STRICT.with_overrides(
        {'additions.confirmation': True})
    rule = base.with_overrides({'additions.heavy_peak_confirmation': True})
    assert rule.phd.confirm_mass == 0.8
    assert len(extractor(rule).extract(heavy, POSE).targets) == 1
    # A lighter peak still needs its streak, and with the switch off a heavy one does too.
    lighter = extractor(rule)
    assert [len(lighter.extract(light, POSE).targets) for _ in range(2)] == [0, 1]
    assert len(extractor(base).extract(heavy, POSE).targets) == 0


# Per radius about (50, 50): a point with dx^2 + dy^2 < r^2 but hypot >= r, and one the other way.
ROUNDING_DISAGREES = {
    0.5: [[50.45273724047382, 49.78779964399618], [49.5899309351337, 49.71391721121382]],
    1.0: [[49.04734579483965, 50.30405585899683], [49.28134524718646, 49.304632941347876]],
    2.0: [[49.10821671719605, 48.20982610439337], [48.38498889461407, 48.82028006311663]]}


@given(st.lists(st.tuples(st.floats(-10.0, 10.0), st.floats(-10.0, 10.0)), max_size=60),
       st.sampled_from(sorted(ROUNDING_DISAGREES)))
def test_the_radius_gate_is_hypot_below_the_radius(offsets, radius):
    """within_radius (box pre-filter, then hypot) gives the plain hypot test's mask."""
    center = np.array([50.0, 50.0])
    points = center + np.array(offsets, dtype=float).reshape(-1, 2)
    # Points on the circle where dx^2 + dy^2 < r^2 and hypot < r disagree (found by a random
    # search), on its box, and non-finite ones.
    points = np.vstack([points, ROUNDING_DISAGREES[radius],
                        center + [[radius, 0.0], [0.0, -radius], [radius, radius]],
                        [[np.nan, 50.0], [np.inf, 50.0], [1e300, 50.0]]])
    with np.errstate(invalid='ignore', over='ignore'):
        expected = np.hypot(*(points - center).T) < radius
        np.testing.assert_array_equal(within_radius(points, center, radius), expected)
