from pathlib import Path

import numpy as np
import pytest

from sat_agent.config import SatParams
from sat_world_sim.scenario import load_scenario, scenario_from_mapping, ScenarioError
from sat_world_sim.world_model import reflect, World

CONFIG = Path(__file__).resolve().parent.parent / 'config'


def scenario(**overrides):
    document = {'name': 'test', 'seed': 3, 'steps': 50, 'truth_process_noise': 0.0,
                'agents': [{'id': 1, 'start': [10.0, 10.0]}, {'id': 2, 'start': [50.0, 10.0]}]}
    document.update(overrides)
    return scenario_from_mapping(document)


def test_paper_scenario_file_matches_the_paper():
    paper = load_scenario(CONFIG / 'scenarios' / 'paper.yaml')
    assert paper.steps == 200
    assert [(a.agent_id, a.start) for a in paper.agents] == [(1, (10.0, 60.0)),
                                                             (2, (60.0, 10.0))]
    t1, t2 = paper.targets
    assert (t1.born, t1.died, t1.start, t1.end) == (104, 179, (50.0, 69.0), (80.0, 31.0))
    assert (t2.born, t2.died, t2.start, t2.end) == (144, 182, (41.0, 29.0), (84.0, 33.0))
    # "Between time-steps k = 147:179, agent 2 tracks both targets": target 1 passes within a
    # sensing square of target 2's birth point (config/scenarios/paper.yaml).
    assert t1.via == ((144, 44.0, 34.0),) and t2.via == ()
    assert np.hypot(44.0 - 41.0, 34.0 - 29.0) < 10.0
    assert load_scenario(CONFIG / 'scenarios' / 'random.yaml').random_births is not None


def test_scripted_targets_are_born_and_die_at_their_steps_and_reach_their_end():
    world = World(scenario(targets=[
        {'id': 5, 'born': 3, 'died': 8, 'start': [20.0, 20.0], 'end': [30.0, 25.0]}]),
        SatParams())
    alive = {}
    for _ in range(12):
        truth = world.truth()
        alive[world.step] = truth.ids.tolist()
        if world.step == 3:
            np.testing.assert_allclose(truth.positions, [[20.0, 20.0]])
        if world.step == 8:
            np.testing.assert_allclose(truth.positions, [[30.0, 25.0]], atol=1e-9)
        world.advance()
    assert [k for k, ids in alive.items() if ids == [5]] == [3, 4, 5, 6, 7, 8]
    assert all(ids == [] for k, ids in alive.items() if k not in range(3, 9))


def test_scripted_targets_turn_at_their_waypoints():
    world = World(scenario(targets=[
        {'id': 5, 'born': 2, 'died': 10, 'start': [20.0, 20.0], 'end': [40.0, 40.0],
         'via': [[4, 20.0, 30.0], [6, 30.0, 30.0]]}]), SatParams())
    path = {}
    for _ in range(11):
        path[world.step] = world.truth().positions.copy()
        world.advance()
    # North 5 m/step to the first waypoint, east 5 m/step to the second, then north-east.
    np.testing.assert_allclose(path[3], [[20.0, 25.0]], atol=1e-9)
    np.testing.assert_allclose(path[4], [[20.0, 30.0]], atol=1e-9)
    np.testing.assert_allclose(path[5], [[25.0, 30.0]], atol=1e-9)
    np.testing.assert_allclose(path[6], [[30.0, 30.0]], atol=1e-9)
    np.testing.assert_allclose(path[10], [[40.0, 40.0]], atol=1e-9)


def test_reflection_keeps_targets_inside_and_flips_the_crossing_velocity():
    states = np.array([[-1.0, -2.0, 50.0, 0.5], [101.5, 3.0, 102.0, 1.0], [250.0, 1.0, 5.0, -1.0]])
    out = reflect(states, 100.0, 100.0)
    np.testing.assert_allclose(out[0], [1.0, 2.0, 50.0, 0.5])
    np.testing.assert_allclose(out[1], [98.5, -3.0, 98.0, -1.0])
    np.testing.assert_allclose(out[2], [50.0, 1.0, 5.0, -1.0])   # two bounces: 250 -> 50


