"""Near-constant-velocity target dynamics (Eqn. single_dynamics_a, Section Evaluation).

States are rows ``[x, vx, y, vy]`` (the paper's ordering); every function takes an (N, 4) array.
"""

import numpy as np

from sat_agent.config import MotionParams

POSITION = (0, 2)   # columns of x and y in a state row (the paper's H matrix)
VELOCITY = (1, 3)


def transition_matrix(dt: float) -> np.ndarray:
    """F of Section Evaluation."""
    return np.array([[1.0, dt, 0.0, 0.0],
                     [0.0, 1.0, 0.0, 0.0],
                     [0.0, 0.0, 1.0, dt],
                     [0.0, 0.0, 0.0, 1.0]])


def process_noise_covariance(dt: float, scale: float = 1.0) -> np.ndarray:
    """Q of the near-constant-velocity model, per axis [[T^3/3, T^2/2], [T^2/2, T]] * scale.

    The discretised continuous white-noise acceleration model (Bar-Shalom, Li and Kirubarajan,
    Sec. 6.2.2) with spectral density ``scale``. The paper writes Q with T/3 and T/2 (Section
    Evaluation) because its T = 1 s, where both forms agree; at another dt only this one keeps
    the position variance growing as T^3, so ``motion.dt`` is a real parameter.
    """
    block = np.array([[dt ** 3 / 3.0, dt ** 2 / 2.0], [dt ** 2 / 2.0, dt]])
    q = np.zeros((4, 4))
    q[np.ix_([0, 1], [0, 1])] = block
    q[np.ix_([2, 3], [2, 3])] = block
    return scale * q


def positions(states: np.ndarray) -> np.ndarray:
    """(N, 2) positions H x of (N, 4) states."""
    return states[:, POSITION]


def propagate(states: np.ndarray, params: MotionParams, rng: np.random.Generator) -> np.ndarray:
    """Sample x_k ~ N(F x_{k-1}, Q) for every row: the transition pi_{k|k-1} of the PHD predict."""
    f = transition_matrix(params.dt)
    q = process_noise_covariance(params.dt, params.process_noise)
    mean = states @ f.T
    if params.process_noise == 0.0:
        return mean
    # Q is singular-free for dt > 0, so a Cholesky factor exists.
    noise = rng.standard_normal(states.shape) @ np.linalg.cholesky(q).T
    return mean + noise
