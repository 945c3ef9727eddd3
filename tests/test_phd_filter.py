"""SMC-PHD update, births and resampling of sat_agent.phd_filter."""

from dataclasses import replace

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent import sensor_model
from sat_agent.config import SatParams
from sat_agent.phd_filter import (birth_spots, measurement_births, particle_budget, ParticlePHD,
                                  resample, SatPhdFilter, uniform_births, update_weights)

POSE = np.array([50.0, 50.0])
SIDE = SatParams().sensor.square_side


def _states(points, velocity=0.0):
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    states = np.zeros((len(points), 4))
    states[:, 0], states[:, 2] = points[:, 0], points[:, 1]
    states[:, 1] = states[:, 3] = velocity
    return states


def _in_square(states, pose=POSE):
    return sensor_model.in_sensing_square(states[:, [0, 2]], pose, SIDE)


def _ideal_params(clutter_rate=1e-6):
    """Single-target analytic setting: p_D = 1, (almost) no clutter, no births."""
    params = SatParams()
    return replace(params,
                   sensor=replace(params.sensor, p_detect=1.0, clutter_rate=clutter_rate),
                   phd=replace(params.phd, birth_rate=0.0, birth_mass_measurement=0.0,
                               min_particles=500, particles_per_target=500, max_particles=5000))


def test_update_leaves_particles_outside_the_square_bit_for_bit():
    rng = np.random.default_rng(1)
    states = _states(rng.uniform(0, 100, (3000, 2)), 0.3)
    weights = rng.random(3000) * 1e-3
    z = np.array([[2.0, 0.3], [4.0, -2.0], [1.0, 1.0]])
    new = update_weights(states, weights, z, POSE, SatParams().sensor)
    outside = ~_in_square(states)
    assert outside.sum() > 2000 and (~outside).sum() > 10
    assert np.array_equal(new[outside], weights[outside])
    assert not np.allclose(new[~outside], weights[~outside])


def test_gating_computes_likelihoods_only_inside(monkeypatch):
    seen = []
    original = sensor_model.log_likelihood

    def spy(z, points, pose, sensor, bandwidth, norm):
        seen.append(len(points))
        return original(z, points, pose, sensor, bandwidth, norm)

    monkeypatch.setattr(sensor_model, 'log_likelihood', spy)
    rng = np.random.default_rng(2)
    states = _states(rng.uniform(0, 100, (5000, 2)))
    update_weights(states, np.ones(5000), np.array([[3.0, 0.0]]), POSE, SatParams().sensor)
    assert seen == [int(_in_square(states).sum())]


def test_update_matches_the_phd_equation_written_out():
    sensor = SatParams().sensor
    rng = np.random.default_rng(3)
    states = _states(POSE + rng.uniform(-6, 6, (200, 2)))
    weights = rng.random(200) / 100
    z = np.array([[2.0, 0.5], [3.5, -1.0]])
    p_d = sensor_model.detection_probability(states[:, [0, 2]], POSE, sensor)
    g = sensor_model.likelihood(z, states[:, [0, 2]], POSE, sensor)
    tau = (p_d * weights) @ g
    kappa = sensor_model.clutter_intensity(sensor)
    expected = weights * (1 - p_d + p_d * (g / (kappa + tau)).sum(axis=1))
    np.testing.assert_allclose(update_weights(states, weights, z, POSE, sensor), expected,
                               rtol=1e-12, atol=0)


def test_no_measurements_scales_inside_weights_by_missed_detection():
    sensor = SatParams().sensor
    states = _states([[50.0, 50.0], [80.0, 80.0]])
    new = update_weights(states, np.array([0.5, 0.5]), np.zeros((0, 2)), POSE, sensor)
    np.testing.assert_allclose(new, [0.5 * (1 - sensor.p_detect), 0.5])


