"""Addition: a searching agent looks closer at tentative peaks and newborn spots.

Paper: an agent searches (follows its closed walk, control "b) Control" of Section
"Multi-agent Searching") until targets are found, then tracks; it has nothing in between.
Addition: a searching agent that sees a tentative peak (an unconfirmed PHD peak, state extraction)
holds its walk for up to ``search.investigate_steps`` steps and places itself with the tracking
control (Eqn. track_control, with its stand-off when additions.track_standoff is on) on that peak;
a target then reaches the confirmation and the agent enters TRACK, a clutter cloud fades and the
walk resumes. One spot at a time, the heaviest; the spot of a spent budget is abandoned: tentative
peaks near it (within ``phd.continue_gate``) are ignored for 2 * investigate_steps steps. Without a
tentative peak, the heaviest newborn spot of this scan (a measurement seeding at least
``phd.tentative_threshold`` of birth mass) gets one step of the budget, spent on the search move
that keeps the spot ``cooperation.track_edge_margin`` inside the next square
(``keep_in_view_action``; ``search.look_spots`` > 1 keeps as many of the heaviest as one move can
hold, ``search.look_spot_share`` < 1 lowers the bar, both measured and left at 1 in session 23,
docs/persistent_trials.md; ``search.spot_move`` 'full' keeps it only by a move as long as the
walk's, measured and left at 'any' in session 40): a real target is then a tentative peak at the
next scan, a false alarm leaves nothing and the walk resumes at once. With ``search.peak_look``
'keep' a tentative peak is looked at the same way, by the search move that keeps it in the next
square, for up to its budget: the walk advances while the peak is scanned (session 37). Nothing is
looked at during the rejoin cooldown (after an overlap exit or leaving followed targets). A peak
that fades for a scan (a miss, a near pass) is looked at like a newborn spot: one step of the
budget on the search move that keeps it, where its velocity takes it, in the next square; back at
the next scan it is a tentative peak again, gone it is left. Following it with the tracking control
for the rest of the budget instead (tried, session 16) detected no more on the dev seeds 2001-2100
(persistent -0.6 points at random and -5.0 at paper_random, cooperative +0.0 at paper_random) and
searched 2.4 points less of the area by k = 100 with two agents (for one step only: 0.9 less);
docs/persistent_trials.md.
Why: one pass of a searching agent gives a target 2-3 scans, too few to confirm it under
clutter (a tracked target's PHD mass grows by ~1 + g / kappa per scan, and not at all while
the agent flies over it); and newborns the next square does not cover are dropped
(additions.newborn_gate), so a target seen once at the trailing edge of a passing square would
otherwise be forgotten.
Switch: ``additions.investigation`` (off: agent_core.NoInvestigation, no look).
"""

from dataclasses import dataclass, replace
from typing import Optional, Sequence

import numpy as np

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.config import SatParams
from sat_agent.mode_machine import Mode
from sat_agent.phd_filter import BirthSpots
from sat_agent.search_planning import action_costs
from sat_agent.sensor_model import in_sensing_square
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate


@dataclass(frozen=True, eq=False)
class Look:
    """What a searching agent looks at this step instead of following its walk alone.

    peaks: positions X-hat_{k+1|k} to track with the tracking control (the walk holds);
    keep: (K, 2) points the search move must keep in the next square. Both None: no look.
    """

    peaks: Optional[MultiTargetEstimate] = None
    keep: Optional[np.ndarray] = None
    full_speed: bool = False   # keep only with a move as long as the walk's (search.spot_move)


NO_LOOK = Look()


