"""Range/bearing sensor with a square field of view (Eqn. sensing_model, Section Evaluation).

The sensing area S_a(s) is the closed a x a square centred on the agent; p_D is p_D^max inside and
0 outside for true targets, 1 inside for virtual targets. A detection is
z = h(x, s) + v with h = [range, bearing] and range-dependent standard deviations.
Bearing is atan2(y - s_y, x - s_x), the direction of the target seen from the agent (the paper's
arctan((s_y - y)/(s_x - x)) is the same line, made unambiguous). Clutter is Poisson with mean
lambda and uniform over the measurement space [0, r_c] x [-pi, pi), so kappa(z) = lambda / (2 pi
r_c). The paper's measurement space Z is that of h over the surveillance area, so r_c
(``sensor.clutter_max_range``) is the area's diagonal by default and most false alarms fall
beyond the square, where no target can be detected (they cost the filter nothing: no particle
with p_D > 0 explains them, and births come only from measurements inside the square).
clutter_max_range = 0 puts all of them within the square's half diagonal r_max (the dense
reading, config/dense_clutter.yaml).
"""

import math

import numpy as np

from sat_agent.beyond_paper.kernel_likelihood import kernel_sigmas
from sat_agent.config import SensorParams

LOG_2PI = math.log(2.0 * math.pi)


