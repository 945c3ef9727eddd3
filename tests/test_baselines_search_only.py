import numpy as np
import pytest

from sat_agent.actions import admissible_mask, candidate_poses
from sat_agent.agent_core import Agent
from sat_agent.baselines import baseline_policy
from sat_agent.baselines.lawnmower import boustrophedon_order, LawnmowerPolicy
from sat_agent.baselines.random_walk import RandomWalkPolicy
from sat_agent.config import AreaParams, ParameterError, SatParams
from sat_agent.mode_machine import Mode
from sat_agent.search_map import SearchMap
from sat_agent.sensor_model import in_sensing_square

PARAMS = SatParams()
MAP = SearchMap.for_area(AreaParams(), 10.0)


def test_boustrophedon_order_is_every_node_once_each_move_to_a_neighbour():
    order = boustrophedon_order(MAP.centers)
    assert sorted(order.tolist()) == list(range(MAP.size))
    points = MAP.centers[order]
    np.testing.assert_allclose(np.linalg.norm(np.diff(points, axis=0), axis=1), 10.0)
    # First row left to right at the bottom, second right to left.
    np.testing.assert_allclose(points[:11], [[x, 5.0] for x in range(5, 100, 10)] + [[95, 15]])


def fly_lawnmower(start, steps):
    policy = LawnmowerPolicy(MAP, PARAMS, start)
    pose = np.asarray(start, dtype=float)
    seen = np.zeros(MAP.size, dtype=bool)
    for step in range(steps):
        seen |= in_sensing_square(MAP.centers, pose, PARAMS.sensor.square_side)
        if seen.all():
            return step, pose
        move = policy.choose(pose, None)
        assert admissible_mask(pose, PARAMS.actions, PARAMS.area)[move.action]
        pose = candidate_poses(pose, PARAMS.actions)[move.action]
    return None, pose


def test_lawnmower_from_a_corner_sees_every_node_in_one_sweep():
    # 100 nodes 10 m apart at up to 4 m a step: one sweep is ~1,000 m, ~250 steps.
    step, _ = fly_lawnmower((5.0, 5.0), 400)
    assert step is not None and step <= 300


def test_lawnmower_from_inside_turns_back_and_still_sees_every_node():
    # From the paper's start of agent 1 the sweep runs to the top, turns, and sweeps back down.
    step, _ = fly_lawnmower((10.0, 60.0), 800)
    assert step is not None


def test_random_walk_takes_admissible_actions_reproducibly_per_seed_and_agent():
    def walk(agent_id, seed, pose=(1.0, 1.0), steps=60):
        policy = RandomWalkPolicy(PARAMS, agent_id, seed)
        pose, actions = np.asarray(pose), []
        for _ in range(steps):
            move = policy.choose(pose, None)
            assert admissible_mask(pose, PARAMS.actions, PARAMS.area)[move.action]
            reached = candidate_poses(pose, PARAMS.actions)[move.action]
            np.testing.assert_allclose(move.goal, reached)
            actions.append(move.action)
            pose = move.goal
        return actions

    assert walk(1, 5) == walk(1, 5)
    assert walk(1, 5) != walk(2, 5) and walk(1, 5) != walk(1, 6)
    assert len(set(walk(1, 5))) > 8      # uses the whole control set, not a few actions


def test_the_policy_parameter_selects_the_baseline_and_refuses_unknown_names():
    lawnmower = PARAMS.with_overrides({'search.policy': 'lawnmower'})
    assert isinstance(baseline_policy(lawnmower, MAP, 1, (5.0, 5.0), 0), LawnmowerPolicy)
    assert baseline_policy(PARAMS, MAP, 1, (5.0, 5.0), 0) is None
    with pytest.raises(ParameterError, match=r"search.policy' = 'spiral'.*'lawnmower'"):
        PARAMS.with_overrides({'search.policy': 'spiral'})
    with pytest.raises(ParameterError, match="search.planner' = 3: must be a string"):
        PARAMS.with_overrides({'search.planner': 3})


def test_a_searching_agent_moves_as_its_baseline_says():
    params = PARAMS.with_overrides({'search.policy': 'lawnmower', 'sensor.clutter_rate': 0.0,
                                    'phd.birth_particles_uniform': 200,
                                    'phd.min_particles': 200})
    agent = Agent(1, params, (10.0, 60.0))
    reference = LawnmowerPolicy(MAP, params, (10.0, 60.0))
    pose = np.array([10.0, 60.0])
    for k in range(1, 6):
        out = agent.step(k, pose, np.zeros((0, 2)), [])
        expected = reference.choose(pose, None)
        assert out.mode == Mode.SEARCH and out.action == expected.action
        np.testing.assert_allclose(out.plan, expected.plan)
        pose = candidate_poses(pose, params.actions)[out.action]
