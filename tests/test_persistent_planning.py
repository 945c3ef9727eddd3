"""Persistent planning (beyond_paper/persistent_planning.py): worth per distance, replans."""

from dataclasses import replace

import numpy as np
import pytest

from sat_agent.actions import candidate_poses
from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.overdue_nodes import (CellViews, cover_point, node_views_defect,
                                                  sweep_steps)
from sat_agent.beyond_paper.persistent_planning import PersistentPlanner, worth_dropped
from sat_agent.config import AreaParams, load_params_file
from sat_agent.search_density import Lattice
from sat_agent.search_map import nodes_in_view, SearchMap
from sat_agent.search_planning import greedy_closed_walk, joint_plan, ReplanReason, SearchPlanner
from sat_agent.sensor_model import in_sensing_square
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.random_scenarios import random_scenario

PERSISTENT = load_params_file('config/persistent.yaml')
MAP = SearchMap.for_area(AreaParams(), 10.0)
CELLS = Lattice.for_area(AreaParams(), 1.0).centers()


def test_walks_take_the_most_worth_per_metre_and_the_nearest_among_equals():
    centers = np.array([[10.0, 0.0], [30.0, 0.0], [-20.0, 0.0]])
    # From the origin: 1 / 10 m < 4 / 30 m, so the far node first; then from (30, 0) the
    # node at 20 m (worth 1, 0.05 / m) before the one at 50 m (worth 2, 0.04 / m).
    worth = np.array([1.0, 4.0, 2.0])
    assert joint_plan({1: (0.0, 0.0)}, centers, [0, 1, 2], worth)[1] == [1, 0, 2]
    # Equal worth: the paper's path-cheapest-arc.
    equal = np.ones(3)
    assert (joint_plan({1: (0.0, 0.0)}, centers, [0, 1, 2], equal)[1]
            == greedy_closed_walk((0.0, 0.0), centers, [0, 1, 2]))


def test_a_joint_plan_on_worth_partitions_every_node_alike_on_both_agents():
    rng = np.random.default_rng(4)
    worth = rng.random(MAP.size)
    starts = {1: (10.0, 60.0), 2: (60.0, 10.0)}
    plans = [joint_plan(dict(reversed(starts.items())), MAP.centers, range(MAP.size), worth),
             joint_plan(starts, MAP.centers, range(MAP.size)[::-1], worth)]
    assert plans[0] == plans[1]
    assert sorted(plans[0][1] + plans[0][2]) == list(range(MAP.size))


def _planned(params=PERSISTENT, worth=None):
    planner = PersistentPlanner(MAP, params)
    assert planner.needs_replan(frozenset({1}), False, step=1) == ReplanReason.NO_PLAN
    planner.plan(1, {1: (10.0, 60.0)}, np.ones(MAP.size) if worth is None else worth)
    return planner


def test_every_node_is_planned_and_joint_plans_are_remade_every_replan_period():
    planner = _planned()
    assert sorted(planner.walk) == list(range(MAP.size))      # no threshold, no fallback
    period = PERSISTENT.search.replan_period
    steps = range(2, 3 * period)
    # Alone, the agent keeps its walk (replanning it from wherever it is leaves stragglers).
    assert not any(planner.needs_replan(frozenset({1}), False, step=k) for k in steps)
    planner.plan(1, {1: (10.0, 60.0), 2: (60.0, 10.0)}, np.ones(MAP.size))
    reasons = [planner.needs_replan(frozenset({1, 2}), False, step=k) for k in steps]
    assert [k for k, r in zip(steps, reasons) if r] == [period, 2 * period]
    assert set(reasons) == {ReplanReason.NONE, ReplanReason.PERIODIC}
    # The paper's planner (the switch off) never replans on the clock.
    off = PERSISTENT.with_overrides({'additions.persistent_planning': False})
    paper = SearchPlanner(MAP, off)
    paper.needs_replan(frozenset({1}), False, step=1)
    paper.plan(1, {1: (10.0, 60.0)}, np.zeros(MAP.size))
    paper.plan(1, {1: (10.0, 60.0), 2: (60.0, 10.0)}, np.zeros(MAP.size))
    assert not any(paper.needs_replan(frozenset({1, 2}), False, step=k) for k in steps)


