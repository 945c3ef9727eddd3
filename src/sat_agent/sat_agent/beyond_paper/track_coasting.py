"""Addition: follow a found target long enough to know its walk, then search on and coast it.

Paper: X-hat_k is extracted over the sensing area S_a(s_k) (Section "Search-and-Track
Density"), so an agent reports only the targets in its square, and an agent that found a
target tracks it (Section "Multi-agent Tracking") until it loses it: to keep a target
estimated, an agent must stop searching.
Addition, three parts:

1. Tracks. Each agent keeps a short track of every target it estimated: its estimates of the
   last ``phd.coast_history`` steps, continued from step to step by the nearest estimate
   within ``phd.coast_gate`` of the track's fit (one-to-one, ``ospa.gated_pairs``). With
   ``additions.measurement_fit`` (session 27) a track stores the agent's measurement of each
   estimate instead, with the sensor's information matrix, and its fit is weighted by them
   (beyond_paper/measurement_fit.py).
2. Coasting. A track of at least ``phd.coast_min_estimates`` estimates (fewer give no velocity
   to trust: a clutter-born track or a glimpse) without an estimate at step k is reported at
   the position its least-squares constant-velocity fit gives for k, while p_S^t >=
   ``phd.coast_survival`` (t: steps since its last estimate; 1/2 is the paper's n_hat =
   round(mass) rule applied to the one target the track stood for, whose PHD mass out of view
   decays with p_S); with ``phd.coast_report`` 'ospa' the threshold also grows with the fit's
   drift (beyond_paper/coast_report.py). It is dropped sooner on evidence that it is wrong: the
   coasted position has lain in the agent's square, or in the square a neighbour in range
   scanned at k - 1, on more than ``phd.coast_misses`` steps without an estimate of it (looked
   and not found), it leaves the area A, or a neighbour in range reports a target within the
   gate of it (that neighbour sees it; two reports of one target would count one as false).
   With ``phd.coast_boundary`` 'reflect' (session 25) the fit is not ended at the border of A
   but folded back into it, as the world's targets bounce (world_model.reflect) and the
   regrowing density keeps undetected targets in A; every use of the fit (the report, the gate,
   the revisit's goal) then sees the folded walk. 'reflect' folds the fit's prediction only, so
   the estimates of a target after its bounce join a history fitted as one line before it;
   'bounce' (session 26) stores each estimate as its mirror image on the fit's unfolded walk,
   so the fit stays the straight line the world's target walks (Track.add). Neither is in a
   profile: both also keep reporting dead targets past the border (OSPA +0.08 to +0.15 m,
   docs/persistent_trials.md, sessions 25-26). With 'clamp' (session 33, coast_point) the
   fit is not folded: while it lies outside A by at most its drift spread it is taken for a
   target at the border (the world's targets stay in A) and reported at its nearest point of
   A; farther out the track ends. A live target walking along the border has a fit that
   leaves A by a fraction of a metre, which 'drop' ends. A coasted track's next position
   (expected_point) is added to the extraction's expected targets (track continuity), so the
   target continues at once when it walks back into the square instead of waiting for
   confirmation.
3. Follow, then search. A tracking agent leaves TRACK (as an overlap leaver does, so
   additions.rejoin_cooldown applies, for ``cooperation.follow_cooldown`` steps: 0 by default
   since session 32) once every target it estimates has been followed long enough: a track of
   at least ``cooperation.follow_steps`` estimates whose fitted velocity has a standard error
   of at most ``cooperation.follow_velocity_error`` (0: the count alone). From then on such a
   target does not make it track again: it is coasted and its track refreshed whenever a
   square passes over it. The error is judged from the fit's own residuals, so a clean track
   is left after a few estimates and a noisy one is followed until its velocity is known as
   well (session 18, dev seeds, docs/persistent_trials.md: against a fixed 20 estimates, the same
   detection gain as a fixed 10 without its loss of tracked target-steps).

Coasted targets are reported only (the swarm's estimate, the metrics): the mode counts the
targets whose tracks are still short, and the tracking control, the overlap test and the
neighbours' reports use X-hat_k as the paper defines it.
Why: the truth the paper and our evaluation simulate walks at near-constant velocity
(process noise 1e-5), which the filter's own NCV model (Q scaled by 1, the paper's) cannot use:
its particle cloud diffuses several metres within a few steps out of view and its velocity
follows the last scans only. A fit whose velocity errs by 4 cm/s (~20 estimates erring 1 m,
fewer when they err less) keeps the position within the detection radius for tens of steps.
An oracle that follows each target 10-20 steps and then coasts it (scripts/oracle_frontier.py
--coast) detects about as many targets as the never-tracking sweep and tracks more
target-steps than the oracle that follows every target until it dies. The cost: a target that
dies out of view is reported until p_S^t falls below the threshold or a square passes over it
(false-track steps).
Switch: ``additions.track_coasting`` (off: the reports hold X-hat_k only and an agent tracks
until it loses its targets).
"""

