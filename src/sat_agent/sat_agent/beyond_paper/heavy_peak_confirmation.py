"""Addition: a heavy new peak is a target on its first scan.

Paper: the first estimate is a target (state_extraction.FirstEstimate); the addition
``additions.confirmation`` asks for ``phd.confirm_scans`` scans in a row instead.
Addition: with confirmation, a peak whose PHD mass reaches ``phd.confirm_mass`` is a target on
its first scan with round(mass) >= 1.
Why: the mass of a measurement-born cloud after its second scan is the PHD's probability that
the two scans saw one target, tau / (kappa + tau) (phd_filter.update_weights), so a heavy cloud
has already passed the test a streak stands for. A pass at 4 m/step holds a target for two or
three scans and the first only seeds its birth (a lone pass, 300 draws: a target in view for 2
scans was confirmed in 1 % of them, for 3 scans in 46 %), so a streak of two costs a target
seen twice. Alone it confirms more clutter than targets (600 dev seeds: detected +1.5, n.s.,
false-track steps +5.2*); with kernel_likelihood and track_probation it is part of issue 15's
detector (README).
Switch: ``additions.heavy_peak_confirmation`` (off: the streak alone; without
additions.confirmation it changes nothing).
"""

import math

from sat_agent.config import SatParams


def heavy_mass(params: SatParams) -> float:
    """Return the PHD mass from which a peak is a target on one scan (inf: never)."""
    return params.phd.confirm_mass if params.additions.heavy_peak_confirmation else math.inf
