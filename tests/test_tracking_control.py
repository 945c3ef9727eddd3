"""Tracking control (Eqns. pims, track_control) of sat_agent.tracking_control."""

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent import actions, sensor_model
from sat_agent.beyond_paper.kernel_likelihood import filter_bandwidth
from sat_agent.beyond_paper.track_standoff import standoff_mask
from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD, update_weights
from sat_agent.search_density import Lattice, SearchDensity
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate
from sat_agent.tracking_control import (predicted_ideal_measurements, pseudo_update_score,
                                        renyi_divergence, TrackingControl)

PARAMS = SatParams()
CONTROL = TrackingControl(PARAMS)
SENSOR = PARAMS.sensor
POSE = np.array([50.0, 50.0])


def _estimate(*points):
    targets = tuple(TargetEstimate(np.array(p, dtype=float), np.zeros(2), np.eye(4), 1.0)
                    for p in points)
    return MultiTargetEstimate(targets, float(len(points)))


def _cloud(center, count=500, spread=1.0, seed=0):
    rng = np.random.default_rng(seed)
    states = np.zeros((count, 4))
    states[:, [0, 2]] = np.asarray(center) + rng.normal(0, spread, (count, 2))
    return ParticlePHD(states, np.full(count, 1.0 / count))


def test_ideal_measurements_are_noise_free_h_of_targets_in_view():
    z = predicted_ideal_measurements(_estimate((53, 54), (80, 80)), POSE, SENSOR)
    np.testing.assert_allclose(z, [[5.0, np.arctan2(4, 3)]])
    assert predicted_ideal_measurements(_estimate(), POSE, SENSOR).shape == (0, 2)


def test_renyi_divergence_is_zero_when_nothing_changes():
    w = np.random.default_rng(1).random(100)
    assert renyi_divergence(w, w.copy(), 0.5) == 0.0


@settings(max_examples=50, deadline=None)
@given(seed=st.integers(0, 10_000), alpha=st.floats(0.05, 0.95))
def test_renyi_divergence_is_the_written_out_formula_and_non_negative(seed, alpha):
    rng = np.random.default_rng(seed)
    w = rng.random(50)
    w_hat = w * rng.uniform(0, 3, 50)
    expected = (w.sum() + alpha / (1 - alpha) * w_hat.sum()
                - (w ** (1 - alpha) * w_hat ** alpha).sum() / (1 - alpha))
    got = renyi_divergence(w, w_hat, alpha)
    assert got == pytest.approx(expected, rel=1e-9, abs=1e-12)
    assert got >= -1e-12


def test_action_that_observes_nothing_scores_zero_and_one_on_the_target_scores_more():
    target = (60.0, 50.0)
    predicted = _cloud(target, spread=0.5)
    _, scores = CONTROL.action(predicted, _estimate(target), POSE)
    moves = actions.action_displacements(PARAMS.actions)
    poses = POSE + moves
    sees = np.array([sensor_model.in_sensing_square(predicted.states[:, [0, 2]], p,
                                                    SENSOR.square_side).any() for p in poses])
    assert np.all(scores[~sees] == 0.0)
    assert np.all(scores[sees] > 0.0)
    assert np.argmax(scores) == 9            # 4 m towards +x: the cloud fully in view


def test_best_action_moves_towards_the_target():
    for direction in range(8):
        angle = direction * np.pi / 4
        target = POSE + 7.5 * np.array([np.cos(angle), np.sin(angle)])
        action, _ = CONTROL.action(_cloud(target, spread=0.8, seed=direction),
                                   _estimate(target), POSE)
        move = actions.action_displacements(PARAMS.actions)[action]
        assert np.dot(move, target - POSE) > 0


def test_inadmissible_actions_are_never_chosen():
    corner = np.array([1.0, 1.0])
    target = (-3.0, -3.0)                    # just outside the area, beyond the corner
    action, scores = CONTROL.action(_cloud(target), _estimate(target), corner)
    allowed = actions.admissible_mask(corner, PARAMS.actions, PARAMS.area)
    assert np.all(np.isneginf(scores[~allowed]))
    assert allowed[action]