from dataclasses import dataclass, field
from typing import List, Optional, Sequence, Tuple

import numpy as np

from sat_agent.actions import fold, inside_area
from sat_agent.beyond_paper.coast_report import report_threshold
from sat_agent.beyond_paper.kernel_likelihood import filter_bandwidth
from sat_agent.beyond_paper.measurement_fit import (
    associate, estimate_position_covariances, measurement_positions, WalkFit,
    weighted_walk_fit)
from sat_agent.config import SatParams
from sat_agent.ospa import gated_pairs
from sat_agent.sensor_model import in_sensing_square


# The fit's drift over its own standard error, measured (beyond_paper/track_revisit.py).
KAPPA = 2.0
NO_MEASUREMENTS = np.zeros((0, 2))
# Why a track without an estimate at step k is dropped (part 2 of the module docstring), in the
# order TrackCoasting tests them; TrackCoasting.drops names them for diagnostics.
DROP_REASONS = ('fit left A', 'report expired', 'short track', 'looked, not found',
                'a neighbour reports it')


@dataclass
class Track:
    """One target's recent estimates (steps and (2,) positions) and its misses in view."""

    steps: List[int]
    positions: List[np.ndarray]
    velocity: np.ndarray
    misses: int = 0
    # Estimates over the track's whole life (steps keeps only the latest).
    length: int = 1
    # (width, height) of the area the fit is folded into (phd.coast_boundary 'reflect' or
    # 'bounce').
    bounds: Optional[tuple] = None
    # 'bounce': positions hold the estimates on the unfolded walk, so the fit stays one line.
    unfolds: bool = False
    # additions.measurement_fit: each position's 2x2 information matrix, and the fit is the
    # weighted one of beyond_paper/measurement_fit.py.
    informations: Optional[List[np.ndarray]] = None
    # The weighted fit of the entries as they are (add clears it): every use of a track at a
    # step reads the same fit.
    _weighted: Optional[WalkFit] = field(default=None, repr=False, compare=False)

    def _fit(self):
        """Least-squares constant-velocity fit: (step offsets, mean position, velocity).

        Around the mean step the slope and the intercept are uncorrelated.
        """
        if self.informations is not None:
            fit = self._weighted_fit()
            return np.asarray(self.steps, dtype=float) - fit.mean_step, fit.mean, fit.velocity
        steps = np.asarray(self.steps, dtype=float)
        positions = np.asarray(self.positions, dtype=float)
        offsets = steps - steps.mean()
        mean = positions.mean(axis=0)
        return offsets, mean, offsets @ (positions - mean) / (offsets @ offsets)

    def _weighted_fit(self):
        """Return the generalised least-squares fit of additions.measurement_fit."""
        if self._weighted is None:
            self._weighted = weighted_walk_fit(self.steps, np.asarray(self.positions),
                                               np.asarray(self.informations))
        return self._weighted

    def _line(self, step: int) -> np.ndarray:
        """Evaluate the track's constant-velocity fit at step, before any fold.

        With one estimate, its filter velocity (the peak's particles) carries it.
        """
        if len(self.steps) < 2:
            return self.positions[-1] + (step - self.steps[-1]) * self.velocity
        offsets, mean, velocity = self._fit()
        return mean + (step - np.mean(self.steps)) * velocity

    def predict(self, step: int) -> np.ndarray:
        """Return where the track's fit puts the target at step.

        With bounds, the fit's walk is folded back into [0, width] x [0, height] (module
        docstring, part 2).
        """
        if self.bounds is None:
            return self._line(step)
        return fold(self._line(step), np.asarray(self.bounds, dtype=float))[0]

    def add(self, step: int, position: np.ndarray, velocity: np.ndarray, history: int,
            information: Optional[np.ndarray] = None):
        """Continue the track with an estimate at step, keeping its latest history ones.

        With ``unfolds`` the estimate is stored as its mirror image on the fit's unfolded walk
        (the image the fold maps to it, nearest the fit's line), so a walk that bounced off a
        border is still one straight line to fit (module docstring, part 2). information: the
        position's 2x2 information matrix, for a track with informations (mirrored with it).
        """
        position = np.asarray(position, dtype=float)
        if self.unfolds:
            line = self._line(step)
            folded, crossings = fold(line, np.asarray(self.bounds, dtype=float))
            # Each crossing mirrors the axis: near the line the fold is +-1 times a shift.
            mirror = (-1.0) ** crossings
            position = line + (position - folded) * mirror
            if information is not None:
                information = information * np.outer(mirror, mirror)
        self.steps.append(int(step))
        self.positions.append(position.copy())
        del self.steps[:-history], self.positions[:-history]
        if self.informations is not None:
            self.informations.append(np.asarray(information, dtype=float).copy())
            del self.informations[:-history]
            self._weighted = None
        self.velocity = np.asarray(velocity, dtype=float).copy()
        self.misses = 0
        self.length += 1

    def velocity_error(self) -> float:
        """Return the standard error (m/s) of the fitted velocity per axis, from the residuals.

        Both axes share one noise variance, sum of squared residuals / (2 (n - 2)); inf with
        fewer than 3 estimates (no residual to judge the fit by). A weighted fit's is the root
        mean of its velocity variances (beyond_paper/measurement_fit.py).
        """
        if len(self.steps) < 3:
            return np.inf
        if self.informations is not None:
            return float(np.sqrt(np.trace(self._weighted_fit().covariance[2:, 2:]) / 2))
        offsets, mean, velocity = self._fit()
        residuals = np.asarray(self.positions, dtype=float) - mean - np.outer(offsets, velocity)
        variance = (residuals ** 2).sum() / (2 * (len(self.steps) - 2))
        return float(np.sqrt(variance / (offsets @ offsets)))

    def prediction_error(self, step: int) -> float:
        """Return the standard error (m) per axis of the fit's position at step.

        The mean position's error sigma / sqrt(n) and the velocity's error times the steps from
        the mean step, which are uncorrelated (_fit); inf with fewer than 3 estimates. A
        weighted fit's is the root mean of its position variances at step.
        """
        if self.informations is not None and len(self.steps) >= 3:
            return float(np.sqrt(np.trace(
                self._weighted_fit().position_covariance(step)) / 2))
        error = self.velocity_error()
        if not np.isfinite(error):
            return np.inf
        offsets = np.asarray(self.steps, dtype=float) - np.mean(self.steps)
        return float(error * np.sqrt(offsets @ offsets / len(self.steps)
                                     + (step - np.mean(self.steps)) ** 2))

    def drift_spread(self, step: int) -> float:
        """Return the per-axis spread (m) of the fit's drift off the target at step.

        KAPPA times prediction_error: the estimates are the filter's peaks, correlated from
        step to step, so the residuals understate it (beyond_paper/track_revisit.py).
        """
        return KAPPA * self.prediction_error(step)


