"""Addition: a searching agent flies back over a coasted target before its fit drifts off it.

Paper: an agent tracks a target until it loses it (Section "Multi-agent Tracking"); there is
no coasting, so nothing to revisit. With additions.track_coasting an agent leaves a target it
followed long enough (cooperation.follow_steps, cooperation.follow_velocity_error) to the
constant-velocity fit of its estimates and searches on; the track is refreshed only when some
square happens to pass over the target.
Addition: in SEARCH (the sat policy, no look at a tentative peak or a newborn spot), for each
target it left to its coasting the agent predicts where it can meet it, the fit's position at
the arrival step k + ceil(distance / top speed) (two fixed-point rounds), and the chance that
the fit has then drifted beyond ``phd.coast_gate``, the farthest an estimate may lie from the
fit and still continue the track:

    P_lost = exp(-g^2 / (2 (KAPPA s)^2)),  s = Track.prediction_error(arrival step),

the tail of a 2-D Gaussian error of per-axis spread KAPPA s (Track.drift_spread). With
``cooperation.revisit_border`` (session 33) a target whose fit has left A since its last
estimate, reported at the border by phd.coast_boundary 'clamp', counts as lost (P_lost = 1):
it walks along the border or died there, and one look tells which (due_loss). Once some
target's P_lost reaches ``cooperation.revisit_loss``, the agent's walk holds and it flies to
the target with the most p_S^t P_lost per metre (t: steps since its last estimate; what the
visit saves, a target, per distance, as the walks weigh node worth,
beyond_paper/persistent_planning.py) among those whose meeting point lengthens the way to the
walk's next node by at most ``cooperation.revisit_detour``. It flies on the search move that
keeps the fit's next position in its next square once it can
(investigation.keep_in_view_action). The scan over it continues the track (track continuity:
the coasted position is an expected target of the extraction), so P_lost falls and the walk
resumes; a target that is not there is dropped after more than ``phd.coast_misses`` looks.
With ``cooperation.revisit_death`` below 1 (session 43) a target is also due once the chance
that it died since its last estimate, 1 - p_S^t at the meeting step, reaches it, and due
targets are ranked by p_S^t P_lost + 1 - p_S^t per metre, the chance that the report is wrong
when the agent gets there: a well-fitted report drifts too slowly to fall due before it ends,
and its target's death would go unseen for up to 68 steps (``visit_saves``). Measured (rule 23,
fresh dev seeds 11051-11350, paired): at 0.2, 6.3 fewer false-track steps a run, but detected
-3.7 points (both p < 0.001) and OSPA +0.01 m; left at 1 (docs/persistent_trials.md).
Why: on dev seeds 2001-2020 of the random default (persistent profile of session 21), 893 of
11,730 target-steps (7.6 %) were of targets followed at least 8 steps and then lost for good
or for a while: at the loss the fit had drifted 5-10 m off (429 target-steps), it had left
the area A (286) or p_S^t had fallen below phd.coast_survival (172). A fit's error grows
with the steps since its last estimate: median 1.8 m at 20-30 steps (20 % beyond 4 m), 3.0 m
at 30-45 (41 %). KAPPA: the fit's own error understates the drift, since its estimates are the
filter's peaks, correlated from step to step and the residuals do not show it: the median of
error / s is 1.8 there where a Gaussian gives 1.18, and KAPPA = 2 gives P(error > 4 m) = 0.13
over 5-45 steps against 0.11 found.
Measured (session 22, by a rule set before the trial; docs/persistent_trials.md): on fresh dev
seeds 2701-3000 of the random default, paired with config/persistent.yaml without it, tracked +2.2
points of target-steps (95 % CI [+1.0, +3.3]), mean OSPA -0.16 m ([-0.24, -0.09]), detected
share -0.1 ([-2.1, +1.8]) and 8.6 fewer false-track steps per run: a look that finds nothing
also drops the coasted report of a target that died.
Switch: ``additions.track_revisit`` (off: NoRevisit, a coasted target is met again only by
chance). Needs additions.track_coasting (without it there is no track).
"""

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from sat_agent.actions import inside_area, top_speed
from sat_agent.beyond_paper.track_coasting import expected_point, followed_long_enough, Track
from sat_agent.config import SatParams
from sat_agent.search_planning import MIN_COST

# Rounds of "where is it when I get there": a target walks ~0.6 m per step against the
# agent's 4, so the second round moves the meeting point by centimetres.
INTERCEPT_ROUNDS = 2


