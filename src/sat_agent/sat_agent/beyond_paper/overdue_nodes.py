"""Addition: an agent takes first the nodes whose ground no square it knows of held for a sweep.

Paper: none. Its density never regrows, so a searched node waits for J to bring it back below
beta (search_planning.SearchPlanner); persistent planning (persistent_planning.py) orders a
walk by worth per metre and replans it alone when its next node has decayed.
Why: with additions.drop_searched_nodes a node whose region was half searched by passes beside
it leaves the walk, and its lower worth puts it late in every walk the decay rule replans: a lone
agent with no target left one node centre, (25, 55), unseen for 768 steps (session 54). And the
paper's visit, a node's centre in the square, leaves ground unseen for good: a walk turns once
the square's edge reaches a centre, 5 m off. Aging centres (session 54's rule) bounded a lone
agent's wait on every centre to 391-445 steps, but over six sweeps from 8 starts some cells in
the outermost metre were never seen and 7.6-10.9 % of all cells waited more than two sweeps
(docs/persistent_trials.md, session 62). Applied only while alone, the rule on cells left a
team's longest wait on a cell at 482-1,501 steps over 1,500 (8 seeds; session 62).
Addition (``search.overdue_sweeps`` > 0): the agent keeps the step at which a square last held
each cell of the search density's lattice (``CellViews``): while it searches, its own and
those of the reports it hears (a neighbour's pose at its report's step, whatever the
neighbour's mode; the planner is not run in TRACK). A node's view is the
oldest over the cells of its region r_v, or, if later, what a report says of it: each report
carries the sender's node views (``PersistentPlanner.node_views``), which it merged the same way
from the reports it heard. So the team's search-path history spreads as the paper's fused
density spreads (its values are that history, J^age per cell; the regrowing density's are not),
and by the same max: each view bounds from below the step of the oldest view of the node's
cells. The radio carries 4 bytes per node in the density message (400 B a report here; none
from a planner without the rule). A node is overdue once its view is H = overdue_sweeps sweeps
old, a sweep being the steps of a walk through every node at the search move's least progress
per step, |V| s / (v - sweep_slack) (``sweep_steps``).

- when a node that the walk's overdue head lacks becomes overdue, among the nodes the agent may
  take (with additions.exhaustion_claims, not those the last joint plan gave the others), the
  agent replans alone (ReplanReason.OVERDUE). The head keeps the overdue nodes it still holds,
  in their order, and takes the new ones after them by the paper's cheapest arc; the other
  nodes follow by worth per metre from the head's last node;
- a joint plan partitions the nodes as before, every member from the same inputs; the own
  walk then takes first the head's nodes it was given, in their order, and its other overdue
  nodes by the cheapest arc; the rest keep the joint plan's order;
- a node of the head is visited once none of its cells is overdue, not when its centre is in
  view. Its goal is the admissible pose whose square holds most of its overdue cells (ties:
  nearest to ``cover_point``, the point nearest to the agent whose square holds them all),
  taken exactly, without the sweeping move's bend; while no pose holds one, the cover point;
- a walk whose next node is in the head is not replanned on decay.

Horizon, a lone agent: a cell unseen for H makes its node overdue; the node enters the head at
once (or is in it), and no node enters the head ahead of it later. So it is reached within the
walk through the head ahead of it, at most a walk through every node: one sweep, if a walk that
covers flies as fast as one that visits centres (each cover move holds at least one overdue
cell, so a visit ends within as many steps as the node has overdue cells once one is in reach;
from three starts over six sweeps a lone agent made cover moves in 56 % of its steps, in runs
of 5 steps, median, up to 37, that often span several nodes). Every cell is then seen within H
plus a sweep: 714 steps for the persistent profile (tests/test_persistent_planning.py; measured
at most 605 over 8 starts and six sweeps).
A team: a member's views miss only what no report told it, so a node it takes for fresh was
seen whole within H, and a node with a cell no agent saw for H is overdue for every member: for
the one whose walk holds it (joint plans give every node to someone), which takes it first.
Partitions change at every joint replan, so no horizon is derived; measured over 1,500 steps on
8 seeds, every cell was seen again within 391-435 steps, and the ground on average as fresh as
when the rule waited for members to be alone (docs/persistent_trials.md, session 63). Merging
only the squares of the agents in range was as bounded (374-477 steps), but a member then took
for overdue nodes that others had seen (seed 1, no target: 6.6 of its 6.8 overdue nodes on
average, against 0.2 of 0.7 with the reports' node views) and the ground was on average 5-6.5
steps older (+12-15 %).
Trust: a report can say cells were seen that no square held, and so keep the team off them; the
reports are authenticated (message_auth.py), and an authenticated liar can as well send a
density that says so. Malformed views (not one per node, or one after the report's step) drop
the report, counted (``node_views_defect``; agent_core, agent_node).
The head takes only the overdue nodes and covers only their overdue cells: covering also the
cells half a sweep old replanned less (10 OVERDUE replans in six sweeps against about 400) but
waited longer (up to 649 steps against 609 in the same version of the code, same starts).
A sweep of the persistent profile is 357 steps (100 nodes 10 m apart, 4 m a step less 1.2 m of
slack), so at overdue_sweeps 1 no node is overdue within the evaluation's 200 steps and its runs
are the same.
"""

