"""Addition: a search move that sweeps unsearched ground on its way to the walk's next node.

Paper: xi_search, the admissible action of Eqn. controlVectors whose pose is nearest to the
walk's next node (search_planning.search_action): a straight line, whatever the squares on
the way have already searched.
Addition (``search.sweep_slack`` > 0): among the admissible actions whose pose is at most
sweep_slack metres farther from the node than the nearest one, the one whose square S_a holds
the most expected undetected targets, sum of u = -ln v over its cells
(SearchDensity.square_worth; beyond_paper/regrowing_density.py). Ties go to the nearer pose,
then to the lower action index, as in xi_search. Each step still closes at least the nearest
pose's progress minus the slack (at the top speed of 4 m a step and 16 headings, about 2.7 m
for a slack of 1.2 m), so the walk reaches its node; 0 is the paper's move.
Why: a walk between two nodes often crosses ground another square searched a few steps
before (docs/persistent_trials.md, session 47: a third of the area the walks bring in has gone
unseen 60 steps); bending within the slack brings fresh ground into the square for the same
arrival.
"""

import numpy as np

from sat_agent.actions import candidate_poses
from sat_agent.config import SatParams
from sat_agent.search_density import SearchDensity
from sat_agent.search_planning import action_costs


def sweeping_action(pose, goal, params: SatParams, density: SearchDensity) -> int:
    """Return the action towards goal that sweeps the most worth (module docstring)."""
    costs = action_costs(pose, goal, params)
    within = np.flatnonzero(costs <= costs.min() + params.search.sweep_slack)
    worth = density.square_worth(candidate_poses(pose, params.actions)[within])
    # lexsort's last key is the primary one: most worth, then the nearer pose, then the index.
    return int(within[np.lexsort((within, costs[within], -worth))[0]])
