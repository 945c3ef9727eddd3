import dataclasses

import numpy as np
import pytest

from sat_agent.actions import candidate_poses
from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.investigation import keep_in_view_action
from sat_agent.config import SatParams
from sat_agent.mode_machine import Mode
from sat_agent.search_density import SearchDensity
from sat_agent.search_map import nodes_in_view, unvisited_nodes
from sat_agent.search_planning import joint_plan, ReplanReason, search_action
from sat_agent.sensor_model import measure

NO_MEASUREMENTS = np.zeros((0, 2))


def small_params():
    # Small particle budgets: these tests are about the agent's bookkeeping, not the filter. The
    # filter's process noise matches the scripted, near-constant-velocity targets below (with the
    # paper's Q a target within ~4 m of the agent cannot hold PHD mass 0.5 against the clutter
    # intensity, see the helper report). The dense reading of the clutter (config/
    # dense_clutter.yaml) keeps confirmation, tentative peaks and looks closer in play.
    return SatParams().with_overrides({
        'motion.process_noise': 0.1,
        'sensor.clutter_max_range': 0.0, 'phd.birth_mass_measurement': 0.12,
        'phd.birth_particles_uniform': 200, 'phd.birth_particles_per_measurement': 30,
        'phd.particles_per_target': 300, 'phd.min_particles': 200, 'phd.max_particles': 2000})


def fly(agents, poses, steps, first_step=1, connected=False, measurements=None):
    """Step agents alone (or exchanging reports when connected); return the last outputs."""
    outputs = {}
    last_reports = {}
    for k in range(first_step, first_step + steps):
        for agent_id, agent in agents.items():
            inbox = [r for a, r in last_reports.items() if connected and a != agent_id]
            z = NO_MEASUREMENTS if measurements is None else measurements(k, poses[agent_id])
            outputs[agent_id] = agent.step(k, poses[agent_id], z, inbox)
        for agent_id, out in outputs.items():
            poses[agent_id] = candidate_poses(poses[agent_id],
                                              agents[agent_id].params.actions)[out.action]
        last_reports = {a: o.report for a, o in outputs.items()}
    return outputs


def test_two_agents_coming_into_range_fuse_densities_and_compute_the_same_joint_plan():
    params = small_params()
    poses = {1: np.array([10.0, 50.0]), 2: np.array([90.0, 50.0])}
    agents = {a: Agent(a, params, poses[a], seed=5) for a in poses}
    alone = fly(agents, poses, 6)
    assert all(o.replan == ReplanReason.NONE for o in alone.values())
    reports = {a: o.report for a, o in alone.items()}
    # Step 7: the radio delivers each agent the other's report of step 6.
    out = {a: agents[a].step(7, poses[a], NO_MEASUREMENTS, [reports[3 - a]]) for a in agents}
    assert out[1].replan == out[2].replan == ReplanReason.NEW_NEIGHBOUR
    # Each density now holds the other's searched cells (elementwise max).
    for a in agents:
        assert np.all(out[a].report.search_values >= reports[3 - a].search_values * 0.999 - 1e-6)
        assert np.all(out[a].report.search_values >= reports[a].search_values * 0.999 - 1e-6)
    # The partition each computed alone is the joint plan of the two step-6 reports, their
    # densities predicted to step 7 with their senders' poses.
    density = SearchDensity(agents[1].filter.search.lattice, params)
    fused = np.maximum(*(density.predicted(r.search_values, r.pose, 1)
                         for r in reports.values()))
    node_values = agents[1].search_map_values(fused)
    nodes = unvisited_nodes(node_values, params.search.unvisited_threshold)
    expected = joint_plan({a: reports[a].pose for a in agents}, agents[1].search_map.centers,
                          nodes)
    walks = {a: list(agents[a].planner.walk) for a in agents}
    assert not set(walks[1]) & set(walks[2])
    for a in agents:
        # The own walk is the expected one minus the nodes already in view at s_7.
        in_view = set(nodes_in_view(agents[a].search_map, poses[a], 10.0).tolist())
        assert walks[a] == [n for n in expected[a] if n not in in_view]
        assert len(expected[a]) > 30
    assert set(expected[1]) | set(expected[2]) == set(nodes.tolist())


