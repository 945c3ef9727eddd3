"""Investigation (beyond_paper/investigation.py): what a searching agent looks at, step by step."""

import numpy as np

from sat_agent.beyond_paper.investigation import Investigation, NO_LOOK
from sat_agent.config import SatParams
from sat_agent.mode_machine import Mode
from sat_agent.phd_filter import BirthSpots
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate

NOTHING = MultiTargetEstimate((), 0.0)


def peak(position, velocity=(0.0, 0.0), weight=0.5) -> TargetEstimate:
    return TargetEstimate(np.array(position, dtype=float), np.array(velocity, dtype=float),
                          np.eye(4), weight)


def spots(position, mass) -> BirthSpots:
    return BirthSpots(np.array([[3.0, 0.0]]), np.array([position], dtype=float),
                      np.array([mass]))


def tentative(estimate: TargetEstimate) -> MultiTargetEstimate:
    """Return an estimate with no confirmed target and this one tentative peak."""
    return MultiTargetEstimate((), 0.0, (estimate,), (0,))


def test_a_tentative_peak_is_followed_with_the_tracking_control_until_the_budget_is_spent():
    params = SatParams()
    budget = params.search.investigate_steps
    look = Investigation(params)
    seen = tentative(peak((50.0, 50.0)))
    for step in range(budget):
        followed = look.look(Mode.SEARCH, seen, 0, BirthSpots.empty())
        assert followed.keep is None, step
        np.testing.assert_allclose(followed.peaks.positions(), [[50.0, 50.0]])
    # Budget spent: the spot is abandoned and the walk resumes; a tentative peak there is
    # ignored for 2 * budget steps, one elsewhere is looked at.
    assert look.look(Mode.SEARCH, seen, 0, BirthSpots.empty()) is NO_LOOK
    assert look.look(Mode.SEARCH, seen, 0, BirthSpots.empty()) is NO_LOOK
    elsewhere = tentative(peak((80.0, 20.0)))
    np.testing.assert_allclose(
        look.look(Mode.SEARCH, elsewhere, 0, BirthSpots.empty()).peaks.positions(), [[80.0, 20.0]])


def test_with_peak_look_keep_a_tentative_peak_is_kept_in_view_by_the_search_move():
    params = SatParams().with_overrides({'search.peak_look': 'keep'})
    budget = params.search.investigate_steps
    look = Investigation(params)
    seen = tentative(peak((50.0, 50.0), velocity=(1.0, 0.0)))
    for step in range(budget):
        kept = look.look(Mode.SEARCH, seen, 0, BirthSpots.empty())
        assert kept.peaks is None, step
        np.testing.assert_allclose(kept.keep, [[51.0, 50.0]])
    # The same budget as with the tracking control: then the spot is abandoned.
    assert look.look(Mode.SEARCH, seen, 0, BirthSpots.empty()) is NO_LOOK


def test_a_peak_that_fades_for_a_scan_is_kept_in_view_one_step_by_the_search_move():
    params = SatParams()
    look = Investigation(params)
    walking = peak((50.0, 50.0), velocity=(1.0, 0.5))
    first = look.look(Mode.SEARCH, tentative(walking), 0, BirthSpots.empty())
    assert first.keep is None
    np.testing.assert_allclose(first.peaks.positions(), [[51.0, 50.5]])
    # Gone from the next scan (a miss, a near pass): kept in the next square where its walk
    # takes it, by the search move, as a newborn spot is (not with the tracking control).
    faded = look.look(Mode.SEARCH, NOTHING, 0, spots((20.0, 20.0), 0.4))
    assert faded.peaks is None
    np.testing.assert_allclose(faded.keep, [[52.0, 51.0]])
    # Gone again: the heaviest newborn spot of this scan gets its look, then the walk resumes.
    newborn = look.look(Mode.SEARCH, NOTHING, 0, spots((20.0, 20.0), 0.4))
    assert newborn.peaks is None
    np.testing.assert_allclose(newborn.keep, [[20.0, 20.0]])
    assert look.look(Mode.SEARCH, NOTHING, 0, BirthSpots.empty()) is NO_LOOK
    # Back after one scan: followed with the tracking control again.
    again = Investigation(params)
    again.look(Mode.SEARCH, tentative(walking), 0, BirthSpots.empty())
    again.look(Mode.SEARCH, NOTHING, 0, BirthSpots.empty())
    back = again.look(Mode.SEARCH, tentative(peak((52.0, 51.0))), 0, BirthSpots.empty())
    assert back.keep is None
    np.testing.assert_allclose(back.peaks.positions(), [[52.0, 51.0]])


