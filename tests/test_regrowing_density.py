"""The regrowing search density (beyond_paper/regrowing_density.py) against its derivation."""

import math

import numpy as np
import pytest
from scipy import special

from sat_agent.actions import candidate_poses
from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.regrowing_density import (
    discrete_gaussian, expected_undetected, Regrowth, step_variance)
from sat_agent.config import load_params_file, SatParams
from sat_agent.search_density import ConstantDecay, Lattice, SearchDensity

PERSISTENT = load_params_file('config/persistent.yaml')
AWAY = np.array([-50.0, -50.0])   # a pose whose square holds no cell: nothing is held
# K the identity: no process noise and no velocity spread (search.density_velocity_std 0 takes
# phd.birth_velocity_std's, which the profile sets apart from it).
NO_MOTION = {'motion.process_noise': 0.0, 'phd.birth_velocity_std': 0.0,
             'search.density_velocity_std': 0.0}


def _params(**values) -> SatParams:
    return PERSISTENT.with_overrides(values)


def _density(params: SatParams) -> SearchDensity:
    return SearchDensity(Lattice.for_area(params.area, params.search.lattice_spacing), params)


def _cell(density: SearchDensity, point) -> tuple:
    spacing = density.lattice.spacing
    return int(point[1] // spacing), int(point[0] // spacing)


def test_the_switch_chooses_the_model():
    assert isinstance(_density(PERSISTENT).model, Regrowth)
    assert _density(PERSISTENT).values.min() == 1.0        # u_0 = 0: the filter starts empty
    paper = PERSISTENT.with_overrides({'additions.regrowing_density': False})
    assert isinstance(_density(paper).model, ConstantDecay)
    assert not _density(paper).values.any()                 # the paper's "never observed"


def test_birth_only_a_searched_cell_regrows_as_the_derivation_says():
    # No motion (sigma_K = 0, K the identity): u_k = b (1 - p_S^k) / (1 - p_S) after a visit
    # with p_D = 1.
    params = _params(**NO_MOTION, **{'sensor.p_detect': 1.0})
    density = _density(params)
    cell = np.array([50.5, 50.5])
    density.values[:] = 0.5
    density.correct(cell)
    assert density.values[_cell(density, cell)] == 1.0
    b = params.phd.birth_rate / density.values.size
    p_s = params.motion.p_survival
    for k in range(1, 301):
        density.predict(AWAY)
        u = expected_undetected(density.values)[_cell(density, cell)]
        assert u == pytest.approx(b * (1 - p_s ** k) / (1 - p_s), rel=1e-9)
    assert u == pytest.approx(density.model.stationary() * (1 - p_s ** 300), rel=1e-9)


def test_birth_plus_diffusion_a_point_of_mass_spreads_as_the_discrete_gaussian():
    # A cell holding mass m amid cells holding none, far from the border: after n steps its u is
    # the uniform births' b (1 - p_S^n) / (1 - p_S) (a uniform field stays uniform under K)
    # plus p_S^n m (e^{-n t} I_0(n t))^2, n steps of K being one of variance n t.
    params = _params(**{'motion.process_noise': 0.02, 'phd.birth_velocity_std': 0.5,
                        'search.density_velocity_std': 0.0})
    density = _density(params)
    t = step_variance(params) / density.lattice.spacing ** 2
    assert t == pytest.approx(0.5 ** 2 + 0.02 / 3)     # sigma_v^2 T^2 + q T^3 / 3
    center = (50, 50)
    mass = 0.3
    u = np.zeros(density.values.shape)
    u[center] = mass
    density.values = np.exp(-u)
    b = params.phd.birth_rate / density.values.size
    p_s = params.motion.p_survival
    for n in range(1, 21):
        density.predict(AWAY)
        got = expected_undetected(density.values)
        births = b * (1 - p_s ** n) / (1 - p_s)
        assert got[center] == pytest.approx(
            births + p_s ** n * mass * special.ive(0, n * t) ** 2, rel=1e-9)
        assert got[center[0], center[1] + 2] == pytest.approx(
            births + p_s ** n * mass * special.ive(0, n * t) * special.ive(2, n * t), rel=1e-9)
        # The border reflects: no mass leaves A.
        assert got.sum() == pytest.approx(density.values.size * births + p_s ** n * mass,
                                          rel=1e-9)


def test_the_kernels_velocity_spread_may_be_set_apart_from_the_filters_births():
    # search.density_velocity_std 0 (the default) takes phd.birth_velocity_std's; set, it
    # alone spreads K and the filter's newborn prior is left to the filter. The persistent
    # profile sets them apart (0.5 and 1, arm S4 of docs/persistent_trials.md).
    dt, q = PERSISTENT.motion.dt, PERSISTENT.motion.process_noise
    shared = _params(**{'phd.birth_velocity_std': 1.0, 'search.density_velocity_std': 0.0})
    births_only = _params(**{'phd.birth_velocity_std': 0.5, 'search.density_velocity_std': 0.0})
    assert step_variance(births_only) == pytest.approx(0.5 ** 2 * dt ** 2 + q * dt ** 3 / 3)
    apart = _params(**{'phd.birth_velocity_std': 0.5, 'search.density_velocity_std': 1.0})
    assert apart.phd.birth_velocity_std == 0.5
    assert step_variance(apart) == pytest.approx(step_variance(shared))
    assert np.array_equal(_density(apart).model.kernel, _density(shared).model.kernel)
    assert not np.array_equal(_density(births_only).model.kernel, _density(shared).model.kernel)
    assert np.array_equal(_density(PERSISTENT).model.kernel, _density(apart).model.kernel)


def test_the_discrete_gaussian_has_unit_mass_and_the_asked_variance():
    for variance in (0.0, 0.1, 0.2567, 1.0, 4.0):
        kernel = discrete_gaussian(variance)
        taps = np.arange(kernel.size) - kernel.size // 2
        assert kernel.sum() == pytest.approx(1.0, abs=1e-14)
        assert kernel @ taps ** 2 == pytest.approx(variance, abs=1e-12)


def test_the_scan_leaves_the_missed_share_of_the_undetected_mass():
    density = _density(PERSISTENT)
    u = np.full(density.values.shape, 2e-4)
    density.values = np.exp(-u)
    pose = np.array([30.0, 40.0])
    density.correct(pose)
    got = expected_undetected(density.values)
    miss = 1.0 - PERSISTENT.sensor.p_detect
    square = np.zeros(u.shape, dtype=bool)
    square[35:45, 25:35] = True
    np.testing.assert_allclose(got[square], miss * 2e-4, rtol=1e-9)
    np.testing.assert_allclose(got[~square], 2e-4, rtol=1e-12)


def test_the_papers_constant_j_is_the_special_case():
    # K the identity, p_S = 1, b = -ln J per cell and p_D = 1: Regrowth predicts and corrects
    # as the paper's J does, the previous square held.
    # A 5 m lattice keeps the birth rate this takes (-ln J per cell) within its range.
    lattice = Lattice.for_area(PERSISTENT.area, 5.0)
    decay = 0.999
    params = _params(**NO_MOTION, **{
        'search.lattice_spacing': 5.0, 'motion.p_survival': 1.0, 'sensor.p_detect': 1.0,
        'phd.birth_rate': -math.log(decay) * lattice.nx * lattice.ny})
    regrowing = SearchDensity(lattice, params)
    paper = SearchDensity(lattice, params.with_overrides({'additions.regrowing_density': False,
                                                          'search.decay': decay}))
    rng = np.random.default_rng(3)
    start = rng.uniform(0.2, 1.0, regrowing.values.shape)
    regrowing.values, paper.values = start.copy(), start.copy()
    for pose in rng.uniform(0.0, 100.0, (30, 2)):
        for density in (regrowing, paper):
            density.predict(pose - 3.0)
            density.correct(pose)
        np.testing.assert_allclose(regrowing.values, paper.values, rtol=1e-12)
    for steps in (1, 3):
        np.testing.assert_allclose(regrowing.predicted(start, AWAY, steps),
                                   paper.predicted(start, AWAY, steps), rtol=1e-12)


def test_a_neighbours_density_ages_like_the_own_one():
    # Fusion aging (issue 14 item 1) uses the same model: a density of two steps ago, predicted
    # with its pose, equals the density predicted twice, the first time with that pose.
    density = _density(PERSISTENT)
    rng = np.random.default_rng(5)
    density.values = np.exp(-rng.uniform(0.0, 1e-4, density.values.shape))
    pose = np.array([20.0, 70.0])
    ahead = density.predicted(density.values, pose, 2)
    density.predict(pose)
    density.predict(AWAY)
    np.testing.assert_allclose(ahead, density.values, rtol=1e-12)


def test_the_density_scales_with_the_birth_rate_so_the_walks_do_not_depend_on_it():
    # u_0 = 0 and every step is linear in u and b (prediction b + p_S K u, correction
    # (1 - p_D) u), so u is proportional to phd.birth_rate (module docstring); the
    # walks weigh node worth, sums of u, against each other only (persistent_planning.py).
    rates = (0.01, 0.04)       # the paper's rate and the random default's (~6 in 150 steps)
    densities = [_density(_params(**{'phd.birth_rate': b})) for b in rates]
    rng = np.random.default_rng(7)
    previous = AWAY
    for pose in rng.uniform(0.0, 100.0, (40, 2)):
        for density in densities:
            density.predict(previous)
            density.correct(pose)
        previous = pose
    low, high = (expected_undetected(d.values) for d in densities)
    assert low.min() > 0.0
    np.testing.assert_allclose(high, 4.0 * low, rtol=1e-6)
    # A lone agent without targets flies the same path at either rate.
    start = np.array([10.0, 60.0])
    paths = []
    for b in rates:
        agent = Agent(1, _params(**{'phd.birth_rate': b}), start, seed=0)
        pose, actions = start, []
        for k in range(1, 121):
            action = agent.step(k, pose, np.zeros((0, 2)), []).action
            actions.append(action)
            pose = candidate_poses(pose, agent.params.actions)[action]
        paths.append(actions)
    assert len(set(paths[0])) > 2 and paths[0] == paths[1]