def test_truth_stays_in_the_area_with_fast_noisy_targets():
    world = World(scenario(truth_process_noise=4.0,
                           random_births={'rate': 2.0, 'survival': 1.0, 'speed_std': 5.0}),
                  SatParams())
    for _ in range(50):
        world.advance()
        pos = world.truth().positions
        assert np.all((pos >= 0.0) & (pos <= 100.0))
    assert len(world.truth().ids) > 50


def test_inadmissible_and_unknown_actions_are_refused_and_the_agent_holds():
    world = World(scenario(agents=[{'id': 1, 'start': [0.0, 50.0]},
                                   {'id': 2, 'start': [50.0, 50.0]},
                                   {'id': 3, 'start': [70.0, 50.0]}]), SatParams())
    # Action 5 moves 2 m along angle pi (left), out of the area from x = 0.
    result = world.apply_actions({1: 5, 2: 99})
    assert not result[1].accepted and 'leaves the area' in result[1].reason
    assert not result[2].accepted and 'outside [0, 16]' in result[2].reason
    assert not result[3].accepted and 'no action' in result[3].reason
    np.testing.assert_allclose(world.pose(1), [0.0, 50.0])
    np.testing.assert_allclose(world.pose(2), [50.0, 50.0])
    result = world.apply_actions({1: 1, 2: 9, 3: 0})   # 2 m right, 4 m right, stay
    assert all(r.accepted for r in result.values())
    np.testing.assert_allclose(world.pose(1), [2.0, 50.0])
    np.testing.assert_allclose(world.pose(2), [54.0, 50.0])
    np.testing.assert_allclose(world.pose(3), [70.0, 50.0])


def test_radio_links_are_the_pairs_within_comm_range():
    world = World(scenario(agents=[{'id': 1, 'start': [0.0, 0.0]},
                                   {'id': 2, 'start': [30.0, 40.0]},     # exactly 50 m from 1
                                   {'id': 3, 'start': [30.0, 90.0]}]), SatParams())
    assert world.links() == {(1, 2), (2, 3)}
    world.apply_actions({1: 0, 2: 11, 3: 0})     # agent 2 moves 4 m up: 1-2 out of range
    assert world.links() == {(2, 3)}


def test_searched_fraction_counts_the_union_of_sensing_squares():
    params = SatParams()
    world = World(scenario(agents=[{'id': 1, 'start': [50.0, 50.0]},
                                   {'id': 2, 'start': [52.0, 50.0]}]), params)
    # Square [45, 55]: 10 x 10 cells of 1 m; agent 2 adds the column strip [55, 57].
    assert world.searched_fraction() == pytest.approx(12 * 10 / 10_000)
    world.apply_actions({1: 1, 2: 0})   # agent 1 to x = 52: nothing new
    assert world.searched_fraction() == pytest.approx(12 * 10 / 10_000)
    world.apply_actions({1: 3, 2: 0})   # agent 1 up 2 m: rows [55, 57] of columns [47, 57]
    assert world.searched_fraction() == pytest.approx((12 * 10 + 10 * 2) / 10_000)
    assert world.coverage.sum() == 140


def test_same_seed_gives_the_same_truth_and_scans_and_another_seed_does_not():
    def run(seed):
        world = World(scenario(seed=seed, truth_process_noise=1.0, random_births={
            'rate': 0.5, 'survival': 0.95, 'speed_std': 1.0}), SatParams())
        out = []
        for _ in range(20):
            scans = world.scan_all()
            out.append((world.truth().states.copy(), scans[1].measurements.copy(),
                        scans[2].source_ids.copy()))
            world.apply_actions({1: 1, 2: 5})
            world.advance()
        return out

    first, second, other = run(4), run(4), run(5)
    for a, b in zip(first, second):
        for x, y in zip(a, b):
            np.testing.assert_array_equal(x, y)
    assert any(a[1].shape != b[1].shape or not np.array_equal(a[1], b[1])
               for a, b in zip(first, other))


