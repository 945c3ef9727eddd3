"""Addition: an agent tracking several targets releases those a neighbour tracks better.

Paper: a tracking agent steers for all its targets (Eqn. track_control); two agents resolve a
tracking overlap only when they track exactly the same targets (Eqn. ospa over a window, then
one leaves TRACK; Section "Multi-agent Tracking", a). An agent tracking {A, B} next to one
tracking {B} keeps steering for both.
Addition: from the k-1 reports (its own and the neighbours' in range that were in TRACK), a
target of the agent's own k-1 estimate is released when a neighbour's k-1 estimate lies within
``phd.continue_gate`` of it with a tighter position covariance (trace of the x and y
variances; equal: the lower id keeps it). Both agents decide from the same two k-1 reports,
so exactly one of them keeps each shared target. The released targets are left out of the
tracking control (the estimates X-hat_{k+1|k} within the gate of a released target moved two
steps, x + 2 v T), as long as at least one target is kept; the estimate itself is unchanged
(the target stays reported while it is in view).
Why: the agent's control then serves the targets only it tracks, instead of compromising
between them and one another agent holds better.
Switch: ``additions.track_release`` (off: agent_core.KeepAll).
"""

from typing import Sequence

import numpy as np

from sat_agent.config import SatParams
from sat_agent.mode_machine import Mode
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate


def position_spread(target: TargetEstimate) -> float:
    """Trace of the position block of the estimate's covariance ([x, vx, y, vy] order)."""
    return float(target.covariance[0, 0] + target.covariance[2, 2])


class TrackRelease:
    """Leaves out of the tracking control what a neighbour tracks better (module docstring)."""

    def __init__(self, params: SatParams):
        self.gate = params.phd.continue_gate
        self.dt = params.motion.dt

    def released(self, own, reports: Sequence) -> list:
        """Return the own k-1 targets (TargetEstimate) a neighbour in TRACK tracks better.

        own: this agent's k-1 report (agent_core.AgentReport) or None; reports: the
        neighbours' k-1 reports.
        """
        if own is None or own.mode != Mode.TRACK:
            return []
        released = []
        for target in own.estimate.targets:
            if any(self._better(target, own.agent_id, other, report.agent_id)
                   for report in reports if report.mode == Mode.TRACK
                   for other in report.estimate.targets):
                released.append(target)
        return released

    def _better(self, mine: TargetEstimate, own_id: int, other: TargetEstimate,
                other_id: int) -> bool:
        if np.hypot(*(mine.position - other.position)) > self.gate:
            return False
        spread, other_spread = position_spread(mine), position_spread(other)
        return other_spread < spread or (other_spread == spread and other_id < own_id)

    def keep(self, targets: MultiTargetEstimate, own, reports: Sequence) -> MultiTargetEstimate:
        """Return X-hat_{k+1|k} without the released targets (all of it if none would be left)."""
        released = self.released(own, reports)
        if not released or not targets.targets:
            return targets
        ahead = np.array([t.position + 2.0 * self.dt * t.velocity for t in released])
        kept = tuple(t for t in targets.targets
                     if np.min(np.hypot(*(ahead - t.position).T)) > self.gate)
        if not kept:
            return targets
        return MultiTargetEstimate(kept, targets.cardinality)
