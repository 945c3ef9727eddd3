"""Addition: a lone agent takes first the nodes its square has not held for a whole sweep.

Paper: none. Its density never regrows, so a searched node waits for J to bring it back below
beta (search_planning.SearchPlanner); persistent planning (persistent_planning.py) orders a
walk by worth per metre and replans it alone when its next node has decayed.
Why: with additions.drop_searched_nodes a node whose region was half searched by passes beside
it leaves the walk, and its lower worth puts it late in every walk the decay rule replans: a lone
agent with no target left one node centre, (25, 55), unseen for 768 steps, past the two sweeps
(714 steps) within which the derivation has every node seen again
(tests/test_persistent_planning.py).
Addition (``search.overdue_sweeps`` > 0): the agent keeps, per node, the last step in SEARCH at
which its own square held the node's centre (the paper's visit). A node is overdue once that
age reaches overdue_sweeps sweeps, a sweep being the steps of a walk through every node at the
search move's least progress per step, |V| s / (v - sweep_slack) (``sweep_steps``). While no
other searching agent is in range: when a node out of the walk's overdue head becomes overdue
the agent replans alone (ReplanReason.OVERDUE), the walk takes the overdue nodes first (worth
per metre among them, then the others on from the last of them), and a walk whose next node
is overdue is not replanned on decay. So an overdue node is seen again within
the walk through the overdue nodes, which is at most the walk through all of them: within
overdue_sweeps + 1 sweeps of its last visit.
Ages ignore the neighbours' squares and the steps out of SEARCH, so the rule waits for a lone
agent: joint plans, which every member computes from the same inputs, are as before. A sweep of
the persistent profile is 357 steps (100 nodes 10 m apart, 4 m a step less 1.2 m of slack), so
at overdue_sweeps 1 no node is overdue within the evaluation's 200 steps and its runs are the
same.
"""

import numpy as np

from sat_agent.config import SatParams


def sweep_steps(params: SatParams, node_count: int, node_spacing: float) -> float:
    """Return |V| s / (v - sweep_slack): the steps of a walk through every node (docstring)."""
    actions = params.actions
    speed = actions.n_radial * actions.radial_step - params.search.sweep_slack
    if speed <= 0.0:
        raise ValueError(f'search.sweep_slack = {params.search.sweep_slack} leaves a walk no '
                         f'progress: it must be below the top speed actions.n_radial x '
                         f'actions.radial_step = {actions.n_radial * actions.radial_step} m')
    return node_count * node_spacing / speed


def overdue_nodes(last_seen: np.ndarray, step: int, horizon: float) -> np.ndarray:
    """Return the indices of the nodes unseen for at least horizon steps at step."""
    return np.flatnonzero(step - np.asarray(last_seen) >= horizon)
