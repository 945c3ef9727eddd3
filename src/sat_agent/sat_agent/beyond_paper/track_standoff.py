"""Addition: the tracking control keeps its targets at a stand-off, inside the square.

Paper: u_k* = argmax of xi_track (Eqn. track_control) over the admissible actions of Eqn.
controlVectors.
Addition: the argmax runs over the admissible actions that keep every predicted target at least
``cooperation.track_standoff`` from the agent and ``cooperation.track_edge_margin`` inside the
square (over all admissible actions when none does). Among them the Renyi divergence decides.
Why: under clutter uniform in [range, bearing] the clutter density in the plane is kappa / d
per m^2; next to the agent a detection is barely told from clutter (and sigma_r = 1 m while the
bearing says nothing in metres). The Renyi score of the ideal measurement set ignores clutter,
so it would put the agent on top of the target, where real updates carry the least
information; and a target near the edge is lost at the next step.
Switch: ``additions.track_standoff`` (off: tracking_control.every_action).
"""

import numpy as np

from sat_agent.config import SatParams


def standoff_mask(poses: np.ndarray, targets: np.ndarray, params: SatParams) -> np.ndarray:
    """Actions keeping every target within [standoff, a / 2 - edge margin] of the agent."""
    if len(targets) == 0:
        return np.ones(len(poses), dtype=bool)
    offset = np.abs(targets[None, :, :] - poses[:, None, :])           # (U, n, 2)
    inner = params.sensor.square_side / 2.0 - params.cooperation.track_edge_margin
    in_square = np.max(offset, axis=2) <= inner
    far_enough = np.hypot(offset[..., 0], offset[..., 1]) >= params.cooperation.track_standoff
    return np.all(in_square & far_enough, axis=1)
