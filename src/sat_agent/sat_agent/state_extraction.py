"""Multi-target state extraction from the particle PHD (Section "Search-and-Track Density").

The paper: n_hat(R) = round(integral of D^1 over R) targets in the sensing area R = S_a(s_k),
and X-hat_k the n_hat highest peaks of the PHD, "as in the original PHD filter". The predicted
multi-target state X-hat_{k|k-1} of the overlap test and the tracking control (Section
"Multi-agent Tracking") is extracted the same way from the predicted PHD. There the paper
integrates over the whole state space; that would count the diffuse birth mass spread over A
(~1 at steady state: b = 0.01 per step, p_S = 0.99) as a target, so it is read over the sensing
area as for X-hat_k (an interpretation).

``NHatExtractor`` is the paper's extractor; ``beyond_paper.peak_extraction.PeakExtractor`` is
the addition that replaces it (per-peak counting with track continuity,
``additions.peak_extraction``). Both share, chosen once at construction (``Extractor``):

- the region: S_a(s_k), or the square grown by ``phd.extraction_margin``
  (``additions.extraction_margin``, beyond_paper/extraction_margin.py);
- the confirmation rule: ``FirstEstimate``, the paper's (a peak is a target on its first
  estimate, so the agent enters TRACK at once), or ``phd.confirm_scans`` scans in a row
  (``additions.confirmation``, beyond_paper/confirmation.py);
- peak finding (``PeakSearch``; the paper does not say how peaks of a particle PHD are found,
  an interpretation): the heaviest cell of the unclaimed weights binned on a ``PEAK_CELL`` grid
  and smoothed over 3 x 3 cells, refined by weighted mean-shift within r = ``phd.peak_radius``
  (so diffuse mass nearby does not drag it); its region, the unclaimed particles within r, is
  claimed before the next peak is sought, so peaks come densest first.

An extractor holds the memory of its last posterior extraction (``ExtractionMemory``: where its
targets and candidate peaks should be now, x + v T): ``extract`` gives X-hat_k from the
posterior PHD and remembers; ``estimate`` gives the estimate of any PHD without remembering
(X-hat_{k+1|k} from the predicted PHD for the tracking control).

No random numbers are used and ties go to the lowest index, so the same PHD always gives the same
estimate. Each estimate carries its cluster's weighted mean velocity, its weighted covariance
(the spread) and its PHD mass (weight). ``cardinality`` is the mass of the whole region.
"""

import abc
from dataclasses import dataclass, field
from typing import Optional, Sequence, Tuple

import numpy as np
from scipy import ndimage

from sat_agent import motion_model, sensor_model
from sat_agent.beyond_paper.confirmation import ScanConfirmation
from sat_agent.beyond_paper.extraction_margin import extraction_side
from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD

# A target's posterior cloud is about 1 m wide (sigma_r ~ 1 m in the square): bins of that size
# resolve it.
PEAK_CELL = 1.0
MEAN_SHIFT_STEPS = 5
# Relative band around a radius where dx^2 + dy^2 leaves the radius test to hypot.
_CIRCLE_MARGIN = 1e-12
# More peaks than any square can hold targets; bounds the loop on pathological input.
MAX_PEAKS = 50


@dataclass(frozen=True)
class TargetEstimate:
    """One extracted target: position (2,), velocity (2,), 4x4 covariance of [x, vx, y, vy]."""

    position: np.ndarray
    velocity: np.ndarray
    covariance: np.ndarray
    weight: float


@dataclass(frozen=True)
class MultiTargetEstimate:
    """The estimated multi-target state X_hat and the PHD mass in the extraction region."""

    targets: Tuple[TargetEstimate, ...]
    cardinality: float
    # Unconfirmed peaks inside the sensing square with at least phd.tentative_threshold of
    # mass: not targets (not reported, not counted), only where the agent may look closer.
    tentative: Tuple[TargetEstimate, ...] = field(default=(), compare=False)
    # Per tentative peak: scans in a row with round(mass) >= 1 (0 for lighter peaks).
    tentative_streaks: Tuple[int, ...] = field(default=(), compare=False)

    def positions(self) -> np.ndarray:
        """(n, 2) positions of the estimated targets."""
        if not self.targets:
            return np.zeros((0, 2))
        return np.array([target.position for target in self.targets])


