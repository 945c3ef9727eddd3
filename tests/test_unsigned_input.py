"""The recorder's bounds on the unsigned topics: the size limits and the per-step budget.

The limits (message_limits.standard_limits) must let the largest genuine message through and
nothing larger; the budget (unsigned_input.StepBudget) must let a genuine publisher (one
message per topic and step, possibly ahead of the step the recorder knows) through and refuse
a flood. The live attack on a recording swarm is in test_attack_observers.py.
"""

from pathlib import Path
import sys

import numpy as np
import pytest
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock

from sat_agent import state_extraction
from sat_agent.config import load_params_file
from sat_agent.ros import views
from sat_agent.ros.message_limits import MessageLimits, standard_limits
from sat_agent.ros.msg_conversions import header, MAX_TARGETS
from sat_agent.search_density import Lattice
from sat_agent.search_map import SearchMap
from sat_agent.topic_names import AGENT_VIEWS, CLOCK, ROBOT_GOAL, TRUTH_MARKERS, VIEW_PREFIX
from sat_world_sim.ros.observer import signature_of
from sat_world_sim.topics import graph_topics
from sat_world_sim.unsigned_input import BURST, PER_STEP, StepBudget, UnsignedInput

CONFIG = Path(__file__).resolve().parents[1] / 'config'
ROSTER = (1, 2, 10)
STEP = 57


@pytest.fixture(scope='module', params=['paper.yaml', 'persistent.yaml'])
def profile(request):
    """Return (params, standard_limits) of a profile with ROSTER."""
    params = load_params_file(CONFIG / request.param)
    return params, standard_limits(params, ROSTER)


def size(msg) -> int:
    return len(serialize_message(msg))


def unsigned_topics(params, roster=ROSTER):
    limits = MessageLimits.compute(params, len(roster))
    return [t.name for t in graph_topics(roster) if signature_of(t.name, limits) is None]


def estimate(count: int, rng) -> state_extraction.MultiTargetEstimate:
    """Return an estimate of count targets as the filter makes them (masses below 10^6)."""
    spread = rng.normal(size=(count, 4, 4))
    targets = tuple(state_extraction.TargetEstimate(
        position=rng.uniform(0, 100, 2), velocity=rng.normal(size=2),
        covariance=s @ s.T, weight=float(rng.uniform(0, 1e6))) for s in spread)
    return state_extraction.MultiTargetEstimate(targets=targets, cardinality=float(count))


def genuine_views(params, agent_id: int, targets: int, rng):
    """Return the largest messages a run's nodes publish, built as they do ('map' frame)."""
    lattice = Lattice.for_area(params.area, params.search.lattice_spacing)
    nodes = SearchMap.for_area(params.area, params.search.node_spacing).size
    stamp = header(STEP, params.motion.dt)
    found = estimate(targets, rng)
    xy = rng.uniform(0, 100, (targets, 2))
    return {
        VIEW_PREFIX + 'search_density': views.occupancy_grid(
            rng.uniform(size=(lattice.ny, lattice.nx)), lattice, stamp),
        VIEW_PREFIX + 'estimates': views.estimate_markers(agent_id, found, stamp),
        VIEW_PREFIX + 'estimate_poses': views.estimate_poses(found, stamp),
        VIEW_PREFIX + 'plan': views.plan_path(rng.uniform(0, 100, (nodes + 1, 2)), stamp),
        VIEW_PREFIX + 'pose': views.pose_stamped((3.0, 4.0), stamp, 0.5),
        ROBOT_GOAL[0]: views.pose_stamped((3.0, 4.0), stamp),
        TRUTH_MARKERS[0]: views.truth_markers(
            range(10 ** 6 - targets, 10 ** 6), xy, {i: (1.0, 2.0) for i in ROSTER},
            (params.area.width, params.area.height), params.sensor.square_side, stamp)}


def test_every_unsigned_topic_of_the_graph_has_a_limit(profile):
    params, limits = profile
    names = [VIEW_PREFIX + name for name in AGENT_VIEWS]
    assert set(limits) == {CLOCK[0], TRUTH_MARKERS[0], ROBOT_GOAL[0], *names}
    topics = unsigned_topics(params)
    unsigned = UnsignedInput(topics, limits)
    assert set(unsigned.max_bytes) == set(topics)
    assert unsigned.max_bytes['/agent_10/view/plan'] == limits['view/plan']
    assert unsigned.max_bytes['/clock'] == limits['/clock']
    # Nine per agent (goal and views) and the world's two: the standard-typed topics.
    assert len(topics) == 2 + len(ROSTER) * (1 + len(AGENT_VIEWS))


def test_the_largest_genuine_messages_fit(profile):
    params, limits = profile
    rng = np.random.default_rng(3)
    for name, msg in genuine_views(params, max(ROSTER), MAX_TARGETS, rng).items():
        assert size(msg) <= limits[name], name


