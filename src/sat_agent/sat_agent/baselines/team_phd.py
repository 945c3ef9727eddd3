"""The PHD the PHD-Voronoi and Thompson-sampling baselines steer by, from what our radio carries.

Both papers steer by a PHD that holds what the whole team has seen: Dames (2020) runs one
distributed PHD filter whose robots apply every detection to the PHD of their Voronoi cells;
in DecSTER (Banerjee and Schneider 2024) every agent updates its own PHD with all the
observations its teammates broadcast. Our agents exchange no particles and no scans, only
what the paper's radio carries between agents in range (search density, estimate X-hat, mode,
pose; agent_core.AgentReport). So the PHD a baseline steers by is a reading of the team's PHD
built from the agent's own SAT-PHD and those reports, as weighted points:

1. The agent's particles (its PHD predicted to k+1, Eqn. satphd_predict). Their diffuse part is
   the birth intensity b_k of the cells this agent has not seen: a cell the agent last saw t
   steps ago holds, besides the (1 - p_D) remnant, the births of the t + 1 predicts since,
   b sum_{j=0}^{t} p_S^j (b = ``phd.birth_rate`` / |A| per step and m^2). That is the
   "birth intensity of cells not seen recently" that draws Dames' robots to explore.
2. The team's looks: the fused search density (Section "Cooperation": max over the agents in
   range) tells when *anyone* last saw a cell, t_team <= t_own. A particle in a cell seen by a
   teammate since this agent last looked is scaled by the ratio of the two birth masses,
   rho = sum_{j<=t_team} p_S^j / sum_{j<=t_own} p_S^j in (0, 1], so the diffuse mass is that of
   the cells the team has not seen; rho = 1 where this agent saw the cell last (its own
   targets keep their weight). The ages are decoded from the densities with Eqn.
   satphd_predict's constant J: a cell last seen t steps ago holds J^t, a cell never seen 0
   (age k: births since the start). A neighbour's report does not say whether it saw a target
   where it looked, so rho also fades this agent's old peaks where a teammate looked since:
   the neighbour's estimate (3.) puts the target back if it was there.
3. The neighbours' estimates X-hat_{k-1} from their k-1 reports, moved to k+1 with x + v T (the
   targets they track), each a point of its PHD mass, unless this agent's own estimate has a
   target within ``phd.peak_radius`` of it (that target is already in its particles).

Only points inside the surveillance region A count: particles the motion model carries out of
A are never seen again (no square reaches them), so their mass would pile up beyond the edges
and hold an agent at the border for ever.

The agent's own search density (its looks only) is kept here, from its poses, with the same
Eqns. satphd_predict and satphd_correct as the filter's (search_density.SearchDensity).
"""

from typing import Optional, Tuple

import numpy as np

from sat_agent import motion_model
from sat_agent.actions import inside_area
from sat_agent.baselines.interface import BaselineView
from sat_agent.config import SatParams
from sat_agent.search_density import Lattice, SearchDensity
from sat_agent.state_extraction import predicted_positions


def steps_since_seen(values: np.ndarray, decay: float, step: int) -> np.ndarray:
    """Age t of every cell of a search density at step k: J^t = value, t = k if never seen.

    J = 1 keeps a searched cell at 1 for ever (age 0); J = 0 forgets it after a step (so only
    the cells in view, value 1, have an age, 0).
    """
    values = np.asarray(values, dtype=float)
    seen = values > 0.0
    if 0.0 < decay < 1.0:
        age = np.log(np.where(seen, values, 1.0)) / np.log(decay)
    else:
        age = np.zeros_like(values)
    return np.where(seen, np.clip(age, 0.0, step), float(step))


def accrued_births(age: np.ndarray, p_survival: float) -> np.ndarray:
    """sum_{j=0}^{t} p_S^j: birth mass a cell of age t holds at k+1, in units of b (docstring)."""
    age = np.asarray(age, dtype=float)
    if p_survival >= 1.0:
        return age + 1.0
    return (1.0 - p_survival ** (age + 1.0)) / (1.0 - p_survival)


def cell_index(points: np.ndarray, lattice: Lattice) -> Tuple[np.ndarray, np.ndarray]:
    """(row, column) of the lattice cell holding each (N, 2) point, clipped to the lattice."""
    cells = np.floor(np.asarray(points, dtype=float) / lattice.spacing).astype(np.int64)
    return np.clip(cells[:, 1], 0, lattice.ny - 1), np.clip(cells[:, 0], 0, lattice.nx - 1)


def team_birth_ratio(own_values: np.ndarray, team_values: np.ndarray, step: int,
                     params: SatParams) -> np.ndarray:
    """Return rho per lattice cell (module docstring, 2.): team birth mass over the own."""
    decay, p_s = params.search.decay, params.motion.p_survival
    own = accrued_births(steps_since_seen(own_values, decay, step), p_s)
    team = accrued_births(steps_since_seen(team_values, decay, step), p_s)
    return np.clip(team / own, 0.0, 1.0)


def neighbour_targets(view: BaselineView, params: SatParams) -> Tuple[np.ndarray, np.ndarray]:
    """(positions at k+1 (M, 2), masses (M,)) of the neighbours' targets (module docstring, 3.)."""
    dt = params.motion.dt
    own = predicted_positions(view.own_report.estimate.targets, dt)
    positions, masses = [], []
    for report in view.reports:
        for target in report.estimate.targets:
            point = target.position + (view.step + 1 - report.step) * dt * target.velocity
            if not np.any(np.hypot(*(own - point).T) <= params.phd.peak_radius):
                positions.append(point)
                masses.append(target.weight)
    return np.reshape(positions, (-1, 2)), np.asarray(masses, dtype=float)


class TeamPhd:
    """The weighted points of one agent's reading of the team's PHD (module docstring)."""

    def __init__(self, params: SatParams):
        self.params = params
        self.own = SearchDensity(Lattice.for_area(params.area, params.search.lattice_spacing),
                                 params)
        self._last: Optional[Tuple[int, np.ndarray]] = None

    def look(self, step: int, pose) -> None:
        """Add the agent's look from s_k to its own search density (once per step)."""
        pose = np.asarray(pose, dtype=float)
        if self._last is not None and self._last[0] == step:
            return
        if self._last is not None:
            self.own.values = self.own.predicted(self.own.values, self._last[1],
                                                 step - self._last[0])
        self.own.correct(pose)
        self._last = (int(step), pose.copy())

    def points(self, pose, view: BaselineView) -> Tuple[np.ndarray, np.ndarray]:
        """Return (positions (N, 2), weights (N,)) in A: particles times rho, others' targets."""
        self.look(view.step, pose)
        rho = team_birth_ratio(self.own.values, view.own_report.search_values, view.step,
                               self.params)
        positions = motion_model.positions(view.phd.states)
        weights = view.phd.weights * rho[cell_index(positions, self.own.lattice)]
        others, masses = neighbour_targets(view, self.params)
        points = np.vstack([positions, others])
        inside = inside_area(points, self.params.area)
        return points[inside], np.concatenate([weights, masses])[inside]
