import pytest

from sat_agent.config import ParameterError, SatParams
from sat_agent.mode_machine import Mode, ModeMachine

PARAMS = SatParams()     # track_timeout 5, overlap_window 5


def tracking_machine(params=PARAMS):
    machine = ModeMachine(params)
    assert machine.update(1, False) == Mode.TRACK
    return machine


def test_mode_values_are_the_message_constants():
    assert (int(Mode.SEARCH), int(Mode.TRACK)) == (0, 1)


def test_search_until_a_target_is_estimated():
    machine = ModeMachine(PARAMS)
    assert machine.mode == Mode.SEARCH and not machine.switched
    assert machine.update(0, False) == Mode.SEARCH and not machine.switched
    assert machine.update(2, False) == Mode.TRACK and machine.switched
    assert machine.update(2, False) == Mode.TRACK and not machine.switched


def test_track_falls_back_to_search_after_the_timeout_without_targets():
    machine = tracking_machine()
    for _ in range(PARAMS.cooperation.track_timeout - 1):
        assert machine.update(0, False) == Mode.TRACK
    assert machine.update(0, False) == Mode.SEARCH and machine.switched
    # No cooldown after a timeout: a new target is tracked at once.
    assert machine.update(1, False) == Mode.TRACK


def test_a_target_seen_again_resets_the_timeout():
    machine = tracking_machine()
    for _ in range(PARAMS.cooperation.track_timeout - 1):
        machine.update(0, False)
    machine.update(1, False)
    for _ in range(PARAMS.cooperation.track_timeout - 1):
        assert machine.update(0, False) == Mode.TRACK
    assert machine.update(0, False) == Mode.SEARCH


def test_overlap_leaver_searches_at_once_and_ignores_targets_during_the_cooldown():
    machine = tracking_machine()
    assert machine.update(1, True) == Mode.SEARCH and machine.switched
    cooldown = PARAMS.cooperation.rejoin_cooldown
    assert machine.cooldown_left == cooldown == 10
    for _ in range(cooldown):
        assert machine.update(1, False) == Mode.SEARCH and not machine.switched
    assert machine.update(1, False) == Mode.TRACK and machine.switched


def test_rejoin_cooldown_switch_off_tracks_again_on_the_next_estimate():
    machine = tracking_machine(PARAMS.with_overrides({'additions.rejoin_cooldown': False}))
    assert machine.update(1, True) == Mode.SEARCH and machine.cooldown_left == 0
    assert machine.update(1, False) == Mode.TRACK and machine.switched


def test_cooldown_can_be_set_and_leave_is_ignored_in_search():
    machine = tracking_machine(PARAMS.with_overrides({'cooperation.rejoin_cooldown': 2}))
    machine.update(1, True)
    assert [machine.update(1, False) for _ in range(3)] == [Mode.SEARCH] * 2 + [Mode.TRACK]
    searching = ModeMachine(PARAMS.with_overrides({'cooperation.rejoin_cooldown': 3}))
    assert searching.update(0, True) == Mode.SEARCH and searching.cooldown_left == 0


def test_refuses_bad_counts_and_cooldowns():
    with pytest.raises(ValueError):
        ModeMachine(PARAMS).update(-1, False)
    with pytest.raises(ValueError):
        ModeMachine(PARAMS).update(1.5, False)
    with pytest.raises(ParameterError, match='cooperation.rejoin_cooldown'):
        PARAMS.with_overrides({'cooperation.rejoin_cooldown': -2})


def test_a_track_on_probation_ends_on_its_first_step_without_targets():
    probation = PARAMS.with_overrides({'additions.track_probation': True})
    assert probation.cooperation.track_probation == 3
    # Estimated on 2 steps (< 3), then gone: SEARCH at once, not after the timeout.
    machine = tracking_machine(probation)
    assert machine.update(1, False) == Mode.TRACK
    assert machine.update(0, False) == Mode.SEARCH and machine.switched
    # Estimated on 3 steps: past probation, the timeout rides out a miss as before.
    machine = tracking_machine(probation)
    for _ in range(2):
        machine.update(1, False)
    for _ in range(PARAMS.cooperation.track_timeout - 1):
        assert machine.update(0, False) == Mode.TRACK
    assert machine.update(0, False) == Mode.SEARCH
    # A new episode starts its probation again; with the switch off it never cuts the timeout.
    assert machine.update(1, False) == Mode.TRACK
    assert machine.update(0, False) == Mode.SEARCH
    assert tracking_machine().update(0, False) == Mode.TRACK


def test_a_tracker_leaving_followed_targets_has_the_follow_cooldown():
    machine = tracking_machine(PARAMS.with_overrides({'cooperation.follow_cooldown': 10}))
    assert machine.update(1, False, followed=True) == Mode.SEARCH and machine.switched
    assert machine.cooldown_left == 10
    for _ in range(10):
        assert machine.update(1, False) == Mode.SEARCH
    assert machine.update(1, False) == Mode.TRACK
    # The default (session 32): no cooldown, so the leaver tracks the next target it estimates.
    none = tracking_machine()
    assert PARAMS.cooperation.follow_cooldown == 0
    assert none.update(1, False, followed=True) == Mode.SEARCH and none.cooldown_left == 0
    assert none.update(1, False) == Mode.TRACK
    # An overlap exit keeps its own cooldown whatever the follow cooldown is.
    assert none.update(1, True, followed=True) == Mode.SEARCH
    assert none.cooldown_left == PARAMS.cooperation.rejoin_cooldown