def test_no_particles_means_stay():
    action, scores = CONTROL.action(ParticlePHD.empty(), _estimate(), POSE)
    assert action == 0 and np.all(scores[np.isfinite(scores)] == 0.0)


KERNEL = PARAMS.with_overrides({'additions.kernel_likelihood': True})


@pytest.mark.parametrize('params', [PARAMS, KERNEL], ids=['own g', 'kernel_likelihood'])
def test_score_equals_divergence_of_a_full_pseudo_update(params):
    """Scoring only the particles near the agent, then inside each square, changes no score.

    Bit for bit with the control's norm (sensor_model.plain_hypot): the scores decide the
    action. The pseudo-update uses the filter's g (with kernel_likelihood, the kernel's).
    """
    rng = np.random.default_rng(3)
    states = np.zeros((3000, 4))
    states[:, [0, 2]] = rng.uniform(0, 100, (3000, 2))
    states[:200, [0, 2]] = POSE + rng.normal(0, 2, (200, 2))
    predicted = ParticlePHD(states, rng.random(3000) * 1e-3)
    estimate = _estimate(POSE + 1.0)
    _, scores = TrackingControl(params).action(predicted, estimate, POSE)
    bandwidth = filter_bandwidth(params)
    for action, pose in enumerate(actions.candidate_poses(POSE, PARAMS.actions)):
        z = predicted_ideal_measurements(estimate, pose, SENSOR)
        full = update_weights(predicted.states, predicted.weights, z, pose, SENSOR,
                              bandwidth=bandwidth, norm=sensor_model.plain_hypot)
        assert scores[action] == renyi_divergence(predicted.weights, full, 0.5)
    assert (bandwidth > 0) == np.any(scores != CONTROL.action(predicted, estimate, POSE)[1])


@pytest.mark.parametrize('seed', range(20))
def test_the_controls_norm_ranks_actions_as_the_filters_exact_one(seed):
    """plain_hypot's scores are the exact norm's to 1e-12 and rank the same action first."""
    rng = np.random.default_rng(seed)
    target = POSE + rng.uniform(-4.0, 4.0, 2)
    predicted = _cloud(target, count=int(rng.integers(200, 5000)), spread=rng.uniform(0.2, 2.0),
                       seed=seed)
    estimate = _estimate(target)
    poses = actions.candidate_poses(POSE, PARAMS.actions)
    points = predicted.states[:, [0, 2]]
    for params in (PARAMS, KERNEL):
        bandwidth = filter_bandwidth(params)
        plain, exact = (np.array([pseudo_update_score(points, predicted.weights, estimate, pose,
                                                      SENSOR, 0.5, bandwidth, norm)
                                  for pose in poses])
                        for norm in (sensor_model.plain_hypot, np.hypot))
        np.testing.assert_allclose(plain, exact, rtol=1e-12, atol=0.0)
        assert np.argmax(plain) == np.argmax(exact)
        scores = TrackingControl(params).action(predicted, estimate, POSE)[1]
        np.testing.assert_array_equal(scores[np.isfinite(scores)], plain[np.isfinite(scores)])


# Metres, radians and sigmas: no square underflows (plain_hypot's docstring).
PHYSICAL = st.floats(-1e3, 1e3).filter(lambda x: x == 0.0 or abs(x) > 1e-100)


@given(PHYSICAL, PHYSICAL)
def test_plain_hypot_is_hypot_within_a_few_ulps(a, b):
    assert sensor_model.plain_hypot(np.float64(a), np.float64(b)) == pytest.approx(
        np.hypot(a, b), rel=4 * np.finfo(float).eps, abs=1e-300)