def test_a_node_whose_worth_fell_by_half_was_searched_by_someone_else():
    worth = np.full(MAP.size, 2e-4)
    planner = _planned(worth=worth)
    now = worth * 1.01                       # regrown a little
    now[[50, 51]] = 0.9e-4                   # someone's square covered most of them
    dropped = planner.mark_visited((-50.0, -50.0), now)
    assert sorted(dropped.tolist()) == [50, 51]
    np.testing.assert_array_equal(worth_dropped(now, None), np.zeros(MAP.size, dtype=bool))
    off = PERSISTENT.with_overrides({'additions.drop_searched_nodes': False})
    assert _planned(off, worth).mark_visited((-50.0, -50.0), now).size == 0


def test_a_walk_whose_next_node_pays_less_than_half_the_best_rate_is_replanned_alone():
    worth = np.ones(MAP.size)
    planner = _planned(worth=worth)
    pose = np.array([10.0, 60.0])              # the start: the walk's next node is the nearest
    planner.mark_visited(pose, worth)
    assert planner.needs_replan(frozenset({1}), False, step=3) == ReplanReason.NONE
    # Worth regrew tenfold everywhere but at its next node (not searched by others: kept).
    decayed = 10.0 * worth
    decayed[planner.walk[0]] = 1.0
    planner.mark_visited(pose, decayed)
    assert planner.needs_replan(frozenset({1}), False, step=3) == ReplanReason.DECAYED
    first = planner.walk[0]
    planner.plan(1, {1: pose}, decayed)
    assert planner.walk[0] != first


FAR = int(np.argmin(np.hypot(*(MAP.centers - (95.0, 5.0)).T)))    # region x 90-100, y 0-10


def _all_seen_but_far(sweeps: float = 1.0):
    """Return a lone planner whose square held every node's whole region once, but FAR's."""
    planner = _planned(PERSISTENT.with_overrides({'search.overdue_sweeps': sweeps}))
    for k, node in enumerate(np.setdiff1d(np.arange(MAP.size), [FAR]), start=2):
        planner.mark_visited(MAP.centers[node])
        assert not planner.needs_replan(frozenset({1}), False, step=k)
    assert planner.walk == (FAR,)
    return planner


def test_a_lone_agent_takes_first_a_node_unseen_for_a_sweep_and_keeps_it_on_decay():
    far = FAR
    on, off = _all_seen_but_far(1.0), _all_seen_but_far(0.0)
    pose, step = MAP.centers[far - 1], int(np.ceil(_sweep(PERSISTENT)))   # 357
    assert on.needs_replan(frozenset({1}), False, step=step - 1) == ReplanReason.NONE
    assert on.needs_replan(frozenset({1}), False, step=step) == ReplanReason.OVERDUE
    assert off.needs_replan(frozenset({1}), False, step=step) == ReplanReason.NONE
    worth = np.ones(MAP.size)
    on.plan(1, {1: pose}, worth)
    assert on.walk[0] == far and sorted(on.walk) == sorted(set(range(MAP.size)) - {far - 1})
    # Worth regrew tenfold everywhere but at far (not searched by others: kept). The decay rule
    # would leave far for a richer node; not while it is overdue.
    decayed = 10.0 * worth
    decayed[far] = 1.0
    for planner in (on, off):
        planner.mark_visited(pose, decayed)
    assert on.needs_replan(frozenset({1}), False, step=step + 1) == ReplanReason.NONE
    assert off.needs_replan(frozenset({1}), False, step=step + 1) == ReplanReason.DECAYED