class Investigation:
    """Looks at tentative peaks and newborn spots from SEARCH (module docstring)."""

    def __init__(self, params: SatParams):
        self.params = params
        self._investigated = 0       # steps spent on the current spot
        self._abandoned: list = []   # (position, steps left) of spots given up on
        self._look: tuple = ()
        self._keeping_in_view = False   # the current look is a newborn spot or a faded peak

    def look(self, mode: Mode, estimate: MultiTargetEstimate, cooldown_left: int,
             birth_spots: BirthSpots) -> Look:
        """Return what to look at this step (positions one step ahead), or NO_LOOK."""
        budget = self.params.search.investigate_steps
        self._abandoned = [(p, t - 1) for p, t in self._abandoned if t > 1]
        if mode != Mode.SEARCH or cooldown_left > 0:
            self._investigated = 0
            return NO_LOOK
        fresh = self._fresh(estimate.tentative)
        faded = not fresh and self._investigated > 0 and not self._keeping_in_view
        if fresh:
            look = (max(fresh, key=lambda t: t.weight),)   # the heaviest spot first
        elif faded:
            look = self._look      # a peak that faded for a scan: keep it in view one step
        else:
            self._investigated = 0
            look = self._fresh(self._newborn_spots(birth_spots))[:self.params.search.look_spots]
            if not look:
                return NO_LOOK
        if self._investigated >= budget:
            self._abandoned += [(t.position, 2 * budget) for t in look]
            self._investigated = 0
            return NO_LOOK
        self._keeping_in_view = not fresh
        self._investigated += 1
        dt = self.params.motion.dt
        self._look = tuple(replace(t, position=t.position + dt * t.velocity) for t in look)
        ahead = MultiTargetEstimate(self._look, 0.0)
        keep = self._keeping_in_view or self.params.search.peak_look == 'keep'
        spot = not fresh and not faded
        return (Look(keep=ahead.positions(),
                     full_speed=spot and self.params.search.spot_move == 'full')
                if keep else Look(peaks=ahead))

    def _fresh(self, spots: Sequence[TargetEstimate]) -> tuple:
        """Return the spots farther than phd.continue_gate from every abandoned spot."""
        gate = self.params.phd.continue_gate
        return tuple(t for t in spots if not any(
            np.hypot(*(t.position - p)) <= gate for p, _ in self._abandoned))

    def _newborn_spots(self, spots: BirthSpots) -> tuple:
        """Return this scan's spots seeding the least birth mass looked at, heaviest first."""
        least = self.params.search.look_spot_share * self.params.phd.tentative_threshold
        order = np.argsort(-spots.masses, kind='stable')
        order = order[spots.masses[order] >= least]
        return tuple(TargetEstimate(spots.positions[i].copy(), np.zeros(2), np.zeros((4, 4)),
                                    float(spots.masses[i])) for i in order)


def keep_in_view_action(pose, goal, params: SatParams, keep: np.ndarray,
                        full_speed: bool = False) -> int:
    """Return the search control's action (search_planning.search_action) keeping points in view.

    keep: (K, 2) points, most wanted first, the next sensing square must hold at least
    ``cooperation.track_edge_margin`` inside its edges (a newborn's measurement is off by
    sigma_r ~ 1 m): the moves kept are those holding the longest run of them from the first
    that some admissible action holds; when none holds the first, no limit. Ties go to the
    lowest action index. full_speed: only the moves as long as the search control's own
    (``search.spot_move`` 'full'), so keeping a point may turn the walk but never slows it.
    """
    pose = np.asarray(pose, dtype=float).reshape(2)
    poses = candidate_poses(pose, params.actions)
    distances = action_costs(pose, goal, params)
    allowed = admissible_mask(pose, params.actions, params.area)
    if full_speed:   # the control's own move is among the kept ones, so some cost is finite
        lengths = np.hypot(*(poses - pose).T)
        slower = lengths < lengths[np.argmin(distances)] - 1e-9
        distances[slower] = np.inf
        allowed &= ~slower
    points = np.asarray(keep, dtype=float).reshape(-1, 2)
    inner = params.sensor.square_side - 2.0 * params.cooperation.track_edge_margin
    holding = in_sensing_square(points[None, :, :], poses[:, None, :], inner)
    held = np.logical_and.accumulate(holding, axis=1).sum(axis=1)
    most = held[allowed].max(initial=0)
    if most > 0:
        distances[held < most] = np.inf
    return int(np.argmin(distances))
