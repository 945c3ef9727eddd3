"""A track's walk fitted on its measurements (beyond_paper/measurement_fit.py)."""

import numpy as np
import pytest

from sat_agent.beyond_paper.measurement_fit import (
    associate, estimate_position_covariances, measurement_positions, weighted_walk_fit)
from sat_agent.beyond_paper.track_coasting import Track, TrackCoasting
from sat_agent.config import load_params_file
from sat_agent.sensor_model import measure, measurement_sigmas
from sat_agent.state_extraction import TargetEstimate
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.scenario import scenario_from_mapping

PARAMS = load_params_file('config/persistent.yaml')
SENSOR = PARAMS.sensor
VELOCITY = np.array([0.6, -0.3])
START = np.array([20.0, 40.0])
NONE = np.zeros((0, 2))


def _scan(point, pose, rng):
    """One noisy range-bearing measurement of point from pose, as the simulated sensor draws."""
    z = measure(np.reshape(point, (1, 2)), pose)[0]
    sigma_r, sigma_b = measurement_sigmas(z[0], SENSOR)
    return z + rng.standard_normal(2) * (sigma_r, sigma_b)


def _walk(step):
    return START + step * VELOCITY


def test_the_information_is_the_inverse_scatter_of_the_converted_measurements():
    rng = np.random.default_rng(1)
    pose, target = np.array([10.0, 10.0]), np.array([12.0, 12.5])
    scans = np.array([_scan(target, pose, rng) for _ in range(20000)])
    scatter = np.cov(measurement_positions(scans, pose, SENSOR)[0].T)
    # The linearised covariance, taken at the noise-free measurement.
    _, information = measurement_positions(measure(target[None], pose), pose, SENSOR)
    np.testing.assert_allclose(np.linalg.inv(information[0]), scatter, rtol=0.05, atol=2e-4)
    # ~1 m along the line of sight, a few cm across it.
    spreads = np.sqrt(np.linalg.eigvalsh(scatter))
    assert spreads[0] < 0.1 and 0.9 < spreads[1] < 1.2


def test_unit_weights_give_the_least_squares_line_and_its_error():
    steps = list(range(1, 13))
    rng = np.random.default_rng(4)
    # Noise of 3 m, so the reduced chi-square of unit weights exceeds 1 and scales the
    # covariance to the residuals' variance, as the unweighted fit judges it.
    noisy = [_walk(k) + rng.normal(0.0, 3.0, 2) for k in steps]
    plain = Track(list(steps), list(noisy), np.zeros(2))
    weighted = Track(list(steps), list(noisy), np.zeros(2),
                     informations=[np.eye(2)] * len(steps))
    np.testing.assert_allclose(weighted.predict(40), plain.predict(40))
    assert weighted.velocity_error() == pytest.approx(plain.velocity_error())
    assert weighted.prediction_error(40) == pytest.approx(plain.prediction_error(40))
    fit = weighted_walk_fit(steps, np.array(noisy), np.array([np.eye(2)] * len(steps)))
    expected = [np.polyfit(steps, np.array(noisy)[:, i], 1)[0] for i in range(2)]
    np.testing.assert_allclose(fit.velocity, expected)


def test_the_weighted_fit_states_its_error_and_drifts_far_less_than_the_estimates_fit():
    rng = np.random.default_rng(2)
    steps, ahead = list(range(1, 11)), 50
    weighted, plain, stated = [], [], []
    for _ in range(400):
        # A tracker within 4 m of its target: the lines of sight turn from scan to scan.
        poses = [_walk(k) + rng.uniform(-4.0, 4.0, 2) for k in steps]
        positions, informations = zip(*(
            measurement_positions(_scan(_walk(k), pose, rng), pose, SENSOR)
            for k, pose in zip(steps, poses)))
        track = Track(list(steps), [p[0] for p in positions], np.zeros(2),
                      informations=[w[0] for w in informations])
        weighted.append(track.predict(ahead) - _walk(ahead))
        stated.append(track.prediction_error(ahead))
        estimates = [_walk(k) + rng.normal(0.0, 1.0, 2) for k in steps]
        plain.append(Track(list(steps), estimates, np.zeros(2)).predict(ahead) - _walk(ahead))
    weighted, plain = np.array(weighted), np.array(plain)
    # The stated per-axis error matches the spread found, and is not an understatement.
    assert np.sqrt(np.mean(weighted ** 2)) == pytest.approx(np.sqrt(np.mean(np.square(stated))),
                                                            rel=0.2)
    assert np.sqrt(np.mean(weighted ** 2)) < np.sqrt(np.mean(plain ** 2)) / 5


