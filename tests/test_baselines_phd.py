"""PHD-Voronoi (Dames 2020) and Thompson-sampling PHD (DecSTER) baselines, hand-built cases."""

import numpy as np
import pytest

from sat_agent.actions import admissible_mask, candidate_poses, inside_area
from sat_agent.agent_core import Agent, AgentReport
from sat_agent.baselines import baseline_policy
from sat_agent.baselines.interface import BaselineView, SearchMove
from sat_agent.baselines.phd_voronoi import PhdVoronoiPolicy
from sat_agent.baselines.team_phd import (
    accrued_births, neighbour_targets, steps_since_seen, team_birth_ratio, TeamPhd)
from sat_agent.baselines.thompson_phd import best_draw, ThompsonPhdPolicy
from sat_agent.config import SatParams
from sat_agent.mode_machine import Mode
from sat_agent.phd_filter import ParticlePHD
from sat_agent.search_density import Lattice, SearchDensity
from sat_agent.search_map import SearchMap
from sat_agent.sensor_model import measure
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate

from sat_world_sim.radio import Radio

PARAMS = SatParams()
LATTICE = Lattice.for_area(PARAMS.area, PARAMS.search.lattice_spacing)
NEVER_SEEN = np.zeros((LATTICE.ny, LATTICE.nx))
NO_TARGETS = MultiTargetEstimate((), 0.0)


