"""The agent's control set (Eqn. controlVectors) and its admissibility inside the area."""

from functools import lru_cache

import numpy as np

from sat_agent.config import ActionParams, AreaParams


# Every planner, the tracking control and world_sim ask for the set several times an agent-step
# (28 us a build: 3 % of a 64-agent composed process's samples), and the parameters are frozen.
@lru_cache(maxsize=16)
def action_displacements(params: ActionParams) -> np.ndarray:
    """(1 + N_R N_theta, 2) displacements; index 0 is 'stay', then ring by ring, angle by angle.

    Action 1 + (l1 - 1) N_theta + l2 moves l1 Delta_R along angle l2 Delta_theta. Read-only:
    one array per parameter set serves every caller.
    """
    rings = np.arange(1, params.n_radial + 1) * params.radial_step
    angles = np.arange(params.n_angular) * (2.0 * np.pi / params.n_angular)
    radius, theta = np.meshgrid(rings, angles, indexing='ij')
    moves = np.column_stack([(radius * np.cos(theta)).ravel(), (radius * np.sin(theta)).ravel()])
    displacements = np.vstack([np.zeros((1, 2)), moves])
    displacements.flags.writeable = False
    return displacements


def top_speed(params: ActionParams) -> float:
    """Return the longest displacement of one action, N_R Delta_R (m per step)."""
    return params.n_radial * params.radial_step


def candidate_poses(pose, params: ActionParams) -> np.ndarray:
    """Return the poses U_k reachable from pose in one step, one row per action index."""
    return np.asarray(pose, dtype=float) + action_displacements(params)


def fold(coordinates, upper):
    """Mirror coordinates back into [0, upper] at its ends, for any overshoot.

    upper: a float, or one per coordinate (broadcast: (x, y) against (width, height)).

    Returns (folded coordinates, how many times each crossed an end): a coordinate that crossed
    b times is mirrored b times, as a walker bouncing off the ends of [0, upper].
    """
    coordinates = np.asarray(coordinates, dtype=float)
    crossings = np.abs(np.floor(coordinates / upper)).astype(int)
    crossings = np.where(coordinates == upper, 0, crossings)
    wrapped = np.mod(coordinates, 2.0 * upper)
    return np.where(wrapped > upper, 2.0 * upper - wrapped, wrapped), crossings


def inside_area(points: np.ndarray, area: AreaParams) -> np.ndarray:
    """Mask of (N, 2) points inside the closed region [0, width] x [0, height]."""
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return (p[:, 0] >= 0) & (p[:, 0] <= area.width) & (p[:, 1] >= 0) & (p[:, 1] <= area.height)


def admissible_mask(pose, params: ActionParams, area: AreaParams) -> np.ndarray:
    """Which actions keep the agent inside the area (staying is always admissible)."""
    mask = inside_area(candidate_poses(pose, params), area)
    mask[0] = True
    return mask
