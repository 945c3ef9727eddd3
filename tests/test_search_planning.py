from hypothesis import given, settings, strategies as st
import numpy as np
import pytest

from sat_agent.actions import candidate_poses, inside_area
from sat_agent.config import AreaParams, SatParams
from sat_agent.search_map import nodes_in_view, SearchMap
from sat_agent.search_planning import (
    greedy_closed_walk, joint_plan, ReplanReason, search_action, SearchPlanner, walk_cost)

PARAMS = SatParams()
MAP = SearchMap.for_area(AreaParams(), 10.0)
ALL_NODES = list(range(MAP.size))

positions = st.tuples(st.floats(0.0, 100.0), st.floats(0.0, 100.0))
node_subsets = st.lists(st.integers(0, MAP.size - 1), min_size=0, max_size=MAP.size)


def line(*xs):
    return np.array([[x, 0.0] for x in xs])


# --- greedy closed walk -------------------------------------------------------------------


def test_greedy_walk_takes_the_cheapest_arc_from_the_head_each_time():
    centers = line(0.0, 1.0, 3.0, 6.0)
    # From 2: nodes 1 (x=1) and 2 (x=3) tie at 1 -> lowest index 1; then 0 (1) beats 2 (2);
    # then 2 (3) beats 3 (6); then 3.
    walk = greedy_closed_walk((2.0, 0.0), centers, [0, 1, 2, 3])
    assert walk == [1, 0, 2, 3]
    # 1 + 1 + 3 + 3, plus the closing leg 6 -> 2.
    assert walk_cost((2.0, 0.0), centers, walk) == pytest.approx(12.0)


def test_greedy_walk_ties_to_lowest_index_even_when_costs_differ_by_rounding_error():
    # 0.1 + 0.2 = 0.30000000000000004: node 0 is "farther" by 5e-17 only; rounding to 1e-9
    # makes it a tie, which goes to the lowest index.
    centers = np.array([[0.1 + 0.2, 0.0], [0.3, 0.0]])
    assert greedy_closed_walk((0.0, 0.0), centers, [1, 0]) == [0, 1]


def test_greedy_walk_on_the_paper_map_from_a_corner_sweeps_the_first_row():
    walk = greedy_closed_walk((0.0, 0.0), MAP.centers, ALL_NODES)
    # From a first-row node, the next node east and the node north are both 10 m away: the tie
    # goes to the lower index, east.
    assert walk[:10] == list(range(10))


def test_greedy_walk_ignores_the_order_and_duplicates_of_its_nodes():
    nodes = [42, 7, 99, 0, 13, 58, 7]
    expected = greedy_closed_walk((33.0, 71.0), MAP.centers, sorted(set(nodes)))
    assert greedy_closed_walk((33.0, 71.0), MAP.centers, nodes[::-1]) == expected


def test_greedy_walk_of_no_nodes_is_empty_and_refuses_unknown_nodes():
    assert greedy_closed_walk((1.0, 1.0), MAP.centers, []) == []
    with pytest.raises(ValueError):
        greedy_closed_walk((1.0, 1.0), MAP.centers, [100])


@settings(max_examples=50, deadline=None)
@given(start=positions, nodes=node_subsets)
def test_closed_walk_visits_every_node_once_each_next_node_nearest_to_the_head(start, nodes):
    walk = greedy_closed_walk(start, MAP.centers, nodes)
    assert sorted(walk) == sorted(set(nodes))
    head = np.asarray(start)
    remaining = set(nodes)
    for node in walk:
        costs = {v: round(float(np.linalg.norm(MAP.centers[v] - head)), 9) for v in remaining}
        assert costs[node] == min(costs.values())
        assert node == min(v for v, c in costs.items() if c == costs[node])
        remaining.remove(node)
        head = MAP.centers[node]


# --- joint plan -------------------------------------------------------------------------


def test_joint_plan_grows_walks_in_turn_in_ascending_id_order():
    centers = line(0, 10, 20, 30, 40, 50)
    starts = {2: (51.0, 0.0), 1: (-1.0, 0.0)}
    assert joint_plan(starts, centers, range(6)) == {1: [0, 1, 2], 2: [5, 4, 3]}


