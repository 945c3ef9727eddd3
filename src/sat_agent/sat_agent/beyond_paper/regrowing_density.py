r"""Addition: a search density that regrows as the filter's model says targets can appear.

Paper: the virtual targets' density D^0 (stored as v = D^0 |A| in [0, 1], 1 = just searched;
search_density.py) decays by a constant J outside the previous pose's square (third line of
Eqn. satphd_predict) and is set to 1 inside the current square (Eqn. satphd_correct). With
J = 0.999 and beta = 0.5 a searched cell is "unvisited" again only after ln 0.5 / ln J ~ 693
steps, whatever the births and motion of the targets: a swarm sweeps once.

Addition: v is derived from the filter's own model of the true targets instead (one source of
truth: ``phd.birth_rate``, ``motion.p_survival``, the NCV motion of ``motion`` and
``phd.birth_velocity_std``, ``sensor.p_detect``). Derivation:

Let u_k(c) be the expected number of targets in lattice cell c at step k that no scan has
detected (the undetected part of the true-target PHD of Eqn. satphd_predict, integrated over c
and over velocity). Its prediction is the PHD's, restricted to targets not seen since:

    u_{k|k-1}(c) = b(c) + p_S sum_{c'} K(c | c') u_{k-1}(c'),

- b(c) = ``phd.birth_rate`` |c| / |A|: the uniform part of the birth intensity b_k over the
  cell (the measurement-driven part is seeded by detections, i.e. by targets already seen, so
  it adds nothing undetected);
- p_S = ``motion.p_survival``;
- K(c | c'): the position marginal of the NCV transition pi_{k|k-1} over one step. A target at
  p' with velocity v' moves to p' + v' T + w, w ~ N(0, q T^3 / 3 I) (the position block of
  Q, q = ``motion.process_noise``). An undetected target's velocity is not observed; at its
  prior N(0, sigma_v^2 I) (sigma_v = ``phd.birth_velocity_std``; beyond the derivation,
  ``search.density_velocity_std`` may set K's sigma_v apart from the filter's) the step is
  N(0, sigma_K^2 I) with sigma_K^2 = sigma_v^2 T^2 + q T^3 / 3. On the lattice, K is the
  separable discrete Gaussian kernel of that variance, e^{-t} I_n(t) per axis with
  t = sigma_K^2 / s^2 (s the lattice spacing; ``discrete_gaussian``): its variance is
  exactly t and n steps of it are exactly one step of n t, so the analytic cases of the tests
  hold to rounding. Redrawing the velocity each step is a Markov approximation on positions:
  it ignores that a walker keeps its velocity, so over many steps the true spread (growing
  like t^2 sigma_v^2) is wider than the blur's (like t sigma_K^2). The boundary reflects
  (scipy.ndimage mode 'reflect'): targets stay in A, where they are born, so undetected mass
  does not leave A.

The correction with the scan at s_k: an undetected target in S_a(s_k) is detected with p_D
(= ``sensor.p_detect``) and stays undetected with 1 - p_D, the missed-detection term of Eqn.
satphd_correct:

    u_k(c) = (1 - p_D) u_{k|k-1}(c) for c in S_a(s_k), u_{k|k-1}(c) elsewhere.

(``search.scan_detection`` 'births', beyond the paper, trialled in session 24 and not kept:
p_D P_in(c) instead of p_D, P_in(c) the chance that the measurement of a target at c lands in
the square, where the filter seeds births; ``birth_detection``.)

What is stored is v_k(c) = exp(-u_k(c)): under the PHD's Poisson approximation the
probability that no undetected target is in c now. It keeps the paper's convention (values in
[0, 1], 1 = just searched with p_D = 1) and its fusion: the elementwise max of v is the min of
u, i.e. each cell as the agent that searched it last knows it. In v:

    v_{k|k-1} = exp(-b) exp(-p_S K u_{k-1}),   v_k = v_{k|k-1}^(1 - p_D) in S_a(s_k).

The paper as a special case: with K the identity, p_S = 1 and b = -ln J the prediction is
v_{k|k-1} = J v_{k-1}, and with p_D = 1 the correction sets v = 1 in the square: Eqns.
satphd_predict and satphd_correct with J constant. Like the paper, the cells of
S_a(s_{k-1}) are held in the prediction (its factor (1 - p_D(s_{k-1})) J + p_D(s_{k-1}) is 1
there); elsewhere this is the paper's third line with the state-dependent
J_k(c) = exp(-[b + p_S K u_{k-1} - u_{k-1}](c)), which exceeds 1 where mass dies or moves
out faster than it arrives (the paper's J is in [0, 1]).

The prior is the filter's: its PHD starts empty (no target at k = 0), so u_0 = 0 and v_0 = 1;
the paper's "never searched" v = 0 is u = inf. Without any search u tends to
b / (1 - p_S) per cell, birth_rate / (1 - p_S) targets over A (1 with the paper's values), the
filter's own steady diffuse birth mass. A cell searched (p_D = 1) at step t amid searched cells
regrows as u(k) = b (1 - p_S^(k - t)) / (1 - p_S); next to unsearched cells K carries their
mass in as well.

Since u_0 = 0 and both steps are linear in u and b, u is proportional to ``phd.birth_rate``: the
rate scales the density and leaves the order of the nodes' worth, what the walks weigh
(beyond_paper/persistent_planning.py), as it is. The paper's 0.01 a step is a quarter of the
random default's (~6 targets over steps 1-150); docs/persistent_trials.md, session 43, measures
what that costs through the filter's diffuse births, the one place the rate still acts.

A neighbour's density of step j < k is predicted to k with the same model (the cells of its
sender's square s_j held in the first step, as for the own density), so fusion ages as the
own density does (issue 14 item 1).

Numbers: with the paper's birth rate b = 1e-6 per 1 m cell and step, so v stays within 1e-3
of 1; the radio carries v in float32, whose resolution near 1 (6e-8) is that of u, a few
per cent of one step's births: enough to order nodes, which is what the planner needs. Values
are handled in float64 inside the agent.

Switch: ``additions.regrowing_density`` (off: search_density.ConstantDecay, the paper's J).
"""

