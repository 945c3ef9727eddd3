"""Baseline search policies for the evaluation: lawnmower and random walk (no search density).

They replace only how a searching agent moves (``search.policy``); the SAT-PHD filter, state
extraction, mode machine and tracking control are the same as for the paper's policy, so a
comparison measures the search strategy alone.

- Lawnmower (boustrophedon): the search-map nodes row by row, bottom to top, alternating the
  direction of travel in each row. Each agent starts at the node of that order nearest to its
  start and sweeps on; at either end of the order it turns and sweeps back (ping-pong), so
  it never idles. A node counts as visited once its centre is in the sensing square (as for
  the closed walks). The agents do not coordinate: each sweeps the whole area, the classic
  baseline without a search density.
- Random walk: at every step a uniformly drawn admissible action (Eqn. controlVectors, inside
  the area), from a generator seeded with (seed, agent id) apart from the filter's.

Both expose ``choose(pose) -> SearchMove``.
"""

from typing import NamedTuple

import numpy as np

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.config import SatParams
from sat_agent.search_map import SearchMap
from sat_agent.search_planning import search_action
from sat_agent.sensor_model import in_sensing_square

# Last spawn_key element of the random walk's generator, keyed (agent_id, this): apart from the
# world's streams ((0,), (1,), ...) and the filter's ((agent_core.FILTER_STREAM, agent_id)).
RANDOM_WALK_STREAM = 1


class SearchMove(NamedTuple):
    """One step of a baseline: the action, the point it steers to and the path ahead (K, 2)."""

    action: int
    goal: np.ndarray
    plan: np.ndarray


def boustrophedon_order(centers: np.ndarray) -> np.ndarray:
    """Order the nodes row by row (ascending y), x ascending in even rows, descending in odd.

    Rows are the distinct y of the centres (rounded to 1e-9 m, so a regular grid has exact rows).
    """
    centers = np.asarray(centers, dtype=float).reshape(-1, 2)
    rows = np.round(centers[:, 1], 9)
    order = []
    for number, y in enumerate(np.unique(rows)):
        members = np.flatnonzero(rows == y)
        members = members[np.argsort(centers[members, 0], kind='stable')]
        order.extend(members[::-1] if number % 2 else members)
    return np.asarray(order, dtype=np.int64)


class LawnmowerPolicy:
    """Boustrophedon sweeps over the search map (module docstring)."""

    def __init__(self, search_map: SearchMap, params: SatParams, start):
        self._centers = search_map.centers
        self._params = params
        self._order = boustrophedon_order(self._centers)
        gaps = np.hypot(*(self._centers[self._order] - np.asarray(start, dtype=float)).T)
        self._index = int(np.argmin(gaps))
        self._direction = 1

    def choose(self, pose) -> SearchMove:
        """Skip the nodes already in view, then steer to the next node of the sweep."""
        pose = np.asarray(pose, dtype=float)
        side = self._params.sensor.square_side
        # At most one full pass: a sensing square holds a few nodes, never all of them.
        for _ in range(2 * len(self._order)):
            if not in_sensing_square(self._centers[[self._order[self._index]]], pose, side)[0]:
                break
            self._advance()
        goal = self._centers[self._order[self._index]].copy()
        ahead = self._order[self._index::self._direction]
        return SearchMove(search_action(pose, goal, self._params), goal,
                          self._centers[ahead].copy())

    def _advance(self):
        last = len(self._order) - 1
        if not 0 <= self._index + self._direction <= last:
            self._direction = -self._direction
        self._index += self._direction


class RandomWalkPolicy:
    """Uniformly random admissible actions (module docstring)."""

    def __init__(self, params: SatParams, agent_id: int, seed: int):
        self._params = params
        self._rng = np.random.default_rng(np.random.SeedSequence(
            int(seed), spawn_key=(int(agent_id), RANDOM_WALK_STREAM)))

    def choose(self, pose) -> SearchMove:
        """Draw one admissible action."""
        pose = np.asarray(pose, dtype=float)
        allowed = np.flatnonzero(admissible_mask(pose, self._params.actions, self._params.area))
        action = int(self._rng.choice(allowed))
        goal = candidate_poses(pose, self._params.actions)[action]
        return SearchMove(action, goal, np.zeros((0, 2)))


def baseline_policy(params: SatParams, search_map: SearchMap, agent_id: int, start, seed: int):
    """Return the baseline of ``search.policy``, or None for the paper's policy ('sat')."""
    policy = params.search.policy
    if policy == 'lawnmower':
        return LawnmowerPolicy(search_map, params, start)
    if policy == 'random_walk':
        return RandomWalkPolicy(params, agent_id, seed)
    return None