def test_far_measurement_does_not_underflow_to_nan():
    """A measurement no particle explains: the term is ~0, not 0/0, whatever the clutter."""
    sensor = SatParams().sensor
    states = _states([[52.0, 50.0]])
    z = np.array([[2.0, np.pi]])                  # opposite side: log g ~ -1.6e4
    new = update_weights(states, np.array([1.0]), z, POSE, sensor)
    np.testing.assert_allclose(new, [1 - sensor.p_detect], rtol=1e-9)
    no_clutter = replace(sensor, clutter_rate=0.0)
    assert np.isfinite(update_weights(states, np.array([1.0]), z, POSE, no_clutter)).all()


def test_zero_clutter_with_no_particle_in_view_is_defined_as_no_information():
    """With kappa = 0 and tau(z) = 0 the term is 0/0; the measurement then changes no weight."""
    sensor = replace(SatParams().sensor, clutter_rate=0.0, p_detect=1.0)
    states = _states([[52.0, 50.0], [90.0, 90.0]])
    weights = np.array([0.0, 0.7])
    new = update_weights(states, weights, np.array([[2.0, 0.0]]), POSE, sensor)
    np.testing.assert_array_equal(new, [0.0, 0.7])


def test_single_target_mass_in_the_square_tends_to_one():
    params = _ideal_params()
    rng = np.random.default_rng(4)
    phd = ParticlePHD(_states(POSE + rng.uniform(-5, 5, (2000, 2))), np.full(2000, 3.0 / 2000))
    target = np.array([[52.0, 48.0]])
    masses = []
    for _ in range(8):
        z, _ = sensor_model.simulate_scan(target, POSE, params.sensor, rng)
        assert len(z) == 1
        phd = ParticlePHD(phd.states, update_weights(phd.states, phd.weights, z, POSE,
                                                     params.sensor))
        phd = resample(phd, params.phd, rng)
        masses.append(phd.mass)
    assert abs(masses[0] - 1.0) < 1e-3       # p_D = 1, kappa ~ 0: one scan gives mass 1
    assert abs(masses[-1] - 1.0) < 1e-3
    centre = np.average(phd.states[:, [0, 2]], axis=0, weights=phd.weights)
    assert np.linalg.norm(centre - target[0]) < 1.0


def test_filter_confirms_a_target_over_repeated_scans():
    params = _ideal_params()
    params = replace(params, phd=replace(params.phd, birth_mass_measurement=0.2))
    rng = np.random.default_rng(5)
    sat = SatPhdFilter(params, rng)
    target = np.array([[53.0, 49.0]])
    inside = []
    for _ in range(6):
        sat.predict(POSE)
        z, _ = sensor_model.simulate_scan(target, POSE, params.sensor, rng)
        sat.correct(z, POSE)
        inside.append(sat.targets.weights[_in_square(sat.targets.states)].sum())
    assert inside[0] == 0.0            # nothing to update yet: births wait for the next scan
    assert abs(inside[-1] - 1.0) < 0.05


def test_uniform_births_cover_the_area_with_the_birth_rate():
    params = SatParams()
    born = uniform_births(params, np.random.default_rng(6))
    assert len(born) == params.phd.birth_particles_uniform
    assert born.mass == pytest.approx(params.phd.birth_rate)
    x, y = born.states[:, 0], born.states[:, 2]
    assert x.min() >= 0 and x.max() <= 100 and y.min() >= 0 and y.max() <= 100
    counts, _, _ = np.histogram2d(x, y, bins=2, range=[[0, 100], [0, 100]])
    assert np.all(np.abs(counts - len(born) / 4) < 5 * np.sqrt(len(born) / 4))
    assert np.std(born.states[:, [1, 3]]) == pytest.approx(params.phd.birth_velocity_std, 0.1)


