"""Addition: state extraction over the sensing square grown by a margin.

Paper: n_hat = round(integral of the PHD over the sensing area S_a(s_k)) (Section
"Search-and-Track Density").
Addition: the region is the a x a square grown by ``phd.extraction_margin`` on every side.
Why: a target moves ~1 m per step and the agent up to 4 m, so a tracked target often leaves the
square for a step; over S_a alone its estimate (and the agent's TRACK) would drop at once. Mass
beyond the square is never corrected (p_D = 0 there), so the peak extraction lets it continue a
target but not start one.
Switch: ``additions.extraction_margin`` (off: the region is S_a(s_k)).
"""

from sat_agent.config import SatParams


def extraction_side(params: SatParams) -> float:
    """Side of the extraction region: the sensing square's side plus the margin on both sides."""
    return params.sensor.square_side + 2.0 * params.phd.extraction_margin
