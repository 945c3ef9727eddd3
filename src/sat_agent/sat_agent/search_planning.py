"""Search planning, search control and joint search plans (Section "Multi-agent Searching").

Walks (a): path-cheapest-arc from the agent's position s_k over the unvisited nodes V-bar. The
walk's head starts at s_k; each step appends the unvisited node with the cheapest arc from the
head and makes it the new head. Arcs are straight lines between any two points (the complete
graph over V with Euclidean costs, see search_map.py for why not E alone). The walk is closed:
after its last node it returns to its start s_k. A walk is stored as the list of node indices
in visiting order and its start; the closing leg is implicit (``walk_cost`` counts it,
``SearchPlanner.walk_points`` ends with it, ``SearchPlanner.next_goal`` heads back to the start
once every node is visited and no new plan has been made).

Determinism: costs are rounded to 1e-9 m before they are compared (so distances equal up to
rounding error tie exactly whatever the floating point path), and ties go to the lowest node
index. Every agent of a group therefore computes the same joint plan from the same inputs.

Cooperation (c): the |S-bar| walks of a group grow one node at a time, agents in ascending id
order, each taking the cheapest arc from its own head to a node no walk has taken yet, until
every unvisited node is taken: the node sets are disjoint, their union is V-bar and their
sizes differ by at most one.

Control (b): the admissible action of Eqn. controlVectors whose pose is nearest to the next
unvisited node of the walk.
"""

import enum
from typing import Mapping, Sequence

import numpy as np

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.config import SatParams
from sat_agent.search_map import nodes_in_view, nodes_to_search, SearchMap
from sat_agent.sensor_model import in_sensing_square

# Costs are compared after rounding to this many decimals (1e-9 m): far below any distance
# that matters, far above float64 rounding error on distances of a few km.
COST_DECIMALS = 9
# A node's search value only decays while nobody looks at it; a rise beyond float noise means an
# agent searched it.
REVISIT_MARGIN = 1e-6


def _costs(head, points: np.ndarray) -> np.ndarray:
    """Return the rounded Euclidean distances from one point to (R, 2) points."""
    delta = points - head
    return np.round(np.hypot(delta[:, 0], delta[:, 1]), COST_DECIMALS)


def _node_array(nodes: Sequence[int], size: int) -> np.ndarray:
    """Nodes as a sorted array of distinct indices, checked against the map size."""
    array = np.unique(np.asarray(nodes, dtype=np.int64).reshape(-1))
    if array.size and (array[0] < 0 or array[-1] >= size):
        raise ValueError(f'node indices must be in [0, {size}), got {array[0]}..{array[-1]}')
    return array


def _point(value) -> np.ndarray:
    point = np.asarray(value, dtype=float).reshape(-1)
    if point.shape != (2,) or not np.all(np.isfinite(point)):
        raise ValueError(f'a position must be 2 finite numbers, got {value!r}')
    return point


def _grow_walks(starts: np.ndarray, centers: np.ndarray, nodes: Sequence[int]) -> list:
    """Grow one walk per start, one node at a time in start order (path-cheapest-arc)."""
    centers = np.asarray(centers, dtype=float)
    candidates = _node_array(nodes, len(centers))
    points = centers[candidates]
    free = np.ones(len(candidates), dtype=bool)
    head_costs = [_costs(start, points) for start in starts]
    walks = [[] for _ in starts]
    for taken in range(len(candidates)):
        walker = taken % len(starts)
        # argmin returns the first minimum; candidates ascend, so ties go to the lowest index.
        pick = int(np.argmin(np.where(free, head_costs[walker], np.inf)))
        free[pick] = False
        walks[walker].append(int(candidates[pick]))
        head_costs[walker] = _costs(points[pick], points)
    return walks


def greedy_closed_walk(start, centers: np.ndarray, nodes: Sequence[int]) -> list:
    """Path-cheapest-arc closed walk from start over the given nodes (module docstring).

    Returns the node indices in visiting order; the walk closes by returning to start after
    the last node (not listed). The order of `nodes` does not matter.
    """
    return _grow_walks([_point(start)], centers, nodes)[0]


def joint_plan(starts: Mapping[int, Sequence[float]], centers: np.ndarray,
               nodes: Sequence[int]) -> dict:
    """Joint search plan of a group (paper's "Cooperation"): agent id -> its closed walk.

    starts maps every agent of the group (own id included) to its position. The walks grow
    one node at a time in ascending agent id; the result does not depend on the order of the
    mapping or of `nodes`.
    """
    if not starts:
        raise ValueError('a joint plan needs at least one agent')
    ids = sorted(int(agent) for agent in starts)
    walks = _grow_walks([_point(starts[agent]) for agent in ids], centers, nodes)
    return dict(zip(ids, walks))


