"""Track coasting (beyond_paper/track_coasting.py): follow, search on, report the walk."""

import numpy as np
import pytest
from scipy import stats

from sat_agent.actions import fold
from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.track_coasting import (
    coast_point, coast_steps, NoCoasting, Track, TrackCoasting)
from sat_agent.config import load_params_file
from sat_agent.mode_machine import Mode
from sat_agent.sensor_model import measure
from sat_agent.state_extraction import TargetEstimate

# The fit of the estimates (the fit of measurements: tests/test_measurement_fit.py).
PARAMS = load_params_file('config/persistent.yaml').with_overrides(
    {'additions.track_coasting': True, 'additions.measurement_fit': False})
FAR = np.array([90.0, 90.0])           # an agent pose whose square sees none of the targets
VELOCITY = np.array([0.6, -0.3])
NONE = np.zeros((0, 2))


def _estimate(position, velocity=(0.0, 0.0)):
    return TargetEstimate(np.asarray(position, float), np.asarray(velocity, float),
                          np.eye(4), 1.0)


def _walk(step, start=(20.0, 40.0)):
    return np.asarray(start) + step * VELOCITY


def _follow(coasting, steps, pose_of=lambda k: _walk(k), noise=0.0, seed=0):
    """Feed one estimate a step of the walk (seen from a square centred on it)."""
    rng = np.random.default_rng(seed)
    result = None
    for k in range(1, steps + 1):
        seen = _walk(k) + noise * rng.standard_normal(2)
        result = coasting.update(k, pose_of(k), [_estimate(seen, VELOCITY)], NONE, NONE)
    return result


def _follow_step(coasting, k, noise, rng):
    """Feed the estimate of step k (noise m off the walk); return the fresh count."""
    seen = _walk(k) + noise * rng.standard_normal(2)
    return coasting.update(k, _walk(k), [_estimate(seen, VELOCITY)], NONE, NONE).fresh


def test_the_fit_is_least_squares_and_its_spread_shrinks_with_the_estimates():
    steps = list(range(1, 11))
    track = Track(steps, [_walk(k) for k in steps], np.zeros(2))
    np.testing.assert_allclose(track.predict(40), _walk(40))
    # With noise the fit equals numpy's least-squares line.
    rng = np.random.default_rng(3)
    noisy = [_walk(k) + rng.normal(0.0, 1.0, 2) for k in steps]
    track = Track(steps, noisy, np.zeros(2))
    expected = [np.polyval(np.polyfit(steps, np.array(noisy)[:, i], 1), 40) for i in range(2)]
    np.testing.assert_allclose(track.predict(40), expected)
    # One estimate: its filter velocity carries it.
    single = Track([5], [_walk(5)], VELOCITY.copy())
    np.testing.assert_allclose(single.predict(9), _walk(9))


def test_coast_steps_follow_p_s():
    # 0.99^68 = 0.505 >= 1/2 > 0.99^69.
    assert coast_steps(PARAMS) == 68
    assert coast_steps(PARAMS.with_overrides({'phd.coast_survival': 0.9})) == 10
    assert coast_steps(PARAMS.with_overrides({'motion.p_survival': 1.0})) > 10 ** 9


def test_a_target_out_of_view_is_reported_on_its_walk_until_p_s_says_it_may_be_gone():
    coasting = TrackCoasting(PARAMS)
    step = _follow(coasting, 20, noise=0.5)
    assert step.coasted.shape == (0, 2) and step.fresh == 0      # 20 estimates: followed
    horizon = coast_steps(PARAMS)
    for k in range(21, 21 + horizon):
        step = coasting.update(k, FAR, [], NONE, NONE)
        assert len(step.coasted) == 1, k
        # 20 estimates erring 0.5 m pin the walk: within 2 m even 68 steps on.
        assert np.hypot(*(step.coasted[0] - _walk(k))) < 2.0, k
        np.testing.assert_allclose(step.expected, [coasting.tracks[0].predict(k + 1)])
    track = coasting.tracks[0]
    assert len(coasting.update(21 + horizon, FAR, [], NONE, NONE).coasted) == 0
    assert coasting.tracks == [] and coasting.drops == [(track, 'report expired')]


