"""Addition: a tracking agent also covers search worth, within a bounded loss of information.

Paper: u_k* = argmax of xi_track (Eqn. track_control, the Renyi divergence of the pseudo
update) over the admissible actions (Section "Multi-agent Tracking", b); a tracking agent does
not search (tracking_control.best_score).
Addition: Eqn. track_control stays the first objective. Among the candidate actions (those the
tracking control would choose from: the stand-off ones with additions.track_standoff) scoring
at least (1 - epsilon) of the best score, epsilon = ``cooperation.track_search_tolerance``,
the agent takes the one whose next sensing square holds the most search worth: the expected
undetected targets sum_c u_c over the cells of S_a(pose) of the search density predicted to
k+1 (u = -ln v, beyond_paper/regrowing_density.py; SearchDensity.square_worth). Ties go to the
higher score, then the lower action index.
Bound: the chosen action's score is >= (1 - epsilon) max score, so at most epsilon of the
information the best action would gain at this step is given up. How confidently the targets
are localised enters through the scores: while a target's cloud is wide, the actions centring
it score far above the others and only they pass the bound; once it is tight, many actions
keep it in view at similar scores and the agent picks among them the one that sweeps fresh
ground. When no action is informative (every score 0, e.g. the targets left every square) all
candidates pass and the agent searches.
Why: an agent that tracks stops searching; with more targets than agents targets born near a
tracked one would otherwise be found only by the searchers.
Measured (persistent profile, paired by seed, 95 % t intervals): at the random default on the
dev seeds 2001-2100, switching it off tracked +4.1 points of target-steps [+1.4, +6.8] with a
mean OSPA 0.24 m lower [-0.41, -0.06] and detected +2.1 points [-2.7, +7.0]; at paper_random
(dev seeds 2001-2100) nothing changed significantly (detected -2.0 [-11.5, +7.5]; on the
reported seeds 1-50 and 1001-1050 -10 and -9 points, neither significant: with two targets,
a tracker that also searches may find the other). At random it loses tracks (seeds 1-50: 79 %
of the target-steps after a target's first detection are tracked with it, 88 % without) and
finds no more targets; so config/persistent.yaml leaves it off, and the persistent profile's
ablation (study_design.persistent_ablation_cells) runs the profile with it. Those figures are of
the profile before track coasting (a tracker then followed until it lost its targets). On the
profile of session 32, where a follow ends once the track's velocity is known, rule 28
(docs/persistent_trials.md, session 48; fresh dev seeds 13627-13926, 300, paired, bootstrap
95 % CIs) found the same direction: OSPA +0.17 m [+0.04, +0.31] (Wilcoxon p 0.033), detected
-2.24 points [-5.14, +0.66], tracked -2.04 [-4.20, +0.03] (both p 0.12); it stays off.
Scope: ``cooperation.track_search_scope`` 'all' (as built and measured above) also moves a
searching agent's look at tentative peaks, which the tracking control places; 'track' leaves
the looks on the best score (TrackingControl.action). Its pilot on dev seeds 13527-13626 moved
nothing (OSPA +0.02 m, detected +0.7, tracked +0.8 points).
Switch: ``additions.search_while_tracking`` (off: tracking_control.best_score).
"""

from typing import Optional

import numpy as np

from sat_agent.search_density import SearchDensity


class SearchWhileTracking:
    """Chooses the tracking action with the most search worth within the bound (docstring)."""

    def __init__(self, tolerance: float):
        self.tolerance = float(tolerance)

    def __call__(self, scores: np.ndarray, candidates: np.ndarray, poses: np.ndarray,
                 search: Optional[SearchDensity]) -> int:
        """Return the action index; scores (U,), candidates bool (U,), poses (U, 2).

        Without a search density (search None) it is the best score's action.
        """
        best = np.max(np.where(candidates, scores, -np.inf))
        near = candidates & (scores >= (1.0 - self.tolerance) * best)
        if search is None:
            near = candidates & (scores == best)
        worth = np.zeros(len(poses)) if search is None else search.square_worth(poses)
        # lexsort: last key first; argmax of (worth, score) among the near actions, ties to
        # the lowest index.
        order = np.lexsort((-scores, -np.where(near, worth, -np.inf)))
        return int(order[0])
