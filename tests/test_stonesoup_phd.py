"""The project's SMC-PHD update against Stone Soup's SMCPHDUpdater (code we did not write).

Stone Soup 1.9's updater computes, per particle i and measurement z (log domain),
    C_k = log p_D + log g(z | x_i) + log w_i,  C(z) = logsumexp_i C_k,
    w_i <- logsumexp([log(1 - p_D) + log w_i, C_k(z) - logaddexp(C(z), log kappa) for z]),
i.e. Eqn. satphd_correct with a scalar p_D. Two things differ from the paper's model and are
given to it by subclassing, not by changing its arithmetic:

- the likelihood: ``CartesianToBearingRange.logpdf`` uses one fixed covariance and, called by
  the updater with ``noise=True``, adds a noise sample to h(x). ``RangeDependentBearingRange``
  evaluates Stone Soup's own noise-free h(x) and bearing wrapping with the paper's
  range-dependent sigmas (scipy's normal log-density);
- p_D(x) = p_D^max 1[x in S_a(s)]: Stone Soup's scalar ``prob_detect`` carries p_D^max, the
  measurement model returns log g = -inf outside the square (so those particles add nothing to
  Stone Soup's tau(z) sum), and ``SquareFovSMCPHDUpdater`` recomputes the missed-detection
  column with 1 - p_D(x), which is 1 outside the square.
"""

from dataclasses import replace

import numpy as np
import pytest

stonesoup = pytest.importorskip(
    'stonesoup', reason='Stone Soup is not installed; the cross-check against its SMC-PHD '
    'updater needs it (pip install stonesoup==1.9.1)')

# Stone Soup is imported only when present (importorskip above), hence below the skip.
from scipy.stats import norm  # noqa: E402
from stonesoup.base import Property  # noqa: E402
from stonesoup.models.measurement.nonlinear import CartesianToBearingRange  # noqa: E402
from stonesoup.resampler.particle import ESSResampler  # noqa: E402
from stonesoup.types.angle import Bearing  # noqa: E402
from stonesoup.types.array import StateVector, StateVectors  # noqa: E402
from stonesoup.types.detection import Detection, MissedDetection  # noqa: E402
from stonesoup.types.hypothesis import SingleHypothesis  # noqa: E402
from stonesoup.types.multihypothesis import MultipleHypothesis  # noqa: E402
from stonesoup.types.numeric import Probability  # noqa: E402
from stonesoup.types.prediction import ParticleStatePrediction  # noqa: E402
from stonesoup.updater.particle import SMCPHDUpdater  # noqa: E402

from sat_agent import sensor_model  # noqa: E402, I100
from sat_agent.config import SatParams, SensorParams  # noqa: E402
from sat_agent.phd_filter import update_weights  # noqa: E402


# SMCPHDUpdater.update in 1.9.1 writes the posterior weights only inside its resampling branch
# (with resampler=None it returns the predicted weights); an ESS resampler whose threshold no
# particle set falls below takes that branch without resampling.
NEVER_RESAMPLE = ESSResampler(threshold=0.0)


class RangeDependentBearingRange(CartesianToBearingRange):
    """Noise-free range/bearing likelihood with the paper's range-dependent sigmas."""

    sensor: SensorParams = Property(doc='sigmas and the sensing square of the paper')

    def logpdf(self, state1, state2, **kwargs):
        predicted = self._function(state2, noise=False)          # rows: bearing, range
        residual = state1.state_vector.astype(np.float64) - predicted
        bearing_error = Bearing.mod_angle(np.asarray(residual[0, :], dtype=float))
        distance = np.asarray(predicted[1, :], dtype=float)
        sigma_range = self.sensor.sigma_range_0 + self.sensor.sigma_range_slope * distance ** 2
        sigma_bearing = (self.sensor.sigma_bearing_0
                         + self.sensor.sigma_bearing_slope * distance)
        log_g = (norm.logpdf(np.asarray(residual[1, :], dtype=float), scale=sigma_range)
                 + norm.logpdf(bearing_error, scale=sigma_bearing))
        return np.where(_in_view(state2.state_vector, self.translation_offset, self.sensor),
                        log_g, -np.inf)