def test_a_newborn_spot_gets_one_step_and_a_light_one_none():
    params = SatParams()
    look = Investigation(params)
    heavy = look.look(Mode.SEARCH, NOTHING, 0, spots((30.0, 40.0), 0.4))
    assert heavy.peaks is None
    np.testing.assert_allclose(heavy.keep, [[30.0, 40.0]])
    # Nothing at the spot at the next scan: the walk resumes at once.
    resumed = look.look(Mode.SEARCH, NOTHING, 0, BirthSpots.empty())
    assert resumed.peaks is None and resumed.keep is None
    light = Investigation(params).look(
        Mode.SEARCH, NOTHING, 0, spots((30.0, 40.0), params.phd.tentative_threshold / 2))
    assert light.peaks is None and light.keep is None


def test_several_newborn_spots_heaviest_first_and_a_lower_mass_bar():
    params = SatParams().with_overrides({'search.look_spots': 3})
    threshold = params.phd.tentative_threshold
    seen = BirthSpots(np.zeros((4, 2)), np.array([[10.0, 10.0], [20.0, 20.0], [30.0, 30.0],
                                                  [40.0, 40.0]]),
                      np.array([threshold, threshold + 0.2, threshold * 0.6, threshold + 0.1]))
    # The three heaviest of at least the threshold, in order of mass; one by default.
    np.testing.assert_allclose(Investigation(params).look(Mode.SEARCH, NOTHING, 0, seen).keep,
                               [[20.0, 20.0], [40.0, 40.0], [10.0, 10.0]])
    np.testing.assert_allclose(Investigation(SatParams()).look(Mode.SEARCH, NOTHING, 0, seen).keep,
                               [[20.0, 20.0]])
    # At half the threshold the light spot is looked at too, after the heavier ones.
    lower = params.with_overrides({'search.look_spots': 4, 'search.look_spot_share': 0.5})
    np.testing.assert_allclose(Investigation(lower).look(Mode.SEARCH, NOTHING, 0, seen).keep,
                               [[20.0, 20.0], [40.0, 40.0], [10.0, 10.0], [30.0, 30.0]])


def test_nothing_is_looked_at_while_tracking_or_in_the_rejoin_cooldown():
    params = SatParams()
    seen = tentative(peak((50.0, 50.0)))
    for mode, cooldown in ((Mode.TRACK, 0), (Mode.SEARCH, 3)):
        result = Investigation(params).look(mode, seen, cooldown, spots((50.0, 50.0), 0.4))
        assert result.peaks is None and result.keep is None


def test_with_spot_move_full_only_newborn_spots_are_kept_at_full_speed():
    params = SatParams().with_overrides({'search.spot_move': 'full'})
    assert not Investigation(SatParams()).look(
        Mode.SEARCH, NOTHING, 0, spots((30.0, 40.0), 0.4)).full_speed
    assert Investigation(params).look(Mode.SEARCH, NOTHING, 0, spots((30.0, 40.0), 0.4)).full_speed
    # A peak that fades for a scan is likelier a target: any move may keep it.
    look = Investigation(params)
    look.look(Mode.SEARCH, tentative(peak((50.0, 50.0))), 0, BirthSpots.empty())
    faded = look.look(Mode.SEARCH, NOTHING, 0, spots((20.0, 20.0), 0.4))
    np.testing.assert_allclose(faded.keep, [[50.0, 50.0]])
    assert not faded.full_speed
    # With peak_look 'keep' a tentative peak is kept by any move too.
    peaks = params.with_overrides({'search.peak_look': 'keep'})
    assert not Investigation(peaks).look(Mode.SEARCH, tentative(peak((50.0, 50.0))), 0,
                                         BirthSpots.empty()).full_speed
