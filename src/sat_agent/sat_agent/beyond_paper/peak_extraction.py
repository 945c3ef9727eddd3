"""Addition: targets counted per PHD peak, with track continuity.

Paper: n_hat(R) = round(integral of the PHD over R = S_a(s_k)) and X-hat_k the n_hat highest
peaks (Section "Search-and-Track Density"; state_extraction.NHatExtractor).
Addition: the regions counted are the PHD's peaks, not the whole square. Within the extraction
region, with r = ``phd.peak_radius``:

1. continued targets first (track continuity): for each target extracted at k-1, in order,
   mean-shift from its predicted position x + v T over the unclaimed particles within r; if the
   peak stays within ``phd.continue_gate`` and its region holds at least
   ``phd.continue_threshold``, the target continues with max(1, floor(mass)) estimates and the
   region is claimed;
2. new peaks, densest first (state_extraction.PeakSearch): a peak stands for
   n = round(its mass) targets (one estimate when n = 1, n weighted k-means clusters
   otherwise) when most of its region's mass is inside the sensing square (mass beyond it is
   never corrected) and the confirmation rule confirms it; lighter or unconfirmed peaks in the
   square with at least ``phd.tentative_threshold`` are tentative;
3. peaks are sought until the unclaimed mass is below the lowest threshold that can still give
   a target or a tentative peak.

Why: rounding the mass of the whole square counts diffuse mass as a target. Under clutter every
scan leaves small clouds of clutter-born mass (each < 0.5, together often > 0.5) over the square,
and the uniform births add more. And under dense clutter a tracked target's mass settles at
~0.3-0.6 (0.99 - kappa / g_bar): requiring round(mass) >= 1 at every step would drop it every
few steps, while continuity keeps it down to ``phd.continue_threshold``; a continued target
splits in two only at a mass of 2, not 1.5 (clutter next to it adds mass).
Switch: ``additions.peak_extraction`` (off: state_extraction.NHatExtractor).
"""

from typing import List, Tuple

import numpy as np

from sat_agent import sensor_model
from sat_agent.phd_filter import ParticlePHD
from sat_agent.state_extraction import (
    ExtractionMemory, Extractor, MAX_PEAKS, MultiTargetEstimate, PEAK_CELL, PeakSearch,
    predicted_positions, summarise, TargetEstimate)

LLOYD_ITERATIONS = 10


class PeakExtractor(Extractor):
    """Per-peak counting with track continuity (module docstring)."""

    def estimate(self, phd: ParticlePHD, pose) -> Tuple[MultiTargetEstimate, ExtractionMemory]:
        """Return the estimate of phd around pose and the memory it would leave."""
        phd_params = self.params.phd
        search = PeakSearch(phd, pose, self.side, phd_params.peak_radius)
        estimates: List[TargetEstimate] = []
        # Track continuity first: each target of k-1 looks for its peak from where it should be.
        for guess in self.memory.expected:
            peak, member = search.around(guess)
            peak_mass = search.weights[member].sum()
            if (np.hypot(*(peak - guess)) > phd_params.continue_gate
                    or peak_mass < phd_params.continue_threshold):
                continue
            estimates.extend(_estimates(*search.claim(member), peak,
                                        max(1, int(np.floor(peak_mass)))))
        # New targets: round(mass) >= 1 around a confirmed peak inside the square; lighter or
        # unconfirmed peaks there with at least tentative_threshold are kept as tentative.
        floor = min(0.5, phd_params.tentative_threshold)
        tentative: List[TargetEstimate] = []
        streaks: List[int] = []
        for _ in range(MAX_PEAKS):
            if search.unclaimed_mass() < floor:
                break
            peak, member = search.densest()
            peak_mass = search.weights[member].sum()
            claimed = search.claim(member)
            seen = sensor_model.in_sensing_square(claimed[1], pose,
                                                  self.params.sensor.square_side)
            if claimed[2][seen].sum() < 0.5 * peak_mass:
                # Mass beyond the square (no p_D there, Eqn. sensing_model) is never corrected
                # and only decays with p_S: it can continue a target but not make a new one.
                continue
            count = int(np.floor(peak_mass + 0.5))
            streak = self.confirmation.streak(peak, self.memory) if count >= 1 else 0
            if count >= 1 and self.confirmation.confirmed(streak, peak_mass):
                estimates.extend(_estimates(*claimed, peak, count))
            elif peak_mass >= phd_params.tentative_threshold:
                tentative.append(summarise(claimed[0], claimed[2], peak))
                streaks.append(streak)
        dt = self.params.motion.dt
        memory = ExtractionMemory(predicted_positions(estimates, dt),
                                  predicted_positions(tentative, dt),
                                  np.array(streaks, dtype=int))
        return (MultiTargetEstimate(tuple(estimates), search.mass, tuple(tentative),
                                    tuple(streaks)), memory)


def _estimates(states: np.ndarray, points: np.ndarray, weights: np.ndarray, peak: np.ndarray,
               count: int) -> List[TargetEstimate]:
    """One estimate at the peak, or count of them by a weighted k-means of the region."""
    if count == 1:
        return [summarise(states, weights, peak)]
    return _split(states, points, weights, count)


def _split(states: np.ndarray, points: np.ndarray, weights: np.ndarray,
           count: int) -> List[TargetEstimate]:
    """Weighted k-means of one peak region into count targets (seeds: heaviest particles)."""
    order = np.argsort(-weights, kind='stable')
    centers = [points[order[0]]]
    for index in order[1:]:
        if len(centers) == count:
            break
        if min(np.hypot(*(np.array(centers) - points[index]).T)) > PEAK_CELL:
            centers.append(points[index])
    centers = np.array(centers)
    for _ in range(LLOYD_ITERATIONS):
        labels = np.argmin(np.linalg.norm(points[:, None, :] - centers[None], axis=2), axis=1)
        mass = np.bincount(labels, weights=weights, minlength=len(centers))
        moved = np.column_stack([
            np.bincount(labels, weights=weights * points[:, axis], minlength=len(centers))
            for axis in range(2)]) / np.where(mass > 0.0, mass, 1.0)[:, None]
        moved[mass <= 0.0] = centers[mass <= 0.0]
        if np.allclose(moved, centers, rtol=0.0, atol=1e-9):
            break
        centers = moved
    labels = np.argmin(np.linalg.norm(points[:, None, :] - centers[None], axis=2), axis=1)
    return [summarise(states[labels == i], weights[labels == i], centers[i])
            for i in range(len(centers)) if weights[labels == i].sum() > 0.0]
