"""SMC-PHD filter for true targets plus the search density: the SAT-PHD filter of the paper.

True-target PHD D^1 is a weighted particle set (Vo, Singh and Doucet 2003); the virtual-target PHD
D^0 is the lattice of ``search_density``. One step is ``predict(s_{k-1})`` (Eqn. satphd_predict)
then ``correct(Z_k, s_k)`` (Eqn. satphd_correct).

Birth intensity b_k(x) of Eqn. satphd_predict, with x = [p, v] (position p, velocity v):

    b_k(x) = r_u U_A(p) N(v; 0, sigma_v^2 I)
           + sum_{z in Z'_{k-1}} m_z integral pi(x | x') beta_z(x') dx',
    beta_z(x') = law of p' = h^{-1}(z + e, s_{k-1}), e ~ N(0, Sigma(z)), kept when p' is in
                 S_a(s_{k-1}), times N(v'; 0, sigma_v^2 I),

- uniform part: mass r_u = ``phd.birth_rate`` per step, positions uniform over A, velocities
  N(0, sigma_v^2), sigma_v = ``phd.birth_velocity_std``; ``phd.birth_particles_uniform`` particles
  of weight r_u / n_u each, drawn at every predict.
- measurement-driven part (adaptive birth, Ristic, Clark, Vo and Vo 2012): after the update with
  Z_k, for every z in Z' (the measurements whose position h^{-1}(z, s_k) lies in the sensing
  square, the only place a target can be detected), ``phd.birth_particles_per_measurement``
  particles are drawn at h^{-1}(z + v, s_k), v ~ N(0, diag(sigma_r^2, sigma_b^2)) at z's range,
  with velocity N(0, sigma_v^2); draws that land outside the square are dropped. Their weight is
  m_z / n_z with m_z = m_b (r(z) / r_max) (1 - tau(z) / (kappa + tau(z))), m_b =
  ``phd.birth_mass_measurement``: a birth intensity uniform over the square's area has density
  proportional to the range r in [range, bearing] space (dx dy = r dr dtheta) while the clutter's
  is flat, so a far measurement is likelier a new target than one next to the agent (where
  clutter is kappa / r per m^2); and the share tau / (kappa + tau) of z that the predicted
  targets already explain (``update_weights``) seeds nothing, as in Ristic et al.'s update of
  newborn weights by kappa + tau + gamma. They are kept aside (not in the
  posterior, so they do not bias the extracted count) and join the targets at the next predict,
  where they are propagated with the motion model like every particle; the next scan then
  confirms them (a target is there) or kills them (clutter).

Both parts are interpretations: the paper leaves the birth model open. The addition
``additions.newborn_gate`` drops the newborns the next square does not cover
(beyond_paper/newborn_gate.py; ``keep_newborns`` is the paper's). ``phd.birth_prior``
'undetected' weighs m_z by where the search density holds undetected targets instead of taking
them uniform over the square (beyond_paper/undetected_birth_prior.py; the default 'uniform' weighs
nothing); m_z is capped at 1 either way.

Gating: p_D is 0 outside the sensing square, so the update leaves those particles' weights
unchanged, (1 - 0) w = w; ``update_weights`` computes likelihoods only for the particles inside
(``detection_factors``).
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from sat_agent import motion_model, sensor_model
from sat_agent.beyond_paper.kernel_likelihood import filter_bandwidth
from sat_agent.beyond_paper.newborn_gate import untested_newborns
from sat_agent.beyond_paper.undetected_birth_prior import undetected_prior
from sat_agent.config import BIRTH_PRIORS, PhdParams, SatParams, SensorParams
from sat_agent.search_density import Lattice, SearchDensity

# Largest exponent used when scaling the clutter term; exp(700) is finite in float64, and a
# clutter term that large makes the measurement's contribution vanish anyway.
_MAX_EXPONENT = 700.0


@dataclass
class ParticlePHD:
    """Weighted particles of the true-target PHD: rows of ``states`` are [x, vx, y, vy]."""

    states: np.ndarray   # (N, 4)
    weights: np.ndarray  # (N,)

    @property
    def mass(self) -> float:
        """Expected number of targets, the integral of the PHD."""
        return float(self.weights.sum())

    @classmethod
    def empty(cls) -> 'ParticlePHD':
        """Return a PHD with no particles (no targets)."""
        return cls(np.zeros((0, 4)), np.zeros(0))

    def __len__(self) -> int:
        return len(self.weights)


def update_weights(states: np.ndarray, weights: np.ndarray, measurements: np.ndarray, pose,
                   sensor: SensorParams, explained: Optional[np.ndarray] = None,
                   bandwidth: float = 0.0, norm=np.hypot) -> np.ndarray:
    """Return the corrected weights of Eqn. satphd_correct (true-target part).

    w_i <- [1 - p_D(x_i) + sum_z p_D(x_i) g(z | x_i) / (kappa(z) + tau(z))] w_i,
    tau(z) = sum_j p_D(x_j) g(z | x_j) w_j, kappa = lambda f_c (sensor_model.clutter_intensity).

    Only particles inside the sensing square are touched (``detection_factors``); the others are
    copied bit for bit.

    explained: optional (M,) output array, filled with tau(z) / (kappa(z) + tau(z)), the share
    of each measurement the predicted targets explain (0 when no particle is in the square).
    bandwidth: g's kernel spread (sensor_model.log_likelihood; 0: the sensor's own g); norm:
    the distances' (sensor_model.log_likelihood).
    """
    new_weights = np.array(weights, dtype=float, copy=True)
    points = motion_model.positions(states)
    inside = np.flatnonzero(sensor_model.in_sensing_square(points, pose, sensor.square_side))
    new_weights[inside] *= detection_factors(points[inside], new_weights[inside], measurements,
                                             pose, sensor, explained, bandwidth, norm)
    return new_weights


def detection_factors(points: np.ndarray, weights: np.ndarray, measurements: np.ndarray, pose,
                      sensor: SensorParams, explained: Optional[np.ndarray] = None,
                      bandwidth: float = 0.0, norm=np.hypot) -> np.ndarray:
    """Return the factors 1 - p_D + sum_z p_D g / (kappa + tau) of particles inside the square.

    points and weights: the (N, 2) positions and weights of the particles inside S_a(pose),
    where p_D = sensor.p_detect (Eqn. sensing_model); tau sums over them alone. Each
    measurement's column is scaled by its largest log-likelihood before exponentiating, so g
    values far below float range do not underflow to 0 / 0. When kappa = 0 and no particle can
    have produced z (tau(z) = 0) the term is 0 / 0; it is taken as 0: z then says nothing about
    the existing particles (the measurement-driven birth accounts for it). explained and
    bandwidth: as in ``update_weights``; norm: as in sensor_model.log_likelihood.
    """
    if explained is not None:
        explained[:] = 0.0
    p_d = sensor.p_detect
    z = np.asarray(measurements, dtype=float).reshape(-1, 2)
    if not len(z) or not len(points):
        return np.full(len(points), 1.0 - p_d)
    log_g = sensor_model.log_likelihood(z, points, pose, sensor, bandwidth, norm)
    peak = log_g.max(axis=0)                    # (M,) scale per measurement
    np.subtract(log_g, peak, out=log_g)
    g_scaled = np.exp(log_g, out=log_g)         # g / exp(peak), in (0, 1]
    tau_scaled = p_d * (weights @ g_scaled)     # tau(z) / exp(peak)
    kappa = sensor_model.clutter_intensity(sensor)
    if kappa > 0.0:
        kappa_scaled = np.exp(np.minimum(np.log(kappa) - peak, _MAX_EXPONENT))
    else:
        kappa_scaled = np.zeros_like(peak)
    denominator = kappa_scaled + tau_scaled
    inverse = np.divide(1.0, denominator, out=np.zeros_like(denominator),
                        where=denominator > 0.0)
    if explained is not None:
        explained[:] = tau_scaled * inverse
    return (1.0 - p_d) + p_d * (g_scaled @ inverse)


def systematic_resample(weights: np.ndarray, count: int, rng: np.random.Generator) -> np.ndarray:
    """Draw ``count`` indices by systematic resampling (one uniform offset, N strata)."""
    cumulative = np.cumsum(weights)
    total = cumulative[-1]
    points = (rng.random() + np.arange(count)) * (total / count)
    return np.minimum(np.searchsorted(cumulative, points, side='right'), len(weights) - 1)


def particle_budget(mass: float, phd: PhdParams) -> int:
    """Particles kept after resampling: particles_per_target per unit of mass, clipped."""
    wanted = int(round(mass * phd.particles_per_target))
    return int(np.clip(wanted, phd.min_particles, phd.max_particles))


def resample(phd_set: ParticlePHD, params: PhdParams, rng: np.random.Generator) -> ParticlePHD:
    """Resample to the budget; every particle gets weight mass / N, so the mass is kept."""
    mass = phd_set.mass
    if len(phd_set) == 0 or not mass > 0.0:
        return ParticlePHD.empty()
    count = particle_budget(mass, params)
    index = systematic_resample(phd_set.weights, count, rng)
    return ParticlePHD(phd_set.states[index], np.full(count, mass / count))


def uniform_births(params: SatParams, rng: np.random.Generator) -> ParticlePHD:
    """Uniform part of b_k: birth_rate mass over A, velocities N(0, birth_velocity_std^2)."""
    count = params.phd.birth_particles_uniform
    if count == 0 or params.phd.birth_rate == 0.0:
        return ParticlePHD.empty()
    states = np.empty((count, 4))
    states[:, 0] = rng.uniform(0.0, params.area.width, count)
    states[:, 2] = rng.uniform(0.0, params.area.height, count)
    states[:, [1, 3]] = rng.normal(0.0, params.phd.birth_velocity_std, (count, 2))
    return ParticlePHD(states, np.full(count, params.phd.birth_rate / count))


@dataclass
class BirthSpots:
    """The measurements of the last scan that seed births, where, and with what masses."""

    measurements: np.ndarray   # (M', 2) the [range, bearing] z of Z' (positions in the square)
    positions: np.ndarray      # (M', 2) h^-1(z, s_k)
    masses: np.ndarray         # (M',) m_z

    @classmethod
    def empty(cls) -> 'BirthSpots':
        """Return no spots."""
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))


# phd.birth_prior's choices, in config.BIRTH_PRIORS' order; 'uniform' weighs nothing (w = 1).
PRIOR_OF = dict(zip(BIRTH_PRIORS, (None, undetected_prior)))


def birth_spots(measurements: np.ndarray, pose, params: SatParams,
                explained: Optional[np.ndarray] = None,
                prior: Optional[np.ndarray] = None) -> BirthSpots:
    """Measurements of Z' (positions in the sensing square) with their birth masses m_z.

    explained: (M,) share tau / (kappa + tau) of each measurement already explained by the
    targets (update_weights); a measurement only seeds the unexplained rest of its mass.
    prior: (M,) weight w(z) of the undetected-target density at each measurement against a
    uniform one (``phd.birth_prior``; None: 1). m_z is capped at 1, one target.
    """
    z = np.asarray(measurements, dtype=float).reshape(-1, 2)
    sensor = params.sensor
    unexplained = np.ones(len(z)) if explained is None else 1.0 - np.asarray(explained, float)
    weight = np.ones(len(z)) if prior is None else np.asarray(prior, dtype=float)
    positions = sensor_model.to_position(z, pose)
    keep = sensor_model.in_sensing_square(positions, pose, sensor.square_side)
    # Birth intensity uniform over the square's area: in measurement space its density grows
    # with the range (dx dy = r dr dtheta) while the clutter's is flat, so a far measurement is
    # more likely a new target than a near one; mass m_z = m_b (r / r_max) (1 - explained) w.
    masses = (params.phd.birth_mass_measurement * np.minimum(z[keep, 0] / sensor.max_range, 1.0)
              * np.clip(unexplained[keep], 0.0, 1.0) * weight[keep])
    return BirthSpots(z[keep], positions[keep], np.minimum(masses, 1.0))


def measurement_births(spots: BirthSpots, pose, params: SatParams,
                       rng: np.random.Generator) -> ParticlePHD:
    """Measurement-driven part of b_{k+1} from the birth spots of Z_k (module docstring)."""
    z, mass_z = spots.measurements, spots.masses
    sensor = params.sensor
    per_z = params.phd.birth_particles_per_measurement
    if len(z) == 0 or per_z == 0 or params.phd.birth_mass_measurement == 0.0:
        return ParticlePHD.empty()
    repeated = np.repeat(z, per_z, axis=0)
    sigma_r, sigma_b = sensor_model.measurement_sigmas(repeated[:, 0], sensor)
    noisy = repeated + rng.standard_normal(repeated.shape) * np.column_stack([sigma_r, sigma_b])
    points = sensor_model.to_position(noisy, pose)
    keep = sensor_model.in_sensing_square(points, pose, sensor.square_side)
    keep &= np.repeat(mass_z > 0.0, per_z)
    count = int(keep.sum())
    states = np.empty((count, 4))
    states[:, motion_model.POSITION] = points[keep]
    states[:, motion_model.VELOCITY] = rng.normal(0.0, params.phd.birth_velocity_std, (count, 2))
    weight = np.repeat(mass_z / per_z, per_z)[keep]
    return ParticlePHD(states, weight)


def keep_newborns(newborn_states: np.ndarray, pose, sensor: SensorParams) -> np.ndarray:
    """Return a mask of none to drop: the paper corrects every newborn like any particle."""
    return np.zeros(len(newborn_states), dtype=bool)


class SatPhdFilter:
    """SAT-PHD filter of one agent: true-target particles and the virtual-target lattice."""

    def __init__(self, params: SatParams, rng: np.random.Generator):
        self.params = params
        self.rng = rng
        self.targets = ParticlePHD.empty()
        self.search = SearchDensity(
            Lattice.for_area(params.area, params.search.lattice_spacing), params)
        # Measurement-driven births from the last scan, joining the targets at the next predict.
        self.pending_births = ParticlePHD.empty()
        # Where pending_births were seeded: a searching agent may look there again (agent_core).
        self.birth_spots = BirthSpots.empty()
        self._newborn = slice(0, 0)
        self._dropped_newborns = (untested_newborns if params.additions.newborn_gate
                                  else keep_newborns)
        self.bandwidth = filter_bandwidth(params)
        self._birth_prior = PRIOR_OF[params.phd.birth_prior]

    def predict(self, previous_pose) -> None:
        """Eqn. satphd_predict: survival p_S, NCV transition, births, search-density decay."""
        params = self.params
        survivors = len(self.targets)
        moving = np.concatenate([self.targets.states, self.pending_births.states])
        weights = np.concatenate([self.targets.weights * params.motion.p_survival,
                                  self.pending_births.weights])
        moved = motion_model.propagate(moving, params.motion, self.rng)
        born = uniform_births(params, self.rng)
        self.targets = ParticlePHD(np.concatenate([moved, born.states]),
                                   np.concatenate([weights, born.weights]))
        self._newborn = slice(survivors, len(moving))
        self.pending_births = ParticlePHD.empty()
        self.search.predict(previous_pose)

    def correct(self, measurements: np.ndarray, pose) -> None:
        """Eqn. satphd_correct: PHD update, search correction, births for k+1, resampling."""
        params = self.params
        explained = np.zeros(len(np.asarray(measurements).reshape(-1, 2)))
        weights = update_weights(self.targets.states, self.targets.weights, measurements, pose,
                                 params.sensor, explained, self.bandwidth)
        dropped = self._dropped_newborns(self.targets.states[self._newborn], pose,
                                         params.sensor)
        weights[self._newborn.start + np.flatnonzero(dropped)] = 0.0
        self.targets = resample(ParticlePHD(self.targets.states, weights), params.phd, self.rng)
        # The births' prior is the density before this scan's correction (as the scan found it).
        prior = None if self._birth_prior is None else self._birth_prior(
            self.search, sensor_model.to_position(measurements, pose), pose,
            params.phd.birth_prior_blur)
        self.search.correct(pose)
        self.birth_spots = birth_spots(measurements, pose, params, explained, prior)
        self.pending_births = measurement_births(self.birth_spots, pose, params, self.rng)
        self._newborn = slice(0, 0)