def test_cover_point_is_the_nearest_point_whose_square_holds_every_cell():
    cells = np.array([[1.0, 1.0], [4.0, 9.0]])
    # x must lie in [4 - 5, 1 + 5], y in [9 - 5, 1 + 5]: from (20, 0), the corner (6, 4).
    point = cover_point((20.0, 0.0), cells, 10.0)
    np.testing.assert_array_equal(point, [6.0, 4.0])
    assert in_sensing_square(cells, point, 10.0).all()
    assert not in_sensing_square(cells, point + (0.1, 0.0), 10.0).all()
    np.testing.assert_array_equal(cover_point((3.0, 5.0), cells, 10.0), [3.0, 5.0])
    # Cells wider apart than the side: the middle of the span.
    np.testing.assert_array_equal(cover_point((0.0, 0.0), [[0.0, 0.0], [12.0, 0.0]], 10.0),
                                  [6.0, 0.0])


def test_cell_views_age_each_node_by_its_oldest_cell():
    views = CellViews(Lattice.for_area(AreaParams(), 1.0), MAP, 10.0)
    views.record((5.0, 5.0), 3)          # node 0's whole region (x, y 0-10)
    views.record((7.0, 5.0), 4)          # its columns x 2.5-9.5, and node 1's x 10.5, 11.5
    oldest = views.oldest()
    assert oldest[0] == 3 and oldest[1] == 0 and not oldest[2:].any()
    # At step 10, cells unseen for 7 steps: node 0's columns x 0.5 and 1.5 (20 cells).
    counts = views.unseen_counts(10, 7, (-50.0, -50.0))
    assert counts[0] == 20 and counts[1] == 80 and counts.sum() == MAP.size * 100 - 100
    cells = views.unseen_cells(0, 10, 7, (-50.0, -50.0))
    assert sorted(set(cells[:, 0])) == [0.5, 1.5] and len(cells) == 20
    # A square that holds them now leaves none.
    assert views.unseen_cells(0, 10, 7, (-3.0, 5.0)).size == 0


def _far_overdue():
    """Return a lone planner at step 357 whose walk takes first FAR, the one node never seen."""
    planner = _all_seen_but_far()
    step = int(np.ceil(_sweep(PERSISTENT)))
    assert planner.needs_replan(frozenset({1}), False, step=step) == ReplanReason.OVERDUE
    planner.plan(1, {1: MAP.centers[FAR - 1]}, np.ones(MAP.size))
    assert planner.walk[0] == FAR
    return planner, FAR, step


def test_a_joint_plan_keeps_the_partition_and_the_own_walk_takes_its_overdue_nodes_first():
    step = int(np.ceil(_sweep(PERSISTENT)))
    starts = {1: MAP.centers[FAR - 1], 2: (5.0, 95.0)}
    walks = {}
    for sweeps in (1.0, 0.0):
        planner = _all_seen_but_far(sweeps)
        # Agent 2 comes in range: a joint plan, the partition every member computes alike.
        assert (planner.needs_replan(frozenset({1, 2}), False, step=step)
                == ReplanReason.NEW_NEIGHBOUR)
        walks[sweeps] = planner.plan(1, starts, np.ones(MAP.size))
    assert FAR in walks[0.0] and sorted(walks[1.0]) == sorted(walks[0.0])
    assert walks[0.0][0] == FAR - 1 and walks[1.0][0] == FAR      # the nearest; the overdue
    assert walks[1.0][1:] == [node for node in walks[0.0] if node != FAR]


