"""records.RunCollector: a long run's metrics from a bounded window of messages."""

from geometry_msgs.msg import Point
from test_rerun_logger import AGENTS, synthetic_messages

from sat_world_sim.metrics import compute_metrics
from sat_world_sim.records import RunCollector, SETTLE_STEPS, step_record


def every_step_record(messages):
    """Build the records from every message of the run, all held in memory at once."""
    truths, traffic, statuses = {}, {}, {}
    for topic, msg in messages:
        if topic == '/world/truth':
            truths[msg.step] = msg
        elif topic == '/world/radio':
            traffic[msg.step] = msg
        elif topic.endswith('/status'):
            statuses.setdefault(msg.step, {})[msg.agent_id] = msg
    return [step_record(truths[k], statuses[k], traffic[k], traffic.get(k - 1))
            for k in sorted(truths)]


def test_run_collector_keeps_a_window_of_steps_and_gives_the_same_metrics():
    steps = 3 * SETTLE_STEPS + 5
    messages = list(synthetic_messages(steps))
    collector = RunCollector(AGENTS)
    most_kept = 0
    for topic, msg in messages:
        collector.add(topic, msg)
        most_kept = max(most_kept, len(collector.truths), len(collector.traffic),
                        len(collector.statuses) // len(AGENTS))
    # The window, the last settled step's traffic and the next step's messages before its truth.
    assert most_kept <= SETTLE_STEPS + 2
    assert collector.complete()
    records = collector.records()
    assert [r.step for r in records] == list(range(1, steps + 1))
    assert compute_metrics(records, 'synthetic', 1) == \
        compute_metrics(every_step_record(messages), 'synthetic', 1)
    # Settled steps drop their plans; the last steps keep theirs (the trajectory plot's).
    assert not records[0].plans and records[-1].plans


def test_a_message_of_a_settled_step_is_dropped():
    steps = SETTLE_STEPS + 10
    messages = list(synthetic_messages(steps))
    late = [(t, m) for t, m in messages if t == '/agent_2/status' and m.step == 2]
    collector = RunCollector(AGENTS)
    for topic, msg in messages:
        if (topic, msg) not in late:
            collector.add(topic, msg)
    collector.add(*late[0])
    assert (2, 2) not in collector.statuses
    record = collector.records()[1]
    assert record.step == 2 and set(record.modes) == {1}


def test_statuses_later_than_other_topics_by_more_than_the_window_still_count():
    # DDS orders each writer's messages, not messages across topics: agent 2's statuses can
    # come after the world's truths of many later steps (a loss repaired on a loaded machine).
    steps = SETTLE_STEPS + 15
    delay = SETTLE_STEPS + 5
    messages = list(synthetic_messages(steps))
    held = [(t, m) for t, m in messages if t == '/agent_2/status']
    delayed = []
    for topic, msg in messages:
        if topic == '/agent_2/status':
            continue
        delayed.append((topic, msg))
        while topic == '/world/truth' and held and held[0][1].step + delay <= msg.step:
            delayed.append(held.pop(0))
    delayed += held
    collector = RunCollector(AGENTS)
    for topic, msg in delayed:
        collector.add(topic, msg)
    records = collector.records()
    assert all(set(r.modes) == {1, 2} for r in records)
    assert compute_metrics(records, 'synthetic', 1) == \
        compute_metrics(every_step_record(messages), 'synthetic', 1)


def test_a_status_reports_its_estimates_and_its_coasted_targets():
    messages = list(synthetic_messages(2))
    for topic, msg in messages:
        if topic == '/agent_2/status':
            msg.coasted = [Point(x=20.0 + msg.step, y=10.0)]
    records = every_step_record(messages)
    # Agent 1 estimates one target in view; agent 2 reports one coasted target.
    assert records[0].estimates[1].shape == (1, 2)
    assert records[0].estimates[2].tolist() == [[21.0, 10.0]]
    assert records[1].estimates[2].tolist() == [[22.0, 10.0]]
    assert compute_metrics(records, 'synthetic', 1)['summary']['false_track_steps'] == 2