def test_joint_plan_lower_id_wins_a_contested_node():
    centers = line(1.0, 2.0)
    assert joint_plan({5: (0.0, 0.0), 2: (0.0, 0.0)}, centers, [0, 1]) == {2: [0], 5: [1]}


def test_joint_plan_with_more_agents_than_nodes_leaves_some_walks_empty():
    plan = joint_plan({1: (0, 0), 2: (50, 50), 3: (90, 90)}, MAP.centers, [0])
    assert plan == {1: [0], 2: [], 3: []}


@settings(max_examples=50, deadline=None)
@given(agents=st.dictionaries(st.integers(0, 50), positions, min_size=1, max_size=4),
       nodes=node_subsets, data=st.data())
def test_joint_plan_partitions_the_nodes_and_ignores_input_order(agents, nodes, data):
    plan = joint_plan(agents, MAP.centers, nodes)
    assert sorted(plan) == sorted(agents)
    walks = list(plan.values())
    assert sorted(sum(walks, [])) == sorted(set(nodes))        # disjoint and covering
    sizes = [len(w) for w in walks]
    assert max(sizes) - min(sizes) <= 1
    order = data.draw(st.permutations(list(agents)))
    shuffled = {agent: agents[agent] for agent in order}
    node_order = data.draw(st.permutations(nodes))
    assert joint_plan(shuffled, MAP.centers, node_order) == plan


def test_joint_plan_of_one_agent_is_its_greedy_walk():
    nodes = [3, 14, 15, 92, 65]
    assert joint_plan({4: (20.0, 30.0)}, MAP.centers, nodes) == {
        4: greedy_closed_walk((20.0, 30.0), MAP.centers, nodes)}


# --- search control ---------------------------------------------------------------------


def test_search_action_moves_the_longest_step_towards_a_far_goal():
    # Action 9 is the 4 m step along angle 0 (east), action 11 the 4 m step north.
    assert search_action((50.0, 50.0), (60.0, 50.0), PARAMS) == 9
    assert search_action((50.0, 50.0), (50.0, 70.0), PARAMS) == 11


def test_search_action_ties_go_to_the_lowest_action():
    assert search_action((50.0, 50.0), (50.0, 50.0), PARAMS) == 0
    # 1 m east: staying and the 2 m step east are both 1 m away -> stay.
    assert search_action((50.0, 50.0), (51.0, 50.0), PARAMS) == 0
    # 3 m east: the 2 m and the 4 m step are both 1 m away -> the 2 m step (index 1).
    assert search_action((50.0, 50.0), (53.0, 50.0), PARAMS) == 1


def test_search_action_never_leaves_the_area_at_a_corner():
    # The goal lies beyond the corner: the 4 m diagonal step would leave the area, the 2 m
    # diagonal step (action 6, angle 225 degrees) is the nearest admissible pose.
    action = search_action((2.0, 2.0), (-10.0, -10.0), PARAMS)
    assert action == 6
    pose = candidate_poses((2.0, 2.0), PARAMS.actions)[action]
    np.testing.assert_allclose(pose, [2.0 - np.sqrt(2.0), 2.0 - np.sqrt(2.0)])
    # From 1 m off the corner every step towards it leaves the area: stay.
    assert search_action((1.0, 1.0), (-10.0, -10.0), PARAMS) == 0


@settings(max_examples=200, deadline=None)
@given(pose=positions, goal=positions)
def test_search_action_is_admissible_and_strictly_closer_when_beyond_one_step(pose, goal):
    action = search_action(pose, goal, PARAMS)
    new_pose = candidate_poses(pose, PARAMS.actions)[action]
    assert inside_area(new_pose, PARAMS.area).all()
    before = np.linalg.norm(np.subtract(goal, pose))
    after = np.linalg.norm(new_pose - np.asarray(goal))
    assert after <= before + 1e-9
    if before > PARAMS.actions.radial_step:
        assert after < before


# --- SearchPlanner ----------------------------------------------------------------------


def fresh_values():
    return np.zeros(MAP.size)


def planned(own_id=1, starts=None, values=None, params=PARAMS):
    planner = SearchPlanner(MAP, params)
    starts = starts or {own_id: (10.0, 60.0)}
    assert planner.needs_replan(frozenset(starts), False) == ReplanReason.NO_PLAN
    planner.plan(own_id, starts, fresh_values() if values is None else values)
    return planner


