"""Baseline: lawnmower (boustrophedon) search, without a search density.

It replaces only how a searching agent moves (``search.policy: lawnmower``,
``steers_tracking`` False); the SAT-PHD filter, state extraction, mode machine and tracking
control are the same as for the paper's policy, so a comparison measures the search strategy
alone.

The search-map nodes row by row, bottom to top, alternating the direction of travel in each row.
Each agent starts at the node of that order nearest to its start and sweeps on; at either end of
the order it turns and sweeps back (ping-pong), so it never idles. A node counts as visited once
its centre is in the sensing square (as for the closed walks). The agents do not coordinate:
each sweeps the whole area, the classic baseline without a search density.
"""

import numpy as np

from sat_agent.baselines.interface import BaselineView, SearchMove
from sat_agent.config import SatParams
from sat_agent.search_map import SearchMap
from sat_agent.search_planning import search_action
from sat_agent.sensor_model import in_sensing_square


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

    steers_tracking = False

    def __init__(self, search_map: SearchMap, params: SatParams, start):
        self._centers = search_map.centers
        self._params = params
        self._order = boustrophedon_order(self._centers)
        gaps = np.hypot(*(self._centers[self._order] - np.asarray(start, dtype=float)).T)
        self._index = int(np.argmin(gaps))
        self._direction = 1

    def choose(self, pose, view: BaselineView) -> SearchMove:
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