def test_each_estimate_takes_its_nearest_measurement_within_the_gate_one_to_one():
    pose = np.array([10.0, 10.0])
    targets = np.array([[12.0, 10.0], [10.0, 13.0]])
    scans = np.vstack([measure(targets, pose), measure(np.array([[14.0, 14.0]]), pose)])
    positions, informations = measurement_positions(scans, pose, SENSOR)
    covariances = estimate_position_covariances([np.eye(4) * 0.25] * 2, 0.3)
    # Estimates 0.8 m off their targets, in reverse order: each gets its own measurement.
    estimates = targets[::-1] + np.array([[0.0, 0.8], [0.8, 0.0]])
    np.testing.assert_array_equal(associate(estimates, covariances, positions, informations),
                                  [1, 0])
    # A measurement beyond the gate is no one's, and with none there is nothing to take.
    far = associate(np.array([[16.0, 10.0]]), covariances[:1], positions, informations)
    np.testing.assert_array_equal(far, [-1])
    np.testing.assert_array_equal(associate(estimates, covariances, NONE, np.zeros((0, 2, 2))),
                                  [-1, -1])


def test_only_a_measurement_in_the_square_continues_a_track():
    """A false alarm far out passes any gate by its width; it is not a detection (session 29).

    One estimate in view with its target's measurement, one out of view whose only candidate is
    a false alarm 90 m away (range sigma ~41 m): its 80 m residual lies inside the 99 % gate of
    the summed covariances, so only the square keeps it out.
    """
    pose = np.array([10.0, 10.0])
    seen, unseen = np.array([12.0, 11.0]), np.array([20.0, 10.0])
    scans = np.vstack([measure(seen[None], pose), [[90.0, 0.0]]])
    far, far_information = measurement_positions(scans[1:], pose, SENSOR)
    assert associate(unseen[None], np.eye(2)[None], far, far_information)[0] == 0
    coasting = TrackCoasting(PARAMS)
    estimates = [TargetEstimate(point + 0.3, VELOCITY, np.eye(4) * 0.25, 1.0)
                 for point in (seen, unseen)]
    coasting.update(1, pose, estimates, NONE, NONE, scans)
    entries = np.array([track.positions[0] for track in coasting.tracks])
    np.testing.assert_allclose(entries, [seen, unseen + 0.3], atol=1e-9)
    # The out-of-view entry weighs as its peak does, not as the false alarm would.
    np.testing.assert_allclose(coasting.tracks[1].informations[0],
                               np.linalg.inv(estimate_position_covariances(
                                   [np.eye(4) * 0.25], SENSOR.likelihood_bandwidth)[0]))


def test_a_peaks_covariance_holds_its_kernel():
    peak = np.diag([0.5, 9.0, 0.2, 9.0])     # [x, vx, y, vy]
    np.testing.assert_allclose(estimate_position_covariances([peak], 0.3)[0],
                               np.diag([0.5 + 0.09, 0.2 + 0.09]))
    # A one-particle peak without a kernel still has an invertible covariance.
    assert np.linalg.det(estimate_position_covariances([np.zeros((4, 4))], 0.0)[0]) > 0