def test_agents_meeting_again_replan_together_whatever_their_plans_groups():
    params = small_params()
    poses = {1: np.array([30.0, 50.0]), 2: np.array([70.0, 50.0])}
    agents = {a: Agent(a, params, poses[a], seed=6) for a in poses}
    fly(agents, poses, 3, connected=True)                    # joint plan at k = 2
    assert agents[1].planner.group == agents[2].planner.group == {1, 2}
    fly(agents, poses, 4, first_step=4)                      # out of radio range
    last = fly(agents, poses, 1, first_step=8)
    reports = {a: o.report for a, o in last.items()}
    out = {a: agents[a].step(9, poses[a], NO_MEASUREMENTS, [reports[3 - a]]) for a in agents}
    assert out[1].replan == out[2].replan == ReplanReason.NEW_NEIGHBOUR
    assert not set(agents[1].planner.walk) & set(agents[2].planner.walk)


def test_a_neighbour_leaving_search_releases_its_nodes():
    params = small_params()
    poses = {1: np.array([40.0, 50.0]), 2: np.array([60.0, 50.0])}
    agents = {a: Agent(a, params, poses[a], seed=2) for a in poses}
    out = fly(agents, poses, 3, connected=True)
    assert agents[1].planner.group == {1, 2}
    before = set(agents[1].planner.walk)
    tracking = dataclasses.replace(out[2].report, mode=Mode.TRACK)
    released = agents[1].step(4, poses[1], NO_MEASUREMENTS, [tracking])
    assert released.replan == ReplanReason.RELEASED
    after = set(agents[1].planner.walk)
    assert agents[1].planner.group == {1}
    assert after - before, 'agent 1 must take over nodes of agent 2'
    assert len(after) > len(before) + 20


def agent_and_neighbour_report(neighbour_pose):
    """Run step 1 of agent 1 at (50, 50) and agent 2 at neighbour_pose; return 1 and 2's report."""
    params = small_params()
    agent = Agent(1, params, (50.0, 50.0), seed=1)
    other = Agent(2, params, neighbour_pose, seed=1)
    report = other.step(1, neighbour_pose, NO_MEASUREMENTS, []).report
    agent.step(1, (50.0, 50.0), NO_MEASUREMENTS, [])
    return agent, report


def test_late_reports_only_add_their_density_predicted_to_the_step():
    agent, late = agent_and_neighbour_report((20.0, 20.0))
    agent.step(2, (50.0, 50.0), NO_MEASUREMENTS, [])
    # A report of step 1 read at step 3 (two steps of radio latency): its square, seen at
    # step 1, held 1 at step 2 (Eqn. satphd_predict keeps the previous square) and J at 3.
    out = agent.step(3, (50.0, 50.0), NO_MEASUREMENTS, [late])
    square = late.search_values == 1.0
    assert square.sum() == 100
    np.testing.assert_allclose(out.report.search_values[square], agent.params.search.decay,
                               rtol=1e-6)
    assert out.replan != ReplanReason.NEW_NEIGHBOUR and agent.planner.group == {1}
    assert agent.dropped_reports == 0


def test_foreign_and_malformed_reports_are_dropped():
    agent, report = agent_and_neighbour_report((60.0, 50.0))
    bad_shape = dataclasses.replace(report, search_values=np.zeros((3, 3)))
    nan_pose = dataclasses.replace(report, pose=np.array([np.nan, 1.0]))
    own = dataclasses.replace(report, agent_id=1)
    future = dataclasses.replace(report, step=5)
    # Node views (persistent planning's overdue rule): none or one per node, none after step 1.
    few_views = dataclasses.replace(report, node_views=np.zeros(3, dtype=np.int64))
    late_views = dataclasses.replace(report, node_views=np.full(agent.search_map.size, 2))
    out = agent.step(2, (50.0, 50.0), NO_MEASUREMENTS, [future, bad_shape, nan_pose, own,
                                                        few_views, late_views, report, report])
    # Ignored: the future report; dropped: bad shape, NaN pose, own id, the two with malformed
    # node views, the second copy.
    assert agent.dropped_reports == 6
    assert out.replan == ReplanReason.NEW_NEIGHBOUR