def test_a_track_needs_a_few_estimates_and_fresh_counts_the_short_ones():
    coasting = TrackCoasting(PARAMS)
    assert _follow(coasting, 2).fresh == 1
    # Two estimates are below phd.coast_min_estimates (3): nothing coasted, track dropped.
    track = coasting.tracks[0]
    assert len(coasting.update(3, FAR, [], NONE, NONE).coasted) == 0
    assert coasting.drops == [(track, 'short track')]
    coasting = TrackCoasting(PARAMS)
    assert _follow(coasting, PARAMS.cooperation.follow_steps - 1).fresh == 1
    assert _follow(TrackCoasting(PARAMS), PARAMS.cooperation.follow_steps).fresh == 0


def test_the_velocity_error_is_the_fits_standard_error():
    steps = list(range(1, 13))
    rng = np.random.default_rng(4)
    noisy = np.array([_walk(k) + rng.normal(0.0, 1.0, 2) for k in steps])
    # Per axis, scipy's standard error of the slope; the track pools both axes' residuals.
    per_axis = [stats.linregress(steps, noisy[:, i]).stderr for i in range(2)]
    track = Track(steps, list(noisy), np.zeros(2))
    assert track.velocity_error() == pytest.approx(np.sqrt(np.mean(np.square(per_axis))))
    assert Track(steps, [_walk(k) for k in steps], np.zeros(2)).velocity_error() < 1e-12
    assert Track([1, 2], [_walk(1), _walk(2)], np.zeros(2)).velocity_error() == np.inf


def test_a_noisy_track_is_followed_until_its_velocity_is_known():
    limit = PARAMS.cooperation.follow_velocity_error
    enough = PARAMS.cooperation.follow_steps
    coasting, rng, last = TrackCoasting(PARAMS), np.random.default_rng(7), 50
    assert PARAMS.phd.coast_history >= last      # the track keeps every estimate fed here
    fresh = [_follow_step(coasting, k, 1.0, rng) for k in range(1, last + 1)]
    errors = [Track(list(range(1, k + 1)), coasting.tracks[0].positions[:k], np.zeros(2))
              .velocity_error() for k in range(1, last + 1)]
    released = [k for k in range(1, last + 1) if not fresh[k - 1]]
    # Estimates erring 1 m: the count alone would release at follow_steps, the error holds on.
    assert errors[enough - 1] > limit and released
    assert released[0] == min(k for k in range(enough, last + 1) if errors[k - 1] <= limit)
    # Exact estimates release at the count; a limit of 0 is the count alone.
    assert not _follow(TrackCoasting(PARAMS), enough).fresh
    counted = TrackCoasting(PARAMS.with_overrides({'cooperation.follow_velocity_error': 0.0}))
    assert not _follow(counted, enough, noise=1.0).fresh


def test_looking_there_and_not_seeing_it_or_a_neighbour_seeing_it_ends_the_report():
    coasting = TrackCoasting(PARAMS)
    _follow(coasting, 20)
    misses = PARAMS.phd.coast_misses
    for k in range(21, 22 + misses):
        # The agent's square over the walk, and no estimate: a miss each scan.
        reported = coasting.update(k, _walk(k), [], NONE, NONE).coasted
        assert len(reported) == (1 if k - 20 <= misses else 0), k
    assert [reason for _, reason in coasting.drops] == ['looked, not found']
    # A neighbour's square counts as looking there.
    coasting = TrackCoasting(PARAMS)
    _follow(coasting, 20)
    for k in range(21, 22 + misses):
        reported = coasting.update(k, FAR, [], _walk(k)[None] + 2.0, NONE).coasted
        assert len(reported) == (1 if k - 20 <= misses else 0), k
    coasting = TrackCoasting(PARAMS)
    _follow(coasting, 20)
    neighbour = _walk(21)[None] + 1.0
    assert len(coasting.update(21, FAR, [], NONE, neighbour).coasted) == 0
    assert [reason for _, reason in coasting.drops] == ['a neighbour reports it']
    # A walk that leaves the area is not reported beyond it.
    coasting = TrackCoasting(PARAMS)
    _follow(coasting, 20)
    steps_out = int(np.ceil(_walk(20)[1] / -VELOCITY[1])) + 1
    assert len(coasting.update(20 + steps_out, FAR, [], NONE, NONE).coasted) == 0
    assert [reason for _, reason in coasting.drops] == ['fit left A']
    # The next update drops nothing more: drops names the last update's only.
    coasting.update(21 + steps_out, FAR, [], NONE, NONE)
    assert coasting.drops == [] and coasting.tracks == []