class SquareFovSMCPHDUpdater(SMCPHDUpdater):
    """Stone Soup's SMC-PHD update with p_D(x) = prob_detect inside the square, 0 outside."""

    sensor_pose: StateVector = Property(doc='agent position [x, y]')
    sensor: SensorParams = Property(doc='sensing square side')

    def get_log_weights_per_hypothesis(self, hypotheses):
        log_weights = super().get_log_weights_per_hypothesis(hypotheses)
        prediction = hypotheses[0].prediction
        in_view = _in_view(prediction.state_vector, self.sensor_pose, self.sensor)
        with np.errstate(divide='ignore'):
            log_missed = np.log(1.0 - float(self.prob_detect))
        log_weights[:, 0] = np.where(in_view, log_missed, 0.0) + prediction.log_weight
        return log_weights


def _in_view(state_vectors, pose, sensor):
    points = np.asarray(state_vectors, dtype=float)[[0, 2], :].T
    return sensor_model.in_sensing_square(points, np.asarray(pose, dtype=float).ravel()[:2],
                                          sensor.square_side)


def _stonesoup_update(states, weights, measurements, pose, sensor):
    offset = StateVector([pose[0], pose[1]])
    model = RangeDependentBearingRange(ndim_state=4, mapping=(0, 2), noise_covar=np.eye(2),
                                       translation_offset=offset, sensor=sensor)
    prediction = ParticleStatePrediction(StateVectors(states.T), log_weight=np.log(weights))
    hypotheses = [SingleHypothesis(prediction, MissedDetection())]
    for z in measurements:    # Stone Soup's bearing-range order: [bearing, range]
        detection = Detection(StateVector([Bearing(z[1]), z[0]]), measurement_model=model)
        hypotheses.append(SingleHypothesis(prediction, detection))
    updater = SquareFovSMCPHDUpdater(
        measurement_model=model, prob_detect=Probability(sensor.p_detect),
        clutter_intensity=sensor_model.clutter_intensity(sensor), resampler=NEVER_RESAMPLE,
        sensor_pose=offset, sensor=sensor)
    return np.exp(np.asarray(updater.update(MultipleHypothesis(hypotheses)).log_weight,
                             dtype=float))


def _scene(seed, n_particles, n_measurements, sensor, pose):
    rng = np.random.default_rng(seed)
    states = rng.normal(0.0, 1.0, (n_particles, 4))
    # Half a tracked cloud around a target in the square, half diffuse over a wide area.
    half = n_particles // 2
    target = pose + rng.uniform(-4, 4, 2)
    states[:half, [0, 2]] = target + rng.normal(0, 1.5, (half, 2))
    states[half:, [0, 2]] = pose + rng.uniform(-20, 20, (n_particles - half, 2))
    weights = rng.uniform(0.1, 1.0, n_particles) * 2.0 / n_particles
    # The target's detection first, then clutter around the agent (most of the paper's clutter
    # falls beyond the square and would leave nothing to compare).
    z, _ = sensor_model.simulate_scan(target[None], pose, replace(sensor, clutter_rate=0.0), rng)
    extra = np.column_stack([rng.uniform(0, sensor.max_range, n_measurements),
                             rng.uniform(-np.pi, np.pi, n_measurements)])
    return states, weights, np.vstack([z, extra])[:max(n_measurements, 0)]


@pytest.mark.parametrize('seed,n_measurements,p_detect', [
    (0, 1, 0.99), (1, 8, 0.99), (2, 15, 0.99), (3, 12, 0.7), (4, 0, 0.99)])
def test_update_weights_equal_stonesoup_smcphd(seed, n_measurements, p_detect):
    params = SatParams()
    sensor = SensorParams(p_detect=p_detect)
    pose = np.array([40.0, 60.0])
    states, weights, z = _scene(seed, 3000, n_measurements, sensor, pose)
    ours = update_weights(states, weights, z, pose, sensor)
    theirs = _stonesoup_update(states, weights, z, pose, sensor)
    assert len(z) == n_measurements
    assert params.sensor.square_side == sensor.square_side
    np.testing.assert_allclose(ours, theirs, rtol=1e-9, atol=0.0)
    in_view = _in_view(states.T, pose, sensor)
    assert in_view.sum() > 500 and (~in_view).sum() > 500
    if n_measurements:
        assert not np.allclose(ours[in_view], weights[in_view] * (1 - p_detect))


def test_stock_stonesoup_differs_when_the_likelihood_is_not_overridden():
    """Guard: the comparison above is sensitive to the likelihood (it is not vacuous)."""
    sensor = SensorParams()
    pose = np.array([40.0, 60.0])
    states, weights, z = _scene(5, 500, 5, sensor, pose)
    ours = update_weights(states, weights, z, pose, sensor)
    coarse = SensorParams(sigma_range_0=2.0)
    theirs = _stonesoup_update(states, weights, z, pose, coarse)
    assert not np.allclose(ours, theirs, rtol=1e-6)