def planned_walks(starts: Mapping[int, Sequence[float]], centers: np.ndarray,
                  nodes: Sequence[int], planner: str = 'greedy') -> dict:
    """joint_plan's walks, improved by OR-Tools local search when planner is 'ortools'."""
    walks = joint_plan(starts, centers, nodes)
    if planner == 'ortools':
        # Imported here: OR-Tools (and its protobuf runtime) loads only when it is chosen.
        from sat_agent.routing import improve_walks
        walks = improve_walks(starts, centers, walks)
    return walks


def walk_cost(start, centers: np.ndarray, walk: Sequence[int]) -> float:
    """Length of the closed walk start -> walk nodes in order -> start."""
    route = np.vstack([_point(start), np.asarray(centers, dtype=float)[list(walk)],
                       _point(start)])
    return float(np.sum(np.linalg.norm(np.diff(route, axis=0), axis=1)))


def search_action(pose, goal, params: SatParams, keep_in_view=None) -> int:
    """Admissible action of Eqn. controlVectors whose pose is nearest to goal (xi_search).

    keep_in_view: optional (K, 2) points the next sensing square must hold at least
    ``cooperation.track_edge_margin`` inside its edges (a newborn's measurement is off by
    sigma_r ~ 1 m); when some admissible action's square holds them all, the choice is limited
    to those actions.
    Ties (after rounding to 1e-9 m) go to the lowest action index, so the agent stays when
    staying is as good as moving.
    """
    poses = candidate_poses(_point(pose), params.actions)
    distances = _costs(_point(goal), poses)
    allowed = admissible_mask(pose, params.actions, params.area)
    if keep_in_view is not None:
        points = np.asarray(keep_in_view, dtype=float).reshape(-1, 2)
        inner = params.sensor.square_side - 2.0 * params.cooperation.track_edge_margin
        holding = in_sensing_square(points[None, :, :], poses[:, None, :], inner).all(axis=1)
        if np.any(allowed & holding):
            allowed &= holding
    distances[~allowed] = np.inf
    return int(np.argmin(distances))


class ReplanReason(enum.IntEnum):
    """Why the planner needs a new plan; NONE (falsy) when it does not."""

    NONE = 0
    NO_PLAN = 1        # never planned
    RESUMED = 2        # own return to SEARCH: the old walk is stale
    RELEASED = 3       # a group member left SEARCH: its nodes are free again (Fig. 4h)
    NEW_NEIGHBOUR = 4  # first contact with a searching agent outside the plan's group
    EXHAUSTED = 5      # every node of the own walk is visited