from typing import Optional

import numpy as np

from sat_agent.config import SatParams
from sat_agent.search_density import Lattice, nearest_index, observed_window
from sat_agent.search_map import SearchMap


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


def node_views_defect(views, nodes: int, step: int) -> Optional[str]:
    """Return why a report's node views are malformed ('wrong_length', 'out_of_range'), or None.

    Well-formed: none (a planner that keeps none), or one per node, each in [0, step].
    """
    views = np.asarray(views)
    if views.shape not in ((0,), (nodes,)):
        return 'wrong_length'
    if views.size and (views.min() < 0 or views.max() > step):
        return 'out_of_range'
    return None


def cover_point(pose, cells: np.ndarray, side: float) -> np.ndarray:
    """Return the point nearest to pose whose square of this side holds every one of (n, 2) cells.

    Per axis the square holds [x - side / 2, x + side / 2], so x must lie in
    [max - side / 2, min + side / 2]; cells spread wider than side: the middle of that span.
    """
    cells = np.asarray(cells, dtype=float).reshape(-1, 2)
    low = cells.max(axis=0) - side / 2.0
    high = cells.min(axis=0) + side / 2.0
    return np.where(low <= high, np.clip(np.asarray(pose, dtype=float), low, high),
                    (low + high) / 2.0)


class CellViews:
    """The step of the last view the agent knows of each lattice cell, and each node's oldest.

    A node's region r_v is search_density's (cells whose centre lies in the node's half-open
    spacing square); a node whose region holds no cell centre has its nearest cell's view.
    Where the area is not a multiple of the spacing, the clipped last row or column of regions
    overlaps its neighbour's (search_map); a cell they share counts for the later node only, so
    every cell still ages one node.
    """

    def __init__(self, lattice: Lattice, search_map: SearchMap, side: float):
        self._xc, self._yc = lattice.x_centers(), lattice.y_centers()
        self._side = side
        self.seen = np.zeros((lattice.ny, lattice.nx))
        half = search_map.spacing / 2.0
        centers = search_map.centers
        in_x = ((self._xc[None, :] >= centers[:, :1] - half)
                & (self._xc[None, :] < centers[:, :1] + half))
        in_y = ((self._yc[None, :] >= centers[:, 1:] - half)
                & (self._yc[None, :] < centers[:, 1:] + half))
        labels = np.full(self.seen.shape, -1)
        for node in range(search_map.size):   # once, at start: one rectangle per node
            labels[np.ix_(in_y[node], in_x[node])] = node
        self._labels = labels
        self._node_count = search_map.size
        # The cells sorted by node, so one reduceat gives every region's oldest view.
        flat = labels.ravel()
        inside = np.flatnonzero(flat >= 0)
        self._by_node = inside[np.argsort(flat[inside], kind='stable')]
        ordered = flat[self._by_node]
        self._starts = np.flatnonzero(np.diff(ordered, prepend=-1) != 0)
        self._with_cells = ordered[self._starts]
        self._nearest = (nearest_index(self._yc, centers[:, 1]),
                         nearest_index(self._xc, centers[:, 0]))

    def _held(self, pose) -> np.ndarray:
        """Bool (ny, nx): the cells whose centre lies in S_a(pose)."""
        held = np.zeros(self.seen.shape, dtype=bool)
        window = observed_window(self._xc, self._yc, pose, self._side)
        if window is not None:
            held[window] = True
        return held

    def record(self, pose, step: int) -> None:
        """Mark the cells S_a(pose) holds as seen at step, unless seen later already."""
        window = observed_window(self._xc, self._yc, pose, self._side)
        if window is not None:
            self.seen[window] = np.maximum(self.seen[window], step)

    def oldest(self) -> np.ndarray:
        """Return each node's oldest view over its region (V,)."""
        oldest = self.seen[self._nearest]
        if self._by_node.size:
            oldest[self._with_cells] = np.minimum.reduceat(self.seen.ravel()[self._by_node],
                                                           self._starts)
        return oldest

    def _unseen(self, step: int, age: float, pose) -> np.ndarray:
        """Bool (ny, nx): cells unseen for age steps or more at step, but those held at pose."""
        return (step - self.seen >= age) & ~self._held(pose) & (self._labels >= 0)

    def unseen_counts(self, step: int, age: float, pose) -> np.ndarray:
        """Return, per node, how many of its cells ``_unseen`` holds (V,)."""
        return np.bincount(self._labels[self._unseen(step, age, pose)],
                           minlength=self._node_count)

    def unseen_cells(self, node: int, step: int, age: float, pose) -> np.ndarray:
        """Return the centres (n, 2) of node's cells that ``_unseen`` holds."""
        rows, cols = np.nonzero(self._unseen(step, age, pose) & (self._labels == node))
        return np.column_stack([self._xc[cols], self._yc[rows]])
