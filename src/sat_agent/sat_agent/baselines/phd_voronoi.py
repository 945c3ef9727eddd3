"""Baseline: PHD-weighted Voronoi coverage (Lloyd's algorithm), after Dames (2020).

P. M. Dames, "Distributed multi-target search and tracking using the PHD filter", Autonomous
Robots 44, 673-689 (2020), doi 10.1007/s10514-019-09840-9. Dames pairs the PHD filter with
Voronoi-based coverage control: every robot moves toward the centroid of its Voronoi cell
weighted by the PHD (Lloyd's algorithm, phi(q) = PHD(q)), so PHD peaks (targets) attract the
robots, and the birth mass the PHD accrues where no robot has looked recently draws them to
explore. One control law does both search and tracking, so this baseline is the agent's whole
controller (``steers_tracking``): the mode machine still runs and the reports carry the mode,
but neither the walks, the Renyi tracking control nor the look at tentative peaks
(additions.investigation) move the agent.

Control at step k, on the PHD predicted to k+1:

1. sites: this agent's pose s_k and the poses of the neighbours whose k-1 reports the radio
   delivered (within C_R); agents out of range do not shape the cell (decentralised);
2. the agent's Voronoi cell: the points of the weighted PHD (team_phd.TeamPhd: its particles
   with the team's looks, plus the neighbours' estimated targets) nearer to s_k than to any
   other site (ties to s_k);
3. the weighted centroid c = sum w q / sum w over the cell; with no mass in the cell the agent
   stays (the centroid of a zero density is undefined);
4. the admissible action of Eqn. controlVectors whose pose is nearest to c
   (search_planning.search_action): one step of Lloyd's algorithm over the 17 actions.

Where ours is a reading of Dames' and not his algorithm:

- Controls: Dames' robots drive continuously toward the centroid; ours take the nearest of
  the 17 poses of Eqn. controlVectors, i.e. at most 2 Delta_R = 4 m a step along one of 8
  headings.
- Filter and sensor: the PHD is our SAT-PHD's (particles; our birth model: uniform births
  ``phd.birth_rate`` plus measurement-driven births) with our square range-bearing sensor and
  clutter, not his PHD implementation, sensor and birth PHD. The weight is that PHD; we add no
  exploration term beyond its own birth mass.
- Communication: his robots share one distributed PHD (each keeps the PHD of its Voronoi cell
  and exchanges it with its Voronoi neighbours). Ours exchange only the paper's reports
  (search density, estimate, mode, pose), read one step late: the cell uses the neighbours'
  k-1 poses, and their looks and targets enter through team_phd's reading.
- The Voronoi partition is computed on the PHD's points (Monte Carlo integration of the cell's
  mass and centroid), not as polygons; cells are clipped to the area because the points are in
  it.
"""

import numpy as np

from sat_agent.baselines.interface import BaselineView, SearchMove
from sat_agent.baselines.team_phd import TeamPhd
from sat_agent.config import SatParams
from sat_agent.search_planning import search_action


def voronoi_sites(pose, view: BaselineView) -> np.ndarray:
    """(1 + n, 2): this agent's pose first, then the poses of the neighbours' k-1 reports."""
    others = [np.asarray(report.pose, dtype=float) for report in view.reports]
    return np.vstack([np.asarray(pose, dtype=float).reshape(1, 2)] + others)


def own_cell(points: np.ndarray, sites: np.ndarray) -> np.ndarray:
    """Mask of the (N, 2) points in the Voronoi cell of sites[0] (ties go to sites[0])."""
    gaps = np.linalg.norm(np.asarray(points, float)[:, None, :] - sites[None, :, :], axis=2)
    return np.argmin(gaps, axis=1) == 0


def weighted_centroid(points: np.ndarray, weights: np.ndarray):
    """Return sum w q / sum w of (N, 2) points, or None when the weights sum to 0."""
    total = float(np.sum(weights))
    if not total > 0.0:
        return None
    return np.asarray(weights, dtype=float) @ np.asarray(points, dtype=float) / total


class PhdVoronoiPolicy:
    """Lloyd's algorithm on the PHD over the agent's Voronoi cell (module docstring)."""

    steers_tracking = True

    def __init__(self, params: SatParams):
        self._params = params
        self._phd = TeamPhd(params)

    def centroid(self, pose, view: BaselineView):
        """Return the PHD-weighted centroid of the agent's Voronoi cell, or None (no mass)."""
        points, weights = self._phd.points(pose, view)
        mine = own_cell(points, voronoi_sites(pose, view))
        return weighted_centroid(points[mine], weights[mine])

    def choose(self, pose, view: BaselineView) -> SearchMove:
        """Steer to the admissible pose nearest to the centroid (stay with no mass)."""
        pose = np.asarray(pose, dtype=float)
        goal = self.centroid(pose, view)
        goal = pose.copy() if goal is None else goal
        return SearchMove(search_action(pose, goal, self._params), goal, np.zeros((0, 2)))
