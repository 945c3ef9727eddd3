"""phd.birth_prior 'undetected' (beyond_paper/undetected_birth_prior.py), hand-built densities."""

from dataclasses import replace

import numpy as np
from scipy import special

from sat_agent import sensor_model
from sat_agent.beyond_paper.regrowing_density import birth_detection
from sat_agent.beyond_paper.undetected_birth_prior import undetected_prior
from sat_agent.config import SatParams
from sat_agent.phd_filter import birth_spots, SatPhdFilter
from sat_agent.search_density import Lattice, SearchDensity

POSE = np.array([50.0, 50.0])


def _persistent(**phd):
    params = SatParams.from_mapping({'additions.regrowing_density': True})
    return replace(params, phd=replace(params.phd, **phd))


def _density(params, u_fresh=2e-4, u_scanned=2e-6, boundary=52.0):
    """Return a density whose cells left of x = boundary were scanned, the rest not."""
    density = SearchDensity(Lattice.for_area(params.area, params.search.lattice_spacing), params)
    x = density.lattice.x_centers()
    u = np.where(x[None, :] < boundary, u_scanned, u_fresh) * np.ones((density.lattice.ny, 1))
    density.values = np.exp(-u)
    return density


def test_the_weight_is_the_cells_share_against_an_even_spread_of_the_squares_mass():
    params = _persistent()
    density = _density(params)
    square = density.undetected_in_square(POSE)
    # Cells with centres 45.5 .. 54.5: 7 columns scanned (< 52), 3 fresh.
    assert square.size == 100
    mean = (7 * 2e-6 + 3 * 2e-4) / 10
    w = undetected_prior(density, np.array([[53.0, 50.0], [47.0, 50.0]]), POSE)
    np.testing.assert_allclose(w, [2e-4 / mean, 2e-6 / mean], rtol=1e-9)
    # Over the square's cells the weights average to 1: clutter seeds as much mass as before.
    cells = np.stack(np.meshgrid(np.arange(45.5, 55.0), np.arange(45.5, 55.0)), -1).reshape(-1, 2)
    assert np.isclose(undetected_prior(density, cells, POSE).mean(), 1.0)


def test_an_even_or_empty_square_keeps_the_uniform_prior():
    params = _persistent()
    even = _density(params, u_fresh=3e-5, u_scanned=3e-5)
    points = np.array([[46.0, 46.0], [54.0, 54.0]])
    np.testing.assert_allclose(undetected_prior(even, points, POSE), 1.0)
    empty = _density(params, u_fresh=0.0, u_scanned=0.0)   # u_0 = 0: the filter's empty prior
    np.testing.assert_array_equal(undetected_prior(empty, points, POSE), 1.0)


def test_masses_follow_the_weight_and_stop_at_one_target():
    params = _persistent(birth_mass_measurement=0.5)
    z = sensor_model.measure(np.array([[54.0, 50.0], [46.0, 50.0]]), POSE)
    plain = birth_spots(z, POSE, params)
    weighted = birth_spots(z, POSE, params, prior=np.array([0.5, 4.0]))
    np.testing.assert_allclose(weighted.masses, [0.5 * plain.masses[0], 1.0])
    np.testing.assert_allclose(plain.masses, 0.5 * z[:, 0] / params.sensor.max_range)


def test_the_filter_seeds_clutter_in_ground_it_just_scanned_with_less_mass():
    """Two measurements at 4 m range, one in the fresh strip, one in ground scanned last step."""
    z = sensor_model.measure(np.array([[54.0, 50.0], [46.0, 50.0]]), POSE)
    masses = {}
    for prior in ('uniform', 'undetected'):
        params = _persistent(birth_prior=prior)
        agent = SatPhdFilter(params, np.random.default_rng(3))
        agent.search = _density(params)
        agent.correct(z, POSE)
        masses[prior] = agent.birth_spots.masses
    np.testing.assert_allclose(masses['uniform'][0], masses['uniform'][1])
    assert masses['undetected'][0] > 2 * masses['uniform'][0]
    assert masses['undetected'][1] < 0.05 * masses['uniform'][1]


def test_a_scan_detects_the_edge_targets_whose_measurements_land_in_the_square():
    """search.scan_detection 'births': P_in ~1 at the centre, 1/2 at an edge, 1/4 at a corner."""
    half, sigma = 5.0, 1.125
    p_in = birth_detection((np.array([0.0, 5.0]), np.array([0.0, 5.0])), half, sigma)
    inside = special.ndtr(half / sigma) - special.ndtr(-half / sigma)    # ~1 on the axis
    edge = 0.5 - special.ndtr(-2 * half / sigma)                          # ~1/2 on the edge
    np.testing.assert_allclose(p_in, [[inside ** 2, inside * edge], [edge * inside, edge ** 2]])
    for mode in ('square', 'births'):
        params = SatParams.from_mapping({'additions.regrowing_density': True,
                                         'search.scan_detection': mode})
        density = _density(params, u_fresh=1.0, u_scanned=1.0)
        density.correct(POSE)
        detected = 1.0 + np.log(density.values)     # 1 - u, u = 1 before the scan
        # Cells centred 0.5 m (row and column 50) and 4.5 m (column 54) from the pose.
        near_edge = special.ndtr(0.5 / sigma) - special.ndtr(-9.5 / sigma)
        centre = special.ndtr(4.5 / sigma) - special.ndtr(-5.5 / sigma)
        expected = (0.99, 0.99) if mode == 'square' else (0.99 * centre ** 2,
                                                          0.99 * centre * near_edge)
        np.testing.assert_allclose([detected[50, 50], detected[50, 54]], expected, rtol=1e-9)
        assert np.isclose(detected[50, 45], detected[50, 54])   # both edges alike
