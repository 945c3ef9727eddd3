import math

from hypothesis import given, settings, strategies as st
import numpy as np

from sat_agent.config import AreaParams
from sat_agent.routing import improve_walks
from sat_agent.search_map import SearchMap
from sat_agent.search_planning import greedy_closed_walk, joint_plan, planned_walks, walk_cost

MAP = SearchMap.for_area(AreaParams(), 10.0)
positions = st.tuples(st.floats(0.0, 100.0), st.floats(0.0, 100.0))
# OR-Tools compares lengths rounded to millimetres: allow that rounding per leg.
TOLERANCE = 1e-3


@settings(max_examples=15, deadline=None)
@given(start=positions, nodes=st.lists(st.integers(0, MAP.size - 1), min_size=1, max_size=25,
                                       unique=True))
def test_ortools_walk_visits_every_node_once_and_is_no_longer_than_greedy(start, nodes):
    greedy = greedy_closed_walk(start, MAP.centers, nodes)
    improved = improve_walks({1: start}, MAP.centers, {1: greedy})[1]
    assert sorted(improved) == sorted(nodes)
    assert walk_cost(start, MAP.centers, improved) <= (
        walk_cost(start, MAP.centers, greedy) + TOLERANCE * (len(nodes) + 1))


def test_ortools_shortens_the_greedy_walk_over_the_whole_map():
    start = (10.0, 60.0)
    greedy = greedy_closed_walk(start, MAP.centers, range(MAP.size))
    improved = planned_walks({1: start}, MAP.centers, range(MAP.size), 'ortools')[1]
    # Greedy leaves long legs back to skipped nodes; local search removes most (1,077 m to
    # ~1,000 m, the length of a perfect sweep of 100 nodes 10 m apart).
    assert walk_cost(start, MAP.centers, improved) < 0.97 * walk_cost(start, MAP.centers, greedy)


def test_ortools_joint_plan_partitions_the_nodes_as_evenly_and_deterministically():
    starts = {3: (90.0, 90.0), 1: (10.0, 60.0), 2: (60.0, 10.0)}
    nodes = list(range(0, MAP.size, 2))
    greedy = joint_plan(starts, MAP.centers, nodes)
    walks = planned_walks(starts, MAP.centers, nodes, 'ortools')
    assert walks == planned_walks(starts, MAP.centers, nodes, 'ortools')
    assert sorted(n for walk in walks.values() for n in walk) == nodes
    assert max(len(walk) for walk in walks.values()) <= math.ceil(len(nodes) / 3)
    total = sum(walk_cost(starts[a], MAP.centers, w) for a, w in walks.items())
    assert total <= sum(walk_cost(starts[a], MAP.centers, w) for a, w in greedy.items())


def test_no_nodes_give_empty_walks():
    assert improve_walks({1: (0.0, 0.0), 2: (5.0, 5.0)}, MAP.centers, {1: [], 2: []}) == {
        1: [], 2: []}
    assert np.asarray(planned_walks({1: (0.0, 0.0)}, MAP.centers, [], 'ortools')[1]).size == 0