class SearchPlanner:
    """The agent's current closed walk, the group it was planned with and the replanning rules.

    Use: every step in SEARCH, ``mark_visited(pose)``; if ``needs_replan(group, released)``,
    ``plan(own_id, starts, node_values)``; then steer to ``next_goal()`` with search_action.

    Replanning rules (``needs_replan``, in priority order, see ReplanReason):
    no plan yet; own return to SEARCH (``resumed=True``); a member of the plan's group left
    SEARCH (``released=True``; every searcher in range sees that at the same step and replans
    jointly, taking over the released nodes); a searching agent in range that is not in the
    plan's group (first contact: both sides see it and replan jointly); the own walk is
    exhausted. Leaving radio range does not trigger a replan: members keep executing the joint
    plan while apart, as in the paper.

    An exhaustion replan is made alone (the other members do not replan at that moment, so a
    joint plan would not be shared): a walk over the unvisited nodes that no other member of
    the last joint plan was given; when every such node is still claimed, a walk over all
    unvisited nodes (and the claims are forgotten), so an agent never idles while nodes are
    unvisited. It keeps the plan's group, so the members do not count as new neighbours.
    A joint replan plans over every unvisited node: nodes of a member out of range (groups of
    three or more) may then be searched twice; radio ranges are not transitive, and the paper
    leaves this case open.
    """

    def __init__(self, search_map: SearchMap, params: SatParams):
        self._map = search_map
        self._params = params
        self._walk = np.zeros(0, dtype=np.int64)
        self._start = None
        self._group = frozenset()
        self._claims = np.zeros(0, dtype=np.int64)
        self._planned = None     # every node's search value when the walk was planned
        self._reason = ReplanReason.NO_PLAN

    @property
    def walk(self) -> tuple:
        """Remaining (not yet visited) node indices of the walk, in visiting order."""
        return tuple(int(node) for node in self._walk)

    @property
    def group(self) -> frozenset:
        """Ids of the agents the current plan was made with (own id included)."""
        return self._group

    @property
    def start(self):
        """Start (and end) point of the current closed walk, or None before the first plan."""
        return None if self._start is None else self._start.copy()

    def mark_visited(self, pose, node_values=None) -> np.ndarray:
        """Drop the walk's nodes whose centre is in the sensing square at pose; return them.

        With node_values (fused search values), nodes another agent searched meanwhile are dropped
        too: their value rose above beta and above the value they had when planned (nodes being
        revisited, search.revisit_share, were planned above beta).
        """
        centers = self._map.centers[self._walk]
        visited = in_sensing_square(centers, _point(pose), self._params.sensor.square_side)
        if node_values is not None:
            values = np.asarray(node_values, dtype=float).reshape(-1)
            if values.size != self._map.size:
                raise ValueError(f'{values.size} search values for {self._map.size} nodes')
            threshold = np.full(self._walk.size, self._params.search.unvisited_threshold)
            if self._planned is not None:
                threshold = np.maximum(threshold, self._planned[self._walk] + REVISIT_MARGIN)
            visited |= values[self._walk] > threshold
        dropped = self._walk[visited]
        self._walk = self._walk[~visited]
        return dropped

    def needs_replan(self, group: frozenset, released: bool,
                     resumed: bool = False) -> ReplanReason:
        """Whether to plan again (the returned ReplanReason is falsy when not).

        group: ids of the agents in radio range that are in SEARCH (own id may be included).
        released: a member of the plan's group was seen to leave SEARCH.
        resumed: this agent has just returned to SEARCH.
        """
        if self._start is None:
            reason = ReplanReason.NO_PLAN
        elif resumed:
            reason = ReplanReason.RESUMED
        elif released:
            reason = ReplanReason.RELEASED
        elif not frozenset(group) <= self._group:
            reason = ReplanReason.NEW_NEIGHBOUR
        elif not self._walk.size:
            reason = ReplanReason.EXHAUSTED
        else:
            reason = ReplanReason.NONE
        self._reason = reason
        return reason

    def plan(self, own_id: int, starts: Mapping[int, Sequence[float]], node_values) -> list:
        """Plan over the unvisited nodes (p_search <= beta); joint when starts has others.

        starts maps own_id and the searching agents in range to their positions; every member
        must pass the same starts and node values to get the same joint plan. How the plan is
        made depends on the reason found by the last ``needs_replan`` (class docstring).
        Returns the own walk.
        """
        if own_id not in starts:
            raise ValueError(f'own id {own_id} is missing from the starts {sorted(starts)}')
        values = np.asarray(node_values, dtype=float).reshape(-1)
        if values.size != self._map.size:
            raise ValueError(f'{values.size} search values for {self._map.size} nodes')
        search = self._params.search
        own_start = _point(starts[own_id])
        if self._reason == ReplanReason.EXHAUSTED:
            self._plan_alone(own_id, own_start, values)
        else:
            nodes = nodes_to_search(values, search.unvisited_threshold, search.revisit_share)
            walks = planned_walks(starts, self._map.centers, nodes, search.planner)
            self._walk = np.asarray(walks.pop(int(own_id)), dtype=np.int64)
            self._claims = np.asarray(sum(walks.values(), []), dtype=np.int64)
            self._group = frozenset(int(agent) for agent in starts)
        self._start = own_start
        self._planned = values.copy()
        self._reason = ReplanReason.NONE
        return self._walk.tolist()

    def _plan_alone(self, own_id: int, start: np.ndarray, node_values: np.ndarray):
        # The nodes in view are being searched now: planning them again would give a walk that
        # is visited at once, and an agent short of a node's far edge would replan that same
        # node at every step and never move.
        values = node_values.copy()
        values[nodes_in_view(self._map, start, self._params.sensor.square_side)] = 1.0
        search = self._params.search
        nodes = nodes_to_search(values, search.unvisited_threshold, search.revisit_share)
        unclaimed = np.setdiff1d(nodes, self._claims)
        if not unclaimed.size:
            unclaimed = nodes
            self._claims = np.zeros(0, dtype=np.int64)
        walks = planned_walks({own_id: start}, self._map.centers, unclaimed, search.planner)
        self._walk = np.asarray(walks[own_id], dtype=np.int64)
        self._group = self._group | {int(own_id)}

    def next_goal(self):
        """Centre of the next unvisited node; the walk's start once all are visited; else None."""
        if self._walk.size:
            return self._map.centers[self._walk[0]].copy()
        return self.start

    def walk_points(self) -> np.ndarray:
        """(K, 2): the remaining nodes' centres in order, then the start closing the walk."""
        if self._start is None:
            return np.zeros((0, 2))
        return np.vstack([self._map.centers[self._walk], self._start])
