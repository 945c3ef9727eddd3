"""The sweeping search move (beyond_paper/sweeping_move.py, search.sweep_slack)."""

from conftest import REPO_ROOT
from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.sweeping_move import sweeping_action
from sat_agent.config import load_params_file, SatParams
from sat_agent.search_density import Lattice, SearchDensity
from sat_agent.search_planning import action_costs, search_action

PERSISTENT = load_params_file(REPO_ROOT / 'config' / 'persistent.yaml')
POSE = np.array([50.0, 50.0])
EAST = np.array([90.0, 50.0])


def _density(params, seed=None):
    """Return a density whose u = -ln v are exponential draws of seed (None: all searched)."""
    density = SearchDensity(Lattice.for_area(params.area, params.search.lattice_spacing),
                            params)
    shape = density.values.shape
    u = np.zeros(shape) if seed is None else np.random.default_rng(seed).exponential(1e-3, shape)
    density.values = np.exp(-u)
    return density


def _worth_to_the_north(params):
    """Undetected mass north of y = 56 only: the ground the straight move flies was searched."""
    density = _density(params)
    u = np.zeros(density.values.shape)
    u[56:, :] = 1e-3    # rows are y (1 m lattice)
    density.values = np.exp(-u)
    return density


@pytest.mark.parametrize('slack', [1.2, 2.5])
def test_the_move_bends_towards_fresh_ground_within_its_slack(slack):
    params = PERSISTENT.with_overrides({'search.sweep_slack': slack})
    density = _worth_to_the_north(params)
    costs = action_costs(POSE, EAST, params)
    poses = candidate_poses(POSE, params.actions)
    worth = density.square_worth(poses)
    straight = search_action(POSE, EAST, params)
    action = sweeping_action(POSE, EAST, params, density)
    assert costs[action] <= costs[straight] + slack
    assert worth[action] > worth[straight]
    assert poses[action][1] > POSE[1] and poses[action][0] > POSE[0]   # north-east, not back
    # No action within the slack sweeps more, and among those that sweep as much it is nearest.
    within = costs <= costs.min() + slack
    assert worth[action] == worth[within].max()
    assert costs[action] == costs[within & (worth == worth[action])].min()


def test_no_slack_or_no_worth_is_the_papers_move():
    still = PERSISTENT.with_overrides({'search.sweep_slack': 0.0})
    density = _worth_to_the_north(still)
    assert sweeping_action(POSE, EAST, still, density) == search_action(POSE, EAST, still)
    flat = _density(PERSISTENT)
    assert sweeping_action(POSE, EAST, PERSISTENT, flat) == search_action(POSE, EAST,
                                                                          PERSISTENT)


@settings(max_examples=60, deadline=None)
@given(st.tuples(st.floats(0, 100), st.floats(0, 100)), st.tuples(st.floats(0, 100),
       st.floats(0, 100)), st.floats(0.1, 4.0), st.integers(0, 2 ** 31 - 1))
def test_the_move_is_admissible_and_within_the_slack(pose, goal, slack, seed):
    params = PERSISTENT.with_overrides({'search.sweep_slack': slack})
    action = sweeping_action(pose, goal, params, _density(params, seed=seed))
    costs = action_costs(pose, goal, params)
    assert admissible_mask(pose, params.actions, params.area)[action]
    assert costs[action] <= costs.min() + slack


def test_a_searching_agent_takes_the_sweeping_move_towards_its_walks_node():
    params = SatParams().with_overrides({'search.sweep_slack': 1.2})
    agent = Agent(1, params, POSE, seed=3)
    out = agent.step(1, POSE, np.zeros((0, 2)), [])
    np.testing.assert_allclose(out.goal, agent.planner.next_goal())
    # A diagonal move's square brings in more unsearched ground than an axis move's: the
    # case is one where the sweeping move and the paper's differ.
    assert out.action == sweeping_action(POSE, out.goal, params, agent.filter.search)
    assert out.action != search_action(POSE, out.goal, params)
