"""OSPA metric of order p with cut-off c (Schuhmacher, Vo and Vo 2008; the paper's Eqn. ospa).

For X = {x_1..x_m}, Y = {y_1..y_n} with m <= n and d_c(x, y) = min(c, ||x - y||_2):

    d_p^c(X, Y)^p = (1/n) (min over assignments pi of sum_i d_c(x_i, y_pi(i))^p + c^p (n - m))
                  = localisation^p + cardinality^p

with localisation^p = (1/n) min sum d_c^p and cardinality^p = c^p (n - m) / n. The optimal
assignment minimises the sum of d_c^p (scipy.optimize.linear_sum_assignment on that matrix).
By convention d = 0 for two empty sets and d = c when exactly one is empty.
"""

from dataclasses import dataclass
import math

import numpy as np
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist


@dataclass(frozen=True)
class OspaResult:
    """OSPA distance and its two components (distance**p = localisation**p + cardinality**p)."""

    distance: float
    localisation: float
    cardinality: float


def _point_set(points, name: str) -> np.ndarray:
    array = np.asarray(points, dtype=float)
    if array.size == 0:
        return np.zeros((0, 2))
    if array.ndim != 2 or not np.all(np.isfinite(array)):
        raise ValueError(f'{name} must be a finite (k, d) array, got shape {array.shape}')
    return array


def ospa(x, y, cutoff: float, order: float = 2) -> OspaResult:
    """OSPA distance of order `order` (p >= 1) with cut-off `cutoff` (c > 0) between point sets.

    x (m, d) and y (n, d) are sets of points of the same dimension d (rows).
    """
    if not (math.isfinite(cutoff) and cutoff > 0):
        raise ValueError(f'OSPA cut-off c = {cutoff!r}: must be finite and > 0')
    if not (math.isfinite(order) and order >= 1):
        raise ValueError(f'OSPA order p = {order!r}: must be finite and >= 1')
    small, large = sorted((_point_set(x, 'x'), _point_set(y, 'y')), key=len)
    n = len(large)
    if n == 0:
        return OspaResult(0.0, 0.0, 0.0)
    if len(small) == 0:
        return OspaResult(float(cutoff), 0.0, float(cutoff))
    if small.shape[1] != large.shape[1]:
        raise ValueError(f'point sets of dimensions {small.shape[1]} and {large.shape[1]}')
    cost = np.minimum(cdist(small, large), cutoff) ** order
    rows, cols = linear_sum_assignment(cost)
    localisation_p = cost[rows, cols].sum() / n
    cardinality_p = cutoff ** order * (n - len(small)) / n
    return OspaResult(float((localisation_p + cardinality_p) ** (1.0 / order)),
                      float(localisation_p ** (1.0 / order)),
                      float(cardinality_p ** (1.0 / order)))


def gated_pairs(first: np.ndarray, second: np.ndarray, gate: float):
    """One-to-one (row of first, row of second) pairs at most gate apart, nearest overall.

    linear_sum_assignment on the distances, where a pair beyond the gate costs more than any sum
    of pairs within it, so it is never chosen over one within; returns two int arrays.
    """
    first = np.asarray(first, dtype=float).reshape(-1, 2)
    second = np.asarray(second, dtype=float).reshape(-1, 2)
    if not len(first) or not len(second):
        return np.zeros(0, dtype=int), np.zeros(0, dtype=int)
    gaps = np.linalg.norm(first[:, None, :] - second[None, :, :], axis=2)
    cost = np.where(gaps <= gate, gaps, gate * (len(first) + len(second) + 1))
    rows, cols = linear_sum_assignment(cost)
    close = gaps[rows, cols] <= gate
    return rows[close], cols[close]