def phd_at(points, weights) -> ParticlePHD:
    """Return a PHD whose particles sit at the given positions, at rest."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    states = np.zeros((len(points), 4))
    states[:, [0, 2]] = points
    return ParticlePHD(states, np.asarray(weights, dtype=float))


def report(agent_id, step, pose, search_values=NEVER_SEEN, estimate=NO_TARGETS):
    return AgentReport(agent_id, step, np.asarray(pose, dtype=float), Mode.SEARCH,
                       np.asarray(search_values, dtype=np.float32), estimate)


def target(position, velocity=(0.0, 0.0), weight=1.0):
    return TargetEstimate(np.asarray(position, float), np.asarray(velocity, float),
                          np.eye(4), weight)


def nearest_admissible(pose, goal):
    """Return the action whose pose is nearest to goal, by brute force over the 17."""
    poses = candidate_poses(pose, PARAMS.actions)
    gaps = np.linalg.norm(poses - np.asarray(goal, float), axis=1)
    gaps[~admissible_mask(pose, PARAMS.actions, PARAMS.area)] = np.inf
    return int(np.argmin(gaps))


# the team's PHD from the agent's own filter and the radio's reports.

def test_steps_since_seen_inverts_the_decay_and_counts_never_seen_cells_from_the_start():
    decay = PARAMS.search.decay
    values = np.array([1.0, decay ** 7, decay ** 150, 0.0])
    np.testing.assert_allclose(steps_since_seen(values, decay, 120), [0.0, 7.0, 120.0, 120.0])
    # J = 1 never forgets a look: a cell ever seen has age 0.
    np.testing.assert_allclose(steps_since_seen(values, 1.0, 120), [0.0, 0.0, 0.0, 120.0])


def test_the_birth_ratio_keeps_own_looks_and_scales_cells_a_teammate_saw_since():
    step, p_s = 60, PARAMS.motion.p_survival
    own = SearchDensity(LATTICE, PARAMS)
    own.correct((25.0, 25.0))                               # this agent looks now
    team = own.values.copy()
    team[70:80, 70:80] = PARAMS.search.decay ** 3           # a teammate looked 3 steps ago
    rho = team_birth_ratio(own.values, team, step, PARAMS)
    assert rho[25, 25] == 1.0 and rho[50, 50] == 1.0          # own look; nobody's look
    expected = accrued_births(3, p_s) / accrued_births(step, p_s)
    np.testing.assert_allclose(rho[75, 75], expected)
    np.testing.assert_allclose(expected, (1 - p_s ** 4) / (1 - p_s ** 61))


def test_neighbours_targets_are_moved_to_the_next_step_and_own_ones_are_not_counted_twice():
    own = MultiTargetEstimate((target((40.0, 40.0)),), 1.0)
    view = BaselineView(10, ParticlePHD.empty(), report(1, 10, (40.0, 40.0), estimate=own), (
        report(2, 9, (60.0, 40.0), estimate=MultiTargetEstimate(
            (target((60.0, 41.0), velocity=(1.0, 0.0), weight=0.8),
             target((41.0, 40.5))), 1.8)),))
    positions, masses = neighbour_targets(view, PARAMS)
    # Sent at k-1 = 9, steered by at k+1 = 11: two steps of x + v T. The second is this
    # agent's own target (within phd.peak_radius of its estimate).
    np.testing.assert_allclose(positions, [[62.0, 41.0]])
    np.testing.assert_allclose(masses, [0.8])


def test_the_team_phd_drops_mass_outside_the_area():
    phd = phd_at([[50.0, 50.0], [-3.0, 50.0], [50.0, 104.0]], [1.0, 5.0, 5.0])
    points, weights = TeamPhd(PARAMS).points((10.0, 10.0), BaselineView(
        1, phd, report(1, 1, (10.0, 10.0))))
    np.testing.assert_allclose(points, [[50.0, 50.0]])
    np.testing.assert_allclose(weights, [1.0])
    assert inside_area(points, PARAMS.area).all()


# PHD-weighted Voronoi (Dames 2020).

def test_voronoi_steers_to_the_admissible_pose_nearest_its_cells_weighted_centroid():
    pose, neighbour = np.array([30.0, 50.0]), np.array([70.0, 50.0])
    # In this agent's cell (x < 50): 3 at (20, 50) and 1 at (40, 60): centroid (25, 52.5). The
    # neighbour's cell holds a heavy peak at (60, 50) that must not pull.
    phd = phd_at([[20.0, 50.0], [40.0, 60.0], [60.0, 50.0]], [3.0, 1.0, 10.0])
    view = BaselineView(5, phd, report(1, 5, pose), (report(2, 4, neighbour),))
    policy = PhdVoronoiPolicy(PARAMS)
    np.testing.assert_allclose(policy.centroid(pose, view), [25.0, 52.5])
    move = policy.choose(pose, view)
    np.testing.assert_allclose(move.goal, [25.0, 52.5])
    assert move.action == nearest_admissible(pose, (25.0, 52.5))
    # Alone, the heavy peak is in its cell and drags the centroid east.
    alone = BaselineView(5, phd, report(1, 5, pose))
    np.testing.assert_allclose(PhdVoronoiPolicy(PARAMS).centroid(pose, alone),
                               (3 * np.array([20, 50]) + [40, 60] + 10 * np.array([60, 50])) / 14)


def test_voronoi_stays_when_its_cell_holds_no_mass():
    pose = np.array([30.0, 50.0])
    view = BaselineView(5, phd_at([[80.0, 50.0]], [1.0]), report(1, 5, pose),
                        (report(2, 4, (70.0, 50.0)),))
    move = PhdVoronoiPolicy(PARAMS).choose(pose, view)
    assert move.action == 0
    np.testing.assert_allclose(move.goal, pose)


def test_an_agent_out_of_radio_range_does_not_shape_the_voronoi_cell():
    params = PARAMS.with_overrides({'search.policy': 'phd_voronoi', 'sensor.clutter_rate': 0.0})
    # Agents 1 and 2 are 40 m apart (in range); agent 3 is 70 m from 1 and 81 m from 2. In range
    # it would take the top of agent 1's cell (y > ~55), where the uniform births are.
    poses = {1: np.array([20.0, 20.0]), 2: np.array([60.0, 20.0]), 3: np.array([20.0, 90.0])}

    def agent_1_after(inbox_of):
        agents = {i: Agent(i, params, poses[i], seed=7) for i in poses}
        first = {i: agents[i].step(1, poses[i], np.zeros((0, 2)), []) for i in poses}
        return agents[1].step(2, poses[1], np.zeros((0, 2)), inbox_of(first))

    radio = Radio(params.cooperation.comm_range)
    for i in poses:
        radio.send(1, i, 'report', i, 0, poses)
    delivered = sorted(d.sender for d in radio.due(2) if d.receiver == 1)
    assert delivered == [2]
    by_radio = agent_1_after(lambda first: [first[i].report for i in delivered])
    everyone = agent_1_after(lambda first: [first[2].report, first[3].report])
    # The far agent would move the goal south a long way; the radio keeps it out of the cell.
    assert by_radio.goal[1] - everyone.goal[1] > 10.0
    sites_alone = agent_1_after(lambda first: [first[2].report])
    np.testing.assert_allclose(by_radio.goal, sites_alone.goal)


# Thompson-sampling PHD (DecSTER).

def test_best_draw_is_the_one_whose_square_holds_most_draws_then_the_nearest():
    draws = np.array([[31.0, 30.0], [80.0, 80.0], [82.0, 81.0], [95.0, 10.0]])
    np.testing.assert_allclose(best_draw(draws, (30.0, 30.0), 10.0), [80.0, 80.0])
    np.testing.assert_allclose(best_draw(draws, (90.0, 90.0), 10.0), [82.0, 81.0])
    np.testing.assert_allclose(best_draw(draws[[0, 3]], (90.0, 20.0), 10.0), [95.0, 10.0])
    assert best_draw(np.zeros((0, 2)), (30.0, 30.0), 10.0) is None


@pytest.mark.parametrize('seed', range(5))
def test_thompson_steers_toward_a_dominant_peak_and_keeps_the_goal_until_it_is_in_view(seed):
    pose = np.array([30.0, 30.0])
    # A dominant peak (mass 20) at (70, 70) and a light spread of mass 0.2 elsewhere.
    spread = np.random.default_rng(0).uniform(0.0, 100.0, (200, 2))
    phd = phd_at(np.vstack([np.full((50, 2), 70.0), spread]),
                 np.concatenate([np.full(50, 0.4), np.full(200, 0.001)]))
    policy = ThompsonPhdPolicy(PARAMS, 1, seed)
    move = policy.choose(pose, BaselineView(3, phd, report(1, 3, pose)))
    np.testing.assert_allclose(move.goal, [70.0, 70.0])
    assert move.action == nearest_admissible(pose, (70.0, 70.0))
    # On its way, a new PHD elsewhere does not change the decision until the peak is in view.
    elsewhere = BaselineView(4, phd_at([[10.0, 90.0]], [20.0]), report(1, 4, pose))
    pose = candidate_poses(pose, PARAMS.actions)[move.action]
    np.testing.assert_allclose(policy.choose(pose, elsewhere).goal, [70.0, 70.0])
    arrived = np.array([67.0, 66.0])
    np.testing.assert_allclose(policy.choose(arrived, BaselineView(
        5, phd_at([[10.0, 90.0]], [20.0]), report(1, 5, arrived))).goal, [10.0, 90.0])


def test_with_no_target_drawn_thompson_goes_to_a_uniformly_drawn_location_not_stays():
    pose = np.array([30.0, 30.0])
    goals = [ThompsonPhdPolicy(PARAMS, 1, seed).choose(
        pose, BaselineView(1, ParticlePHD.empty(), report(1, 1, pose))).goal
        for seed in range(20)]
    assert inside_area(np.array(goals), PARAMS.area).all()
    assert len({tuple(g) for g in goals}) == 20


def run_agent(policy, seed, steps=25, agent_id=1):
    params = PARAMS.with_overrides({'search.policy': policy, 'sensor.clutter_rate': 0.0,
                                    'phd.birth_particles_uniform': 300,
                                    'phd.min_particles': 300})
    agent = Agent(agent_id, params, (50.0, 50.0), seed=seed)
    pose, actions = np.array([50.0, 50.0]), []
    for k in range(1, steps + 1):
        out = agent.step(k, pose, np.zeros((0, 2)), [])
        assert admissible_mask(pose, params.actions, params.area)[out.action]
        actions.append(out.action)
        pose = candidate_poses(pose, params.actions)[out.action]
    return actions


def test_thompson_runs_are_reproducible_per_seed_and_agent():
    assert run_agent('thompson', 3) == run_agent('thompson', 3)
    assert run_agent('thompson', 3) != run_agent('thompson', 4)
    assert run_agent('thompson', 3) != run_agent('thompson', 3, agent_id=2)


def test_voronoi_runs_are_reproducible_per_seed():
    assert run_agent('phd_voronoi', 3) == run_agent('phd_voronoi', 3)


# the plug-in: which baselines steer tracking too.

class RecordingBaseline:
    """Goes east whatever it sees; remembers what it was shown."""

    def __init__(self, steers_tracking):
        self.steers_tracking = steers_tracking
        self.views = []

    def choose(self, pose, view):
        self.views.append(view)
        return SearchMove(1, np.asarray(pose, float) + (2.0, 0.0), np.zeros((0, 2)))


@pytest.mark.parametrize('steers_tracking', [True, False])
def test_a_baseline_that_steers_tracking_controls_the_tracking_agent_too(steers_tracking):
    # Without additions.investigation a searching agent never looks at tentative peaks, so in
    # SEARCH every baseline moves it.
    params = PARAMS.with_overrides({'sensor.clutter_rate': 0.0, 'motion.process_noise': 0.1,
                                    'phd.birth_particles_uniform': 200,
                                    'phd.min_particles': 200, 'additions.investigation': False})
    pose, spot = np.array([50.0, 50.0]), np.array([[52.0, 51.0]])
    agent = Agent(1, params, pose, seed=4)
    agent.baseline = RecordingBaseline(steers_tracking)
    outputs = [agent.step(k, pose, measure(spot, pose), []) for k in range(1, 7)]
    tracking = [o for o in outputs if o.mode == Mode.TRACK]
    assert tracking and outputs[0].mode == Mode.SEARCH
    assert all(o.action == 1 for o in outputs if o.mode == Mode.SEARCH)
    assert all((o.action == 1) == steers_tracking for o in tracking)
    shown = [v.step for v in agent.baseline.views]
    assert shown == [k for k, o in enumerate(outputs, 1) if steers_tracking or
                     o.mode == Mode.SEARCH]
    if steers_tracking:
        view = agent.baseline.views[-1]
        assert view.phd is agent.filter.targets and view.own_report is outputs[-1].report


def test_the_policy_parameter_selects_the_phd_baselines():
    search_map = SearchMap.for_area(PARAMS.area, PARAMS.search.node_spacing)
    for name, kind in (('phd_voronoi', PhdVoronoiPolicy), ('thompson', ThompsonPhdPolicy)):
        policy = baseline_policy(PARAMS.with_overrides({'search.policy': name}), search_map, 1,
                                 (5.0, 5.0), 0)
        assert isinstance(policy, kind) and policy.steers_tracking
