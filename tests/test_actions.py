"""The control set of Eqn. controlVectors (sat_agent/actions.py), built once per parameter set."""

import numpy as np
import pytest

from sat_agent.actions import action_displacements, candidate_poses
from sat_agent.config import ActionParams


@pytest.mark.parametrize('n_angular', [8, 16])
def test_the_set_is_stay_then_ring_by_ring_angle_by_angle(n_angular):
    params = ActionParams(radial_step=2.0, n_radial=2, n_angular=n_angular)
    moves = action_displacements(params)
    assert moves.shape == (1 + 2 * n_angular, 2)
    np.testing.assert_array_equal(moves[0], [0.0, 0.0])
    for l1 in (1, 2):
        for l2 in range(n_angular):
            angle = l2 * 2.0 * np.pi / n_angular
            np.testing.assert_allclose(moves[1 + (l1 - 1) * n_angular + l2],
                                       [2.0 * l1 * np.cos(angle), 2.0 * l1 * np.sin(angle)],
                                       atol=1e-12)


def test_one_read_only_set_serves_every_caller_and_poses_are_the_callers_own():
    params = ActionParams(radial_step=2.0, n_radial=2, n_angular=8)
    first = action_displacements(params)
    assert action_displacements(ActionParams(radial_step=2.0, n_radial=2, n_angular=8)) is first
    with pytest.raises(ValueError):
        first[1, 0] = 99.0
    poses = candidate_poses((10.0, 20.0), params)
    poses[:] = 0.0
    np.testing.assert_allclose(candidate_poses((10.0, 20.0), params), first + (10.0, 20.0))
    other = action_displacements(ActionParams(radial_step=1.0, n_radial=2, n_angular=8))
    np.testing.assert_allclose(other, first / 2.0)
