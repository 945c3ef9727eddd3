"""Multi-target state extraction from the particle PHD (Section "Search-and-Track Density").

The paper estimates n_hat(R) = round(integral of D^1 over R) targets in a region R and takes the
n_hat highest peaks. Rounding the mass of the whole sensing square counts diffuse mass as a
target: under dense clutter (10 false alarms per scan around the agent) every scan leaves small
clouds of clutter-born mass (each < 0.5, together often > 0.5) scattered over the square. So
the regions R here are the PHD's peaks: mass is counted per peak, and a peak stands for
round(its mass) targets.

Within the extraction region (the sensing square grown by ``phd.extraction_margin``), with
r = ``phd.peak_radius``:

1. continued targets first (track continuity, a choice the paper leaves open): for each target
   extracted at k-1, in order, mean-shift from its predicted position x + v T over the
   unclaimed particles within r; if the peak stays within ``phd.continue_gate`` and its region
   (unclaimed particles within r) holds at least ``phd.continue_threshold``, the target
   continues with max(1, floor(mass)) estimates and the region is claimed. Under dense
   clutter a tracked target's mass settles at ~0.3-0.6 (0.99 - kappa / g_bar), so requiring
   round(mass) >= 1 at every step would drop it every few steps;
2. new peaks: the heaviest cell of the unclaimed weights binned on a ``PEAK_CELL`` grid and
   smoothed over 3 x 3 cells, refined by weighted mean-shift within r (so diffuse mass nearby
   does not drag it); its region stands for n = round(mass) targets (one estimate when n = 1,
   n weighted k-means clusters otherwise). A new target needs most of its region's mass inside
   the sensing square (mass beyond it is never corrected) and, when the caller passes the
   tentative peaks
   of k-1 (``candidates``), round(mass) >= 1 on ``phd.confirm_scans`` scans in a row at peaks
   within ``phd.confirm_gate``: clutter-born clouds seldom stay that heavy twice. Lighter or
   not yet confirmed peaks in the square with at least ``phd.tentative_threshold`` are
   returned as ``tentative`` (not targets; the agent may look closer, agent_core);
3. regions are claimed and the next peak is sought until the unclaimed mass is below the
   lowest threshold that can still give a target or a tentative peak.

No random numbers are used and ties go to the lowest index, so the same PHD always gives the same
estimate. Each estimate carries its cluster's weighted mean velocity, its weighted covariance
(the spread) and its PHD mass (weight). ``cardinality`` is the mass of the whole region.
"""

from dataclasses import dataclass, field
from typing import List, Optional, Tuple

import numpy as np
from scipy import ndimage

from sat_agent import motion_model, sensor_model
from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD

# A target's posterior cloud is about 1 m wide (sigma_r ~ 1 m in the square): bins of that size
# resolve it.
PEAK_CELL = 1.0
MEAN_SHIFT_STEPS = 5
LLOYD_ITERATIONS = 10
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


def extract_targets(phd: ParticlePHD, pose, params: SatParams,
                    previous: Optional[np.ndarray] = None,
                    candidates: Optional[np.ndarray] = None) -> MultiTargetEstimate:
    """Estimate the targets around pose (see the module docstring).

    previous: (n, 2) positions where the targets extracted at the last step are expected now
    (x + v T); a peak within ``phd.continue_gate`` of one of them continues that target while
    its region keeps at least ``phd.continue_threshold`` of mass. None or empty: no target
    continues, every estimate needs round(mass) >= 1 and a peak inside the sensing square.
    candidates: (positions (m, 2), streaks (m,)) of the tentative peaks of k-1, positions
    predicted to k. When given (not None), a peak with round(mass) >= 1 becomes a new target
    only on its ``phd.confirm_scans``-th scan in a row with round(mass) >= 1 (its streak: one
    more than the longest streak of a candidate within ``phd.confirm_gate``); before that it
    is a tentative peak with that streak. None: one scan is enough.
    """
    phd_params = params.phd
    radius = phd_params.peak_radius
    side = params.sensor.square_side + 2.0 * phd_params.extraction_margin
    points = motion_model.positions(phd.states)
    region = sensor_model.in_sensing_square(points, pose, side)
    mass = float(phd.weights[region].sum())
    # The unclaimed particles: claimed regions are cut out, so later peaks scan fewer rows.
    region &= phd.weights > 0.0
    states, points, weights = phd.states[region], points[region], phd.weights[region]
    origin = np.asarray(pose, dtype=float) - side / 2.0
    estimates: List[TargetEstimate] = []
    # Track continuity first: each target of k-1 looks for its peak from where it should be.
    for guess in np.zeros((0, 2)) if previous is None else np.asarray(
            previous, dtype=float).reshape(-1, 2):
        peak = _mean_shift(points, weights, guess, radius)
        member = np.hypot(*(points - peak).T) < radius
        peak_mass = weights[member].sum()
        if (np.hypot(*(peak - guess)) > phd_params.continue_gate
                or peak_mass < phd_params.continue_threshold):
            continue
        # The PHD over-counts a tracked target under clutter (clutter points next to it add
        # mass): a continued target splits in two only at a mass of 2, not 1.5.
        estimates.extend(_estimates(states[member], points[member], weights[member], peak,
                                    max(1, int(np.floor(peak_mass)))))
        states, points, weights = states[~member], points[~member], weights[~member]
    # New targets: round(mass) >= 1 around a peak inside the square; lighter peaks there with
    # at least tentative_threshold are kept as tentative.
    floor = min(0.5, phd_params.tentative_threshold)
    tentative: List[TargetEstimate] = []
    streaks: List[int] = []
    for _ in range(MAX_PEAKS):
        if weights.sum() < floor:
            break
        peak = _mean_shift(points, weights, _densest_cell(points, weights, origin, side),
                           radius)
        member = np.hypot(*(points - peak).T) < radius
        peak_mass = weights[member].sum()
        claimed = states[member], points[member], weights[member]
        states, points, weights = states[~member], points[~member], weights[~member]
        seen = sensor_model.in_sensing_square(claimed[1], pose, params.sensor.square_side)
        if claimed[2][seen].sum() < 0.5 * peak_mass:
            # Mass beyond the square (no p_D there, Eqn. sensing_model) is never corrected and
            # only decays with p_S: it can continue a target but not make a new one.
            continue
        count = int(np.floor(peak_mass + 0.5))
        streak = _streak(peak, candidates, phd_params.confirm_gate) if count >= 1 else 0
        if count >= 1 and (candidates is None or streak >= phd_params.confirm_scans):
            estimates.extend(_estimates(*claimed, peak, count))
        elif peak_mass >= phd_params.tentative_threshold:
            tentative.append(_summarise(claimed[0], claimed[2], peak))
            streaks.append(streak)
    return MultiTargetEstimate(tuple(estimates), mass, tuple(tentative), tuple(streaks))