def target_measurements(target, rng):
    def measurements(k, pose):
        z = measure(np.array([target(k)]), pose)
        return z + rng.normal(0.0, [0.5, 0.01], z.shape) if np.max(
            np.abs(target(k) - pose)) <= 5.0 else NO_MEASUREMENTS
    return measurements


def hover_over_walking_target(steps, **additions):
    """Run an agent the world holds at (50, 50) for steps scans of a target walking past it.

    additions: switches of params.additions to set. Returns (params, pose, target(k), the
    agent, its outputs of steps 1..steps).
    """
    params = small_params().with_overrides({f'additions.{k}': v for k, v in additions.items()})
    pose = np.array([50.0, 50.0])
    agent = Agent(1, params, pose, seed=4)
    target = (lambda k: np.array([52.0 + 0.3 * k, 51.0]))
    measurements = target_measurements(target, np.random.default_rng(0))
    outputs = [agent.step(k, pose, measurements(k, pose), []) for k in range(1, steps + 1)]
    return params, pose, target, agent, outputs


def test_agent_detects_a_target_in_view_and_switches_to_tracking_control():
    params, pose, target, _, outputs = hover_over_walking_target(6)
    # Births from scan 1 grow with every scan; a new target needs round(mass) >= 1 on
    # phd.confirm_scans = 2 scans in a row: tentative (round(mass) = 0, then 1) before that.
    assert [o.mode for o in outputs] == [Mode.SEARCH] * 5 + [Mode.TRACK]
    assert outputs[3].estimate.tentative and outputs[4].estimate.tentative_streaks == (1,)
    search, track = outputs[0], outputs[5]
    assert len(search.plan) > 0 and len(track.plan) == 0
    (estimate,) = track.estimate.targets
    assert np.linalg.norm(estimate.position - target(6)) < 1.5
    assert track.report.mode == Mode.TRACK and track.report.estimate is track.estimate
    np.testing.assert_allclose(track.goal, candidate_poses(pose, params.actions)[track.action])
    # Tracking control keeps the target in the square it chooses, at the stand-off.
    assert np.max(np.abs(target(7) - track.goal)) <= 5.0
    assert np.linalg.norm(estimate.position - track.goal) >= params.cooperation.track_standoff


def test_searching_agent_holds_its_walk_to_look_at_a_tentative_peak():
    params, pose, _, agent, outputs = hover_over_walking_target(4)
    assert outputs[3].mode == Mode.SEARCH and outputs[3].estimate.tentative
    peak = outputs[3].estimate.tentative[0].position
    # The walk's next node is not where it looks: the action is the tracking control's.
    assert not np.allclose(outputs[3].goal, agent.planner.next_goal())
    assert np.max(np.abs(peak - outputs[3].goal)) <= 5.0 - params.cooperation.track_edge_margin
    # Without anything tentative, the same agent follows its walk.
    fresh = Agent(1, params, pose, seed=3)
    quiet = [fresh.step(k, pose, NO_MEASUREMENTS, []) for k in range(1, 5)]
    assert not quiet[3].estimate.tentative
    np.testing.assert_allclose(quiet[3].goal, fresh.planner.next_goal())


def test_investigation_switch_holds_the_walk_on_a_tentative_peak_or_follows_it():
    _, pose, _, _, outputs = hover_over_walking_target(4)
    assert outputs[3].mode == Mode.SEARCH and outputs[3].estimate.tentative
    paper, _, _, agent, off = hover_over_walking_target(4, investigation=False)
    # The same scans give the same tentative peak, but the paper's agent follows its walk.
    np.testing.assert_allclose(off[3].estimate.tentative[0].position,
                               outputs[3].estimate.tentative[0].position)
    np.testing.assert_allclose(off[3].goal, agent.planner.next_goal())
    assert off[3].action == search_action(pose, agent.planner.next_goal(), paper)
    assert off[3].action != outputs[3].action


