"""What the views draw, without a viewer: sigma ellipses, headings, agent colours, occupancy.

Shared by the Rerun view (sat_world_sim.rerun_view) and the standard RViz2/Foxglove messages
(sat_agent.ros.views), so both draw the same ellipses in the same colours. Beyond the paper:
it is display only.
"""

import numpy as np

# Distinct agent colours (the tab10 palette) and the truth's colour, RGB 0-255.
PALETTE = [(31, 119, 180), (255, 127, 14), (44, 160, 44), (148, 103, 189), (140, 86, 75),
           (227, 119, 194), (188, 189, 34), (23, 190, 207)]
TRUTH_COLOUR = (214, 39, 40)
SIGMAS = 2.0


def agent_colour(agent_id: int):
    """Return the RGB colour of an agent (ids from 1)."""
    return PALETTE[(int(agent_id) - 1) % len(PALETTE)]


def sigma_ellipses(cov_xy, sigmas: float = SIGMAS):
    """Return the semi-axes (n, 2) and yaw (n,) of the sigmas-ellipses of (n, 2, 2) covariances.

    Semi-axis j lies along the j-th eigenvector; yaw is the direction of the first (the minor)
    in radians from the x axis.
    """
    cov = np.asarray(cov_xy, dtype=float).reshape(-1, 2, 2)
    values, vectors = np.linalg.eigh(0.5 * (cov + np.swapaxes(cov, 1, 2)))
    semi = sigmas * np.sqrt(np.clip(values, 0.0, None))
    return semi, np.arctan2(vectors[:, 1, 0], vectors[:, 0, 0])


def ellipse_points(centre, semi, yaw: float, count: int) -> np.ndarray:
    """Return count points of the closed ellipse with these semi-axes and yaw, (count, 2)."""
    angles = np.linspace(0.0, 2.0 * np.pi, count)
    local = np.stack([np.cos(angles) * semi[0], np.sin(angles) * semi[1]], axis=1)
    rotation = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    return np.asarray(centre, dtype=float) + local @ rotation.T


def yaw_quaternions(yaw) -> np.ndarray:
    """(n, 4) quaternions x, y, z, w of rotations by yaw (rad) about z."""
    half = 0.5 * np.asarray(yaw, dtype=float).reshape(-1)
    zeros = np.zeros_like(half)
    return np.stack([zeros, zeros, np.sin(half), np.cos(half)], axis=1)


def occupancy(values) -> np.ndarray:
    """Search density values in [0, 1] as OccupancyGrid cells: 100 never searched, 0 just searched.

    A cell's 'occupancy' is how much it still needs a look, 1 - D^0 |A| (search_density.py's
    storage convention): RViz2's map colours draw the unsearched area dark and the searched
    area light. int8, same shape.
    """
    return np.rint(100.0 * (1.0 - np.clip(values, 0.0, 1.0))).astype(np.int8)