def coast_point(track: Track, step: int, params: SatParams) -> Optional[np.ndarray]:
    """Return where a coasted track stands at step in A, or None once its fit has left A.

    With phd.coast_boundary 'clamp' a fit outside A by at most its drift spread is the target
    at the border (the world's targets stay in A): its nearest point of A.
    """
    point = track.predict(step)
    area = params.area
    if inside_area(point, area)[0]:
        return point
    if params.phd.coast_boundary != 'clamp':
        return None
    clamped = np.clip(point, 0.0, (area.width, area.height))
    return clamped if np.hypot(*(point - clamped)) <= track.drift_spread(step) else None


def expected_point(track: Track, step: int, params: SatParams) -> np.ndarray:
    """Return where to expect the target at step: coast_point, else the fit's line.

    Past the border the line still gates an estimate at the border (TrackCoasting.update).
    """
    point = coast_point(track, step, params)
    return track.predict(step) if point is None else point


def coast_steps(params: SatParams) -> int:
    """Return the largest t with p_S^t >= phd.coast_survival: the longest a track is coasted."""
    survival, threshold = params.motion.p_survival, params.phd.coast_survival
    if survival >= 1.0:
        return np.iinfo(np.int64).max
    if survival <= 0.0:
        return 0
    # The small slack keeps t when p_S^t equals the threshold up to rounding.
    return int(np.floor(np.log(threshold) / np.log(survival) + 1e-9))