import math

import numpy as np
from scipy import ndimage, special

from sat_agent import density_codec
from sat_agent.config import SatParams
from sat_agent.sensor_model import measurement_sigmas

# Kernel taps are added until the next one is below this share of the kernel's mass: the
# truncated kernel's variance is then that of the untruncated one to ~1e-12.
KERNEL_TAIL = 1e-15
# Smallest value whose logarithm is taken (v = 0, never searched under the paper's density,
# stands for u = -ln(tiny) ~ 708 expected targets in the cell: more than anywhere else).
TINY = np.finfo(float).tiny


def expected_undetected(values: np.ndarray) -> np.ndarray:
    """Return u = -ln v, the expected number of undetected targets per cell (module docstring)."""
    return -np.log(np.clip(values, TINY, 1.0))


def density_velocity_std(params: SatParams) -> float:
    """sigma_v of K: ``search.density_velocity_std``, or ``phd.birth_velocity_std`` when 0."""
    return params.search.density_velocity_std or params.phd.birth_velocity_std


def step_variance(params: SatParams) -> float:
    """sigma_K^2 = sigma_v^2 T^2 + q T^3 / 3 (m^2): the one-step position spread of K."""
    dt = params.motion.dt
    return (density_velocity_std(params) ** 2 * dt ** 2
            + params.motion.process_noise * dt ** 3 / 3.0)


