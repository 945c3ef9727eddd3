"""Baseline: random walk search.

It replaces only how a searching agent moves (``search.policy: random_walk``,
``steers_tracking`` False), like the lawnmower: at every step a uniformly drawn admissible action
(Eqn. controlVectors, inside the area), from a generator seeded with (seed, agent id,
RANDOM_WALK_STREAM) apart from the filter's and the world's.
"""

import numpy as np

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.baselines.interface import (
    baseline_rng, BaselineView, RANDOM_WALK_STREAM, SearchMove)
from sat_agent.config import SatParams


class RandomWalkPolicy:
    """Uniformly random admissible actions (module docstring)."""

    steers_tracking = False

    def __init__(self, params: SatParams, agent_id: int, seed: int):
        self._params = params
        self._rng = baseline_rng(seed, agent_id, RANDOM_WALK_STREAM)

    def choose(self, pose, view: BaselineView) -> SearchMove:
        """Draw one admissible action."""
        pose = np.asarray(pose, dtype=float)
        allowed = np.flatnonzero(admissible_mask(pose, self._params.actions, self._params.area))
        action = int(self._rng.choice(allowed))
        goal = candidate_poses(pose, self._params.actions)[action]
        return SearchMove(action, goal, np.zeros((0, 2)))
