"""Track release (beyond_paper/track_release.py): what a neighbour tracks better is let go."""

import numpy as np

from sat_agent.agent_core import Agent, AgentReport, KeepAll
from sat_agent.beyond_paper.track_release import TrackRelease
from sat_agent.config import load_params_file
from sat_agent.mode_machine import Mode
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate

PARAMS = load_params_file('config/persistent.yaml')
SHARED = np.array([50.0, 50.0])
OWN_ONLY = np.array([44.0, 52.0])


def _target(position, spread, velocity=(0.0, 0.0)):
    covariance = np.diag([spread, 0.1, spread, 0.1])
    return TargetEstimate(np.asarray(position, float), np.asarray(velocity, float), covariance,
                          1.0)


def _report(agent_id, targets, mode=Mode.TRACK):
    return AgentReport(agent_id, 9, np.array([48.0, 50.0]), mode, np.zeros((100, 100)),
                       MultiTargetEstimate(tuple(targets), float(len(targets))))


def test_the_agent_with_the_looser_estimate_releases_a_shared_target_and_only_one_does():
    one = _report(1, [_target(OWN_ONLY, 0.5), _target(SHARED, 0.9)])      # tracks both
    two = _report(2, [_target(SHARED + 0.4, 0.3)])                          # tighter on SHARED
    release = TrackRelease(PARAMS)
    released = release.released(one, [two])
    assert len(released) == 1 and np.allclose(released[0].position, SHARED)
    assert release.released(two, [one]) == []
    # The control of agent 1 serves OWN_ONLY alone; its estimate is not touched.
    ahead = MultiTargetEstimate((_target(OWN_ONLY, 0.5), _target(SHARED, 0.9)), 2.0)
    kept = release.keep(ahead, one, [two])
    np.testing.assert_allclose(kept.positions(), [OWN_ONLY])
    assert len(ahead.targets) == 2


def test_equal_estimates_go_to_the_lower_id_and_searching_or_far_neighbours_are_ignored():
    release = TrackRelease(PARAMS)
    one = _report(1, [_target(OWN_ONLY, 0.5), _target(SHARED, 0.5)])
    two = _report(2, [_target(OWN_ONLY + 20.0, 0.5), _target(SHARED, 0.5)])
    assert release.released(one, [two]) == []
    assert len(release.released(two, [one])) == 1
    searching = _report(2, [_target(SHARED, 0.1)], Mode.SEARCH)
    far = _report(2, [_target(SHARED + 10.0, 0.1)])
    assert release.released(one, [searching]) == release.released(one, [far]) == []


def test_a_lone_shared_target_is_kept_the_overlap_test_decides_there():
    release = TrackRelease(PARAMS)
    one = _report(1, [_target(SHARED, 0.9)])
    two = _report(2, [_target(SHARED, 0.3)])
    ahead = MultiTargetEstimate((_target(SHARED, 0.9),), 1.0)
    assert release.keep(ahead, one, [two]) is ahead


def test_the_switch_chooses_release_or_the_papers_keep_all():
    one = _report(1, [_target(OWN_ONLY, 0.5), _target(SHARED, 0.9)])
    two = _report(2, [_target(SHARED, 0.3)])
    ahead = MultiTargetEstimate((_target(OWN_ONLY, 0.5), _target(SHARED, 0.9)), 2.0)
    on = Agent(1, PARAMS, (48.0, 50.0)).release
    off = Agent(1, PARAMS.with_overrides({'additions.track_release': False}), (48.0, 50.0))
    assert len(on.keep(ahead, one, [two]).targets) == 1
    assert isinstance(off.release, KeepAll) and off.release.keep(ahead, one, [two]) is ahead