def test_an_estimate_continues_the_nearest_track_one_to_one():
    coasting = TrackCoasting(PARAMS)
    short = PARAMS.cooperation.follow_steps - 3      # both tracks stay short: both fresh
    _follow(coasting, short)
    other = np.array([70.0, 20.0])
    step = coasting.update(short + 1, _walk(short + 1),
                           [_estimate(other), _estimate(_walk(short + 1) + 0.5)], NONE, NONE)
    assert len(coasting.tracks) == 2 and step.fresh == 2
    lengths = sorted(track.length for track in coasting.tracks)
    assert lengths == [1, short + 1]


def test_the_papers_agent_coasts_nothing():
    step = NoCoasting().update(4, FAR, [_estimate(FAR)], NONE, NONE)
    assert step.fresh == 1 and step.coasted.shape == (0, 2) and step.expected.shape == (0, 2)
    assert isinstance(Agent(1, load_params_file('config/paper.yaml'), FAR).coasting,
                      NoCoasting)
    assert isinstance(Agent(1, PARAMS, FAR).coasting, TrackCoasting)


@pytest.mark.parametrize('coast', [False, True])
def test_a_followed_target_releases_the_tracker_to_search(coast):
    """A lone target walks slowly under an agent held still.

    With coasting the agent returns to SEARCH once it has follow_steps estimates, still
    estimating the target; without, it tracks on.
    """
    params = PARAMS.with_overrides({'additions.track_coasting': coast,
                                    'sensor.clutter_rate': 0.0})
    start = np.array([50.0, 50.0])
    agent = Agent(1, params, start, seed=5)
    rng = np.random.default_rng(0)
    modes, reported = [], []
    for k in range(1, 41):
        truth = start + np.array([2.0, 1.0]) + (k - 1) * np.array([0.1, 0.0])
        measurement = measure(truth[None], start) + [0.1 * rng.standard_normal(), 0.0]
        output = agent.step(k, start, measurement, [])
        modes.append(output.mode)
        reported.append(len(output.reported_positions()))
    follow = params.cooperation.follow_steps
    assert Mode.TRACK in modes
    if coast:
        first_track = modes.index(Mode.TRACK)
        assert Mode.SEARCH in modes[first_track:first_track + follow + 3]
        assert min(reported[first_track + 2:]) >= 1      # the target stays reported
    else:
        assert modes[-1] == Mode.TRACK


@pytest.mark.parametrize('boundary', ['drop', 'reflect'])
def test_a_fit_that_leaves_the_area_ends_or_folds_back_as_phd_coast_boundary_says(boundary):
    coasting = TrackCoasting(PARAMS.with_overrides({'phd.coast_boundary': boundary}))
    start = (20.0, 10.0)          # y = 10 - 0.3 k leaves the area after k = 33
    for k in range(1, 21):
        coasting.update(k, _walk(k, start), [_estimate(_walk(k, start), VELOCITY)], NONE, NONE)
    for k in range(21, 34):
        step = coasting.update(k, FAR, [], NONE, NONE)
        np.testing.assert_allclose(step.coasted, [_walk(k, start)])
    step = coasting.update(40, FAR, [], NONE, NONE)
    if boundary == 'drop':
        assert step.coasted.shape == (0, 2) and coasting.tracks == []
    else:
        # Mirrored at y = 0 as the world's reflect does: 10 - 12 = -2 becomes 2.
        np.testing.assert_allclose(step.coasted, [(44.0, 2.0)])
        np.testing.assert_allclose(step.expected, [(44.6, 2.3)])
        np.testing.assert_allclose(coasting.tracks[0].predict(40), (44.0, 2.0))


def _along_the_border(coasting, steps=20, seed=4):
    """Feed a noisy walk 1 m inside y = 0 that drifts out at 2 cm a step; return its track."""
    rng = np.random.default_rng(seed)
    velocity = np.array([0.6, -0.02])
    for k in range(1, steps + 1):
        seen = np.array([20.0, 1.0]) + k * velocity + 0.3 * rng.standard_normal(2)
        coasting.update(k, seen, [_estimate(seen, velocity)], NONE, NONE)
    return coasting.tracks[0]


