"""The start-up handshake's rule (sat_agent.ros.readiness.unmet), without a graph."""

import json

import pytest

from sat_agent.ros.readiness import (
    announcement, AnnouncementError, MAX_ANNOUNCEMENT_BYTES, parse, unmet)

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
])
def test_a_malformed_announcement_is_refused_with_its_reason(text):
    with pytest.raises(AnnouncementError):
        parse(text)
