"""Addition: a new target is confirmed on several scans in a row.

Paper: X-hat_k is the n_hat highest peaks of the PHD, and an agent switches to TRACK when
targets are found (Sections "Search-and-Track Density", "Multi-agent Tracking"): the first
estimate is a target.
Addition: a peak with round(mass) >= 1 becomes a target on its ``phd.confirm_scans``-th scan in
a row with round(mass) >= 1 at peaks within ``phd.confirm_gate`` of each other (its streak);
before that it is tentative (a heavy one may confirm at once: heavy_peak_confirmation.py).
Why: a clutter-born cloud can reach round(mass) = 1 on one scan but seldom stays that heavy
twice; without confirmation every such cloud would start a (false) track.
Switch: ``additions.confirmation`` (off: state_extraction.FirstEstimate).
"""

import numpy as np

from sat_agent.beyond_paper.heavy_peak_confirmation import heavy_mass
from sat_agent.config import SatParams


class ScanConfirmation:
    """Streaks of peaks across scans; confirmed at ``phd.confirm_scans`` (or a heavy mass)."""

    def __init__(self, params: SatParams):
        self._scans = int(params.phd.confirm_scans)
        self._gate = float(params.phd.confirm_gate)
        self._mass = heavy_mass(params)

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
        return streak >= self._scans or mass >= self._mass