def test_keep_in_view_action_keeps_a_point_inside_the_next_square():
    params = SatParams()
    inner = params.sensor.square_side / 2.0 - params.cooperation.track_edge_margin
    poses = candidate_poses((50.0, 50.0), params.actions)
    # A point 3 m behind the agent: the 4 m step east would leave it 7 m behind, outside the
    # square; the 2 m step east keeps it 5 m behind, outside the inner square too. Of the
    # actions that hold it, staying is the nearest to the goal.
    behind = np.array([[47.0, 50.0]])
    action = keep_in_view_action((50.0, 50.0), (60.0, 50.0), params, behind)
    assert action == 0 and search_action((50.0, 50.0), (60.0, 50.0), params) == 9
    assert np.max(np.abs(poses[action] - behind[0])) <= inner
    # A point ahead costs nothing: the free choice already holds it.
    ahead = np.array([[55.0, 50.0]])
    assert keep_in_view_action((50.0, 50.0), (60.0, 50.0), params, ahead) == 9
    # No action can hold a point 20 m away: the constraint is dropped.
    far = np.array([[30.0, 50.0]])
    assert keep_in_view_action((50.0, 50.0), (60.0, 50.0), params, far) == 9


def test_keep_in_view_action_holds_the_longest_run_of_points_from_the_first():
    params = SatParams()
    pose, goal = (50.0, 50.0), (50.0, 60.0)
    poses = candidate_poses(pose, params.actions)
    first, second, far = [47.0, 50.0], [53.0, 52.0], [90.0, 90.0]

    def lands(keep):
        return poses[keep_in_view_action(pose, goal, params, np.array(keep))]
    # The first alone: 4 m north-west is the nearest to the goal of the moves holding it
    # (3.5 m inside each edge); the second too: 2 m north, which holds both.
    np.testing.assert_allclose(lands([first]), [50.0 - 2.0 * 2 ** 0.5, 50.0 + 2.0 * 2 ** 0.5])
    np.testing.assert_allclose(lands([first, second]), [50.0, 52.0])
    # A point no move can hold ends the run; first in the list, it lifts every limit.
    np.testing.assert_allclose(lands([first, far, second]), lands([first]))
    np.testing.assert_allclose(lands([far, first]), [50.0, 54.0])


def test_keep_in_view_action_at_full_speed_steers_the_walk_but_never_slows_it():
    params = SatParams()
    pose, goal = (50.0, 50.0), (50.0, 60.0)
    poses = candidate_poses(pose, params.actions)
    walk = search_action(pose, goal, params)
    first, second = [47.0, 50.0], [53.0, 52.0]

    def lands(keep, full_speed=True):
        return poses[keep_in_view_action(pose, goal, params, np.array(keep), full_speed)]
    # Held by a 4 m move (north-west), the first is kept as before: the walk only turns.
    np.testing.assert_allclose(lands([first]), lands([first], full_speed=False))
    # Both are held only by the 2 m step north; at full speed the run is the first alone.
    np.testing.assert_allclose(lands([first, second], full_speed=False), [50.0, 52.0])
    np.testing.assert_allclose(lands([first, second]), lands([first]))
    # A point 3 m behind an agent flying east: of the moves holding it standing is the nearest
    # to the goal; at full speed it is 4 m north-west (the turn, not the pace, pays for it).
    behind = np.array([[47.0, 50.0]])
    east = (60.0, 50.0)
    assert keep_in_view_action(pose, east, params, behind) == 0
    np.testing.assert_allclose(poses[keep_in_view_action(pose, east, params, behind, True)],
                               [50.0 - 2.0 * 2 ** 0.5, 50.0 + 2.0 * 2 ** 0.5])
    for keep in ([first], [first, second], [[90.0, 90.0]]):
        step = lands(keep) - np.asarray(pose)
        assert np.hypot(*step) == pytest.approx(np.hypot(*(poses[walk] - np.asarray(pose))))