def test_planner_solo_plan_covers_the_unvisited_nodes_and_closes_at_its_start():
    values = fresh_values()
    values[[0, 1, 2]] = 0.9          # recently searched: not in the plan
    planner = planned(values=values)
    assert sorted(planner.walk) == list(range(3, 100))
    assert planner.walk == tuple(greedy_closed_walk((10.0, 60.0), MAP.centers, range(3, 100)))
    np.testing.assert_allclose(planner.next_goal(), MAP.centers[planner.walk[0]])
    points = planner.walk_points()
    assert points.shape == (98, 2)
    np.testing.assert_allclose(points[-1], [10.0, 60.0])
    assert planner.group == frozenset({1})
    assert not planner.needs_replan(frozenset({1}), False)


def test_planner_marks_nodes_in_the_sensing_square_visited():
    planner = planned()
    dropped = planner.mark_visited((10.0, 10.0))
    assert sorted(dropped.tolist()) == [0, 1, 10, 11]
    assert not {0, 1, 10, 11} & set(planner.walk)
    assert len(planner.walk) == 96


def test_visit_share_counts_a_node_visited_only_in_the_middle_of_the_square():
    middle = planned(params=PARAMS.with_overrides({'search.visit_share': 0.6}))
    # (10, 10): four centres on the square's edges, 5 m off: in view, not in its middle 6 m.
    assert middle.mark_visited((10.0, 10.0)).size == 0
    assert len(middle.walk) == 100
    assert middle.mark_visited((7.0, 7.0)).tolist() == [0]
    assert len(middle.walk) == 99


def test_planner_drops_nodes_searched_by_others_when_given_fused_values():
    planner = planned()
    values = fresh_values()
    values[[50, 51]] = 0.8
    planner.mark_visited((-50.0, -50.0), values)
    assert len(planner.walk) == 98 and not {50, 51} & set(planner.walk)


def test_drop_searched_nodes_switch_off_keeps_nodes_others_searched_in_the_walk():
    paper = PARAMS.with_overrides({'additions.drop_searched_nodes': False})
    planner = planned(params=paper)
    values = fresh_values()
    values[[50, 51]] = 0.8
    assert planner.mark_visited((-50.0, -50.0), values).size == 0
    assert len(planner.walk) == 100
    # Only its own visits leave the walk.
    assert sorted(planner.mark_visited(MAP.centers[50]).tolist()) == [50]


def test_planner_goes_back_to_its_start_when_its_walk_is_exhausted_and_then_replans():
    values = np.ones(MAP.size)
    values[[44, 45]] = 0.0
    planner = planned(values=values)
    assert planner.walk == (44, 45)
    planner.mark_visited(MAP.centers[44])
    planner.mark_visited(MAP.centers[45])
    assert planner.walk == ()
    np.testing.assert_allclose(planner.next_goal(), [10.0, 60.0])
    assert planner.needs_replan(frozenset({1}), False) == ReplanReason.EXHAUSTED


def test_first_contact_triggers_a_joint_replan_identical_on_both_agents():
    starts = {1: (10.0, 60.0), 2: (60.0, 10.0)}
    one, two = planned(1), planned(2, {2: starts[2]})
    assert one.needs_replan(frozenset({1, 2}), False) == ReplanReason.NEW_NEIGHBOUR
    assert two.needs_replan(frozenset({2, 1}), False) == ReplanReason.NEW_NEIGHBOUR
    one.plan(1, starts, fresh_values())
    two.plan(2, {2: starts[2], 1: starts[1]}, fresh_values())
    expected = joint_plan(starts, MAP.centers, ALL_NODES)
    assert list(one.walk) == expected[1] and list(two.walk) == expected[2]
    assert sorted(one.walk + two.walk) == ALL_NODES
    assert one.group == two.group == frozenset({1, 2})


def test_leaving_radio_range_does_not_trigger_a_replan():
    planner = planned(1, {1: (10.0, 60.0), 2: (60.0, 10.0)})
    walk = planner.walk
    assert not planner.needs_replan(frozenset({1}), False)
    assert not planner.needs_replan(frozenset({1, 2}), False)   # back in range: same group
    assert planner.walk == walk