def _streak(peak: np.ndarray, candidates, gate: float) -> int:
    """Count the scans in a row with round(mass) >= 1 at this peak, this one included."""
    if candidates is None or len(candidates[0]) == 0:
        return 1
    positions = np.asarray(candidates[0], dtype=float).reshape(-1, 2)
    near = np.hypot(*(positions - peak).T) <= gate
    return 1 + int(np.max(np.asarray(candidates[1])[near], initial=0))


def _estimates(states: np.ndarray, points: np.ndarray, weights: np.ndarray, peak: np.ndarray,
               count: int) -> List[TargetEstimate]:
    """One estimate at the peak, or count of them by a weighted k-means of the region."""
    if count == 1:
        return [_summarise(states, weights, peak)]
    return _split(states, points, weights, count)


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
        near = np.hypot(*(points - center).T) < radius
        total = weights[near].sum()
        if total <= 0.0:
            break
        moved = weights[near] @ points[near] / total
        # np.allclose costs more than the shift itself for two numbers.
        if np.abs(moved - center).max() <= 1e-6:
            break
        center = moved
    return center


def _split(states: np.ndarray, points: np.ndarray, weights: np.ndarray,
           count: int) -> List[TargetEstimate]:
    """Weighted k-means of one peak region into count targets (seeds: heaviest particles)."""
    order = np.argsort(-weights, kind='stable')
    centers = [points[order[0]]]
    for index in order[1:]:
        if len(centers) == count:
            break
        if min(np.hypot(*(np.array(centers) - points[index]).T)) > PEAK_CELL:
            centers.append(points[index])
    centers = np.array(centers)
    for _ in range(LLOYD_ITERATIONS):
        labels = np.argmin(np.linalg.norm(points[:, None, :] - centers[None], axis=2), axis=1)
        mass = np.bincount(labels, weights=weights, minlength=len(centers))
        moved = np.column_stack([
            np.bincount(labels, weights=weights * points[:, axis], minlength=len(centers))
            for axis in range(2)]) / np.where(mass > 0.0, mass, 1.0)[:, None]
        moved[mass <= 0.0] = centers[mass <= 0.0]
        if np.allclose(moved, centers, rtol=0.0, atol=1e-9):
            break
        centers = moved
    labels = np.argmin(np.linalg.norm(points[:, None, :] - centers[None], axis=2), axis=1)
    return [_summarise(states[labels == i], weights[labels == i], centers[i])
            for i in range(len(centers)) if weights[labels == i].sum() > 0.0]


def _summarise(states: np.ndarray, weights: np.ndarray, center: np.ndarray) -> TargetEstimate:
    mass = float(weights.sum())
    mean = weights @ states / mass
    deviation = states - mean
    covariance = (deviation * weights[:, None]).T @ deviation / mass
    return TargetEstimate(position=np.array(center, dtype=float),
                          velocity=mean[list(motion_model.VELOCITY)].copy(),
                          covariance=covariance, weight=mass)
