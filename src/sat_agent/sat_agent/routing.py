"""OR-Tools routing for the closed walks (``search.planner: ortools``), an option of ours.

The paper uses path-cheapest-arc walks because optimal vehicle routing is too slow on line. Here
the greedy walks (search_planning.joint_plan) are the initial solution of an OR-Tools routing
model over the same complete Euclidean graph: one vehicle per agent of the group, starting and
ending at the agent's position, every node visited by exactly one vehicle. Greedy descent
(OR-Tools' local search operators: 2-opt, or-opt, relocate, exchange, ...) then runs to a local
optimum, so the walks are never longer than the greedy ones and, with no random choice and no
wall-clock cut in practice, every member of a group computes the same plan from the same inputs.

Objective: the total length, with at most ceil(N / |S|) of the N nodes per walk, the balance of
the paper's joint plans (whose node counts differ by at most one), so no member is left idle.
(A cost on the longest walk balances lengths instead, but makes each solve ~20 times slower.)
"""

import math
from typing import Mapping, Sequence

import numpy as np
from ortools.constraint_solver import pywrapcp, routing_enums_pb2

# OR-Tools costs are integers: distances in millimetres.
COST_SCALE = 1000
# A safety cap per solve: greedy descent on 100 nodes and 1-8 walks ends in under 0.1 s; a cut
# by the clock would make the result depend on the CPU, so the cap is far above that.
TIME_LIMIT_S = 2


def _distance_matrix(points: np.ndarray) -> list:
    gaps = np.linalg.norm(points[:, None, :] - points[None, :, :], axis=2)
    return np.round(gaps * COST_SCALE).astype(np.int64).tolist()


def improve_walks(starts: Mapping[int, Sequence[float]], centers: np.ndarray,
                  walks: Mapping[int, Sequence[int]]) -> dict:
    """Improve closed walks (agent id -> node indices) by OR-Tools local search.

    starts and walks have the same agent ids and the walks at most ceil(N / |S|) nodes each (as
    joint_plan's); the result visits the same nodes, each once, within the same bound, with a
    total length (rounded to millimetres) no higher than the input's.
    """
    ids = sorted(int(agent) for agent in starts)
    nodes = sorted(int(n) for agent in ids for n in walks[agent])
    if not nodes:
        return {agent: [] for agent in ids}
    points = np.vstack([np.asarray([starts[agent] for agent in ids], dtype=float),
                        np.asarray(centers, dtype=float)[nodes]])
    location = {node: len(ids) + row for row, node in enumerate(nodes)}
    manager = pywrapcp.RoutingIndexManager(len(points), len(ids), list(range(len(ids))),
                                           list(range(len(ids))))
    routing = pywrapcp.RoutingModel(manager)
    transit = routing.RegisterTransitMatrix(_distance_matrix(points))
    routing.SetArcCostEvaluatorOfAllVehicles(transit)
    visits = routing.RegisterUnaryTransitVector([0] * len(ids) + [1] * len(nodes))
    routing.AddDimension(visits, 0, math.ceil(len(nodes) / len(ids)), True, 'visits')
    parameters = pywrapcp.DefaultRoutingSearchParameters()
    parameters.local_search_metaheuristic = (
        routing_enums_pb2.LocalSearchMetaheuristic.GREEDY_DESCENT)
    parameters.time_limit.FromSeconds(TIME_LIMIT_S)
    routing.CloseModelWithParameters(parameters)
    initial = routing.ReadAssignmentFromRoutes(
        [[location[int(n)] for n in walks[agent]] for agent in ids], True)
    if initial is None:
        raise RuntimeError('OR-Tools refused the greedy walks as an initial solution')
    solution = routing.SolveFromAssignmentWithParameters(initial, parameters) or initial
    result = {}
    for vehicle, agent in enumerate(ids):
        index = routing.Start(vehicle)
        route = []
        while not routing.IsEnd(index):
            node = manager.IndexToNode(index)
            if node >= len(ids):
                route.append(nodes[node - len(ids)])
            index = solution.Value(routing.NextVar(index))
        result[agent] = route
    return result
