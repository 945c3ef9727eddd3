"""Baseline: Thompson-sampling PHD search and tracking, after DecSTER (Banerjee and Schneider).

A. Banerjee and J. Schneider, "Decentralized Multi-Agent Active Search and Tracking when Targets
Outnumber Agents", arXiv 2401.03154 (2024). DecSTER: every agent keeps an SMC-PHD posterior
and decides alone by Thompson sampling: it draws a multi-target state from its posterior,
takes the action that would be best were the draw the truth, and the randomness of the draws
spreads the team without a central controller. Their best variant, TS-PHD-II, draws the target
count from a Poisson distribution with the PHD's mass and the locations from the normalised
PHD. One rule both explores (draws from birth mass where nobody looked) and tracks (draws from
the peaks of detected targets), so this baseline is the agent's whole controller
(``steers_tracking``): the mode machine still runs and the reports carry the mode, but neither
the walks, the Renyi tracking control nor the look at tentative peaks move the agent.

A decision (TS-PHD-II on team_phd.TeamPhd's weighted points, the PHD predicted to k+1):

1. n ~ Poisson(M), M the total weight; n locations drawn i.i.d. in proportion to the weights;
2. the value of sensing at a drawn location is the number of drawn targets its sensing square
   would hold; the goal is the best drawn location, ties to the one nearest the agent;
3. the agent steers to the admissible pose of Eqn. controlVectors nearest to the goal
   (search_planning.search_action) and keeps the goal until it is inside its sensing square
   (the action is done), then decides again. With no target drawn (probability e^-M, high
   while the PHD holds less than a target's mass, e.g. early in a run: births add
   ``phd.birth_rate`` per step) every location has the same value 0 and the tie goes to a
   location drawn uniformly over A, the usual random tie-break of an argmax (staying would
   idle the agent until a draw is not empty).

Draws come from a generator seeded with (seed, agent id, THOMPSON_STREAM), apart from the
filter's and the world's streams, so a run is reproducible.

Where ours is a reading of DecSTER and not their algorithm:

- Posterior: theirs is updated with the observations every teammate broadcasts (asynchronously,
  possibly late); ours is the agent's own SAT-PHD with the team's looks and targets taken from
  the paper's reports of the agents in range (team_phd), the only things our radio carries.
- Actions and reward: their agents choose sensing actions in a continuous space, scored by the
  reward they would earn under the draw; ours choose among the drawn locations by the number of
  drawn targets a sensing square there would hold (a detection-count reading of the reward),
  and fly there with the 17 actions, at most 4 m a step. Keeping the goal until it is reached
  reads their asynchronous decisions: an agent decides again when its action is done.
- Filter and sensor: our SAT-PHD (particles, our birth model) and our square range-bearing
  sensor with clutter, not their PHD implementation and sensor model.
"""

from typing import Optional

import numpy as np

from sat_agent.baselines.interface import baseline_rng, BaselineView, SearchMove, THOMPSON_STREAM
from sat_agent.baselines.team_phd import TeamPhd
from sat_agent.config import SatParams
from sat_agent.search_planning import search_action
from sat_agent.sensor_model import in_sensing_square


def draw_targets(points: np.ndarray, weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """TS-PHD-II: n ~ Poisson(sum w) locations drawn from the points in proportion to w."""
    total = float(np.sum(weights))
    if not total > 0.0:
        return np.zeros((0, 2))
    count = int(rng.poisson(total))
    index = rng.choice(len(weights), size=count, p=np.asarray(weights, dtype=float) / total)
    return np.asarray(points, dtype=float)[index]


def best_draw(draws: np.ndarray, pose, side: float) -> Optional[np.ndarray]:
    """Return the drawn location whose square holds the most draws, ties to the nearest."""
    if len(draws) == 0:
        return None
    held = in_sensing_square(draws[None, :, :], draws[:, None, :], side).sum(axis=1)
    gaps = np.hypot(*(draws - np.asarray(pose, dtype=float)).T)
    return draws[np.lexsort((gaps, -held))[0]].copy()


class ThompsonPhdPolicy:
    """Thompson sampling on the PHD, one decision per reached goal (module docstring)."""

    steers_tracking = True

    def __init__(self, params: SatParams, agent_id: int, seed: int):
        self._params = params
        self._phd = TeamPhd(params)
        self._rng = baseline_rng(seed, agent_id, THOMPSON_STREAM)
        self._goal: Optional[np.ndarray] = None

    def choose(self, pose, view: BaselineView) -> SearchMove:
        """Decide when the goal is reached (or at the first step), then steer to the goal."""
        pose = np.asarray(pose, dtype=float)
        side = self._params.sensor.square_side
        self._phd.look(view.step, pose)
        if self._goal is None or in_sensing_square(self._goal, pose, side):
            self._goal = best_draw(draw_targets(*self._phd.points(pose, view), self._rng),
                                   pose, side)
            if self._goal is None:
                area = self._params.area
                self._goal = self._rng.uniform((0.0, 0.0), (area.width, area.height))
        goal = self._goal.copy()
        return SearchMove(search_action(pose, goal, self._params), goal, np.zeros((0, 2)))
