"""Addition: search planning that keeps searching, on the nodes' worth, over the whole mission.

Paper: the walks visit V-bar = {v: p_search(r_v) <= beta} by path-cheapest-arc (Section
"Multi-agent Searching"); a plan is remade when it is exhausted, at first contact with a
searching agent or when a member leaves SEARCH (search_planning.SearchPlanner). With a density
that regrows (beyond_paper/regrowing_density.py) an absolute beta has no fixed meaning: the
values are probabilities near 1 that regrow at the birth rate, and the paper's V-bar is empty
for hundreds of steps after a sweep.
Addition (``PersistentPlanner``):

- worth of a node: the expected number of undetected targets in its region r_v, the sum of
  u = -ln v over its cells (SearchDensity.node_worth). It is what a visit can find; it grows
  back after a visit as the density regrows. With the paper's density (J constant) it is the
  cells' ages times -ln J, and a never-searched cell counts ~708: such nodes come first.
- every node is a candidate at every plan (no threshold, so no "V-bar empty" and no
  fallback: additions.revisit_fallback has nothing left to do), except, in a replan made
  alone, the nodes in view;
- walks collect worth per distance: each walk grows (in turn, as joint plans do) by the free
  node with the highest worth / distance from its head (search_planning._grow_walks with
  worth; equal worth: the nearest, the paper's cheapest arc). This is the ratio greedy of the
  orienteering problem: a node twice as worth may be twice as far;
- replans follow the density over the whole mission: besides the paper's events, every agent
  in SEARCH replans at the steps k that are multiples of ``search.replan_period``
  (ReplanReason.PERIODIC). All agents see the same k, so the searching agents in range replan
  jointly at the same step from the same k-1 reports (agent_core) and compute the same node
  partition, as at first contact; in between a walk's value decays as the density regrows
  elsewhere and others search its nodes;
- a node of the walk that another agent searched meanwhile (with additions.
  drop_searched_nodes) is one whose fused worth fell below DROPPED_SHARE of its worth when
  the walk was planned;
- with search.overdue_sweeps, an agent takes first the nodes with a cell no square it knows of
  (its own, its neighbours', what their reports' node views say) has held for that many
  sweeps, and sees every such cell (beyond_paper/overdue_nodes.py): the decay replans and the
  drop above would otherwise leave a node late in every walk, and the paper's visit, a centre
  in the square, leaves part of its ground unseen.

Why: targets are born all through the mission; a swarm that sweeps once never looks again
where later targets appear, and one that plans on an absolute threshold either holds or
revisits without telling which node pays most.
Switch: ``additions.persistent_planning`` (off: search_planning.SearchPlanner).
"""

import numpy as np

from sat_agent.actions import candidate_poses
from sat_agent.beyond_paper.overdue_nodes import (CellViews, cover_point, overdue_nodes,
                                                  sweep_steps)
from sat_agent.config import SatParams
from sat_agent.search_density import Lattice, SearchDensity
from sat_agent.search_map import nodes_in_view, SearchMap
from sat_agent.search_planning import (_costs, ALONE_REASONS, MIN_COST, own_visits_only,
                                       planned_walks, ReplanReason, SearchPlanner)
from sat_agent.sensor_model import in_sensing_square

# A scan removes p_D = 99 % of the undetected mass it covers; a node whose worth fell below
# half of its planned worth was mostly covered by someone's square since (its worth only
# grows otherwise, up to the mass that dies or walks out).
DROPPED_SHARE = 0.5
# A walk has decayed when its next node pays (worth per metre from the pose) less than half of
# what the best node out of view and unclaimed would: a new walk alone then pays twice as much.
DECAYED_SHARE = 0.5


def every_node(node_worth: np.ndarray) -> np.ndarray:
    """Return every node index: each has worth to collect (module docstring)."""
    return np.arange(np.asarray(node_worth).size)


def worth_dropped(worth: np.ndarray, planned, beta: float = 0.0) -> np.ndarray:
    """Bool mask of the walk's nodes someone searched since planning (module docstring).

    planned: their worth when the walk was planned (None: unknown, then none is dropped);
    beta is not used (no threshold).
    """
    if planned is None:
        return np.zeros(np.shape(worth), dtype=bool)
    return worth < DROPPED_SHARE * np.asarray(planned, dtype=float)