def test_a_report_ages_the_cells_its_square_held_and_lends_its_node_views():
    step = int(np.ceil(_sweep(PERSISTENT)))           # 357
    no_views = np.zeros(0, dtype=np.int64)
    heard = _all_seen_but_far()
    # A neighbour's report: its square held FAR's whole region at step 5.
    heard.hear_views([(MAP.centers[FAR], 5, no_views)])
    assert heard.needs_replan(frozenset({1}), False, step=step) == ReplanReason.NONE
    assert heard.needs_replan(frozenset({1}), False, step=step + 4) == ReplanReason.OVERDUE
    # An older report does not make a cell older than a later view: still overdue at 361.
    heard.hear_views([(MAP.centers[FAR], 1, no_views)])
    assert heard.needs_replan(frozenset({1}), False, step=step + 4) == ReplanReason.OVERDUE
    np.testing.assert_array_equal(heard.node_views()[[FAR, 0]], [5, 2])
    # The search-path history a report carries: views of FAR's cells as late as step 100, by
    # agents this one never heard. FAR is no longer overdue, and leaves the walk's head.
    told = _all_seen_but_far()
    assert told.needs_replan(frozenset({1}), False, step=step) == ReplanReason.OVERDUE
    told.plan(1, {1: MAP.centers[FAR - 1]}, np.ones(MAP.size))
    assert told.walk[0] == FAR
    views = np.zeros(MAP.size, dtype=np.int64)
    views[FAR] = 100
    told.hear_views([((-50.0, -50.0), 300, views)])
    assert told.node_views()[FAR] == 100
    assert told.needs_replan(frozenset({1}), False, step=step + 1) == ReplanReason.NONE
    assert FAR in told.mark_visited((-50.0, -50.0))
    # A report without views (a planner that keeps none) lends nothing; malformed ones never
    # reach the planner (agent_core and agent_node drop them, counted).
    told.hear_views([((-50.0, -50.0), 330, no_views)])
    assert told.node_views()[FAR] == 100
    assert node_views_defect(views, MAP.size, 300) is None
    assert node_views_defect(no_views, MAP.size, 300) is None
    assert node_views_defect(views[:5], MAP.size, 300) == 'wrong_length'
    assert node_views_defect(views, MAP.size, 99) == 'out_of_range'
    assert node_views_defect(-views, MAP.size, 300) == 'out_of_range'


def test_an_overdue_node_is_visited_once_its_cells_are_seen_not_its_centre():
    planner, far, step = _far_overdue()           # far's region: x 90-100, y 0-10
    # At (91, 5) the square holds far's centre (95, 5), the paper's visit, but not the cells
    # east of x = 96: far stays, and the goal is the admissible pose holding most of them,
    # taken exactly (no sweeping bend).
    pose = np.array([91.0, 5.0])
    assert planner.mark_visited(pose).size == 0 and planner.walk[0] == far
    goal = planner.next_goal()
    assert planner.covering
    poses = candidate_poses(pose, PERSISTENT.actions)
    cells = Lattice.for_area(AreaParams(), 1.0).centers()
    cells = cells[(cells[:, 0] > 96.0) & (cells[:, 1] < 10.0)]
    held = in_sensing_square(cells[None], poses[:, None], 10.0).sum(axis=1)
    assert held.max() == cells.shape[0]
    assert held[np.flatnonzero(np.all(poses == goal, axis=1))[0]] == held.max()
    planner.needs_replan(frozenset({1}), False, step=step + 1)
    assert far in planner.mark_visited(goal)
    # The paper's visit, without the rule.
    off = _planned(PERSISTENT.with_overrides({'search.overdue_sweeps': 0.0}))
    assert far in off.mark_visited(pose)
    assert not off.covering


def test_a_replan_keeps_the_overdue_head_ahead_of_newly_overdue_nodes():
    planner, far, step = _far_overdue()
    # Node 0's region was seen at step 2 only: overdue at 2 + 357. The agent is beside it,
    # and a cheapest arc over the two would take it first; the head keeps far first.
    pose = (15.0, 5.0)
    planner.mark_visited(pose)
    assert planner.needs_replan(frozenset({1}), False, step=step + 1) == ReplanReason.NONE
    assert planner.needs_replan(frozenset({1}), False, step=step + 2) == ReplanReason.OVERDUE
    planner.plan(1, {1: pose}, np.ones(MAP.size))
    assert planner.walk[:2] == (far, 0)
    assert greedy_closed_walk(pose, MAP.centers, [0, far])[0] == 0