def test_the_limits_are_the_builders_largest_messages(profile):
    """Every list at its bound, the map frame, the longest labels: the limit exactly.

    One element more exceeds it. The longest labels: the weight of the longest '{:.2f}' (the
    most negative float), target ids of 10 digits (uint32).
    """
    params, limits = profile
    lattice = Lattice.for_area(params.area, params.search.lattice_spacing)
    nodes = SearchMap.for_area(params.area, params.search.node_spacing).size
    stamp = header(STEP, params.motion.dt)
    area = (params.area.width, params.area.height)

    def largest(extra: int):
        target = state_extraction.TargetEstimate(
            position=np.zeros(2), velocity=np.zeros(2), covariance=np.eye(4),
            weight=-sys.float_info.max)
        found = state_extraction.MultiTargetEstimate(
            targets=(target,) * (MAX_TARGETS + extra), cardinality=0.0)
        return {
            'view/search_density': views.occupancy_grid(
                np.zeros((lattice.ny, lattice.nx + extra)), lattice, stamp),
            'view/estimates': views.estimate_markers(10, found, stamp),
            'view/estimate_poses': views.estimate_poses(found, stamp),
            'view/plan': views.plan_path(np.zeros((nodes + 1 + extra, 2)), stamp),
            TRUTH_MARKERS[0]: views.truth_markers(
                [2 ** 32 - 1] * (MAX_TARGETS + extra), np.zeros((MAX_TARGETS + extra, 2)),
                dict.fromkeys(ROSTER, (0.0, 0.0)), area, params.sensor.square_side, stamp)}

    assert {name: size(msg) for name, msg in largest(0).items()} == \
        {name: limits[name] for name in largest(0)}
    for name, msg in largest(1).items():
        assert size(msg) > limits[name], name
    assert limits['view/pose'] == limits[ROBOT_GOAL[0]] == size(
        views.pose_stamped((0.0, 0.0), stamp))
    assert limits[CLOCK[0]] == size(Clock())


def test_a_payload_one_byte_too_large_or_huge_is_refused_and_spends_no_budget(profile):
    params, limits = profile
    unsigned = UnsignedInput(unsigned_topics(params), limits, StepBudget(1, 1))
    topic = '/agent_2/view/search_density'
    limit = limits['view/search_density']
    for payload in (limit + 1, 10 ** 9):
        reason, detail = unsigned.refusal(topic, payload, STEP)
        assert reason == 'too_large'
        assert detail == f'{topic}: {payload} bytes (at most {limit})'
    # The budget of one message was not spent by the refused ones.
    assert unsigned.refusal(topic, limit, STEP) is None
    assert unsigned.refusal(topic, limit, STEP)[0] == 'rate_limited'


def test_the_budget_before_the_first_step_is_the_burst():
    budget = StepBudget()
    assert all(budget.take('/clock', None) for _ in range(BURST))
    assert not budget.take('/clock', None)
    # Step 0 is "before the first step" too.
    assert not budget.take('/clock', 0)


def test_a_new_step_gives_per_step_more_up_to_the_burst():
    budget = StepBudget()
    assert sum(budget.take('/agent_1/view/pose', 5) for _ in range(BURST + 50)) == BURST
    for step in (6, 7):
        assert [budget.take('/agent_1/view/pose', step) for _ in range(PER_STEP + 1)] == \
            [True] * PER_STEP + [False]
    # A long silence saves up no more than the burst.
    assert sum(budget.take('/agent_1/view/pose', 1000) for _ in range(BURST * 3)) == BURST
    # Each topic has its own budget.
    assert budget.take('/agent_2/view/pose', 1000)


def test_the_n_plus_first_message_of_a_step_is_refused_with_its_reason(profile):
    params, limits = profile
    unsigned = UnsignedInput(unsigned_topics(params), limits)
    topic = '/world/truth_markers'
    refusals = [unsigned.refusal(topic, 100, 9) for _ in range(BURST + 1)]
    assert refusals[:BURST] == [None] * BURST
    reason, detail = refusals[-1]
    assert reason == 'rate_limited'
    assert detail.startswith(f'{topic}: at step 9, over its budget of {BURST} messages')
    assert [unsigned.refusal(topic, 100, 10) for _ in range(PER_STEP)] == [None] * PER_STEP
    assert unsigned.refusal(topic, 100, 10)[0] == 'rate_limited'


@pytest.mark.parametrize('lead', [0, 1, 10, BURST - 1])
def test_a_genuine_publisher_ahead_of_the_known_step_is_never_refused(lead):
    """One message per step, the recorder knowing the step late: always, or in jumps.

    Always `lead` steps late, or not at all for `lead` steps and then at once (a world
    writer's samples held back, then repaired).
    """
    steady, stalled = StepBudget(), StepBudget()
    for k in range(1, 1001):
        assert steady.take('/clock', max(k - lead, 0)), k
        frozen = k - k % (lead + 1)         # learns the step once every lead + 1 steps
        assert stalled.take('/clock', frozen), k


def test_a_budget_needs_a_message_per_step_at_least():
    with pytest.raises(ValueError, match='1 <= per_step <= burst'):
        StepBudget(per_step=0)
    with pytest.raises(ValueError, match='1 <= per_step <= burst'):
        StepBudget(per_step=3, burst=2)