def wrap_angle(angle):
    """Map angles to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def in_sensing_square(points: np.ndarray, pose, side: float) -> np.ndarray:
    """Boolean mask of the (..., 2) points inside S_a(pose): max(|dx|, |dy|) <= a / 2.

    Written as |dx| <= a / 2 and |dy| <= a / 2, the same test (NaN fails both): a max over
    the last axis of length 2 costs twenty times more, and every step gates by this square.
    """
    points, pose, half = np.asarray(points, dtype=float), np.asarray(pose, dtype=float), side / 2.0
    return ((np.abs(points[..., 0] - pose[..., 0]) <= half)
            & (np.abs(points[..., 1] - pose[..., 1]) <= half))


def squares_intersect(pose_a, pose_b, side: float) -> bool:
    """Whether S_a(pose_a) and S_a(pose_b) share a point (the indicator I of Eqn. ospa)."""
    gap = np.abs(np.asarray(pose_a, dtype=float) - np.asarray(pose_b, dtype=float))
    return bool(np.all(gap <= side))


def detection_probability(points: np.ndarray, pose, sensor: SensorParams) -> np.ndarray:
    """p_D(x, s) of Eqn. sensing_model for true targets at the (N, 2) points."""
    return np.where(in_sensing_square(points, pose, sensor.square_side), sensor.p_detect, 0.0)


def measure(points: np.ndarray, pose) -> np.ndarray:
    """Noise-free h(x, s): (N, 2) rows of [range, bearing] of the (N, 2) points."""
    return np.column_stack(_range_bearing(points, pose))


def plain_hypot(a, b):
    """sqrt(a^2 + b^2) by the formula: within a few ulps of np.hypot, several times faster.

    np.hypot (libm's, within an ulp) is the default of every norm here, so a run's figures are
    the same bit for bit; the tracking control takes this one (tracking_control.py), since
    its pseudo updates only rank actions and hypot is a third of their cost. No overflow for the
    metres, radians and sigmas it meets.
    """
    return np.sqrt(np.square(a) + np.square(b))


def _range_bearing(points: np.ndarray, pose, norm=np.hypot):
    """h(x, s) of the (N, 2) points as two contiguous (N,) arrays: range, bearing."""
    points, pose = np.asarray(points, dtype=float), np.asarray(pose, dtype=float)
    dx, dy = points[:, 0] - pose[0], points[:, 1] - pose[1]
    return norm(dx, dy), np.arctan2(dy, dx)


def measurement_sigmas(distance, sensor: SensorParams):
    """(sigma_range, sigma_bearing) at the given distances (Section Evaluation)."""
    d = np.asarray(distance, dtype=float)
    return (sensor.sigma_range_0 + sensor.sigma_range_slope * d ** 2,
            sensor.sigma_bearing_0 + sensor.sigma_bearing_slope * d)


def log_likelihood(measurements: np.ndarray, points: np.ndarray, pose,
                   sensor: SensorParams, bandwidth: float = 0.0, norm=np.hypot) -> np.ndarray:
    """Return log g(z | x, s) for every point (rows) and measurement (columns): an (N, M) array.

    g is N(z; h(x, s), diag(sigma_r^2, sigma_b^2)) with the sigmas evaluated at the point's
    distance; bearing residuals are wrapped. bandwidth h > 0: g of a Gaussian kernel of spread h
    around each point instead (beyond_paper/kernel_likelihood.py). The arithmetic runs in place
    on (M, N) arrays (returned transposed), so per-point factors broadcast along contiguous
    memory: the filter's update at 20k particles is bound by these passes over memory.
    norm: the distance's and the kernel's sqrt(a^2 + b^2) (np.hypot, or ``plain_hypot``).
    """
    z = np.asarray(measurements, dtype=float).reshape(-1, 2)
    distance, bearing = _range_bearing(points, pose, norm)
    sigma_r, sigma_b = measurement_sigmas(distance, sensor)
    if bandwidth > 0.0:
        sigma_r, sigma_b = kernel_sigmas(sigma_r, sigma_b, distance, bandwidth, norm)
    log_g = np.subtract.outer(z[:, 0], distance)
    log_g *= 1.0 / sigma_r
    np.square(log_g, out=log_g)
    db = np.subtract.outer(z[:, 1], bearing)
    db += np.pi
    db -= (2.0 * np.pi) * np.floor(db * (0.5 / np.pi))   # wrap to [-pi, pi) after the shift
    db -= np.pi
    db *= 1.0 / sigma_b
    np.square(db, out=db)
    log_g += db
    log_g *= -0.5
    log_g -= LOG_2PI + np.log(sigma_r * sigma_b)
    return log_g.T


def likelihood(measurements: np.ndarray, points: np.ndarray, pose,
               sensor: SensorParams, bandwidth: float = 0.0) -> np.ndarray:
    """Return g(z | x, s) as an (N, M) array (see log_likelihood)."""
    return np.exp(log_likelihood(measurements, points, pose, sensor, bandwidth))


def clutter_intensity(sensor: SensorParams) -> float:
    """kappa(z) = lambda f_c(z), f_c uniform over [0, r_c] x [-pi, pi)."""
    return sensor.clutter_rate / (2.0 * math.pi * sensor.clutter_range)


def to_position(measurements: np.ndarray, pose) -> np.ndarray:
    """Inverse of h: the (M, 2) positions of [range, bearing] rows seen from pose."""
    z = np.asarray(measurements, dtype=float).reshape(-1, 2)
    return np.asarray(pose, dtype=float) + z[:, :1] * np.column_stack(
        [np.cos(z[:, 1]), np.sin(z[:, 1])])


def simulate_scan(target_points: np.ndarray, pose, sensor: SensorParams,
                  rng: np.random.Generator):
    """Draw one measurement set Z_k: detections of the points plus Poisson clutter.

    Returns (measurements (M, 2), source (M,)) where source is the index of the detected point
    or -1 for clutter; rows are shuffled so their order carries no information.
    """
    points = np.asarray(target_points, dtype=float).reshape(-1, 2)
    p_detect = detection_probability(points, pose, sensor)
    detected = np.flatnonzero(rng.random(len(points)) < p_detect)
    clean = measure(points[detected], pose)
    sigma_r, sigma_b = measurement_sigmas(clean[:, 0], sensor)
    noisy = clean + rng.standard_normal(clean.shape) * np.column_stack([sigma_r, sigma_b])
    noisy[:, 0] = np.abs(noisy[:, 0])
    noisy[:, 1] = wrap_angle(noisy[:, 1])
    n_clutter = rng.poisson(sensor.clutter_rate)
    clutter = np.column_stack([rng.uniform(0.0, sensor.clutter_range, n_clutter),
                               rng.uniform(-math.pi, math.pi, n_clutter)])
    z = np.vstack([noisy, clutter])
    source = np.concatenate([detected, np.full(n_clutter, -1)])
    order = rng.permutation(len(z))
    return z[order], source[order]
