import math

import numpy as np
import pytest

from sat_agent.actions import top_speed
from sat_agent.beyond_paper.track_coasting import coast_steps
from sat_agent.config import AreaParams, SatParams
from sat_agent.sensor_model import in_sensing_square
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.oracle_sweep import Confirmation, follow_position, lane_ends, lap_positions
from sat_world_sim.oracle_sweep import run_oracle_sweep
from sat_world_sim.oracle_sweep import strip_lanes, sweep_cycle, sweep_positions, tour_cycle
from sat_world_sim.oracle_sweep import tour_lap, tour_positions
from sat_world_sim.random_scenarios import random_scenario
from sat_world_sim.scenario import scenario_from_mapping
from sat_world_sim.world_model import World

PARAMS = SatParams()
SIDE = PARAMS.sensor.square_side


def derived_period(lanes: int, length: float, speed: float) -> int:
    """P = 2 (m ceil(l / v) + (m - 1) ceil(a / v)) of the module docstring."""
    return 2 * (lanes * math.ceil(length / speed) + (lanes - 1) * math.ceil(SIDE / speed))


def strip_cells(lanes: np.ndarray) -> np.ndarray:
    """Centres of the 1 m lattice cells of a strip (its lanes' squares, side by side)."""
    xs = np.arange(lanes.min() - SIDE / 2 + 0.5, lanes.max() + SIDE / 2, 1.0)
    ys = np.arange(0.5, PARAMS.area.height, 1.0)
    return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)


@pytest.mark.parametrize('agents', [1, 2, 4, 8])
def test_the_oracle_visits_every_cell_of_its_strip_within_its_period(agents):
    speed = top_speed(PARAMS.actions)
    low, high = lane_ends(PARAMS)
    for lanes in strip_lanes(PARAMS, agents):
        lap = lap_positions(sweep_cycle(lanes, lane_ends(PARAMS)), speed)
        period = derived_period(len(lanes), high - low, speed)
        assert len(lap) == period
        # seen[t, c]: cell c in the square at step t of the lap. The path repeats the lap, so
        # every window of P consecutive steps holds each step of the lap once: seeing every
        # cell within any window is seeing it at some step of the lap.
        seen = in_sensing_square(strip_cells(lanes)[None, :, :], lap[:, None, :], SIDE)
        assert seen.any(axis=0).all(), lanes
        # The period is tight: some cell is seen at one step of the lap only, so a window of
        # P - 1 steps starting right after it misses it.
        assert (seen.sum(axis=0) == 1).any()


def test_strips_are_disjoint_and_their_lanes_tile_the_area():
    for agents in (1, 2, 3, 4, 8, 10):
        lanes = np.concatenate(strip_lanes(PARAMS, agents))
        np.testing.assert_allclose(lanes, np.arange(SIDE / 2, PARAMS.area.width, SIDE))
    with pytest.raises(ValueError, match='11 agents for 10 lanes'):
        strip_lanes(PARAMS, 11)


def test_sweep_positions_start_at_the_start_and_never_exceed_the_speed():
    speed = top_speed(PARAMS.actions)
    cycle = sweep_cycle(strip_lanes(PARAMS, 4)[2], lane_ends(PARAMS))
    path = sweep_positions((12.3, 81.7), cycle, speed, 400)
    assert path.shape == (400, 2)
    np.testing.assert_allclose(path[0], (12.3, 81.7))
    steps = np.hypot(*np.diff(path, axis=0).T)
    assert steps.max() <= speed + 1e-9
    assert np.all((path >= 0.0) & (path <= 100.0))


def area_cells(area: AreaParams) -> np.ndarray:
    """Centres of the area's 1 m lattice cells."""
    xs, ys = np.arange(0.5, area.width, 1.0), np.arange(0.5, area.height, 1.0)
    return np.stack(np.meshgrid(xs, ys), axis=-1).reshape(-1, 2)


def test_the_tour_is_one_closed_lap_over_every_lane_flown_once():
    lap = tour_lap(PARAMS)
    # 10 lanes: up the first (90 m), nine snaked over 80 m with 10 m between them, 10 m down
    # to the lowest row and 90 m back along it: 1000 m, each leg in ceil(length / 4 m) steps.
    assert len(lap) == 2 * 23 + 9 * 20 + 9 * 3 + 3 == 256
    np.testing.assert_allclose(lap[-1], (5.0, 5.0))
    steps = np.hypot(*np.diff(np.vstack([lap[-1:], lap]), axis=0).T)
    assert steps.max() <= top_speed(PARAMS.actions) + 1e-9
    assert math.isclose(steps.sum(), 1000.0)
    seen = in_sensing_square(area_cells(PARAMS.area)[None, :, :], lap[:, None, :], SIDE)
    assert seen.any(axis=0).all()


