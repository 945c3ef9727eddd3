"""The start-up handshake's rule (sat_agent.ros.readiness), without a graph.

What world_sim waits for (unmet), what it takes as an announcement (parse), what it takes with
the run's key (seal, unseal: a signed envelope) and what it keeps (Announcements); and, on one
node of the test process, how often a node announces (ReadyAnnouncer).
"""

import json
import time

import pytest
import rclpy
from ros_harness import ros_node, spin_until
from std_msgs.msg import String

from sat_agent.message_auth import MonotonicCounter, run_key
from sat_agent.ros.readiness import (
    announcement, AnnouncementError, Announcements, MAX_ANNOUNCEMENT_BYTES, parse, QOS,
    ReadyAnnouncer, RESEND_S, seal, TOPIC, unmet, unseal)

KEY = bytes(range(32))

WORLD_READS = ['/agent_1/cmd', '/agent_1/radio/out/mode']
WORLD_WRITES = {'/agent_1/measurements': 2, '/world/step': 1}


def agent(cmd=2, status=1, mode=2):
    return json.loads(announcement(
        '/agent_1/agent', ['/agent_1/measurements'],
        {'/agent_1/cmd': cmd, '/agent_1/status': status, '/agent_1/radio/out/mode': mode}))


def recorder():
    return json.loads(announcement(
        '/recorder', ['/agent_1/cmd', '/agent_1/status', '/agent_1/measurements',
                      '/agent_1/radio/out/mode', '/world/step'], {}))


def test_a_run_whose_writers_matched_every_announced_reader_can_start():
    announced = {'/agent_1/agent': agent(), '/recorder': recorder()}
    assert unmet(announced, WORLD_READS, WORLD_WRITES, [1], observers=1) == []


def test_a_writer_that_has_not_matched_an_observer_holds_the_start():
    # The recorder sees the agent's status writer, but that writer does not see it yet.
    announced = {'/agent_1/agent': agent(status=0), '/recorder': recorder()}
    assert unmet(announced, WORLD_READS, WORLD_WRITES, [1], observers=1) == [
        '/agent_1/agent writes /agent_1/status to 0 of 1 readers']


def test_world_sim_counts_itself_and_the_observers_among_the_readers():
    # cmd is read by world_sim and the recorder: one match is not enough.
    announced = {'/agent_1/agent': agent(cmd=1), '/recorder': recorder()}
    assert unmet(announced, WORLD_READS, WORLD_WRITES, [1], observers=1) == [
        '/agent_1/agent writes /agent_1/cmd to 1 of 2 readers']
    # And its own writers must have matched the agent and the recorder.
    assert unmet({'/agent_1/agent': agent(), '/recorder': recorder()}, WORLD_READS,
                 dict(WORLD_WRITES, **{'/agent_1/measurements': 1}), [1], observers=1) == [
        'world_sim writes /agent_1/measurements to 1 of 2 readers']


def test_missing_agents_and_observers_are_named():
    problems = unmet({'/recorder': recorder()}, WORLD_READS, WORLD_WRITES, [1, 2], observers=2)
    assert 'agent 1 has not announced itself' in problems
    assert 'agent 2 has not announced itself' in problems
    assert "1 of 2 observers announced (['/recorder'])" in problems


def test_one_node_may_play_several_agents():
    both = json.loads(announcement('/scripted', [], {'/agent_1/cmd': 1, '/agent_2/cmd': 1}))
    assert unmet({'/scripted': both}, ['/agent_1/cmd', '/agent_2/cmd'], {}, [1, 2],
                 observers=0) == []