def test_a_member_leaving_search_releases_its_nodes_to_the_remaining_searcher():
    starts = {1: (10.0, 60.0), 2: (60.0, 10.0)}
    planner = planned(1, starts)
    own_nodes = set(planner.walk)
    assert len(own_nodes) == 50
    assert planner.needs_replan(frozenset({1}), True) == ReplanReason.RELEASED
    planner.plan(1, {1: (20.0, 60.0)}, fresh_values())
    assert sorted(planner.walk) == ALL_NODES     # its own and the released nodes (Fig. 4h)
    assert planner.group == frozenset({1})


def test_own_return_to_search_triggers_a_replan():
    planner = planned()
    assert planner.needs_replan(frozenset({1}), False, resumed=True) == ReplanReason.RESUMED
    planner.plan(1, {1: (90.0, 90.0)}, fresh_values())
    np.testing.assert_allclose(planner.start, [90.0, 90.0])
    # Nodes 88 (85, 85) and 99 (95, 95) are equally near: the lowest index comes first; from
    # 88, nodes 78, 87, 89 and 98 are all 10 m away: 78.
    assert planner.walk[:2] == (88, 78)


def test_exhaustion_replan_is_solo_and_leaves_the_other_members_claims_alone():
    starts = {1: (10.0, 60.0), 2: (60.0, 10.0)}
    planner = planned(1, starts)
    own = list(planner.walk)
    others = sorted(set(ALL_NODES) - set(own))
    searched = fresh_values()
    searched[own] = 1.0
    planner.mark_visited((10.0, 60.0), searched)
    assert planner.needs_replan(frozenset({1, 2}), False) == ReplanReason.EXHAUSTED
    # Three of its own nodes decayed below beta again; agent 2 has not searched its share. The
    # nodes in view of the new start are being searched and are not planned again.
    in_view = set(nodes_in_view(MAP, (30.0, 30.0), PARAMS.sensor.square_side).tolist())
    decayed = fresh_values()
    decayed[own[3:]] = 1.0
    planner.plan(1, {1: (30.0, 30.0), 2: (60.0, 10.0)}, decayed)
    assert planner.walk and sorted(planner.walk) == sorted(set(own[:3]) - in_view)
    assert planner.group == frozenset({1, 2})
    assert not planner.needs_replan(frozenset({1, 2}), False)
    # Once nothing unclaimed is left, it helps with the claimed (still unvisited) nodes.
    for node in own[:3]:
        planner.mark_visited(MAP.centers[node])
    assert planner.needs_replan(frozenset({1, 2}), False) == ReplanReason.EXHAUSTED
    remaining = fresh_values()
    remaining[own] = 1.0
    planner.plan(1, {1: (30.0, 30.0)}, remaining)
    assert sorted(planner.walk) == sorted(set(others) - in_view)


def test_exhaustion_claims_switch_off_plans_over_the_other_members_nodes_too():
    starts = {1: (10.0, 60.0), 2: (60.0, 10.0)}
    paper = PARAMS.with_overrides({'additions.exhaustion_claims': False})
    walks, owns = {}, {}
    for name, params in (('claims', PARAMS), ('paper', paper)):
        planner = planned(1, starts, params=params)
        own = owns[name] = list(planner.walk)     # the same joint plan either way
        searched = fresh_values()
        searched[own] = 1.0
        planner.mark_visited((10.0, 60.0), searched)
        assert planner.needs_replan(frozenset({1, 2}), False) == ReplanReason.EXHAUSTED
        decayed = fresh_values()
        decayed[own[3:]] = 1.0      # three own nodes due again, agent 2's share unsearched
        planner.plan(1, {1: (30.0, 30.0), 2: (60.0, 10.0)}, decayed)
        walks[name] = set(planner.walk)
    in_view = set(nodes_in_view(MAP, (30.0, 30.0), PARAMS.sensor.square_side).tolist())
    others = set(ALL_NODES) - set(own)
    assert owns['claims'] == owns['paper']
    assert walks['claims'] == set(own[:3]) - in_view
    assert walks['paper'] == (set(own[:3]) | others) - in_view


