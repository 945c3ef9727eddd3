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

Three additions live beside the planner (beyond_paper/, chosen once in ``SearchPlanner``):
``additions.revisit_fallback`` (what to plan when V-bar is empty; the paper's reading: V-bar
alone, so the walk over no node is s_k and the agent holds until a node decays below beta),
``additions.exhaustion_claims`` (``NoClaims`` is the paper's reading) and
``additions.drop_searched_nodes`` (``own_visits_only`` is the paper's).
"""

import enum
from functools import partial
from typing import Mapping, Optional, Sequence

import numpy as np

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.beyond_paper import drop_searched_nodes, exhaustion_claims, revisit_fallback
from sat_agent.config import SatParams
from sat_agent.search_density import SearchDensity
from sat_agent.search_map import nodes_in_view, SearchMap, unvisited_nodes
from sat_agent.sensor_model import in_sensing_square

# Costs are compared after rounding to this many decimals (1e-9 m): far below any distance
# that matters, far above float64 rounding error on distances of a few km.
COST_DECIMALS = 9
# Worth per metre (persistent planning): worth relative to the largest is rounded to 1e-6, so
# nodes regrown alike tie exactly and the nearer one (then the lower index) wins; a node at
# the head costs MIN_COST (1e-9 m), not 0.
WORTH_DECIMALS = 6
MIN_COST = 10.0 ** -COST_DECIMALS


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


def _grow_walks(starts: np.ndarray, centers: np.ndarray, nodes: Sequence[int],
                worth: Optional[np.ndarray] = None) -> list:
    """Grow one walk per start, one node at a time in start order (path-cheapest-arc).

    With worth (one value >= 0 per node of the map), each walker instead takes the free node
    of the highest worth per metre from its head (beyond_paper/persistent_planning.py).
    """
    centers = np.asarray(centers, dtype=float)
    candidates = _node_array(nodes, len(centers))
    points = centers[candidates]
    free = np.ones(len(candidates), dtype=bool)
    head_costs = [_costs(start, points) for start in starts]
    walks = [[] for _ in starts]
    value = None if worth is None else _relative_worth(worth, candidates)
    for taken in range(len(candidates)):
        walker = taken % len(starts)
        # argmin returns the first minimum; candidates ascend, so ties go to the lowest index.
        if value is None:
            pick = int(np.argmin(np.where(free, head_costs[walker], np.inf)))
        else:
            rate = value / np.maximum(head_costs[walker], MIN_COST)
            pick = int(np.argmin(np.where(free, -rate, np.inf)))
        free[pick] = False
        walks[walker].append(int(candidates[pick]))
        head_costs[walker] = _costs(points[pick], points)
    return walks


def _relative_worth(worth: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """Return the candidates' worth over the largest, rounded to WORTH_DECIMALS (exact ties)."""
    value = np.asarray(worth, dtype=float).reshape(-1)[candidates]
    top = value.max(initial=0.0)
    # No worth anywhere: every node alike, so the nearest is taken.
    return np.round(value / top, WORTH_DECIMALS) if top > 0.0 else np.ones(value.size)


def greedy_closed_walk(start, centers: np.ndarray, nodes: Sequence[int]) -> list:
    """Path-cheapest-arc closed walk from start over the given nodes (module docstring).

    Returns the node indices in visiting order; the walk closes by returning to start after
    the last node (not listed). The order of `nodes` does not matter.
    """
    return _grow_walks([_point(start)], centers, nodes)[0]


def joint_plan(starts: Mapping[int, Sequence[float]], centers: np.ndarray,
               nodes: Sequence[int], worth: Optional[np.ndarray] = None) -> dict:
    """Joint search plan of a group (paper's "Cooperation"): agent id -> its closed walk.

    starts maps every agent of the group (own id included) to its position. The walks grow
    one node at a time in ascending agent id; the result does not depend on the order of the
    mapping or of `nodes`. worth: see _grow_walks.
    """
    if not starts:
        raise ValueError('a joint plan needs at least one agent')
    ids = sorted(int(agent) for agent in starts)
    walks = _grow_walks([_point(starts[agent]) for agent in ids], centers, nodes, worth)
    return dict(zip(ids, walks))


def planned_walks(starts: Mapping[int, Sequence[float]], centers: np.ndarray,
                  nodes: Sequence[int], planner: str = 'greedy',
                  worth: Optional[np.ndarray] = None) -> dict:
    """joint_plan's walks, improved by OR-Tools local search when planner is 'ortools'."""
    walks = joint_plan(starts, centers, nodes, worth)
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


def action_costs(pose, goal, params: SatParams) -> np.ndarray:
    """xi_search of every action: the distance from its pose to goal (rounded to 1e-9 m).

    Inadmissible actions (Eqn. controlVectors, outside the area) cost inf.
    """
    distances = _costs(_point(goal), candidate_poses(_point(pose), params.actions))
    distances[~admissible_mask(pose, params.actions, params.area)] = np.inf
    return distances


def search_action(pose, goal, params: SatParams) -> int:
    """Admissible action of Eqn. controlVectors whose pose is nearest to goal (xi_search).

    Ties (after rounding to 1e-9 m) go to the lowest action index, so the agent stays when
    staying is as good as moving.
    """
    return int(np.argmin(action_costs(pose, goal, params)))


class NoClaims:
    """The paper's reading of an exhaustion replan: plan over all of V-bar (no claims)."""

    def remember(self, other_walks) -> None:
        """Do nothing: no claims to remember."""

    def unclaimed(self, nodes: np.ndarray) -> np.ndarray:
        """Return every node: all are free."""
        return nodes

    free = unclaimed


def own_visits_only(values: np.ndarray, planned: Optional[np.ndarray],
                    beta: float) -> np.ndarray:
    """Return a mask of none: in the paper only the agent's own visits leave the walk."""
    return np.zeros(np.shape(values), dtype=bool)


class ReplanReason(enum.IntEnum):
    """Why the planner needs a new plan; NONE (falsy) when it does not."""

    NONE = 0
    NO_PLAN = 1        # never planned
    RESUMED = 2        # own return to SEARCH: the old walk is stale
    RELEASED = 3       # a group member left SEARCH: its nodes are free again (Fig. 4h)
    NEW_NEIGHBOUR = 4  # first contact with a searching agent outside the plan's group
    EXHAUSTED = 5      # every node of the own walk is visited
    PERIODIC = 6       # additions.persistent_planning: a joint replan at every replan_period
    DECAYED = 7        # additions.persistent_planning: the walk collects too little worth
    OVERDUE = 8        # search.overdue_sweeps: a node went unseen too long


# Replans made alone, on the agent's own values (the others are joint when others are in range).
ALONE_REASONS = (ReplanReason.EXHAUSTED, ReplanReason.DECAYED, ReplanReason.OVERDUE)


class SearchPlanner:
    """The agent's current closed walk, the group it was planned with and the replanning rules.

    Use: every step in SEARCH, ``mark_visited(pose)``; if ``needs_replan(group, released)``,
    ``plan(own_id, starts, node_values)``; then ``choose(pose)`` (search_action towards
    ``next_goal()``).

    Replanning rules (``needs_replan``, in priority order, see ReplanReason):
    no plan yet; own return to SEARCH (``resumed=True``); a member of the plan's group left
    SEARCH (``released=True``; every searcher in range sees that at the same step and replans
    jointly, taking over the released nodes); a searching agent in range that is not in the
    plan's group (first contact: both sides see it and replan jointly); the own walk is
    exhausted. Leaving radio range does not trigger a replan: members keep executing the joint
    plan while apart, as in the paper.

    An exhaustion replan is made alone (the other members do not replan at that moment, so a
    joint plan would not be shared): a walk over the unvisited nodes, except those in view of
    the agent (visited by the paper's definition: planning them gave a walk visited at once,
    and an agent short of a node's far edge replanned that node at every step and hovered) and,
    with additions.exhaustion_claims, those the last joint plan gave the other members while
    others are left. It keeps the plan's group, so the members do not count as new neighbours.
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
        self._planned = None     # every node's search value when the walk was planned
        self._reason = ReplanReason.NO_PLAN
        # Whether next_goal is a pose the move must take exactly: never in the paper.
        self.covering = False
        search, additions = params.search, params.additions
        self._nodes_to_search = (
            partial(revisit_fallback.nodes_to_search, beta=search.unvisited_threshold,
                    revisit_share=search.revisit_share) if additions.revisit_fallback
            else partial(unvisited_nodes, beta=search.unvisited_threshold))
        self._claims = (exhaustion_claims.Claims() if additions.exhaustion_claims
                        else NoClaims())
        self._searched_meanwhile = (drop_searched_nodes.searched_meanwhile
                                    if additions.drop_searched_nodes else own_visits_only)

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

        With search.visit_share below 1 only the middle of the square counts (beyond the paper).

        With node_values (fused search values) and additions.drop_searched_nodes, nodes another
        agent searched meanwhile are dropped too (beyond_paper/drop_searched_nodes.py).
        Persistent planning's overdue nodes are visited by their cells instead (``_visited``).
        """
        centers = self._map.centers[self._walk]
        side = self._params.sensor.square_side * self._params.search.visit_share
        visited = in_sensing_square(centers, _point(pose), side)
        if node_values is not None:
            values = np.asarray(node_values, dtype=float).reshape(-1)
            if values.size != self._map.size:
                raise ValueError(f'{values.size} search values for {self._map.size} nodes')
            planned = None if self._planned is None else self._planned[self._walk]
            visited |= self._searched_meanwhile(values[self._walk], planned,
                                                self._params.search.unvisited_threshold)
        visited = self._visited(_point(pose), visited)
        dropped = self._walk[visited]
        self._walk = self._walk[~visited]
        return dropped

    def _visited(self, pose: np.ndarray, visited: np.ndarray) -> np.ndarray:
        """Return the mask of the walk's nodes visited at pose: the rules above, the paper's."""
        return visited

    def hear_views(self, views: Sequence[tuple]) -> None:
        """Note what others saw, (pose, step, node_views) of their reports: the paper uses none."""

    def node_views(self) -> np.ndarray:
        """Return what a report tells of the nodes' views: nothing in the paper."""
        return np.zeros(0, dtype=np.int64)

    def needs_replan(self, group: frozenset, released: bool,
                     resumed: bool = False, step: int = 0) -> ReplanReason:
        """Whether to plan again (the returned ReplanReason is falsy when not).

        group: ids of the agents in radio range that are in SEARCH (own id may be included).
        released: a member of the plan's group was seen to leave SEARCH.
        resumed: this agent has just returned to SEARCH.
        step: the step k (the persistent planner's periodic replans).
        """
        if self._start is None:
            reason = ReplanReason.NO_PLAN
        elif resumed:
            reason = ReplanReason.RESUMED
        elif released:
            reason = ReplanReason.RELEASED
        elif not frozenset(group) <= self._group:
            reason = ReplanReason.NEW_NEIGHBOUR
        elif self._periodic(step, frozenset(group)):
            reason = ReplanReason.PERIODIC
        elif not self._walk.size:
            reason = ReplanReason.EXHAUSTED
        elif self._decayed():
            reason = ReplanReason.DECAYED
        else:
            reason = ReplanReason.NONE
        self._reason = reason
        return reason

    def _periodic(self, step: int, group: frozenset) -> bool:
        """Whether step is due for a periodic replan with group: never in the paper."""
        return False

    def _decayed(self) -> bool:
        """Whether the walk's value has decayed: never in the paper (J only lowers values)."""
        return False

    def node_values(self, density: SearchDensity) -> np.ndarray:
        """Return what the planner knows of each node: Eqn. search_value (1 = just searched)."""
        return density.node_values(self._map.centers, self._map.spacing)

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
        own_start = _point(starts[own_id])
        if self._reason in ALONE_REASONS:
            self._plan_alone(own_id, own_start, values)
        else:
            walks = planned_walks(starts, self._map.centers, self._nodes_to_search(values),
                                  self._params.search.planner, self._walk_worth(values))
            self._walk = np.asarray(walks.pop(int(own_id)), dtype=np.int64)
            self._claims.remember(walks)
            self._group = frozenset(int(agent) for agent in starts)
        self._start = own_start
        self._planned = values.copy()
        self._reason = ReplanReason.NONE
        return self._walk.tolist()

    def _plan_alone(self, own_id: int, start: np.ndarray, node_values: np.ndarray):
        in_view = nodes_in_view(self._map, start, self._params.sensor.square_side)
        nodes = self._claims.unclaimed(self._nodes_out_of_view(node_values, in_view))
        self._walk = self._walk_alone(own_id, start, nodes, node_values)
        self._group = self._group | {int(own_id)}

    def _walk_alone(self, own_id: int, start: np.ndarray, nodes: np.ndarray,
                    node_values: np.ndarray) -> np.ndarray:
        """Return the walk from start over nodes of a replan made alone."""
        walks = planned_walks({own_id: start}, self._map.centers, nodes,
                              self._params.search.planner, self._walk_worth(node_values))
        return np.asarray(walks[own_id], dtype=np.int64)

    def _nodes_out_of_view(self, node_values: np.ndarray, in_view: np.ndarray) -> np.ndarray:
        """Return the nodes to search, those in view counting as visited (class docstring)."""
        values = node_values.copy()
        values[in_view] = 1.0
        return self._nodes_to_search(values)

    def _walk_worth(self, node_values: np.ndarray) -> Optional[np.ndarray]:
        """Node worth for the walks' growth: None, the paper's path-cheapest-arc."""
        return None

    def next_goal(self):
        """Centre of the next unvisited node; the walk's start once all are visited; else None."""
        if self._walk.size:
            return self._map.centers[self._walk[0]].copy()
        return self.start

    def choose(self, pose):
        """Return (action, goal, plan): the search control towards the walk's next node.

        The same move as the evaluation's baselines (baselines/); before any plan
        the goal is pose (stay).
        """
        goal = self.next_goal()
        goal = np.asarray(pose, dtype=float) if goal is None else goal
        return search_action(pose, goal, self._params), goal, self.walk_points()

    def walk_points(self) -> np.ndarray:
        """(K, 2): the remaining nodes' centres in order, then the start closing the walk."""
        if self._start is None:
            return np.zeros((0, 2))
        return np.vstack([self._map.centers[self._walk], self._start])