def test_a_node_that_says_observer_is_one_even_when_it_writes_an_agents_commands():
    # An attack test hijacks agent 1's commands: its writer must match world_sim's reader, and
    # it is the observer world_sim waits for, not agent 1.
    hostile = json.loads(announcement('/hostile', [],
                                      {'/agent_1/cmd': 2}, observer=True))
    announced = {'/agent_1/agent': agent(), '/recorder': recorder(), '/hostile': hostile}
    assert unmet(announced, WORLD_READS, WORLD_WRITES, [1], observers=2) == []
    assert unmet({'/recorder': recorder(), '/hostile': hostile}, WORLD_READS, WORLD_WRITES,
                 [1], observers=2) == ['agent 1 has not announced itself']
    hostile['writes']['/agent_1/cmd'] = 1
    assert unmet(announced, WORLD_READS, WORLD_WRITES, [1], observers=2) == [
        '/hostile writes /agent_1/cmd to 1 of 2 readers']
    # Without the flag the same announcement speaks for agent 1, as a scripted agent's does.
    assert 'observer' not in json.loads(announcement('/scripted', [], {'/agent_1/cmd': 1}))


def test_an_announcement_parses_back_to_what_was_announced():
    text = announcement('/metrics', ['/world/step'], {'/metrics/ready': 2}, observer=True)
    assert parse(text) == json.loads(text)
    assert parse(announcement('/agent_1/agent', [], {}))['writes'] == {}