@dataclass(frozen=True)
class Revisit:
    """Where to fly this step (goal) and the point to keep in the next square (keep, (1, 2))."""

    goal: np.ndarray
    keep: np.ndarray


def meeting_step(track: Track, pose, step: int, speed: float) -> int:
    """Return the first step at which the agent, flying at speed from pose, reaches the fit."""
    arrival = step
    for _ in range(INTERCEPT_ROUNDS):
        gap = np.hypot(*(track.predict(arrival) - np.asarray(pose, dtype=float)))
        arrival = step + max(1, int(np.ceil(gap / speed)))
    return arrival


def loss_probability(track: Track, step: int, gate: float) -> float:
    """Return P_lost at step: the chance the fit errs by more than gate (module docstring)."""
    spread = track.drift_spread(step)
    if not np.isfinite(spread):
        return 1.0
    return float(np.exp(-gate ** 2 / (2.0 * max(spread, MIN_COST) ** 2)))


def due_loss(track: Track, arrival: int, params: SatParams) -> float:
    """Return what a visit at the arrival step saves of the track, as a chance of losing it.

    With ``cooperation.revisit_border``, 1 when the fit lies outside A at the arrival step
    (reported at the border, phd.coast_boundary 'clamp') and inside it at the track's last
    estimate: one look tells a target walking along the border from one that died there;
    a track refreshed with its fit already outside is not due again. Else P_lost.
    """
    if params.cooperation.revisit_border:
        inside = inside_area(np.array([track.predict(track.steps[-1]), track.predict(arrival)]),
                             params.area)
        if inside[0] and not inside[1]:
            return 1.0
    return loss_probability(track, arrival, params.phd.coast_gate)


def visit_saves(alive: float, lost: float, loss: float, death: float) -> Optional[float]:
    """Return what a visit saves (module docstring), or None when the target is not due.

    alive = p_S^t and lost = P_lost at the meeting step. Due when lost reaches
    ``cooperation.revisit_loss`` (loss) or the chance of a death since the last estimate,
    1 - alive, reaches death (``cooperation.revisit_death``, 1: never). A visit saves the
    track of a live target that drifted, alive lost; with the death check, also the report
    of a dead one, 1 - alive: the chance that the report is wrong when the agent gets there.
    """
    checks_death = death < 1.0
    if lost < loss and not (checks_death and 1.0 - alive >= death):
        return None
    return alive * lost + (1.0 - alive if checks_death else 0.0)


class NoRevisit:
    """Without the addition a coasted target is seen again only when a square passes over it."""

    def revisit(self, step: int, pose, tracks: Sequence[Track], walk_goal) -> Optional[Revisit]:
        """Return None: nothing to fly to."""
        return None


@dataclass(frozen=True)
class TrackRevisit:
    """Picks the coasted target to fly back to, if any is due (module docstring)."""

    params: SatParams

    def revisit(self, step: int, pose, tracks: Sequence[Track], walk_goal) -> Optional[Revisit]:
        """Return where to fly at step k from pose for the most worth-per-metre due target.

        tracks: the agent's tracks after step k's update; those left to their coasting are
        the ones without an estimate at k that were followed long enough. walk_goal: the
        walk's next node. None: none is due.
        """
        params = self.params
        pose = np.asarray(pose, dtype=float).reshape(2)
        walk_goal = np.asarray(walk_goal, dtype=float).reshape(2)
        direct = np.hypot(*(walk_goal - pose))
        speed = top_speed(params.actions)
        best, best_rate = None, 0.0
        # A handful of tracks per agent: this loop is over targets, not particles.
        for track in tracks:
            if track.steps[-1] >= step or not followed_long_enough(track, params):
                continue
            arrival = meeting_step(track, pose, step, speed)
            lost = due_loss(track, arrival, params)
            alive = params.motion.p_survival ** (arrival - track.steps[-1])
            saves = visit_saves(alive, lost, params.cooperation.revisit_loss,
                                params.cooperation.revisit_death)
            if saves is None:
                continue
            goal = expected_point(track, arrival, params)
            reach = float(np.hypot(*(goal - pose)))
            if reach + np.hypot(*(walk_goal - goal)) - direct > params.cooperation.revisit_detour:
                continue
            rate = saves / max(reach, MIN_COST)
            if rate > best_rate:
                keep = expected_point(track, step + 1, params)[None, :]
                best, best_rate = Revisit(goal, keep), rate
        return best