def predicted_positions(targets: Sequence[TargetEstimate], dt: float) -> np.ndarray:
    """(n, 2) positions x + v T of the targets one step ahead."""
    if not targets:
        return np.zeros((0, 2))
    return np.array([t.position + dt * t.velocity for t in targets], dtype=float)


@dataclass(frozen=True, eq=False)
class ExtractionMemory:
    """What an extraction at k-1 tells the next one, positions predicted to k (x + v T).

    expected: the targets (track continuity); candidates and streaks: the peaks on their way
    to confirmation with their scans in a row (the confirmation rule).
    """

    expected: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    candidates: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    streaks: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))


class FirstEstimate:
    """The paper's confirmation rule: a peak is a target on its first estimate."""

    def streak(self, peak: np.ndarray, memory: ExtractionMemory) -> int:
        """Return 1: every peak is on its first scan."""
        return 1

    def confirmed(self, streak: int, mass: float) -> bool:
        """Return True: every peak is a target."""
        return True


class PeakSearch:
    """The particles of the extraction region, from which peaks are claimed one at a time."""

    def __init__(self, phd: ParticlePHD, pose, side: float, radius: float):
        points = motion_model.positions(phd.states)
        region = sensor_model.in_sensing_square(points, pose, side)
        self.mass = float(phd.weights[region].sum())
        # The unclaimed particles: claimed regions are cut out, so later peaks scan fewer rows.
        region = np.flatnonzero(region & (phd.weights > 0.0))
        self.states, self.points, self.weights = (phd.states[region], points[region],
                                                  phd.weights[region])
        self._origin = np.asarray(pose, dtype=float) - side / 2.0
        self._side = side
        self._radius = radius

    def unclaimed_mass(self) -> float:
        """PHD mass of the particles not claimed yet."""
        return self.weights.sum()

    def around(self, guess: np.ndarray):
        """Return (peak, member mask): the mean-shift peak from guess and its region."""
        peak = _mean_shift(self.points, self.weights, guess, self._radius)
        return peak, within_radius(self.points, peak, self._radius)

    def densest(self):
        """Return (peak, member mask) of the densest unclaimed peak (module docstring)."""
        return self.around(_densest_cell(self.points, self.weights, self._origin, self._side))

    def claim(self, member: np.ndarray):
        """Remove the member particles from the search; return their (states, points, weights)."""
        # Integer indices: boolean indexing of (N, 4) rows costs several times more.
        taken, kept = np.flatnonzero(member), np.flatnonzero(~member)
        claimed = self.states[taken], self.points[taken], self.weights[taken]
        self.states, self.points, self.weights = (
            self.states[kept], self.points[kept], self.weights[kept])
        return claimed


class Extractor(abc.ABC):
    """X-hat around the agent's pose from a particle PHD, with its memory (module docstring)."""

    def __init__(self, params: SatParams, memory: Optional[ExtractionMemory] = None):
        self.params = params
        additions = params.additions
        self.side = (extraction_side(params) if additions.extraction_margin
                     else params.sensor.square_side)
        self.confirmation = (ScanConfirmation(params) if additions.confirmation
                             else FirstEstimate())
        self.memory = ExtractionMemory() if memory is None else memory

    @abc.abstractmethod
    def estimate(self, phd: ParticlePHD, pose) -> Tuple[MultiTargetEstimate, ExtractionMemory]:
        """Return the estimate of phd around pose and the memory it would leave."""

    def extract(self, phd: ParticlePHD, pose) -> MultiTargetEstimate:
        """Return X-hat of the posterior phd around pose and remember it for the next step."""
        estimate, self.memory = self.estimate(phd, pose)
        return estimate