def test_searching_agent_keeps_a_spot_seen_once_in_its_next_square_then_resumes_its_walk():
    # The paper reading of the clutter: one measurement 4 m from the agent seeds 0.28 of birth
    # mass, above phd.tentative_threshold.
    params = small_params().with_overrides({'sensor.clutter_max_range': 141.42,
                                            'phd.birth_mass_measurement': 0.5})
    pose = np.array([50.0, 50.0])
    free = Agent(1, params, pose, seed=4).step(1, pose, NO_MEASUREMENTS, [])
    ahead = candidate_poses(pose, params.actions)[free.action] - pose
    spot = pose - 4.0 * ahead / np.linalg.norm(ahead)     # seen once, behind the move
    assert np.max(np.abs(spot - free.goal)) > params.sensor.square_side / 2.0 or \
        np.max(np.abs(spot - (pose + ahead))) > params.sensor.square_side / 2.0
    agent = Agent(1, params, pose, seed=4)
    first = agent.step(1, pose, measure(spot[None], pose), [])
    assert first.mode == Mode.SEARCH and not first.estimate.targets
    next_pose = candidate_poses(pose, params.actions)[first.action]
    inner = params.sensor.square_side / 2.0 - params.cooperation.track_edge_margin
    assert np.max(np.abs(spot - next_pose)) <= inner
    # The walk is unchanged: the goal is still its next node.
    np.testing.assert_allclose(first.goal, agent.planner.next_goal())
    # Nothing there at the next scan (a false alarm): the walk's own move, at once.
    second = agent.step(2, next_pose, NO_MEASUREMENTS, [])
    assert not second.estimate.tentative
    expected = search_action(next_pose, agent.planner.next_goal(), params)
    assert second.action == expected


def test_two_trackers_of_one_target_detect_the_overlap_and_the_higher_id_leaves():
    params = small_params()
    poses = {1: np.array([48.0, 50.0]), 2: np.array([52.0, 50.0])}
    agents = {a: Agent(a, params, poses[a], seed=4) for a in poses}
    target = (lambda k: np.array([50.0 + 0.05 * k, 50.0]))
    measurements = target_measurements(target, np.random.default_rng(1))
    reports, events = {}, []
    # The world holds both agents (2 m either side of the target), so only the overlap logic
    # decides who tracks.
    for k in range(1, 25):
        out = {a: agents[a].step(k, poses[a], measurements(k, poses[a]),
                                 [r for b, r in reports.items() if b != a]) for a in agents}
        reports = {a: o.report for a, o in out.items()}
        events += [(k, a, o.left_overlap_with) for a, o in out.items() if o.left_overlap_with]
        if events:
            break
    assert events, 'two agents tracking one target in overlapping squares must notice it'
    step, leaver, kept = events[0]
    assert (leaver, kept) == (2, 1)
    # The window (overlap_window = 5 steps of both in TRACK) must be full before the verdict.
    assert step >= 3 + params.cooperation.overlap_window
    assert out[2].mode == Mode.SEARCH and out[1].mode == Mode.TRACK
    assert len(out[2].plan) > 0, 'the leaver plans a search at once'


def test_same_seed_same_outputs():
    params = small_params()
    target = (lambda k: np.array([48.0 + 0.5 * k, 49.0]))

    def run(seed):
        poses = {1: np.array([50.0, 50.0])}
        agent = Agent(1, params, poses[1], seed=seed)
        trace = []
        for k in range(1, 13):
            out = fly({1: agent}, poses, 1, first_step=k,
                      measurements=target_measurements(target, np.random.default_rng(k)))
            trace.append((out[1].action, out[1].mode,
                          [t.position.tolist() for t in out[1].estimate.targets],
                          agent.filter.targets.weights.sum()))
        return trace

    assert run(11) == run(11)
    assert run(11) != run(12)


def test_filter_stream_redraws_the_particles_of_the_same_seed_only():
    """phd.filter_stream gives another filter stream for a seed; the default is stream 0."""
    params = small_params()
    pose = np.array([50.0, 50.0])

    def particles(values, seed=11):
        return Agent(1, values, pose, seed=seed).filter.targets.states

    assert params.phd.filter_stream == 0
    np.testing.assert_array_equal(particles(params), particles(params))
    other = params.with_overrides({'phd.filter_stream': 1})
    assert particles(other).shape == particles(params).shape
    assert not np.array_equal(particles(other), particles(params))
    # Not merely the next seed's stream.
    assert not np.array_equal(particles(other), particles(params, seed=12))


