"""The near-constant-velocity model's F and Q at the paper's T = 1 s and at other dt."""

import numpy as np
import pytest
from scipy.integrate import quad_vec

from sat_agent.config import MotionParams
from sat_agent.motion_model import process_noise_covariance, propagate, transition_matrix

PAPER_Q = np.array([[1 / 3, 1 / 2, 0, 0], [1 / 2, 1, 0, 0],
                    [0, 0, 1 / 3, 1 / 2], [0, 0, 1 / 2, 1]])


def white_acceleration_q(dt: float) -> np.ndarray:
    """Q = integral over [0, dt] of F(t) G G^T F(t)^T, G the acceleration input (x and y)."""
    g = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 0.0], [0.0, 1.0]])

    def integrand(t):
        f = transition_matrix(t)
        return f @ g @ g.T @ f.T

    return quad_vec(integrand, 0.0, dt)[0]


def test_q_at_the_papers_t_is_the_papers_matrix():
    assert np.allclose(process_noise_covariance(1.0), PAPER_Q)
    assert np.allclose(process_noise_covariance(1.0, 2.5), 2.5 * PAPER_Q)


@pytest.mark.parametrize('dt', [0.1, 0.5, 2.0, 3.0])
def test_q_is_the_discretised_white_acceleration_model_at_any_dt(dt):
    assert np.allclose(process_noise_covariance(dt), white_acceleration_q(dt))
    block = np.array([[dt ** 3 / 3, dt ** 2 / 2], [dt ** 2 / 2, dt]])
    assert np.allclose(process_noise_covariance(dt, 0.7)[:2, :2], 0.7 * block)


@pytest.mark.parametrize('dt', [0.25, 0.5, 2.0])
def test_two_half_steps_spread_as_much_as_one_whole_step(dt):
    # A model that is right at every dt composes: predicting twice by dt/2 gives Q(dt).
    half_f, half_q = transition_matrix(dt / 2), process_noise_covariance(dt / 2)
    assert np.allclose(half_f @ half_q @ half_f.T + half_q, process_noise_covariance(dt))


def test_sampled_transitions_have_mean_f_x_and_covariance_q_at_half_a_second():
    params = MotionParams(dt=0.5, process_noise=2.0)
    state = np.array([10.0, 1.0, 20.0, -2.0])
    samples = propagate(np.tile(state, (200_000, 1)), params, np.random.default_rng(3))
    assert np.allclose(samples.mean(axis=0), transition_matrix(0.5) @ state, atol=0.01)
    assert np.allclose(np.cov(samples.T), process_noise_covariance(0.5, 2.0), atol=0.01)