def test_an_agent_short_of_a_nodes_far_edge_does_not_replan_that_node_forever():
    # The last node's centre came into view 4.8 m away, so the strip beyond the square's edge
    # keeps the node's search value below beta (paper scenario, agent 2 from k = 143). Planning
    # it again gave a walk visited at once: the agent replanned it at every step and hovered.
    planner = planned(1, {1: (80.0, 95.0)})
    corner = int(np.flatnonzero(np.all(MAP.centers == (95.0, 95.0), axis=1))[0])
    values = np.ones(MAP.size)
    values[corner] = 0.4
    values[0] = 0.2                                   # the node at (5, 5) is due again
    planner.plan(1, {1: (80.0, 95.0)}, values)
    assert planner.walk == (0, corner) or planner.walk == (corner, 0)
    planner.mark_visited((90.2, 94.4), values)
    assert planner.walk == (0,)
    planner.mark_visited((5.0, 5.0), values)
    assert planner.needs_replan(frozenset({1}), False) == ReplanReason.EXHAUSTED
    planner.plan(1, {1: (90.2, 94.4)}, values)
    assert corner not in planner.walk and planner.walk


def test_replan_priority_and_bad_input():
    planner = planned()
    assert planner.needs_replan(frozenset({1, 2}), True, resumed=True) == ReplanReason.RESUMED
    assert planner.needs_replan(frozenset({1, 2}), True) == ReplanReason.RELEASED
    with pytest.raises(ValueError):
        planner.plan(3, {1: (0.0, 0.0)}, fresh_values())
    with pytest.raises(ValueError):
        planner.plan(1, {1: (0.0, 0.0)}, np.zeros(99))


def test_planner_before_any_plan_has_no_goal():
    planner = SearchPlanner(MAP, PARAMS)
    assert planner.next_goal() is None
    assert planner.walk_points().shape == (0, 2)


def test_following_the_walk_with_search_control_visits_every_node():
    planner = planned()
    pose = np.array([10.0, 60.0])
    visited = set(planner.mark_visited(pose).tolist())
    for step in range(1000):
        if not planner.walk:
            break
        pose = candidate_poses(pose, PARAMS.actions)[search_action(pose, planner.next_goal(),
                                                                   PARAMS)]
        assert inside_area(pose, PARAMS.area).all()
        visited |= set(planner.mark_visited(pose).tolist())
    assert visited == set(ALL_NODES)
    # 100 nodes 10 m apart at up to 4 m per step: a sweep takes about 250 steps.
    assert step < 350


def test_with_every_node_searched_the_agent_revisits_the_least_searched_ones():
    params = SatParams()
    search_map = SearchMap.for_area(params.area, params.search.node_spacing)
    planner = SearchPlanner(search_map, params)
    values = np.linspace(0.6, 1.0, search_map.size)    # all above beta: nothing unvisited
    planner.needs_replan(frozenset({1}), released=False)
    walk = planner.plan(1, {1: (50.0, 50.0)}, values)
    share = params.search.revisit_share
    assert sorted(walk) == list(range(int(np.ceil(share * search_map.size))))
    # Revisited nodes stay in the walk while their value only decays...
    planner.mark_visited((500.0, 500.0), values * params.search.decay)
    assert len(planner.walk) == len(walk)
    # ...and leave it once someone searched them (their value rose).
    searched = values.copy()
    searched[walk[0]] = 1.0
    planner.mark_visited((500.0, 500.0), searched)
    assert walk[0] not in planner.walk and len(planner.walk) == len(walk) - 1


def test_revisit_fallback_switch_off_plans_no_node_and_holds_while_none_is_below_beta():
    paper = SatParams().with_overrides({'additions.revisit_fallback': False})
    planner = SearchPlanner(MAP, paper)
    values = np.linspace(0.6, 1.0, MAP.size)    # all above beta: V-bar is empty
    planner.needs_replan(frozenset({1}), released=False)
    assert planner.plan(1, {1: (50.0, 50.0)}, values) == []
    # The closed walk over no node is s_k: the agent holds (action 0 stays).
    action, goal, plan = planner.choose((50.0, 50.0))
    assert action == 0 and np.allclose(goal, (50.0, 50.0)) and plan.tolist() == [[50.0, 50.0]]
    # It plans again at the next step and then takes the node that decayed below beta.
    assert planner.needs_replan(frozenset({1}), released=False) == ReplanReason.EXHAUSTED
    values[7] = 0.5
    assert planner.plan(1, {1: (50.0, 50.0)}, values) == [7]
