"""Multi-target state extraction of sat_agent.state_extraction."""

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD
from sat_agent.state_extraction import extract_targets

PARAMS = SatParams()
POSE = np.array([50.0, 50.0])


def _cloud(rng, center, mass, count=400, spread=0.5, velocity=(0.0, 0.0)):
    states = np.zeros((count, 4))
    states[:, [0, 2]] = np.asarray(center) + rng.normal(0, spread, (count, 2))
    states[:, [1, 3]] = np.asarray(velocity) + rng.normal(0, 0.1, (count, 2))
    return states, np.full(count, mass / count)


def _phd(*clouds):
    return ParticlePHD(np.vstack([c[0] for c in clouds]), np.concatenate([c[1] for c in clouds]))


def test_no_mass_gives_no_targets():
    rng = np.random.default_rng(0)
    estimate = extract_targets(_phd(_cloud(rng, (52, 50), 0.3)), POSE, PARAMS)
    assert estimate.targets == () and estimate.cardinality == pytest.approx(0.3)
    assert extract_targets(ParticlePHD.empty(), POSE, PARAMS).targets == ()


def test_mass_outside_the_region_is_not_counted():
    rng = np.random.default_rng(1)
    far = _cloud(rng, (80, 80), 3.0)
    near = _cloud(rng, (53, 48), 1.0)
    estimate = extract_targets(_phd(far, near), POSE, PARAMS)
    assert estimate.cardinality == pytest.approx(1.0)
    assert len(estimate.targets) == 1
    np.testing.assert_allclose(estimate.targets[0].position, (53, 48), atol=0.15)


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 10_000), count=st.integers(1, 4))
def test_well_separated_clusters_give_count_and_positions(seed, count):
    rng = np.random.default_rng(seed)
    corners = np.array([(45.0, 45.0), (55.0, 55.0), (45.0, 55.0), (55.0, 45.0)])[:count]
    velocities = rng.uniform(-1, 1, (count, 2))
    clouds = [_cloud(rng, c, 1.0, velocity=v) for c, v in zip(corners, velocities)]
    estimate = extract_targets(_phd(*clouds), POSE, PARAMS)
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
    target = extract_targets(_phd(cloud), POSE, PARAMS).targets[0]
    assert target.covariance.shape == (4, 4)
    np.testing.assert_allclose(np.sqrt(np.diag(target.covariance))[[0, 2]], 0.7, rtol=0.08)
    np.testing.assert_allclose(target.covariance, target.covariance.T)


def test_diffuse_mass_does_not_drag_the_peak():
    rng = np.random.default_rng(3)
    peak = _cloud(rng, (48, 52), 0.9)
    diffuse = (np.column_stack([rng.uniform(40, 60, 2000), np.zeros(2000),
                                rng.uniform(40, 60, 2000), np.zeros(2000)]),
               np.full(2000, 0.3 / 2000))
    estimate = extract_targets(_phd(peak, diffuse), POSE, PARAMS)
    assert len(estimate.targets) == 1
    np.testing.assert_allclose(estimate.targets[0].position, (48, 52), atol=0.2)


def test_extraction_is_deterministic_and_order_independent():
    rng = np.random.default_rng(4)
    phd = _phd(_cloud(rng, (46, 46), 1.0), _cloud(rng, (54, 53), 1.2))
    first = extract_targets(phd, POSE, PARAMS)
    again = extract_targets(phd, POSE, PARAMS)
    order = rng.permutation(len(phd))
    shuffled = extract_targets(ParticlePHD(phd.states[order], phd.weights[order]), POSE, PARAMS)
    assert [t.position.tolist() for t in first.targets] == \
        [t.position.tolist() for t in again.targets]
    np.testing.assert_allclose(np.sort(first.positions(), axis=0),
                               np.sort(shuffled.positions(), axis=0), atol=1e-9)


def test_close_targets_still_get_their_count():
    rng = np.random.default_rng(5)
    phd = _phd(_cloud(rng, (50, 50), 1.0, spread=0.3), _cloud(rng, (51.5, 50), 1.0, spread=0.3))
    estimate = extract_targets(phd, POSE, PARAMS)
    assert len(estimate.targets) == 2
    xs = np.sort(estimate.positions()[:, 0])
    assert xs[0] < 50.75 < xs[1]