def test_measurement_births_sit_on_measurements_inside_the_square():
    params = SatParams()
    rng = np.random.default_rng(7)
    z = np.array([[3.0, 0.0], [2.0, np.pi / 2], [7.0, 0.0]])   # last one: beyond the edge
    outside_square = ~sensor_model.in_sensing_square(
        sensor_model.to_position(z[2:], POSE), POSE, SIDE)
    assert outside_square.all()
    born = measurement_births(birth_spots(z, POSE, params), POSE, params, rng)
    per_z = params.phd.birth_particles_per_measurement
    # m_z = m_b r / r_max: a birth intensity uniform over the square's area.
    m_b, r_max = params.phd.birth_mass_measurement, params.sensor.max_range
    assert born.mass == pytest.approx(m_b * (3.0 + 2.0) / r_max, rel=0.1)
    assert born.weights[0] == pytest.approx(m_b * 3.0 / r_max / per_z)
    assert _in_square(born.states).all()
    anchors = sensor_model.to_position(z[:2], POSE)
    nearest = np.min(np.linalg.norm(born.states[:, None, [0, 2]] - anchors[None], axis=2), 1)
    assert np.median(nearest) < 1.5


def test_measurements_the_targets_explain_seed_no_births():
    params = SatParams()
    z = np.array([[3.0, 0.0], [4.0, np.pi / 2]])
    explained = np.array([1.0, 0.25])
    born = measurement_births(birth_spots(z, POSE, params, explained), POSE, params,
                              np.random.default_rng(3))
    anchors = sensor_model.to_position(z, POSE)
    gaps = np.linalg.norm(born.states[:, None, [0, 2]] - anchors[None], axis=2)
    assert np.all(np.argmin(gaps, axis=1) == 1)         # nothing born from the explained one
    expected = params.phd.birth_mass_measurement * 4.0 / params.sensor.max_range * 0.75
    per_z = params.phd.birth_particles_per_measurement
    np.testing.assert_allclose(born.weights, expected / per_z, rtol=1e-12)


def test_birth_spots_are_the_seeding_measurements_with_their_birth_masses():
    params = SatParams()
    z = np.array([[3.0, 0.0], [7.0, 0.0], [4.0, np.pi / 2]])   # the 7 m one: beyond the edge
    explained = np.array([0.0, 0.0, 0.5])
    spots = birth_spots(z, POSE, params, explained)
    np.testing.assert_allclose(spots.positions, [[53.0, 50.0], [50.0, 54.0]], atol=1e-12)
    m_b, r_max = params.phd.birth_mass_measurement, params.sensor.max_range
    np.testing.assert_allclose(spots.masses, [m_b * 3.0 / r_max, m_b * 4.0 / r_max * 0.5])
    # The particles measurement_births seeds carry exactly these masses.
    per_z = params.phd.birth_particles_per_measurement
    born = measurement_births(spots, POSE, params, np.random.default_rng(2))
    np.testing.assert_allclose(np.unique(born.weights), np.sort(spots.masses) / per_z)
    sat = SatPhdFilter(params, np.random.default_rng(2))
    sat.correct(z, POSE)
    np.testing.assert_allclose(sat.birth_spots.positions, spots.positions)


def test_update_reports_the_share_of_each_measurement_the_targets_explain():
    params = SatParams()
    target = POSE + np.array([3.0, 0.0])
    states = np.tile([target[0], 0.0, target[1], 0.0], (500, 1))
    weights = np.full(500, 1.0 / 500)
    z = np.vstack([sensor_model.measure(target[None], POSE), [[3.0, np.pi / 2]]])
    explained = np.full(2, -1.0)
    update_weights(states, weights, z, POSE, params.sensor, explained)
    kappa = sensor_model.clutter_intensity(params.sensor)
    g = sensor_model.likelihood(z, target[None], POSE, params.sensor)[0]
    tau = params.sensor.p_detect * g
    np.testing.assert_allclose(explained, tau / (kappa + tau), rtol=1e-9, atol=1e-12)
    assert explained[0] > 0.9 and explained[1] < 1e-6