@pytest.mark.parametrize('width, height', [(90.0, 100.0), (10.0, 60.0), (60.0, 10.0)])
def test_odd_lane_counts_one_lane_and_one_row_still_close_and_cover_the_area(width, height):
    params = SatParams().with_overrides({'area.width': width, 'area.height': height})
    cycle = tour_cycle(np.array([(x, y) for x in np.arange(5.0, width, 10.0)
                                 for y in np.arange(5.0, height, 10.0)]))
    np.testing.assert_allclose(cycle[0], (5.0, 5.0))
    lap = tour_lap(params)
    np.testing.assert_allclose(lap[-1], cycle[0])
    seen = in_sensing_square(area_cells(params.area)[None, :, :], lap[:, None, :], SIDE)
    assert seen.any(axis=0).all()


@pytest.mark.parametrize('agents', [1, 2, 3, 4, 8])
def test_evenly_phased_slots_see_every_cell_within_ceil_p_over_n_steps(agents):
    # A cell slot 0 sees at t is seen by slot r at t - floor(r P / n): consecutive sightings
    # are at most ceil(P / n) apart, against a strip's whole ping-pong period (150 steps for
    # the 4-agent strips of three lanes).
    lap = tour_lap(PARAMS)
    period = len(lap)
    offsets = np.arange(agents) * period // agents
    slots = lap[(np.arange(period)[:, None] + offsets[None, :]) % period]
    seen = in_sensing_square(area_cells(PARAMS.area)[None, None, :, :], slots[:, :, None, :],
                             SIDE).any(axis=1)
    times = [np.flatnonzero(column) for column in seen.T]
    gaps = [np.diff(np.append(t, t[0] + period)).max() for t in times]
    assert max(gaps) <= math.ceil(period / agents)


def test_tour_positions_fly_to_the_first_reachable_slot_point_wait_and_ride():
    lap, speed = tour_lap(PARAMS), top_speed(PARAMS.actions)
    start, phase = np.array([52.3, 47.9]), 200
    path = tour_positions(start, lap, phase, speed, 300)
    assert path.shape == (300, 2)
    np.testing.assert_allclose(path[0], start)
    assert np.hypot(*np.diff(path, axis=0).T).max() <= speed + 1e-9
    slot = lap[(phase + np.arange(300)) % len(lap)]
    riding = np.flatnonzero(np.all(np.isclose(path, slot), axis=1))
    meet = riding[0]
    np.testing.assert_array_equal(riding, np.arange(meet, 300))
    # No earlier point of the slot was within reach.
    ahead = np.arange(1, meet)
    assert np.all(np.hypot(*(slot[ahead] - start).T) > ahead * speed)


