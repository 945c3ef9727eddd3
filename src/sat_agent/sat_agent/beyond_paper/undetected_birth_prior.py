r"""Beyond the paper: measurement-driven births where the search density holds undetected targets.

Paper: the birth intensity b_k is open. phd_filter seeds, for every measurement z whose position
x_z lies in the sensing square, the mass m_z = m_b (r(z) / r_max) (1 - tau(z) / (kappa + tau(z)))
(adaptive birth, Ristic, Clark, Vo and Vo 2012). That is the small-rho form of the probability
that z is a new target,

    P(new | z) = rho(x_z) / (kappa(x_z) + rho(x_z)) ~ rho(x_z) / kappa(x_z),

with rho = p_D times the density of undetected targets and kappa the clutter's density at x_z in
position space (lambda / (r_c 2 pi r) per m^2 for clutter uniform in range and bearing, hence the
r), taken with rho uniform over the square: m_b / r_max stands for the unknown p_D rho / (lambda /
(r_c 2 pi)).

Here (``phd.birth_prior`` 'undetected'): rho follows the undetected-target density the agent
already keeps, the search density's u = -ln v per cell (beyond_paper/regrowing_density.py: the
expected undetected targets in the cell), predicted to this scan and fused, before the scan's own
correction. Each m_z is multiplied by

    w(z) = u(c_z) / mean_{c in S_a(s_k)} u(c),

the undetected mass at z's cell against an even spread over the square's cells. The clutter's
expected seeded mass per scan is unchanged (clutter density times r is flat over the square, so its
mean of w is 1); it moves from the part of the square the agent scanned on the previous step,
where a new target is ~1 / (1 - p_D) = 100 times less likely than unscanned ground, to the part
not scanned lately (a searching agent's leading strip), where new targets enter the square. m_z is
capped at 1: one measurement stands for one target at most. ``phd.birth_prior_blur`` reads u
through a Gaussian of that spread: the measurement errs ~1 m in range, as deep as a quarter of
the strip a searching agent's move uncovers. A square with no undetected mass
(u = 0 in every cell: the start of a mission, the filter's empty prior) keeps the uniform prior.

Why: at the random default ~0.4 false alarms fall in a square per scan against ~0.03 targets, and
most measurements a searching agent looks at are clutter (docs/persistent_trials.md, session 23);
clutter in ground just scanned is the part the filter's own model can tell apart.
Measured (session 24, persistent profile, random, 300 fresh dev seeds each, paired): sharp,
detected -3.7 and tracked -3.1 points (the density counts a square's edge and a cell the noisy
measurement fell into as scanned); blurred by 1.125 m with search.scan_detection 'births',
+0.5 and +0.2, not significant. Not kept: docs/persistent_trials.md.
Choice: ``phd.birth_prior`` ('uniform': w = 1, phd_filter.PRIOR_OF).
"""

import numpy as np


def undetected_prior(density, positions: np.ndarray, pose, blur: float = 0.0) -> np.ndarray:
    """Return w(z) for each position (module docstring): u at its cell over the square's mean u.

    density: the agent's SearchDensity, predicted to this scan and not yet corrected with it;
    blur: ``phd.birth_prior_blur``, u read through a Gaussian of that spread (m).
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 2)
    square = density.undetected_in_square(pose)
    mean = float(square.mean()) if square.size else 0.0
    if mean <= 0.0:
        return np.ones(len(positions))
    return density.undetected_at(positions, blur) / mean
