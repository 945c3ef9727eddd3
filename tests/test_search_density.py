"""Search density (virtual-target lattice) of sat_agent.search_density."""

from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.config import AreaParams, ParameterError, SatParams
from sat_agent.search_density import Lattice, SearchDensity

PARAMS = SatParams()
SENSOR = PARAMS.sensor
J = PARAMS.search.decay


def _density(spacing=1.0):
    return SearchDensity(Lattice.for_area(PARAMS.area, spacing), PARAMS)


def _cell_value(density, point):
    """Value of the cell holding point."""
    s = density.lattice.spacing
    return density.values[int(point[1] // s), int(point[0] // s)]


def test_lattice_tiles_the_area_with_cell_centres():
    lattice = Lattice.for_area(AreaParams(100.0, 60.0), 2.0)
    assert (lattice.nx, lattice.ny) == (50, 30)
    centers = lattice.centers()
    assert centers.shape == (1500, 2)
    np.testing.assert_allclose(centers[0], [1.0, 1.0])
    np.testing.assert_allclose(centers[-1], [99.0, 59.0])
    np.testing.assert_allclose(centers[1], [3.0, 1.0])        # row-major like values.ravel()


def test_lattice_refuses_a_spacing_that_does_not_tile_the_area():
    with pytest.raises(ParameterError, match='area.width'):
        Lattice.for_area(AreaParams(100.0, 100.0), 3.0)


def test_new_density_is_unsearched():
    assert _density().values.shape == (100, 100)
    assert not _density().values.any()


def test_visit_sets_the_square_to_one_and_nothing_else():
    density = _density()
    pose = np.array([30.0, 40.0])
    density.correct(pose)
    centers = density.lattice.centers()
    inside = np.max(np.abs(centers - pose), axis=1) <= SENSOR.square_side / 2
    np.testing.assert_array_equal(density.values.ravel(), inside.astype(float))
    assert inside.sum() == 100


@settings(max_examples=25, deadline=None)
@given(steps=st.integers(0, 60), node=st.sampled_from([(15.0, 25.0), (45.0, 75.0), (85.0, 55.0)]))
def test_unobserved_node_value_is_j_to_the_k_and_one_after_a_visit(steps, node):
    density = _density()
    node = np.array([node])
    density.correct(node[0])           # the 10 m square is the node's region
    assert density.node_values(node, 10.0)[0] == 1.0
    away = np.array([5.0, 95.0])
    for _ in range(steps):
        density.predict(away)
        density.correct(away)
    assert density.node_values(node, 10.0)[0] == pytest.approx(J ** steps, rel=1e-12)
    density.correct(node[0])
    assert density.node_values(node, 10.0)[0] == 1.0


def test_cells_seen_from_the_previous_pose_do_not_decay():
    density = _density()
    pose = np.array([50.0, 50.0])
    density.correct(pose)
    density.predict(pose)
    assert _cell_value(density, pose) == 1.0
    density.predict(pose + 40)
    assert _cell_value(density, pose) == pytest.approx(J)


@pytest.mark.parametrize('steps', [1, 2, 5])
def test_a_density_of_steps_ago_is_predicted_with_its_pose_then_decays_by_j(steps):
    density, theirs = _density(), _density()
    rng = np.random.default_rng(7)
    theirs.values[:] = rng.random(theirs.values.shape)
    pose = np.array([30.0, 70.0])
    before = theirs.values.copy()
    ahead = density.predicted(theirs.values, pose, steps)
    np.testing.assert_array_equal(theirs.values, before)
    # One step of Eqn. satphd_predict at the pose of its step, then J per further step.
    theirs.predict(pose)
    np.testing.assert_allclose(ahead, theirs.values * J ** (steps - 1), rtol=1e-12)
    square = np.zeros(before.shape, dtype=bool)
    square[65:75, 25:35] = True
    np.testing.assert_allclose(ahead[square], before[square] * J ** (steps - 1), rtol=1e-12)
    np.testing.assert_allclose(ahead[~square], before[~square] * J ** steps, rtol=1e-12)
    with pytest.raises(ValueError, match='steps >= 1'):
        density.predicted(before, pose, 0)


def test_node_value_is_the_mean_over_the_region():
    density = _density()
    density.values[:, :] = 0.0
    density.values[0:10, 0:5] = 1.0            # half of the node at (5, 5) searched
    density.values[0:10, 10:20] = 0.4
    nodes = np.array([[5.0, 5.0], [15.0, 5.0], [55.0, 55.0]])
    np.testing.assert_allclose(density.node_values(nodes, 10.0), [0.5, 0.4, 0.0])


def test_node_region_is_clipped_to_the_area():
    density = _density()
    density.values[0:5, 0:5] = 1.0             # the part of the node at (0, 0) inside A
    np.testing.assert_allclose(density.node_values(np.array([[0.0, 0.0]]), 10.0), [1.0])


def test_node_values_stay_in_unit_interval_and_match_a_direct_mean():
    density = _density()
    rng = np.random.default_rng(1)
    density.values[:] = rng.random(density.values.shape)
    nodes = rng.uniform(0, 100, (50, 2))
    got = density.node_values(nodes, 10.0)
    centers = density.lattice.centers()
    for node, value in zip(nodes, got):
        member = np.all((centers >= node - 5) & (centers < node + 5), axis=1)
        assert value == pytest.approx(density.values.ravel()[member].mean(), rel=1e-9)
    assert np.all((got >= 0) & (got <= 1))


def test_fuse_is_elementwise_max():
    rng = np.random.default_rng(2)
    mine, theirs = _density(), _density()
    mine.values[:] = rng.random(mine.values.shape)
    theirs.values[:] = rng.random(theirs.values.shape)
    expected = np.maximum(mine.values, theirs.values)
    before_theirs = theirs.values.copy()
    mine.fuse(theirs.values)
    np.testing.assert_array_equal(mine.values, expected)
    np.testing.assert_array_equal(theirs.values, before_theirs)


def test_fuse_refuses_a_different_lattice():
    with pytest.raises(ValueError, match='shape'):
        _density().fuse(np.zeros((50, 50)))