def test_the_tour_oracle_finds_what_enters_and_a_follower_rejoins_its_slot():
    scenario = random_scenario(5, 4, 200)
    run = run_oracle_sweep(scenario, PARAMS, tour=True)
    summary = compute_metrics(run.records, scenario.name, 5)['summary']
    assert summary['detected_share'] == summary['detectable_share'] > 0.0
    lap = tour_lap(PARAMS)
    # By the last step every agent rides its slot, a quarter lap apart.
    last = len(run.records) - 1
    for rank, agent_id in enumerate(sorted(run.records[-1].agent_poses)):
        np.testing.assert_allclose(run.records[-1].agent_poses[agent_id],
                                   lap[(last + rank * len(lap) // 4) % len(lap)])
    followed = followed_scenario()
    run = run_oracle_sweep(followed, PARAMS, follow=True, tour=True)
    poses = np.array([r.agent_poses[1] for r in run.records])
    modes = [r.modes[1] for r in run.records]
    back = modes.index('SEARCH')
    assert back > 1 and 'TRACK' not in modes[back:]
    np.testing.assert_allclose(poses[back:], tour_positions(
        poses[back], lap, back % len(lap), top_speed(PARAMS.actions), len(poses) - back))


def test_the_oracle_detects_exactly_the_targets_that_enter_a_square_on_the_same_truth():
    scenario = random_scenario(5, 4, 200)
    run = run_oracle_sweep(scenario, PARAMS)
    summary = compute_metrics(run.records, scenario.name, 5)['summary']
    assert summary['detected_share'] == summary['detectable_share'] > 0.0
    assert summary['false_track_steps'] == 0 and summary['duplicate_tracking_steps'] == 0
    assert {m for r in run.records for m in r.modes.values()} == {'SEARCH'}
    # The oracle's truth is the World's for the seed, whoever flies.
    world = World(scenario, PARAMS)
    for record in run.records[:150]:
        truth = world.truth()
        np.testing.assert_array_equal(record.truth_ids, truth.ids)
        np.testing.assert_allclose(record.truth_positions, truth.positions)
        world.advance()
    # 150 steps is the longest period with 4 agents: by then every cell has been seen.
    assert run.records[-1].searched_fraction == 1.0


def test_place_agents_refuses_positions_outside_the_area():
    world = World(random_scenario(1, 2, 10), PARAMS)
    with pytest.raises(ValueError, match='leave the area'):
        world.place_agents({1: np.array([50.0, 50.0]), 2: np.array([101.0, 50.0])})
    world.place_agents({1: np.array([50.0, 50.0]), 2: np.array([0.0, 100.0])})
    np.testing.assert_allclose(world.pose(2), (0.0, 100.0))


def followed_scenario(steps: int = 120):
    """Agent 1 starts on a target walking east at 1 m/s (born 1, dies 60); agent 2 far away."""
    return scenario_from_mapping({
        'name': 'follow', 'seed': 3, 'steps': steps, 'truth_process_noise': 1.0e-4,
        'agents': [{'id': 1, 'start': [20.0, 50.0]}, {'id': 2, 'start': [90.0, 90.0]}],
        'targets': [{'id': 1, 'born': 1, 'died': 60, 'start': [21.0, 51.0],
                     'end': [80.0, 51.0]}]})


def test_sweep_and_track_follows_a_target_in_view_until_it_dies_then_sweeps_again():
    scenario = followed_scenario()
    run = run_oracle_sweep(scenario, PARAMS, follow=True)
    speed = top_speed(PARAMS.actions)
    poses = np.array([r.agent_poses[1] for r in run.records])
    assert np.hypot(*np.diff(poses, axis=0).T).max() <= speed + 1e-9
    alive = [r for r in run.records if 1 in r.truth_ids]
    assert [r.step for r in alive] == list(range(1, 61))
    for record in alive:
        # In view at every step of its life, reported, and agent 1 is the one tracking it.
        assert in_sensing_square(record.truth_positions, record.agent_poses[1], SIDE).all()
        np.testing.assert_allclose(record.estimates[1], record.truth_positions)
        assert record.modes == {1: 'TRACK', 2: 'SEARCH'}
    after = run.records[60:]
    assert {m for r in after for m in r.modes.values()} == {'SEARCH'}
    # Back on its strip: the sweep's path from where the target died, leg to the nearest
    # waypoint then laps.
    cycle = sweep_cycle(strip_lanes(PARAMS, 2)[0], lane_ends(PARAMS))
    expected = sweep_positions(poses[60], cycle, speed, len(after))
    np.testing.assert_allclose(poses[60:], expected)
    summary = compute_metrics(run.records, scenario.name, 3)['summary']
    assert summary['tracked_share'] == 1.0
    # The sweep alone passes it by.
    sweep = compute_metrics(run_oracle_sweep(scenario, PARAMS).records, scenario.name, 3)
    assert sweep['summary']['tracked_share'] < 0.5


def test_sweep_and_track_gives_each_target_one_follower_and_finds_what_enters():
    scenario = random_scenario(7, 4, 200)
    run = run_oracle_sweep(scenario, PARAMS, follow=True)
    summary = compute_metrics(run.records, scenario.name, 7)['summary']
    assert summary['detected_share'] == summary['detectable_share'] > 0.0
    assert summary['false_track_steps'] == 0
    sweep = compute_metrics(run_oracle_sweep(scenario, PARAMS).records, scenario.name, 7)
    assert summary['tracked_share'] > sweep['summary']['tracked_share']
    followers = 0
    for record in run.records:
        tracking = [a for a, mode in record.modes.items() if mode == 'TRACK']
        followers += len(tracking)
        for agent in tracking:
            # A follower has some target in view at every step it follows.
            assert len(record.estimates[agent]) >= 1
    assert followers > 0


def test_follow_position_aims_at_the_next_true_position_at_most_one_sweep_step_away():
    speed = top_speed(PARAMS.actions)
    # [x, vx, y, vy]: the target will be at (31, 40) after T = 1 s.
    np.testing.assert_allclose(follow_position((29.0, 40.0), (30.0, 1.0, 40.0, 0.0), speed,
                                               PARAMS), (31.0, 40.0))
    far = follow_position((0.0, 0.0), (30.0, 0.0, 40.0, 0.0), speed, PARAMS)
    np.testing.assert_allclose(far, (0.6 * speed, 0.8 * speed))
    # A target at the border heading out: the aim stays inside the area.
    np.testing.assert_allclose(follow_position((99.0, 50.0), (99.5, 2.0, 50.0, 0.0), speed,
                                               PARAMS), (100.0, 50.0))


def test_a_follow_limit_releases_the_target_for_good_and_sends_the_agent_back_to_its_strip():
    scenario = followed_scenario()
    run = run_oracle_sweep(scenario, PARAMS, follow=True, follow_limit=10)
    modes = [r.modes[1] for r in run.records]
    assert modes[:10] == ['TRACK'] * 10
    # Released at step 11 and never followed again, by anyone, while it lives (to k = 60).
    assert {m for r in run.records[10:] for m in r.modes.values()} == {'SEARCH'}
    poses = np.array([r.agent_poses[1] for r in run.records])
    cycle = sweep_cycle(strip_lanes(PARAMS, 2)[0], lane_ends(PARAMS))
    np.testing.assert_allclose(poses[10:], sweep_positions(
        poses[10], cycle, top_speed(PARAMS.actions), len(poses) - 10))
    tracked = compute_metrics(run.records, scenario.name, 3)['summary']['tracked_share']
    assert tracked < 1.0


def test_with_one_follower_the_other_agent_sweeps_past_a_target_it_sees():
    scenario = followed_scenario()
    # Agent 2 alone may follow and never has the target in its square: nobody follows it.
    run = run_oracle_sweep(scenario, PARAMS, follow=True, followers=1)
    sweep = run_oracle_sweep(scenario, PARAMS)
    assert {m for r in run.records for m in r.modes.values()} == {'SEARCH'}
    for mine, swept in zip(run.records, sweep.records):
        np.testing.assert_allclose(mine.agent_poses[1], swept.agent_poses[1])
        np.testing.assert_allclose(mine.agent_poses[2], swept.agent_poses[2])
    assert len(run.records[0].estimates[1]) == 1
    with pytest.raises(ValueError, match='followers = 3 for a team of 2: must be 0 to 2'):
        run_oracle_sweep(scenario, PARAMS, follow=True, followers=3)


def test_dispatch_sends_the_free_follower_to_a_target_another_agent_has_seen():
    scenario = followed_scenario()
    run = run_oracle_sweep(scenario, PARAMS, follow=True, followers=1, dispatch=True)
    speed = top_speed(PARAMS.actions)
    poses = np.array([r.agent_poses[2] for r in run.records])
    assert np.hypot(*np.diff(poses, axis=0).T).max() <= speed + 1e-9
    # Agent 1 sees the target at k = 1 (its start); agent 2, 70 m off, is dispatched at once
    # and flies to it at v, then holds it in view until it dies at k = 60.
    modes = [r.modes for r in run.records]
    assert all(m == {1: 'SEARCH', 2: 'TRACK'} for m in modes[:60])
    assert {m for r in modes[60:] for m in r.values()} == {'SEARCH'}
    arrived = next(k for k, r in enumerate(run.records)
                   if in_sensing_square(r.truth_positions, r.agent_poses[2], SIDE).all())
    assert 10 < arrived < 40
    for record in run.records[arrived:60]:
        assert in_sensing_square(record.truth_positions, record.agent_poses[2], SIDE).all()
    # Without dispatch agent 2 never goes there.
    alone = run_oracle_sweep(scenario, PARAMS, follow=True, followers=1)
    assert not any(len(r.estimates[2]) for r in alone.records)


def test_coasting_reports_a_released_target_on_its_walk_and_a_dead_one_until_the_horizon():
    scenario = followed_scenario(140)
    run = run_oracle_sweep(scenario, PARAMS, follow=True, follow_limit=10, coast=True)
    plain = run_oracle_sweep(scenario, PARAMS, follow=True, follow_limit=10)
    for mine, other in zip(run.records, plain.records):
        np.testing.assert_allclose(mine.agent_poses[1], other.agent_poses[1])
    horizon = coast_steps(PARAMS)
    coasted = []
    for record in run.records:
        seen = in_sensing_square(record.truth_positions, record.agent_poses[1], SIDE)
        if 1 in record.truth_ids and not seen.any():
            # Out of view and alive: reported where it is (the oracle knows the velocity; the
            # truth process noise moves it ~1 m off the line in 45 steps).
            assert record.estimates[1].shape == (1, 2)
            assert np.hypot(*(record.estimates[1] - record.truth_positions)[0]) < 2.0
            coasted.append(record.step)
    assert len(coasted) > 20
    last_seen = min(coasted) - 1
    # Dead at k = 60 and out of every square: reported on, as a false track, until the
    # horizon p_S^t >= 1/2 unless a square passes over the point.
    false = [r.step for r in run.records if 1 not in r.truth_ids and len(r.estimates[1])]
    assert false and max(false) <= last_seen + horizon
    summary = compute_metrics(run.records, scenario.name, 3)['summary']
    assert summary['tracked_share'] == 1.0 > compute_metrics(
        plain.records, scenario.name, 3)['summary']['tracked_share']
    assert summary['false_track_steps'] == len(false)


@pytest.mark.parametrize('scans, window', [(2, 2), (2, 4), (3, 4)])
def test_a_multi_scan_oracle_reports_a_target_once_one_agent_saw_it_often_enough(scans, window):
    scenario = random_scenario(5, 4, 200)
    run = run_oracle_sweep(scenario, PARAMS, scans=scans, window=window)
    sweep = run_oracle_sweep(scenario, PARAMS)
    found, glimpsed = set(), set()
    views = {}  # (agent, target) -> steps it was in that agent's square
    for mine, perfect in zip(run.records, sweep.records):
        # The sweep's paths do not depend on what it finds.
        for agent in perfect.agent_poses:
            np.testing.assert_allclose(mine.agent_poses[agent], perfect.agent_poses[agent])
        for agent, pose in perfect.agent_poses.items():
            seen = in_sensing_square(perfect.truth_positions, pose, SIDE)
            for target in perfect.truth_ids[seen].tolist():
                glimpsed.add(target)
                steps = views.setdefault((agent, target), [])
                steps.append(perfect.step)
                if sum(s > perfect.step - window for s in steps) >= scans:
                    found.add(target)
        for agent, pose in perfect.agent_poses.items():
            seen = in_sensing_square(perfect.truth_positions, pose, SIDE)
            expected = seen & np.isin(perfect.truth_ids, list(found))
            np.testing.assert_allclose(mine.estimates[agent], perfect.truth_positions[expected])
    summary = compute_metrics(run.records, scenario.name, 5)['summary']
    assert summary['detected_share'] == len(found) / len(scenario.targets)
    assert found <= glimpsed


def test_a_two_scan_follower_starts_following_at_the_second_scan():
    scenario = followed_scenario()
    run = run_oracle_sweep(scenario, PARAMS, follow=True, scans=2, window=2)
    # Agent 1 starts on the target and still has it in view after its first move.
    assert run.records[0].modes[1] == 'SEARCH' and len(run.records[0].estimates[1]) == 0
    for record in run.records[1:60]:
        assert record.modes[1] == 'TRACK'
        np.testing.assert_allclose(record.estimates[1], record.truth_positions)
    summary = compute_metrics(run.records, scenario.name, 3)['summary']
    assert summary['tracked_share'] == pytest.approx(59 / 60)
    with pytest.raises(ValueError, match='scans = 3, window = 2'):
        run_oracle_sweep(scenario, PARAMS, scans=3, window=2)


def test_the_scans_must_fall_within_the_window_and_come_from_one_agent():
    ids = np.array([7, 8])
    only_7, none = np.array([True, False]), np.array([False, False])
    # Agent 1 sees target 7 at steps 1 and 3, agent 2 at step 2.
    views = {1: {1: only_7, 2: none}, 2: {1: none, 2: only_7}, 3: {1: only_7, 2: none}}
    for window, found_at in ((2, None), (3, 3)):
        confirmation = Confirmation(2, window)
        reported = [confirmation.found_in_view(step, ids, views[step])[1][0] for step in (1, 2, 3)]
        assert reported == [False, False, found_at == 3]
    # Once found, every agent reports it in view, here agent 2 at its single glimpse.
    confirmation = Confirmation(2, 3)
    for step in (1, 2, 3):
        confirmation.found_in_view(step, ids, views[step])
    assert confirmation.found_in_view(4, ids, {1: none, 2: only_7})[2].tolist() == [True, False]