@pytest.mark.parametrize('pose', [(0.0, 0.0), (100.0, 37.0)])
def test_actions_are_admissible_at_the_border(pose):
    params = small_params()
    poses = {1: np.array(pose)}
    agent = Agent(1, params, poses[1], seed=0)
    for k in range(1, 6):
        out = agent.step(k, poses[1], NO_MEASUREMENTS, [])
        nxt = candidate_poses(poses[1], params.actions)[out.action]
        assert 0.0 <= nxt[0] <= 100.0 and 0.0 <= nxt[1] <= 100.0
        poses[1] = nxt


def square_walk(rows):
    """Poses jumping one sensing square (11 m) per step along the given rows of y, then holding.

    Each cell under a jump is seen at one step only (the squares do not touch).
    """
    poses = [np.array([5.5 + 11.0 * i, y]) for y in rows for i in range(9)]
    return lambda k: poses[min(k, len(poses)) - 1]


def test_two_agents_in_range_age_a_cell_seen_once_as_a_lone_agent_does():
    """Fusion ages correctly (issue 14): two agents in range for 200 steps against lone agents.

    Each received density is predicted to the receiver's step before the max. A cell seen at
    step t only holds 1 in the posterior of t and, by Eqn. satphd_predict (a cell in the
    previous pose's square keeps its value), still 1 at t + 1; then it decays by J per step:
    J^(k-t-1) at every k > t. The issue writes J^(k-t): it counts the prediction to t + 1 as a
    decay, which the paper's recursion does not. Agent 1 and a lone twin sweep the lower rows,
    agent 2 and its twin the upper rows, each cell under a jump seen at one step only; the pair
    exchanges reports every step (in range). For a cell only one of them saw, both agents of the
    pair hold the lone agent's value at every k > t (the neighbour learns it one step late).
    """
    params = small_params()
    J = params.search.decay
    walks = {1: square_walk([5.5, 16.5, 27.5, 38.5]), 2: square_walk([60.5, 71.5, 82.5, 93.5])}
    pair = {a: Agent(a, params, walks[a](1), seed=1) for a in walks}
    lone = {a: Agent(a, params, walks[a](1), seed=1) for a in walks}
    lattice = pair[1].filter.search.lattice
    centers = lattice.centers()
    seen = {a: np.zeros((201, len(centers)), dtype=bool) for a in walks}    # [k, cell]
    values = {name: np.zeros((201, len(centers))) for name in ('pair1', 'pair2', 'lone1', 'lone2')}
    reports = {}
    for k in range(1, 201):
        out = {a: pair[a].step(k, walks[a](k), NO_MEASUREMENTS,
                               [reports[b]] if b in reports else [])
               for a, b in ((1, 2), (2, 1))}
        reports = {a: o.report for a, o in out.items()}
        for a in walks:
            alone = lone[a].step(k, walks[a](k), NO_MEASUREMENTS, [])
            values[f'lone{a}'][k] = alone.report.search_values.ravel()
            values[f'pair{a}'][k] = out[a].report.search_values.ravel()
            seen[a][k] = np.all(np.abs(centers - walks[a](k)) <= 5.0, axis=1)
    for a, other in ((1, 2), (2, 1)):
        once = (seen[a].sum(axis=0) == 1) & ~seen[other].any(axis=0)
        cells = np.flatnonzero(once)
        assert len(cells) > 3000, 'both sweeps see most of their cells once'
        first = np.argmax(seen[a][:, cells], axis=0)                     # t of each cell
        for k in range(2, 201):
            later = first < k
            age = np.maximum(k - first[later] - 1, 0)
            expected = J ** age
            np.testing.assert_allclose(values[f'lone{a}'][k, cells[later]], expected, rtol=1e-6)
            # float32 on the wire: each hop rounds, and the max keeps the upward roundings.
            for name in ('pair1', 'pair2'):
                np.testing.assert_allclose(values[name][k, cells[later]], expected, rtol=1e-5)
    # The figure: after 200 steps the cells swept at the start have aged in both.
    assert values['pair2'][200, np.flatnonzero(seen[1][1])].max() < J ** 190