def followed_long_enough(track: Track, params: SatParams) -> bool:
    """Whether a tracker may leave this target to its coasting (module docstring, part 3)."""
    cooperation = params.cooperation
    return track.length >= cooperation.follow_steps and (
        cooperation.follow_velocity_error <= 0.0
        or track.velocity_error() <= cooperation.follow_velocity_error)


@dataclass(frozen=True)
class CoastingStep:
    """What the tracks give at step k.

    coasted: (m, 2) positions reported for the targets not estimated at k; fresh: how many of
    X-hat_k's targets still have short tracks (the ones the agent follows); expected: (j, 2)
    the coasted tracks' positions at k + 1, for the extraction's track continuity.
    """

    coasted: np.ndarray
    fresh: int
    expected: np.ndarray


class NoCoasting:
    """The paper's agent: it reports X-hat_k only and follows every target it estimates."""

    tracks: tuple = ()
    drops: tuple = ()

    def update(self, step: int, pose, estimates: Sequence, neighbour_poses,
               neighbour_targets, measurements=NO_MEASUREMENTS) -> CoastingStep:
        """Nothing coasted; every estimated target is fresh."""
        return CoastingStep(np.zeros((0, 2)), len(estimates), np.zeros((0, 2)))


@dataclass
class TrackCoasting:
    """The agent's tracks, the coasted positions and the fresh count (module docstring)."""

    params: SatParams
    tracks: List[Track] = field(default_factory=list)
    # The tracks the last update dropped, each with its reason (one of DROP_REASONS).
    drops: List[Tuple[Track, str]] = field(default_factory=list)

    def update(self, step: int, pose, estimates: Sequence, neighbour_poses,
               neighbour_targets, measurements=NO_MEASUREMENTS) -> CoastingStep:
        """Continue the tracks with X-hat_k (TargetEstimates) and coast the others.

        neighbour_poses: (i, 2) where the neighbours in range scanned at k - 1;
        neighbour_targets: (j, 2) the targets they report, predicted to k; measurements: the
        agent's Z_k (range, bearing rows), which additions.measurement_fit fits on.
        """
        phd = self.params.phd
        positions = np.array([t.position for t in estimates], dtype=float).reshape(-1, 2)
        entries, informations = self._entries(pose, estimates, positions, measurements)
        predicted = np.array([track.predict(step) for track in self.tracks]).reshape(-1, 2)
        pairs = list(zip(*gated_pairs(predicted, positions, phd.coast_gate)))
        fresh = len(estimates)
        side = self.params.sensor.square_side
        looked = np.vstack([np.reshape(pose, (1, 2)), np.reshape(neighbour_poses, (-1, 2))])
        kept: List[Track] = []
        for t, e in pairs:
            track = self.tracks[t]
            track.add(step, entries[e], estimates[e].velocity, phd.coast_history,
                      None if informations is None else informations[e])
            fresh -= followed_long_enough(track, self.params)
            kept.append(track)
        coasted = []
        self.drops = []
        matched_tracks = {t for t, _ in pairs}
        for t in range(len(self.tracks)):
            if t in matched_tracks:
                continue
            track, position = self.tracks[t], coast_point(self.tracks[t], step, self.params)
            if position is None:
                self.drops.append((track, DROP_REASONS[0]))
                continue
            track.misses += bool(in_sensing_square(position, looked, side).any())
            reason = self._drop_reason(track, position, step, neighbour_targets)
            if reason is None:
                kept.append(track)
                coasted.append(position)
            else:
                self.drops.append((track, reason))
        matched_estimates = {e for _, e in pairs}
        for e in range(len(estimates)):
            if e not in matched_estimates:
                kept.append(Track([int(step)], [entries[e].copy()],
                                  np.asarray(estimates[e].velocity, dtype=float).copy(),
                                  bounds=self._bounds(),
                                  unfolds=self.params.phd.coast_boundary == 'bounce',
                                  informations=None if informations is None
                                  else [informations[e]]))
        self.tracks = kept
        expected = [expected_point(track, step + 1, self.params) for track in kept
                    if track.steps[-1] < step]
        return CoastingStep(np.array(coasted).reshape(-1, 2), fresh,
                            np.array(expected).reshape(-1, 2))

    def _entries(self, pose, estimates: Sequence, positions: np.ndarray, measurements):
        """Return what each estimate adds to its track: (E, 2) positions, information or None.

        The estimates, unweighted; with additions.measurement_fit the estimate's associated
        measurement in the agent's square where there is one, else the estimate, and their
        (E, 2, 2) information matrices (beyond_paper/measurement_fit.py).
        """
        params = self.params
        if not params.additions.measurement_fit:
            return positions, None
        # The particles are kernels only with additions.kernel_likelihood (filter_bandwidth).
        covariances = estimate_position_covariances(
            [t.covariance for t in estimates], filter_bandwidth(params))
        scanned, scanned_informations = measurement_positions(measurements, pose,
                                                              params.sensor)
        # Only the square holds detections (Eqn. sensing_model's p_D); a false alarm far out
        # has a covariance so wide that it would pass the gate of any estimate (session 29).
        seen = in_sensing_square(scanned, pose, params.sensor.square_side)
        scanned, scanned_informations = scanned[seen], scanned_informations[seen]
        matched = associate(positions, covariances, scanned, scanned_informations)
        entries, informations = positions.copy(), np.linalg.inv(covariances)
        found = matched >= 0
        entries[found] = scanned[matched[found]]
        informations[found] = scanned_informations[matched[found]]
        return entries, informations

    def _bounds(self) -> Optional[tuple]:
        """Return the area a new track's fit is folded into, if phd.coast_boundary says so."""
        area = self.params.area
        folds = self.params.phd.coast_boundary in ('reflect', 'bounce')
        return (area.width, area.height) if folds else None

    def _drop_reason(self, track: Track, position: np.ndarray, step: int,
                     neighbour_targets) -> Optional[str]:
        """Why a track without an estimate at step, its fit in A, is dropped; None: reported.

        The first of DROP_REASONS[1:] that holds (module docstring).
        """
        neighbours = np.asarray(neighbour_targets, dtype=float).reshape(-1, 2)
        phd = self.params.phd
        if not self._alive_enough(track, step):
            return DROP_REASONS[1]
        if track.length < phd.coast_min_estimates:
            return DROP_REASONS[2]
        if track.misses > phd.coast_misses:
            return DROP_REASONS[3]
        if len(neighbours) and np.min(np.hypot(*(neighbours - position).T)) <= phd.coast_gate:
            return DROP_REASONS[4]
        return None

    def _alive_enough(self, track: Track, step: int) -> bool:
        """Whether p_S^t is high enough to report the track, by phd.coast_report."""
        params = self.params
        since = step - track.steps[-1]
        if params.phd.coast_report == 'survival':
            return since <= coast_steps(params)
        threshold = report_threshold(params.phd.coast_survival, track.drift_spread(step),
                                     params.cooperation.ospa_cutoff)
        return params.motion.p_survival ** since >= threshold