class PersistentPlanner(SearchPlanner):
    """SearchPlanner on node worth, over every node, replanned periodically (module docstring)."""

    def __init__(self, search_map: SearchMap, params: SatParams):
        super().__init__(search_map, params)
        self._latest = (None, None)
        self._period = int(params.search.replan_period)
        self._nodes_to_search = every_node
        self._searched_meanwhile = (worth_dropped if params.additions.drop_searched_nodes
                                    else own_visits_only)
        sweeps = params.search.overdue_sweeps
        self._overdue_after = (sweeps * sweep_steps(params, search_map.size, search_map.spacing)
                               if sweeps > 0.0 else np.inf)
        self._views = CellViews(Lattice.for_area(params.area, params.search.lattice_spacing),
                                search_map, params.sensor.square_side)
        self._step = 0
        self._overdue = np.zeros(0, dtype=np.int64)
        self._overdue_head = np.zeros(0, dtype=np.int64)
        self._heard = np.zeros(search_map.size)

    def node_values(self, density: SearchDensity) -> np.ndarray:
        """Each node's worth: the expected undetected targets in its region."""
        return density.node_worth(self._map.centers, self._map.spacing)

    def mark_visited(self, pose, node_values=None) -> np.ndarray:
        """SearchPlanner.mark_visited; remembers pose and worth for the decay test."""
        self._latest = (np.asarray(pose, dtype=float), node_values)
        return super().mark_visited(pose, node_values)

    def hear_views(self, views) -> None:
        """Age the cells the reports' squares held as seen, and merge the reports' node views.

        beyond_paper/overdue_nodes.py.
        """
        if np.isfinite(self._overdue_after):
            for pose, step, node_views in views:
                self._views.record(pose, step)
                if np.size(node_views):
                    # Each view, the report's or the own, bounds the oldest of the node's cells
                    # from below, so their maximum does too (malformed ones were dropped).
                    self._heard = np.maximum(self._heard, node_views)

    def node_views(self) -> np.ndarray:
        """Return each node's oldest view this agent knows of (beyond_paper/overdue_nodes.py)."""
        if not np.isfinite(self._overdue_after):
            return super().node_views()
        return np.maximum(self._views.oldest(), self._heard).astype(np.int64)

    def plan(self, own_id: int, starts, node_values) -> list:
        """SearchPlanner.plan; a joint plan's own walk takes its overdue nodes first.

        The partition is every member's (the same inputs); only the order of the own walk
        changes: the overdue head, then the rest in the joint plan's order
        (beyond_paper/overdue_nodes.py).
        """
        joint = self._reason not in ALONE_REASONS
        # The head's nodes the old walk no longer holds were visited.
        self._overdue_head = self._overdue_head[np.isin(self._overdue_head, self._walk)]
        super().plan(own_id, starts, node_values)
        if joint:
            head = self._overdue_first(own_id, self._start, self._walk)
            self._walk = np.concatenate([head, self._walk[~np.isin(self._walk, head)]])
            self._overdue_head = head
        return self._walk.tolist()

    def needs_replan(self, group: frozenset, released: bool, resumed: bool = False,
                     step: int = 0) -> ReplanReason:
        """SearchPlanner.needs_replan, and OVERDUE (beyond_paper/overdue_nodes.py)."""
        pose = self._latest[0]
        ruled = np.isfinite(self._overdue_after)
        if pose is not None and ruled:
            self._views.record(pose, step)
        self._step = step
        self._overdue = (overdue_nodes(self.node_views(), step, self._overdue_after)
                         if ruled else np.zeros(0, dtype=np.int64))
        reason = super().needs_replan(group, released, resumed, step)
        if not reason and self._overdue.size and self._pending_overdue().size:
            reason = self._reason = ReplanReason.OVERDUE
        return reason

    def _pending_overdue(self) -> np.ndarray:
        """Return the overdue nodes a replan alone would take but the walk's overdue head lacks.

        A replan alone takes the unclaimed nodes (_plan_alone).
        """
        takeable = np.intersect1d(self._claims.free(np.arange(self._map.size)), self._overdue)
        return np.setdiff1d(takeable, np.intersect1d(self._overdue_head, self._walk))

    def _visited(self, pose: np.ndarray, visited: np.ndarray) -> np.ndarray:
        """Return the visits: the paper's; an overdue-head node's once none of its cells is."""
        head = np.isin(self._walk, self._overdue_head)
        if not head.any():
            return visited
        left = self._views.unseen_counts(self._step, self._overdue_after, pose)
        seen = (left[self._walk] == 0) | ~np.isin(self._walk, self._overdue)
        return np.where(head, seen, visited)

    def next_goal(self):
        """SearchPlanner.next_goal; for an overdue-head node, a pose to see its overdue cells.

        The admissible pose whose square holds most of them (ties: nearest to their
        cover_point), which the move takes exactly (``covering``); while none holds one, their
        cover_point (beyond_paper/overdue_nodes.py).
        """
        goal = super().next_goal()
        self.covering = False
        pose = self._latest[0]
        if pose is None or not self._walk.size or self._walk[0] not in self._overdue_head:
            return goal
        cells = self._views.unseen_cells(int(self._walk[0]), self._step, self._overdue_after,
                                         pose)
        if not cells.size:
            return goal
        side = self._params.sensor.square_side
        target = cover_point(pose, cells, side)
        poses = candidate_poses(pose, self._params.actions)
        held = in_sensing_square(cells[None, :, :], poses[:, None, :], side).sum(axis=1)
        if not held.any():
            return target
        self.covering = True
        return poses[np.lexsort((_costs(target, poses), -held))[0]]

    def _overdue_first(self, own_id: int, start: np.ndarray, nodes: np.ndarray) -> np.ndarray:
        """Return the overdue head over nodes, from start (beyond_paper/overdue_nodes.py).

        It keeps the nodes of the last head still in the walk and among nodes, in their order,
        and takes the other overdue nodes after them by the cheapest arc.
        """
        head = self._overdue_head
        kept = head[np.isin(head, self._walk) & np.isin(head, nodes)]
        first = np.setdiff1d(np.intersect1d(nodes, self._overdue), kept)
        if not first.size:
            return kept
        from_point = self._map.centers[kept[-1]] if kept.size else start
        walks = planned_walks({own_id: from_point}, self._map.centers, first,
                              self._params.search.planner)
        return np.concatenate([kept, np.asarray(walks[own_id], dtype=np.int64)])

    def _walk_alone(self, own_id: int, start: np.ndarray, nodes: np.ndarray,
                    node_values: np.ndarray) -> np.ndarray:
        """Return the overdue head from start, then the others' walk from its last node."""
        head = self._overdue_head = self._overdue_first(own_id, start, nodes)
        if not head.size:
            return super()._walk_alone(own_id, start, nodes, node_values)
        tail = super()._walk_alone(own_id, self._map.centers[head[-1]],
                                   np.setdiff1d(nodes, head), node_values)
        return np.concatenate([head, tail])

    def _periodic(self, step: int, group: frozenset) -> bool:
        return step % self._period == 0 and len(group) > 1

    def _decayed(self) -> bool:
        """Whether the next node pays less than DECAYED_SHARE of the best rate (docstring).

        Never while the next node is in the overdue head (beyond_paper/overdue_nodes.py).
        """
        pose, worth = self._latest
        if worth is None or not self._walk.size or self._walk[0] in self._overdue_head:
            return False
        worth = np.asarray(worth, dtype=float).reshape(-1)
        in_view = nodes_in_view(self._map, pose, self._params.sensor.square_side)
        nodes = self._claims.free(np.setdiff1d(every_node(worth), in_view))
        rates = worth[nodes] / np.maximum(_costs(pose, self._map.centers[nodes]), MIN_COST)
        next_node = self._walk[:1]
        rate = worth[next_node] / np.maximum(_costs(pose, self._map.centers[next_node]),
                                             MIN_COST)
        return bool(rate[0] < DECAYED_SHARE * rates.max(initial=0.0))

    def _nodes_out_of_view(self, node_values: np.ndarray, in_view: np.ndarray) -> np.ndarray:
        """Every node but those in view; an overdue one in view still has cells to see."""
        return np.setdiff1d(every_node(node_values), np.setdiff1d(in_view, self._overdue))

    def _walk_worth(self, node_values: np.ndarray) -> np.ndarray:
        return node_values