@pytest.mark.parametrize('text', [
    '[' * 1000,                                        # nests past the JSON parser's recursion
    '{"node": "/x", "reads": [' + '"/t",' * (MAX_ANNOUNCEMENT_BYTES // 5) + '"/t"], "writes": {}}',
    'null', '[]', '"node"', '{"node": 1, "reads": [], "writes": {}}',
    '{"node": "/x", "writes": {}}',
    '{"node": "/x", "reads": [["/t"]], "writes": {}}',  # unhashable: unmet() raised TypeError
    '{"node": "/x", "reads": [], "writes": {"/t": "many"}}',
    '{"node": "/x", "reads": [], "writes": {"/t": -1}}',
    '{"node": "/x", "reads": [], "writes": {"/t": true}}',
    '{"node": "/x", "reads": [], "writes": {"/t": 1.5}}',
    '{"node": "/x", "reads": [], "writes": [], "observer": true}',
    '{"node": "/x", "reads": [], "writes": {}, "observer": "yes"}',
    '{"node": "\\ud800", "reads": [], "writes": {}}',  # no UTF-8: rclpy's logger raised
])
def test_a_malformed_announcement_is_refused_with_its_reason(text):
    with pytest.raises(AnnouncementError):
        parse(text)


def test_with_a_key_an_announcement_travels_signed_and_opens_to_its_text():
    text = announcement('/metrics', ['/world/step'], {}, observer=True)
    counter = MonotonicCounter(lambda: 41)
    sealed = seal(text, KEY, counter)
    assert json.loads(sealed)['signed'] == text
    assert unseal(sealed, KEY) == (text, 41)
    assert unseal(seal(text, KEY, counter), KEY) == (text, 42)
    # Without a key both sides use the plain text; an envelope (nodes with a key, world_sim
    # without) gives its text unverified.
    assert seal(text, None, counter) == text and unseal(text, None) == (text, None)
    assert unseal(sealed, None) == (text, None)


def envelope(**change) -> str:
    good = json.loads(seal(announcement('/fake', [], {}, observer=True), KEY,
                           MonotonicCounter(lambda: 7)))
    return json.dumps({**good, **change})


@pytest.mark.parametrize('data, reason', [
    # A well-formed announcement, unsigned: it could start the run before an observer is ready.
    (announcement('/fake', [], {}, observer=True), 'unsigned'),
    ('{"signed": "{}", "counter": 1}', 'unsigned'),
    (envelope(counter=True), 'unsigned'),
    (envelope(counter=-1), 'unsigned'),
    (envelope(extra=1), 'unsigned'),
    (envelope(mac='00' * 32), 'bad_signature'),
    (envelope(counter=8), 'bad_signature'),          # the counter is signed too
    (envelope(signed=announcement('/fake', [], {'/agent_1/cmd': 9})), 'bad_signature'),
    (seal(announcement('/fake', [], {}), bytes(32), MonotonicCounter()), 'bad_signature'),
    (envelope(mac='\u00e9' * 64), 'unsigned'),        # compare_digest raised TypeError
    (envelope(mac='AB' * 32), 'unsigned'),
    ('[' * 1000, 'bad_announcement'),
    (' ' * (MAX_ANNOUNCEMENT_BYTES + 1), 'bad_announcement'),
    ('{"signed": "\\ud800", "counter": 1, "mac": "' + '0' * 64 + '"}', 'bad_announcement'),
])
def test_with_a_key_anything_but_a_verified_envelope_is_refused_with_its_reason(data, reason):
    with pytest.raises(AnnouncementError) as error:
        unseal(data, KEY)
    assert error.value.reason == reason


def test_an_announcement_of_another_run_is_refused_naming_the_node_it_claims_to_be():
    # Nodes given different run ids (or keys) refuse each other: the log line says who and why.
    other_run = seal(announcement('/agent_1/agent', [], {}), run_key(KEY, 'other-run'),
                     MonotonicCounter())
    with pytest.raises(AnnouncementError) as error:
        unseal(other_run, KEY)
    assert error.value.reason == 'bad_signature'
    assert "'/agent_1/agent' (unverified) does not verify (a node of another key or run id?)" \
        in str(error.value)
    with pytest.raises(AnnouncementError, match='the MAC of an announcement does not'):
        unseal(envelope(signed='[1]', mac='00' * 32), KEY)
    # Bounded and escaped: a long name is cut, a newline cannot start a log line of its own.
    with pytest.raises(AnnouncementError) as error:
        unseal(seal(announcement('/x\n' + 'y' * 500, [], {}), bytes(32), MonotonicCounter()),
               KEY)
    assert '\n' not in str(error.value) and len(str(error.value)) < 200


def test_world_sim_keeps_a_nodes_announcement_only_while_its_counter_grows():
    book = Announcements(room=2)
    first, later = json.loads(announcement('/a', [], {'/t': 0})), \
        json.loads(announcement('/a', [], {'/t': 1}))
    assert book.take(first, 10) is None and book.take(later, 11) is None
    # A replay of the older one (fewer matched readers) would hold the start.
    assert book.take(first, 10)[0] == 'replayed' and book['/a'] == later
    assert book.take(json.loads(announcement('/b', [], {})), 1) is None
    assert book.take(json.loads(announcement('/c', [], {})), 1)[0] == 'too_many_announcers'
    # Without a key there is no counter: the last one is kept.
    plain = Announcements(room=1)
    assert plain.take(later, None) is None and plain.take(first, None) is None
    assert plain['/a'] == first


def spin_for(node, seconds: float):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        rclpy.spin_once(node, timeout_sec=0.05)


@pytest.mark.ros
@pytest.mark.timeout(60)
def test_a_node_announces_again_until_it_sees_the_run_start():
    # A flood of the topic can push a node's announcement out of world_sim's reader before it
    # is taken; one sent only once (or only on a change) would then hold the start.
    started = []
    with ros_node('announcer') as node:
        heard, at = [], []
        node.create_subscription(String, TOPIC, lambda msg: (
            heard.append(unseal(msg.data, KEY)), at.append(time.monotonic())), QOS)
        ReadyAnnouncer(node, [], key=KEY, observer=True, started=lambda: bool(started))
        spin_until(node, lambda: len(heard) >= 3, 10 * RESEND_S, 'three announcements')
        texts, counters = zip(*heard)
        assert len(set(texts)) == 1 and json.loads(texts[0])['observer'] is True
        assert list(counters) == sorted(set(counters))    # each a new envelope
        # Once a RESEND_S, not at every check of the timer (its period is a tenth of it).
        assert min(b - a for a, b in zip(at, at[1:])) > 0.5 * RESEND_S
        started.append(True)
        spin_for(node, 0.5)
        sent = len(heard)
        spin_for(node, 3 * RESEND_S)
        assert len(heard) == sent