def test_a_sweep_needs_a_slack_below_the_top_speed():
    # 100 nodes 10 m apart at 4 m a step, less the profile's 1.2 m of slack, or none.
    assert sweep_steps(PERSISTENT, MAP.size, MAP.spacing) == pytest.approx(1000.0 / 2.8)
    no_slack = PERSISTENT.with_overrides({'search.sweep_slack': 0.0})
    assert sweep_steps(no_slack, MAP.size, MAP.spacing) == pytest.approx(250.0)
    with pytest.raises(ValueError, match='search.sweep_slack = 4.0 leaves a walk no progress'):
        sweep_steps(PERSISTENT.with_overrides({'search.sweep_slack': 4.0}), MAP.size, 10.0)


def _revisit_gaps(params, steps: int, start=(10.0, 60.0)) -> np.ndarray:
    """Return each 1 m cell's longest wait between squares of a lone agent, no target."""
    agent = Agent(1, params, start, seed=0)
    pose = np.array(start)
    last = np.zeros(len(CELLS))
    gaps = np.zeros(len(CELLS))
    for k in range(1, steps + 1):
        out = agent.step(k, pose, np.zeros((0, 2)), [])
        _view(gaps, last, k, in_sensing_square(CELLS, pose, params.sensor.square_side))
        pose = candidate_poses(pose, params.actions)[out.action]
    return np.maximum(gaps, steps + 1 - last)


def _view(gaps: np.ndarray, last: np.ndarray, k: int, seen) -> None:
    """Record at step k the views of the points seen (gaps, last in place)."""
    gaps[seen] = np.maximum(gaps[seen], k - last[seen])
    last[seen] = k


def _sweep(params) -> float:
    """Return |V| s / (v - slack): the steps of a walk through every node (the test below)."""
    return sweep_steps(params, MAP.size, MAP.spacing)


def test_a_lone_agent_with_no_target_sees_every_cell_again_within_two_sweeps():
    # The derivation: one step after a visit a node's worth is >= its cells' births b > 0
    # (beyond_paper/regrowing_density.py), so every plan holds every node out of view. A lone
    # agent replans when its walk is exhausted, so a node is seen again at the latest by the
    # end of the next walk; a walk through the |V| nodes, one spacing s apart, flown at the
    # top speed v = N_R Delta_R, takes |V| s / v steps (250 here): horizon 2 |V| s / v. The
    # sweeping move (search.sweep_slack) may end each step up to its slack farther from the
    # node than the nearest pose, so a walk closes at least v - slack a step (357 steps for
    # the profile's 1.2 m).
    # The paper's visit (a node's centre in the square) and drop_searched_nodes' drops leave
    # a node's ground partly unseen, and the decay rule's replans put such a node late in
    # every walk: without search.overdue_sweeps some cells near the border are never seen.
    # With it (the profile's 1 sweep) a node with a cell unseen for a sweep joins the lone
    # walk's head, whose visits end when the square has held every such cell; the head is at
    # most a walk through every node: within two sweeps again (beyond_paper/overdue_nodes.py).
    drop_off = PERSISTENT.with_overrides({'additions.drop_searched_nodes': False})
    cases = [(PERSISTENT, start) for start in ((10.0, 60.0), (97.0, 3.0), (50.0, 50.0))]
    cases += [(PERSISTENT.with_overrides({'search.sweep_slack': 0.0}), (10.0, 60.0)),
              (drop_off, (10.0, 60.0))]
    for case, start in cases:
        sweep = _sweep(case)
        assert np.max(_revisit_gaps(case, int(3 * sweep), start)) <= 2 * sweep
    starving = PERSISTENT.with_overrides({'search.overdue_sweeps': 0.0})
    steps = int(3 * _sweep(starving))
    gaps = _revisit_gaps(starving, steps)
    assert np.max(gaps) == steps + 1                       # never seen
    assert np.min(np.minimum(CELLS, 100.0 - CELLS)[np.argmax(gaps)]) < 1.0
    # The paper's density and planner (config/paper.yaml) sweep once, then wait for J to
    # bring nodes below beta (or revisit the least searched half): some wait far longer.
    paper = load_params_file('config/paper.yaml')
    sweep = _sweep(paper)
    assert np.max(_revisit_gaps(paper, int(3 * sweep))) > 2 * sweep


