import math

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.config import AreaParams
from sat_agent.search_map import nodes_in_view, SearchMap, unvisited_nodes


def paper_map():
    return SearchMap.for_area(AreaParams(), 10.0)


def test_paper_map_is_a_row_major_grid_of_cell_centres():
    search_map = paper_map()
    assert search_map.size == 100
    np.testing.assert_allclose(search_map.centers[0], [5.0, 5.0])
    np.testing.assert_allclose(search_map.centers[1], [15.0, 5.0])     # x varies fastest
    np.testing.assert_allclose(search_map.centers[10], [5.0, 15.0])
    np.testing.assert_allclose(search_map.centers[99], [95.0, 95.0])


def test_centres_are_clipped_onto_the_area_when_it_is_not_a_multiple_of_the_spacing():
    search_map = SearchMap.for_area(AreaParams(width=25.0, height=10.0), 10.0)
    np.testing.assert_allclose(search_map.centers, [[5, 5], [15, 5], [25, 5]])


@settings(max_examples=60, deadline=None)
@given(width=st.floats(1.0, 200.0), height=st.floats(1.0, 200.0), spacing=st.floats(1.0, 50.0),
       seed=st.integers(0, 2**32 - 1))
def test_nodes_lie_in_the_area_and_their_squares_cover_it(width, height, spacing, seed):
    search_map = SearchMap.for_area(AreaParams(width=width, height=height), spacing)
    centers = search_map.centers
    assert np.all(centers >= 0) and np.all(centers[:, 0] <= width)
    assert np.all(centers[:, 1] <= height)
    points = np.random.default_rng(seed).uniform([0, 0], [width, height], (200, 2))
    chebyshev = np.max(np.abs(points[:, None, :] - centers[None, :, :]), axis=2)
    assert np.all(chebyshev.min(axis=1) <= spacing / 2 + 1e-9)


def test_edges_join_the_8_neighbourhood_with_euclidean_costs():
    pairs, costs = paper_map().edges()
    # 10 x 10 grid: 90 horizontal + 90 vertical + 2 * 81 diagonal edges.
    assert len(pairs) == 342
    assert np.all(pairs[:, 0] < pairs[:, 1])
    assert len({tuple(p) for p in pairs}) == 342
    assert set(np.round(costs, 9)) == {10.0, round(10.0 * math.sqrt(2.0), 9)}
    edge_set = {tuple(p) for p in pairs}
    assert (0, 1) in edge_set and (0, 10) in edge_set and (0, 11) in edge_set
    assert (1, 10) in edge_set          # the other diagonal
    assert (0, 2) not in edge_set and (0, 20) not in edge_set and (9, 10) not in edge_set


def test_unvisited_nodes_are_those_at_or_below_beta():
    np.testing.assert_array_equal(unvisited_nodes([0.1, 0.5, 0.6, 0.0, 1.0], 0.5), [0, 1, 3])
    assert unvisited_nodes(np.ones(4), 0.5).size == 0


def test_unvisited_nodes_refuses_nan():
    with pytest.raises(ValueError):
        unvisited_nodes([0.1, math.nan], 0.5)


def test_nodes_in_view_uses_the_closed_sensing_square():
    search_map = paper_map()
    np.testing.assert_array_equal(nodes_in_view(search_map, (10.0, 10.0), 10.0), [0, 1, 10, 11])
    np.testing.assert_array_equal(nodes_in_view(search_map, (5.0, 5.0), 10.0), [0])
    np.testing.assert_array_equal(nodes_in_view(search_map, (52.0, 47.0), 10.0), [45])
    assert nodes_in_view(search_map, (10.0, 10.0), 9.0).size == 0


def test_search_map_refuses_bad_input():
    with pytest.raises(ValueError):
        SearchMap.for_area(AreaParams(), 0.0)
    with pytest.raises(ValueError):
        SearchMap(np.zeros((3, 3)), 10.0)
    with pytest.raises(ValueError):
        SearchMap(np.array([[0.0, math.inf]]), 10.0)