def test_clamp_reports_a_fit_just_outside_the_area_at_the_border_and_ends_it_farther_out():
    params = PARAMS.with_overrides({'phd.coast_boundary': 'clamp'})
    track = _along_the_border(TrackCoasting(params))
    assert track.bounds is None                    # 'clamp' does not fold the walk
    steps = np.arange(21, 130)                     # x = 20 + 0.6 k stays inside the area
    below = np.array([-track.predict(k)[1] for k in steps])          # how far out of y = 0
    spread = np.array([track.drift_spread(k) for k in steps])
    just_out = steps[(below > 0) & (below <= spread)]
    far_out = steps[below > spread]
    assert len(just_out) and len(far_out)
    for k in (just_out[0], just_out[-1]):
        np.testing.assert_allclose(coast_point(track, k, params), (track.predict(k)[0], 0.0))
        assert coast_point(track, k, PARAMS) is None                   # 'drop'
    assert coast_point(track, far_out[0], params) is None
    inside = steps[below <= 0][0]
    np.testing.assert_allclose(coast_point(track, inside, params), track.predict(inside))
    # Through the coasting: reported at the border while just out, with 'drop' not at all.
    for boundary, reported in (('clamp', [(track.predict(just_out[0])[0], 0.0)]), ('drop', NONE)):
        coasting = TrackCoasting(PARAMS.with_overrides({'phd.coast_boundary': boundary}))
        _along_the_border(coasting)
        step = coasting.update(int(just_out[0]), FAR, [], NONE, NONE)
        np.testing.assert_allclose(step.coasted.reshape(-1, 2), np.reshape(reported, (-1, 2)))


@pytest.mark.parametrize('boundary', ['reflect', 'bounce'])
def test_a_followed_target_that_bounces_keeps_one_straight_fit_only_with_bounce(boundary):
    coasting = TrackCoasting(PARAMS.with_overrides({'phd.coast_boundary': boundary}))
    start, area = (20.0, 10.0), np.array([100.0, 100.0])

    def seen(k):          # the world's target: y = 10 - 0.3 k bounces off y = 0 at k = 33.3
        return fold(_walk(k, start), area)[0]

    for k in range(1, 51):
        coasting.update(k, seen(k), [_estimate(seen(k), VELOCITY)], NONE, NONE)
    if boundary == 'bounce':
        assert len(coasting.tracks) == 1 and coasting.tracks[0].length == 50
        # Stored on the unfolded walk: the last estimate is y = 10 - 15 = -5, not 5.
        np.testing.assert_allclose(coasting.tracks[0].positions[-1], _walk(50, start))
        # Coasted 20 steps on, the fit of the unbroken line lands on the target.
        np.testing.assert_allclose(coasting.update(70, FAR, [], NONE, NONE).coasted, [seen(70)])
    else:
        # The estimates after the bounce bend the fitted line until one falls outside the
        # gate: the target starts a new track, its history (and follow count) lost.
        assert len(coasting.tracks) == 1 and coasting.tracks[0].length < 10


def test_an_estimate_is_unfolded_to_the_mirror_image_nearest_the_fit():
    track = Track([1, 2, 3], [np.array([50.0, 3.0]), np.array([50.0, 2.0]),
                              np.array([50.0, 1.0])], np.zeros(2), bounds=(100.0, 100.0),
                  unfolds=True)
    # The line is at y = -1 at step 5 (folded: 1); an estimate at y = 1.4 lies 0.4 m past the
    # folded point along the bounced walk, so 0.4 m past the line's -1 on the unfolded one.
    track.add(5, np.array([50.2, 1.4]), np.zeros(2), history=50)
    np.testing.assert_allclose(track.positions[-1], (50.2, -1.4))
    # Mirrored at x = 100 and y = 0 at once (two axes, one crossing each).
    corner = Track([0, 1], [np.array([98.0, 2.0]), np.array([99.0, 1.0])], np.zeros(2),
                   bounds=(100.0, 100.0), unfolds=True)
    corner.add(3, np.array([98.5, 1.5]), np.zeros(2), history=50)
    np.testing.assert_allclose(corner.positions[-1], (101.5, -1.5))