def _team_revisit_gaps(params, steps: int, seed: int) -> tuple:
    """Return the steps between consecutive views by any agent of the team: (nodes, cells)."""
    scenario = replace(random_scenario(seed, agents=4, steps=steps), targets=(),
                       random_births=None)
    swarm = InProcessSwarm(scenario, params)
    last, gaps = np.zeros(MAP.size), np.zeros(MAP.size)
    cells_last, cells_gaps = np.zeros(len(CELLS)), np.zeros(len(CELLS))
    side = params.sensor.square_side
    for k in range(1, steps + 1):
        for pose in swarm.step().agent_poses.values():
            _view(gaps, last, k, nodes_in_view(MAP, pose, side))
            _view(cells_gaps, cells_last, k, in_sensing_square(CELLS, pose, side))
    return (np.maximum(gaps, steps + 1 - last),
            np.maximum(cells_gaps, steps + 1 - cells_last))


def test_a_team_with_no_target_sees_every_node_again_within_a_lone_sweep():
    # No derivation bounds a team's wait: its agents plan jointly in range, alone out of it,
    # and the partition changes at every joint replan. Measured (session 56, the random
    # default's starts, no target, no clutter, three lone sweeps): the longest wait was
    # 173-245 steps on seeds 1-6 and 10-12, at most 0.69 of the 357 a lone agent takes to fly
    # every node. One lone sweep is the bound held here: a team that starved a node as the
    # lone agent once did (768 steps) would fail it, and so does the paper's team, whose
    # density does not regrow (a node waits 289 steps of its 250-step sweep). The bound is
    # measured without clutter only: over 1,500 steps (session 63) quiet teams waited at most
    # 242-305 steps on seeds 1-8, teams with the seed's targets and clutter 280-365.
    quiet = {'sensor.clutter_rate': 0.0}
    for profile, within in ((PERSISTENT, True), (load_params_file('config/paper.yaml'), False)):
        params = profile.with_overrides(quiet)
        sweep = _sweep(params)
        gaps, _ = _team_revisit_gaps(params, int(2 * _sweep(PERSISTENT)), seed=1)
        assert (np.max(gaps) <= sweep) == within


def test_a_team_with_no_target_sees_every_cell_again_within_a_sweep_and_a_half():
    # search.overdue_sweeps in a team (beyond_paper/overdue_nodes.py): every member ages the
    # cells by its own squares and the reports' (so a cell it takes for fresh was seen), takes
    # its overdue nodes first in every plan, joint ones included, and sees their cells whole.
    # No horizon is derived for a team; over 1,500 steps (session 63, no target, no clutter)
    # quiet teams saw every cell again within 374-466 steps on seeds 1-8, with the seed's
    # targets and clutter within 409-477; applied only while alone (session 62), the rule left
    # cells unseen for 482-1,501 steps, on seed 3 the corner cell (0.5, 98.5) for good. Held
    # here: a sweep and a half (536 steps) on seed 3 over two sweeps; without the rule a corner
    # cell is never seen.
    quiet = PERSISTENT.with_overrides({'sensor.clutter_rate': 0.0})
    sweep = _sweep(quiet)
    steps = int(2 * sweep)
    _, cells = _team_revisit_gaps(quiet, steps, seed=3)
    assert np.max(cells) <= 1.5 * sweep
    _, cells = _team_revisit_gaps(quiet.with_overrides({'search.overdue_sweeps': 0.0}), steps,
                                  seed=3)
    assert np.max(cells) == steps + 1