def test_track_standoff_switch_keeps_the_target_at_the_stand_off_or_takes_the_pure_argmax():
    """Among the stand-off actions the Renyi score decides; the scores stay the Renyi ones."""
    target = POSE + np.array([0.5, 0.0])                 # next to the agent
    action, scores = CONTROL.action(_cloud(target, spread=0.8), _estimate(target), POSE)
    chosen = actions.candidate_poses(POSE, PARAMS.actions)[action]
    offset = np.abs(target - chosen)
    assert np.hypot(*offset) >= PARAMS.cooperation.track_standoff
    assert offset.max() <= SENSOR.square_side / 2.0 - PARAMS.cooperation.track_edge_margin
    assert np.isfinite(scores).all() and scores[action] > 0.0
    # The switch off, the paper's pure argmax over the admissible actions (the same scores):
    # the agent would stay on top of the target (or move closer).
    paper = TrackingControl(PARAMS.with_overrides({'additions.track_standoff': False}))
    best, same = paper.action(_cloud(target, spread=0.8), _estimate(target), POSE)
    np.testing.assert_array_equal(same, scores)
    assert best == np.argmax(scores) != action
    assert np.hypot(*(actions.candidate_poses(POSE, PARAMS.actions)[best] - target)) < (
        PARAMS.cooperation.track_standoff)


def _worth_to_the_north(params):
    """Return a search density with undetected mass north of y = 55 (the rest just searched)."""
    density = SearchDensity(Lattice.for_area(params.area, params.search.lattice_spacing),
                            params)
    u = np.zeros(density.values.shape)
    u[55:, :] = 1e-4
    density.values = np.exp(-u)
    return density


@pytest.mark.parametrize('tolerance', [0.1, 0.2, 0.5])
def test_search_while_tracking_covers_search_worth_within_its_bound(tolerance):
    # A tight target cloud east of the agent, fresh ground to the north: the agent gives up at
    # most epsilon of the best Renyi score to cover worth, and covers more than the best
    # action does.
    params = PARAMS.with_overrides({'additions.search_while_tracking': True,
                                    'cooperation.track_search_tolerance': tolerance})
    target = POSE + np.array([1.0, 0.0])
    cloud, estimate = _cloud(target, spread=0.3), _estimate(target)
    search = _worth_to_the_north(params)
    action, scores = TrackingControl(params).action(cloud, estimate, POSE, search)
    best, paper_scores = CONTROL.action(cloud, estimate, POSE)
    np.testing.assert_array_equal(scores, paper_scores)
    assert scores[action] >= (1.0 - tolerance) * scores[best]
    poses = actions.candidate_poses(POSE, PARAMS.actions)
    worth = search.square_worth(poses)
    assert worth[action] > worth[best]
    # No other stand-off action within the bound covers more worth.
    near = standoff_mask(poses, estimate.positions(), params) & (
        scores >= (1.0 - tolerance) * scores[best])
    assert worth[action] == worth[near].max()


def test_search_while_tracking_switch_off_or_zero_tolerance_takes_the_best_score():
    target = POSE + np.array([1.0, 0.0])
    cloud, estimate = _cloud(target, spread=0.3), _estimate(target)
    best, _ = CONTROL.action(cloud, estimate, POSE, _worth_to_the_north(PARAMS))
    zero = PARAMS.with_overrides({'additions.search_while_tracking': True,
                                  'cooperation.track_search_tolerance': 0.0})
    assert TrackingControl(zero).action(cloud, estimate, POSE,
                                        _worth_to_the_north(zero))[0] == best
    on = PARAMS.with_overrides({'additions.search_while_tracking': True})
    assert TrackingControl(on).action(cloud, estimate, POSE, _worth_to_the_north(on))[0] != best


@pytest.mark.parametrize('scope, look_searches', [('all', True), ('track', False)])
def test_search_while_tracking_scope_decides_whether_a_look_searches(scope, look_searches):
    # In TRACK the search worth moves the action whatever the scope; a searching agent's look
    # at tentative peaks is moved by it only with the scope 'all'.
    target = POSE + np.array([1.0, 0.0])
    cloud, estimate = _cloud(target, spread=0.3), _estimate(target)
    best, _ = CONTROL.action(cloud, estimate, POSE)
    params = PARAMS.with_overrides({'additions.search_while_tracking': True,
                                    'cooperation.track_search_scope': scope})
    control, search = TrackingControl(params), _worth_to_the_north(params)
    tracking, _ = control.action(cloud, estimate, POSE, search)
    looking, _ = control.action(cloud, estimate, POSE, search, look=True)
    assert tracking != best
    assert looking == (tracking if look_searches else best)