def test_an_estimate_weighs_with_a_kernel_only_when_the_filter_has_kernels():
    """additions.kernel_likelihood off: the peak's particles are points, no bandwidth added."""
    pose, point = np.array([10.0, 10.0]), np.array([30.0, 30.0])   # out of view: no scan
    estimate = [TargetEstimate(point, VELOCITY, np.eye(4) * 0.25, 1.0)]
    for kernels, bandwidth in ((True, SENSOR.likelihood_bandwidth), (False, 0.0)):
        coasting = TrackCoasting(PARAMS.with_overrides({'additions.kernel_likelihood': kernels}))
        coasting.update(1, pose, estimate, NONE, NONE, np.zeros((0, 2)))
        np.testing.assert_allclose(coasting.tracks[0].informations[0], np.linalg.inv(
            estimate_position_covariances([np.eye(4) * 0.25], bandwidth)[0]))


def _track_steps(measurement_fit, steps, seed=5):
    """Feed a track estimates erring 1 m and the tracker's measurements; return fresh counts."""
    params = PARAMS.with_overrides({'additions.measurement_fit': measurement_fit})
    coasting, rng = TrackCoasting(params), np.random.default_rng(seed)
    fresh = []
    for k in range(1, steps + 1):
        pose = _walk(k) + rng.uniform(-4.0, 4.0, 2)
        estimate = TargetEstimate(_walk(k) + rng.normal(0.0, 1.0, 2), VELOCITY,
                                  np.eye(4), 1.0)
        scan = _scan(_walk(k), pose, rng)[None]
        fresh.append(coasting.update(k, pose, [estimate], NONE, NONE, scan).fresh)
    return coasting, fresh


def test_a_measurement_fit_stores_the_measurements_and_releases_the_tracker_sooner():
    steps = 30
    coasting, fresh = _track_steps(True, steps)
    track, = coasting.tracks
    assert track.length == steps and len(track.informations) == steps
    # Every entry is the scan's measurement (within its ~1 m range noise of the walk).
    errors = np.hypot(*(np.array(track.positions) - [_walk(k) for k in track.steps]).T)
    assert errors.max() < 4.0
    released = fresh.index(0) + 1
    assert released == PARAMS.cooperation.follow_steps
    plain, plain_fresh = _track_steps(False, steps)
    assert plain.tracks[0].informations is None
    assert 0 not in plain_fresh[:released]


def test_a_mirrored_entry_mirrors_its_information():
    track = Track([1, 2, 3], [np.array([50.0, 3.0]), np.array([50.0, 2.0]),
                              np.array([50.0, 1.0])], np.zeros(2), bounds=(100.0, 100.0),
                  unfolds=True, informations=[np.eye(2)] * 3)
    information = np.array([[4.0, 1.0], [1.0, 2.0]])
    track.add(5, np.array([50.2, 1.4]), np.zeros(2), history=50, information=information)
    # Mirrored in y: the x-y coupling changes sign.
    np.testing.assert_allclose(track.informations[-1], [[4.0, -1.0], [-1.0, 2.0]])


def test_an_agent_fits_its_tracks_on_the_scans_the_world_gave_it():
    """Agent.step hands its scan to the coasting: a swarm-built track holds measurements.

    A measurement's information is the sensor's, ~1 m along the line of sight and centimetres
    across it; an estimate's is near isotropic. No clutter, one target under the lone agent.
    """
    scenario = scenario_from_mapping({
        'seed': 3, 'steps': 12, 'agents': [{'id': 1, 'start': [30.0, 30.0]}],
        'targets': [{'id': 1, 'born': 1, 'died': 12, 'start': [31.0, 31.0],
                     'end': [38.0, 36.0]}]})
    swarm = InProcessSwarm(scenario, PARAMS.with_overrides({'sensor.clutter_rate': 0.0}))
    for _ in range(12):
        swarm.step()
    track = max(swarm.agents[1].coasting.tracks, key=lambda t: t.length)
    assert track.length >= 8 and len(track.informations) == len(track.steps)
    spreads = np.array([np.linalg.eigvalsh(w) for w in track.informations])
    assert np.median(spreads[:, 1] / spreads[:, 0]) > 100.0