def test_newborns_the_next_square_misses_are_dropped():
    params = SatParams()
    sat = SatPhdFilter(params, np.random.default_rng(8))
    sat.correct(np.array([[2.0, 0.0]]), POSE)           # births near (52, 50)
    assert sat.pending_births.mass > 0
    sat.predict(POSE)
    far = POSE + np.array([30.0, 0.0])
    sat.correct(np.zeros((0, 2)), far)
    near_old_square = np.abs(sat.targets.states[:, [0, 2]] - POSE).max(axis=1) < 8
    assert sat.targets.weights[near_old_square].sum() < params.phd.birth_rate


def test_newborn_gate_switch_off_keeps_the_newborns_the_next_square_misses():
    params = SatParams().with_overrides({'additions.newborn_gate': False})
    sat = SatPhdFilter(params, np.random.default_rng(8))
    sat.correct(np.array([[2.0, 0.0]]), POSE)
    born = sat.pending_births.mass
    sat.predict(POSE)
    sat.correct(np.zeros((0, 2)), POSE + np.array([30.0, 0.0]))
    near_old_square = np.abs(sat.targets.states[:, [0, 2]] - POSE).max(axis=1) < 8
    # Resampling keeps the mass: the newborns are all there (plus a little uniform birth mass).
    assert sat.targets.weights[near_old_square].sum() == pytest.approx(
        born, abs=params.phd.birth_rate)
    assert born > 10 * params.phd.birth_rate


@settings(max_examples=30, deadline=None)
@given(mass=st.floats(0.01, 30.0), n=st.integers(1, 4000), seed=st.integers(0, 1000))
def test_resampling_keeps_mass_and_respects_budget(mass, n, seed):
    params = SatParams().phd
    rng = np.random.default_rng(seed)
    weights = rng.random(n) + 1e-12
    weights *= mass / weights.sum()
    out = resample(ParticlePHD(rng.random((n, 4)), weights), params, rng)
    assert out.mass == pytest.approx(mass, rel=1e-9)
    assert len(out) == particle_budget(mass, params)
    assert params.min_particles <= len(out) <= params.max_particles
    assert len(out) == min(max(round(mass * params.particles_per_target),
                               params.min_particles), params.max_particles)


def test_systematic_resampling_follows_the_weights():
    params = SatParams().phd
    states = np.arange(4, dtype=float)[:, None] * np.ones((1, 4))
    weights = np.array([0.5, 0.3, 0.2, 0.0])
    out = resample(ParticlePHD(states, weights), params, np.random.default_rng(9))
    shares = np.bincount(out.states[:, 0].astype(int), minlength=4) / len(out)
    np.testing.assert_allclose(shares, weights, atol=1.0 / len(out))


def test_filter_step_is_deterministic_for_a_seed():
    params = SatParams()
    outputs = []
    for _ in range(2):
        rng = np.random.default_rng(10)
        sat = SatPhdFilter(params, rng)
        for step in range(3):
            sat.predict(POSE)
            sat.correct(np.array([[2.0, 0.1 * step]]), POSE)
        outputs.append((sat.targets.states.copy(), sat.targets.weights.copy()))
    np.testing.assert_array_equal(outputs[0][0], outputs[1][0])
    np.testing.assert_array_equal(outputs[0][1], outputs[1][1])


def test_predict_decays_search_density_and_correct_marks_the_square():
    params = SatParams()
    sat = SatPhdFilter(params, np.random.default_rng(11))
    sat.correct(np.zeros((0, 2)), POSE)
    sat.predict(POSE)              # s_{k-1} = POSE: the cells it saw keep their value
    assert sat.search.values.max() == 1.0
    sat.predict(POSE + 30)
    assert sat.search.values.max() == pytest.approx(params.search.decay)


def test_empty_phd_has_zero_mass():
    empty = ParticlePHD.empty()
    assert len(empty) == 0 and empty.mass == 0.0 and empty.states.shape == (0, 4)