def discrete_gaussian(variance: float) -> np.ndarray:
    """Return the symmetric kernel e^{-t} I_n(t), n = -r..r, t = variance (lattice units^2).

    Its taps sum to 1 (renormalised after truncation) and its variance is t (module
    docstring); t = 0 is the identity [1].
    """
    if variance <= 0.0:
        return np.ones(1)
    radius = 1
    while special.ive(radius, variance) > KERNEL_TAIL:
        radius += 1
    taps = special.ive(np.abs(np.arange(-radius, radius + 1)), variance)
    return taps / taps.sum()


def birth_detection(offsets, half: float, sigma: float) -> np.ndarray:
    """Return P_in per cell: a target there gives a measurement inside the square (births).

    offsets: (rows' y, columns' x) from the pose; the square is [-half, half]^2. Per axis the
    measurement errs N(0, sigma^2) (the range sigma, taken along both axes), so P_in is the
    product of the two axes' Gaussian masses over [-half, half]: ~1 at the centre, 1/2 at an
    edge's middle, 1/4 at a corner. A measurement outside the square seeds no birth (phd_filter),
    so the scan detects the target there only with p_D P_in (``search.scan_detection``).
    """
    rows, cols = (np.asarray(a, dtype=float) for a in offsets)
    per_axis = [special.ndtr((half - a) / sigma) - special.ndtr((-half - a) / sigma)
                for a in (rows, cols)]
    return np.outer(per_axis[0], per_axis[1])


class Regrowth:
    """The undetected-target model of the search density (module docstring).

    ``predicted`` and ``corrected`` work on v (the stored values) like the paper's
    search_density.ConstantDecay, which this replaces.
    """

    # v_0 = exp(-u_0) with u_0 = 0: the filter's PHD starts empty.
    initial = 1.0
    # Values within 1e-3 of 1 that differ by a few ulps from cell to cell (density_codec.py).
    wire_encoding = density_codec.SMOOTH

    def __init__(self, params: SatParams, cells: int, spacing: float):
        self.birth = params.phd.birth_rate / cells
        self.survival = params.motion.p_survival
        self.miss = 1.0 - params.sensor.p_detect
        self.half_side = params.sensor.square_side / 2.0
        # The range sigma at the square's half side: the noise that carries an edge target's
        # measurement out of the square.
        self.edge_sigma = (float(measurement_sigmas(self.half_side, params.sensor)[0])
                           if params.search.scan_detection == 'births' else None)
        self.kernel = discrete_gaussian(step_variance(params) / spacing ** 2)

    def predicted(self, values: np.ndarray, window, steps: int) -> np.ndarray:
        """Return v predicted `steps` steps ahead; the cells of window are held in the first."""
        u = expected_undetected(np.asarray(values, dtype=float))
        for step in range(steps):
            ahead = self.birth + self.survival * self.blurred(u)
            if step == 0 and window is not None:
                ahead[window] = u[window]
            u = ahead
        return np.exp(-u)

    def blurred(self, u: np.ndarray) -> np.ndarray:
        """K u: the discrete Gaussian along both axes, reflected at the area's border."""
        if self.kernel.size == 1:
            return u.copy()
        across = ndimage.convolve1d(u, self.kernel, axis=1, mode='reflect')
        return ndimage.convolve1d(across, self.kernel, axis=0, mode='reflect')

    def corrected(self, seen: np.ndarray, offsets=None) -> np.ndarray:
        """Return v of the cells in the square after the scan: v^(1 - d), u times 1 - d.

        d = p_D, or with ``search.scan_detection`` 'births' p_D P_in (``birth_detection``;
        offsets: the rows' y and the columns' x from the pose, needed then).
        """
        if self.edge_sigma is None:
            return np.power(seen, self.miss)
        detect = (1.0 - self.miss) * birth_detection(offsets, self.half_side, self.edge_sigma)
        return np.power(seen, 1.0 - detect)

    def stationary(self) -> float:
        """Return u per cell with no search at all: b / (1 - p_S) (inf when p_S = 1)."""
        return self.birth / (1.0 - self.survival) if self.survival < 1.0 else math.inf