def test_scans_detect_targets_in_the_square_and_name_their_source():
    world = World(scenario(targets=[
        {'id': 7, 'born': 1, 'died': 50, 'start': [12.0, 11.0], 'end': [12.0, 11.0]}]),
        SatParams())
    detections = 0
    for _ in range(30):
        scans = world.scan_all()
        detections += int(np.sum(scans[1].source_ids == 7))
        assert np.all(scans[2].source_ids == -1)      # agent 2 is 38 m away
        world.advance()
    assert detections >= 27                            # p_D = 0.99


@pytest.mark.parametrize('change, message', [
    ({'steps': 0}, "'steps' = 0: allowed range is [1,"),
    ({'seed': 'x'}, "'seed' = 'x': must be an integer"),
    ({'colour': 'red'}, "unknown key(s) ['colour']"),
    ({'agents': []}, 'at least one agent'),
    ({'agents': [{'id': 1, 'start': [10.0, 200.0]}]}, "'agents[0].start[1]' = 200.0"),
    ({'agents': [{'id': 1, 'start': [1.0, 2.0]}, {'id': 1, 'start': [3.0, 4.0]}]},
     'id 1 appears twice'),
    ({'agents': [{'id': 1, 'pose': [1.0, 2.0]}]}, "unknown key(s) ['pose']"),
    ({'targets': [{'id': 1, 'born': 10, 'died': 5, 'start': [1, 1], 'end': [2, 2]}]},
     "'targets[0].died' = 5: allowed range is [10,"),
    ({'targets': [{'id': 1, 'born': 10, 'start': [1, 1], 'end': [2, 2]}]},
     "'targets[0].died' is missing"),
    ({'targets': [{'id': 1, 'born': 10, 'died': 20, 'start': [1, 1], 'end': [2, 2],
                   'via': [[10, 5.0, 5.0]]}]},
     "'targets[0].via[0][0]' = 10: allowed range is [11, 19]"),
    ({'targets': [{'id': 1, 'born': 10, 'died': 20, 'start': [1, 1], 'end': [2, 2],
                   'via': [[15, 5.0, 5.0], [12, 6.0, 6.0]]}]},
     "'targets[0].via[1][0]' = 12: allowed range is [16, 19]"),
    ({'targets': [{'id': 1, 'born': 10, 'died': 20, 'start': [1, 1], 'end': [2, 2],
                   'via': [[15, 5.0]]}]},
     "'targets[0].via[0]' = [15, 5.0]: must be a list [k, x, y]"),
    ({'targets': [{'id': 1, 'born': 10, 'died': 20, 'start': [1, 1], 'end': [2, 2],
                   'via': [[15, 5.0, 500.0]]}]},
     "'targets[0].via[0][2]' = 500.0: allowed range is [0, 100]"),
    ({'random_births': {'rate': -1.0, 'survival': 0.9, 'speed_std': 1.0}},
     "'random_births.rate' = -1.0: allowed range is [0,"),
    ({'truth_process_noise': float('nan')}, "'truth_process_noise' = nan"),
])
def test_scenario_validation_names_the_key_the_value_and_what_is_allowed(change, message):
    with pytest.raises(ScenarioError) as error:
        scenario(**change)
    assert message in str(error.value)


def test_missing_required_key_is_refused():
    with pytest.raises(ScenarioError, match="'agents' is missing"):
        scenario_from_mapping({'seed': 1, 'steps': 3})
    with pytest.raises(ScenarioError, match='must be a mapping'):
        scenario_from_mapping([1, 2])


def test_malformed_yaml_file_is_refused_with_its_path(tmp_path):
    path = tmp_path / 'bad.yaml'
    path.write_text('seed: [1,\n')
    with pytest.raises(ScenarioError, match='bad.yaml: not valid YAML'):
        load_scenario(path)
