"""Addition: a new target is confirmed on several scans in a row.

Paper: X-hat_k is the n_hat highest peaks of the PHD, and an agent switches to TRACK when
targets are found (Sections "Search-and-Track Density", "Multi-agent Tracking"): the first
estimate is a target.
Addition: a peak with round(mass) >= 1 becomes a target on its ``phd.confirm_scans``-th scan in
a row with round(mass) >= 1 at peaks within ``phd.confirm_gate`` of each other (its streak),
or on its first such scan when its mass reaches ``phd.confirm_mass`` (0: the streak alone);
before that it is tentative.
Why: a clutter-born cloud can reach round(mass) = 1 on one scan but seldom stays that heavy
twice; without confirmation every such cloud would start a (false) track. The mass of a
measurement-born cloud after its second scan is the PHD's probability that the two scans saw
one target, tau / (kappa + tau) (phd_filter.update_weights), so a heavy cloud has already
passed the test a streak stands for; a pass at 4 m/step holds a target for two or three scans
(the first only seeds its birth), so a streak of two costs a target seen twice.
Switch: ``additions.confirmation`` (off: state_extraction.FirstEstimate).
"""

import numpy as np

from sat_agent.config import PhdParams


class ScanConfirmation:
    """Streaks of peaks across scans; confirmed at ``phd.confirm_scans``."""

    def __init__(self, phd: PhdParams):
        self._scans = int(phd.confirm_scans)
        self._gate = float(phd.confirm_gate)
        self._mass = float(phd.confirm_mass)

    def streak(self, peak: np.ndarray, memory) -> int:
        """Count the scans in a row with round(mass) >= 1 at this peak, this one included.

        memory (state_extraction.ExtractionMemory): the candidate peaks of k-1, predicted to k,
        with their streaks; the longest streak within the gate continues.
        """
        if len(memory.candidates) == 0:
            return 1
        positions = np.asarray(memory.candidates, dtype=float).reshape(-1, 2)
        near = np.hypot(*(positions - peak).T) <= self._gate
        return 1 + int(np.max(np.asarray(memory.streaks)[near], initial=0))

    def confirmed(self, streak: int, mass: float) -> bool:
        """Whether a peak with this streak and PHD mass is a target."""
        return streak >= self._scans or 0.0 < self._mass <= mass
