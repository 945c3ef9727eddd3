"""Addition (choice of additions.track_coasting): report a coasted track while it lowers OSPA.

Paper: n_hat = round(mass) (Section "Search-and-Track Density") keeps a target while its PHD
mass is at least 1/2; out of view that mass decays with p_S, so track_coasting's default
('survival') reports a coasted track while p_S^t >= tau = ``phd.coast_survival`` (t: steps
since its last estimate). That rule asks only whether the target still exists, not whether the
fit still lies on it.
Addition (``phd.coast_report`` 'ospa', session 26): report the fit's position x_hat at step k
while doing so is expected to lower the OSPA of Eqn. ospa (cut-off c =
``cooperation.ospa_cutoff``). The target exists with probability a = p_S^t; if it does, the
fit errs by d, a 2-D Gaussian of per-axis spread s = KAPPA times the fit's standard error
(Track.drift_spread: the fit understates its drift, beyond_paper/track_revisit.py). Per target,
before OSPA's normalisation by max(m, n):

    report:       a E + (1 - a) c^2,   E = E[min(d, c)^2] = 2 s^2 (1 - exp(-c^2 / (2 s^2)))
    stay silent:  a c^2

(E: d is Rayleigh, P(d^2 > u) = exp(-u / (2 s^2)), integrated over [0, c^2]). Weighing a
false report by w = tau / (1 - tau), so that the rule is the paper's threshold again for a fit
without error, a track is reported while

    a (c^2 - E) >= w (1 - a) c^2   <=>   a >= tau / (1 - (1 - tau) E / c^2).

At s = 0 that is tau (the 'survival' rule); as s grows E tends to c^2 and the threshold to 1,
so a fit that has drifted, or never knew its velocity, stops being reported before p_S^t says
the target is gone. A report within 5 m of the target is what the tracked share counts, and
the rule drops reports only when they are likely to lie far off.
Measured (session 26, by a rule set before the trial; docs/persistent_trials.md): on dev seeds
4901-5200 of the random default, paired with config/persistent.yaml, OSPA -0.02 m (95 % CI
[-0.05, -0.01], p 0.028), tracked -0.20 points (p < 0.001), false-track steps -4.6 per run;
not kept (the rule asked for an OSPA fall at p < 0.01 with no loss of tracked share).
"""

import numpy as np


def expected_squared_distance(spread: float, cutoff: float) -> float:
    """Return E[min(d, c)^2] for a 2-D Gaussian error of per-axis spread (module docstring).

    c^2 for an infinite spread (a fit with no error estimate), 0 for none.
    """
    if not np.isfinite(spread):
        return cutoff ** 2
    if spread <= 0.0:
        return 0.0
    return float(-2.0 * spread ** 2 * np.expm1(-cutoff ** 2 / (2.0 * spread ** 2)))


def report_threshold(survival_threshold: float, spread: float, cutoff: float) -> float:
    """Return the least p_S^t at which a fit of this spread is reported (module docstring)."""
    miss = expected_squared_distance(spread, cutoff) / cutoff ** 2
    return survival_threshold / (1.0 - (1.0 - survival_threshold) * miss)
