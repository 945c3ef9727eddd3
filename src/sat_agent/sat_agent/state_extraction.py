"""Multi-target state extraction from the particle PHD (Section "Search-and-Track Density").

n_hat = round(integral of D^1 over R) with R the sensing square grown by
``phd.extraction_margin``; the targets are the n_hat highest peaks of the PHD in R. Peaks are
found deterministically (no random numbers, ties go to the lowest index):

1. seeds: the particle weights in R are binned on a 1 m grid and smoothed over 3 x 3 cells; the
   heaviest cell is a seed, cells within ``PEAK_SEPARATION`` of it are suppressed, and so on
   until n_hat seeds (if suppression leaves too few cells, the heaviest unchosen cells are used);
2. refinement: weighted Lloyd iterations (assign every particle to its nearest centre, move each
   centre to the weighted mean of its particles within ``PEAK_RADIUS``), so diffuse mass assigned
   to a cluster does not drag its peak.

Each estimate carries the cluster's weighted mean velocity, its weighted covariance (spread) and
its PHD mass (weight).
"""

from dataclasses import dataclass
from typing import Tuple

import numpy as np
from scipy import ndimage

from sat_agent import motion_model, sensor_model
from sat_agent.config import SatParams
from sat_agent.phd_filter import ParticlePHD

# A target's posterior cloud is about 1 m wide (sigma_r ~ 1 m in the square); bins of that size
# resolve it, and peaks closer than 2 m are one target blurred by the motion noise.
PEAK_CELL = 1.0
PEAK_SEPARATION = 2.0
PEAK_RADIUS = 3.0
LLOYD_ITERATIONS = 10


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

    def positions(self) -> np.ndarray:
        """(n, 2) positions of the estimated targets."""
        if not self.targets:
            return np.zeros((0, 2))
        return np.array([target.position for target in self.targets])


def extract_targets(phd: ParticlePHD, pose, params: SatParams) -> MultiTargetEstimate:
    """Estimate the targets around pose (see the module docstring)."""
    side = params.sensor.square_side + 2.0 * params.phd.extraction_margin
    points = motion_model.positions(phd.states)
    region = sensor_model.in_sensing_square(points, pose, side)
    weights = phd.weights[region]
    mass = float(weights.sum())
    count = min(int(np.floor(mass + 0.5)), int(np.count_nonzero(weights > 0.0)))
    if count <= 0:
        return MultiTargetEstimate((), mass)
    states = phd.states[region]
    points = points[region]
    centers = _peak_seeds(points, weights, count, np.asarray(pose, dtype=float) - side / 2.0,
                          side)
    labels, centers = _weighted_lloyd(points, weights, centers)
    estimates = []
    for index in range(len(centers)):
        member = labels == index
        if weights[member].sum() > 0.0:
            estimates.append(_summarise(states[member], weights[member], centers[index]))
    return MultiTargetEstimate(tuple(estimates), mass)


def _peak_seeds(points: np.ndarray, weights: np.ndarray, count: int, origin: np.ndarray,
                side: float) -> np.ndarray:
    """Greedy non-maximum suppression on the smoothed weight histogram: (count, 2) seeds."""
    bins = max(1, int(np.ceil(side / PEAK_CELL)))
    cell = np.clip(np.floor((points - origin) / PEAK_CELL).astype(int), 0, bins - 1)
    histogram = np.bincount(cell[:, 1] * bins + cell[:, 0], weights=weights,
                            minlength=bins * bins).reshape(bins, bins)
    smooth = ndimage.uniform_filter(histogram, size=3, mode='constant')
    grid = (np.arange(bins) + 0.5) * PEAK_CELL
    cell_x, cell_y = np.meshgrid(origin[0] + grid, origin[1] + grid)
    score = np.where(histogram > 0.0, smooth, -np.inf).ravel()
    fallback = score.copy()
    seeds = []
    for _ in range(count):
        best = int(np.argmax(score)) if np.isfinite(score.max()) else int(np.argmax(fallback))
        seeds.append((cell_x.flat[best], cell_y.flat[best]))
        near = np.hypot(cell_x.ravel() - cell_x.flat[best],
                        cell_y.ravel() - cell_y.flat[best]) < PEAK_SEPARATION
        score[near] = -np.inf
        fallback[best] = -np.inf
    return np.array(seeds)


def _weighted_lloyd(points: np.ndarray, weights: np.ndarray, centers: np.ndarray):
    """Weighted k-means with trimmed centre updates; returns (labels (N,), centers (K, 2))."""
    centers = centers.copy()
    labels = np.zeros(len(points), dtype=int)
    for _ in range(LLOYD_ITERATIONS):
        distance = np.linalg.norm(points[:, None, :] - centers[None, :, :], axis=2)
        labels = np.argmin(distance, axis=1)
        near = distance[np.arange(len(points)), labels] < PEAK_RADIUS
        mass = np.bincount(labels[near], weights=weights[near], minlength=len(centers))
        moved = centers.copy()
        for axis in range(2):
            total = np.bincount(labels[near], weights=weights[near] * points[near, axis],
                                minlength=len(centers))
            moved[:, axis] = np.where(mass > 0.0, total / np.where(mass > 0.0, mass, 1.0),
                                      centers[:, axis])
        if np.allclose(moved, centers, rtol=0.0, atol=1e-9):
            break
        centers = moved
    return labels, centers


def _summarise(states: np.ndarray, weights: np.ndarray, center: np.ndarray) -> TargetEstimate:
    mass = float(weights.sum())
    mean = weights @ states / mass
    deviation = states - mean
    covariance = (deviation * weights[:, None]).T @ deviation / mass
    return TargetEstimate(position=np.array(center, dtype=float),
                          velocity=mean[list(motion_model.VELOCITY)].copy(),
                          covariance=covariance, weight=mass)