class NHatExtractor(Extractor):
    """The paper's X-hat: the n_hat = round(mass in the region) highest peaks.

    Of the n_hat highest peaks, those the confirmation rule confirms are the targets and the
    others tentative (with their streaks); beyond them, peaks of at least
    ``phd.tentative_threshold`` are tentative too (streak 0), for additions.investigation.
    """

    def estimate(self, phd: ParticlePHD, pose) -> Tuple[MultiTargetEstimate, ExtractionMemory]:
        """Return the estimate of phd around pose and the memory it would leave."""
        phd_params = self.params.phd
        search = PeakSearch(phd, pose, self.side, phd_params.peak_radius)
        n_hat = int(np.floor(search.mass + 0.5))
        targets, target_streaks, tentative, streaks = [], [], [], []
        ranked = 0
        for _ in range(MAX_PEAKS):
            unclaimed = search.unclaimed_mass()
            if not unclaimed > 0.0 or (ranked >= n_hat
                                       and unclaimed < phd_params.tentative_threshold):
                break
            peak, member = search.densest()
            states, _, weights = search.claim(member)
            if not weights.sum() > 0.0:
                break
            if ranked < n_hat:
                ranked += 1
                streak = self.confirmation.streak(peak, self.memory)
                confirmed = self.confirmation.confirmed(streak, float(weights.sum()))
            elif weights.sum() >= phd_params.tentative_threshold:
                streak, confirmed = 0, False
            else:
                continue
            (targets if confirmed else tentative).append(summarise(states, weights, peak))
            (target_streaks if confirmed else streaks).append(streak)
        dt = self.params.motion.dt
        memory = ExtractionMemory(predicted_positions(targets, dt),
                                  predicted_positions(targets + tentative, dt),
                                  np.array(target_streaks + streaks, dtype=int))
        return (MultiTargetEstimate(tuple(targets), search.mass, tuple(tentative),
                                    tuple(streaks)), memory)


def _densest_cell(points: np.ndarray, weights: np.ndarray, origin: np.ndarray,
                  side: float) -> np.ndarray:
    """Centre of the heaviest cell of the 3 x 3-smoothed weight histogram."""
    bins = max(1, int(np.ceil(side / PEAK_CELL)))
    cell = np.clip(np.floor((points - origin) / PEAK_CELL).astype(int), 0, bins - 1)
    histogram = np.bincount(cell[:, 1] * bins + cell[:, 0], weights=weights,
                            minlength=bins * bins).reshape(bins, bins)
    smooth = ndimage.uniform_filter(histogram, size=3, mode='constant')
    row, col = np.unravel_index(int(np.argmax(smooth)), smooth.shape)
    return origin + (np.array([col, row]) + 0.5) * PEAK_CELL


def _mean_shift(points: np.ndarray, weights: np.ndarray, center: np.ndarray,
                radius: float) -> np.ndarray:
    """Move center to the weighted mean of the particles within radius, repeatedly."""
    for _ in range(MEAN_SHIFT_STEPS):
        near = np.flatnonzero(within_radius(points, center, radius))
        near_weights = weights[near]
        total = near_weights.sum()
        if total <= 0.0:
            break
        moved = near_weights @ points[near] / total
        # np.allclose costs more than the shift itself for two numbers.
        if np.abs(moved - center).max() <= 1e-6:
            break
        center = moved
    return center


def within_radius(points: np.ndarray, center: np.ndarray, radius: float) -> np.ndarray:
    """Mask of the (N, 2) points with hypot(dx, dy) < radius from center.

    dx^2 + dy^2 decides all but the points within a relative 1e-12 of the circle (hypot is
    within an ulp of the true distance, so these are the only ones the two could disagree on);
    the hypot of those decides them: the same mask bit for bit, without a hypot per point.
    """
    dx, dy = points[:, 0] - center[0], points[:, 1] - center[1]
    squared, limit = dx * dx + dy * dy, radius * radius
    mask = squared < limit * (1.0 - _CIRCLE_MARGIN)
    unsure = np.flatnonzero(np.abs(squared - limit) <= limit * _CIRCLE_MARGIN)
    mask[unsure] = np.hypot(dx[unsure], dy[unsure]) < radius
    return mask


def summarise(states: np.ndarray, weights: np.ndarray, center) -> TargetEstimate:
    """One estimate at center: the particles' mean velocity, covariance and mass."""
    mass = float(weights.sum())
    mean = weights @ states / mass
    deviation = states - mean
    covariance = (deviation * weights[:, None]).T @ deviation / mass
    return TargetEstimate(position=np.array(center, dtype=float),
                          velocity=mean[list(motion_model.VELOCITY)].copy(),
                          covariance=covariance, weight=mass)
