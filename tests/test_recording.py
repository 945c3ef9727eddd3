"""Recording and replay of a run: the bag of the paper run, offline replay, live re-publishing."""

from collections import Counter
import subprocess
import sys

import pytest
from ros_harness import executable, ros_node, scaled, spin_until
from rosbags.rosbag2 import Reader

from sat_agent.ros.msg_conversions import message_class
from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.ros.replay import deep
from sat_world_sim.ros.replay_support import topic_qos
from sat_world_sim.topics import graph_topics

pytestmark = [pytest.mark.ros, pytest.mark.slow]
PER_STEP = ('/world/truth', '/world/radio', '/agent_1/measurements', '/agent_1/cmd',
            '/agent_1/status', '/agent_1/radio/out/search_density', '/agent_1/radio/out/mode',
            '/agent_2/measurements', '/agent_2/cmd', '/agent_2/status',
            '/agent_2/radio/out/estimate')


def read_bag(bag):
    """Return {topic: [deserialised messages]} and {topic: (msgtype, offered QoS)} of a bag."""
    store = sat_typestore()
    messages, meta = {}, {}
    with Reader(bag) as reader:
        for connection in reader.connections:
            meta[connection.topic] = (connection.msgtype,
                                      connection.ext.offered_qos_profiles)
        for connection, _, raw in reader.messages():
            messages.setdefault(connection.topic, []).append(
                store.deserialize_cdr(raw, connection.msgtype))
    return messages, meta


@pytest.mark.timeout(600)
def test_the_bag_holds_every_topic_at_every_step(paper_run):
    run_dir, code, metrics, output = paper_run
    assert code == 0, output[-3000:]
    bag = run_dir / 'bag'
    assert 'storage_identifier: mcap' in (bag / 'metadata.yaml').read_text()
    messages, meta = read_bag(bag)
    expected = {t.name: t.msgtype for t in graph_topics((1, 2))}
    assert {topic: msgtype for topic, (msgtype, _) in meta.items()} == expected
    assert all(qos for _, qos in meta.values()), 'a topic without its QoS profile'
    for topic in PER_STEP:
        assert [m.step for m in messages[topic]] == list(range(1, 201)), topic
    steps = [m.step for m in messages['/world/step']]
    assert steps == list(range(1, 201)) + [200] and messages['/world/step'][-1].finished
    # Radio: each report a neighbour received is one the sender sent the step before.
    sent = {(m.agent_id, m.step) for m in messages['/agent_2/radio/out/search_density']}
    received = [(m.agent_id, m.step) for m in messages['/agent_1/radio/in/search_density']]
    assert received and set(received) <= sent


@pytest.mark.timeout(600)
def test_offline_replay_of_the_paper_bag_gives_the_live_metrics(paper_run, tmp_path):
    run_dir, code, _, output = paper_run
    assert code == 0, output[-3000:]
    out = tmp_path / 'replay'
    result = subprocess.run([executable('sat_world_sim', 'replay'), str(run_dir / 'bag'),
                             '--offline', '--out', str(out)],
                            capture_output=True, text=True, timeout=scaled(300))
    assert result.returncode == 0, result.stderr[-3000:]
    assert result.stdout.strip().splitlines()[-1] == str(out)
    assert (out / 'metrics.json').read_text() == (run_dir / 'metrics.json').read_text()
    assert sorted(p.name for p in (out / 'plots').glob('*.png')) == sorted(
        p.name for p in (run_dir / 'plots').glob('*.png'))


@pytest.mark.timeout(600)
def test_republishing_the_bag_delivers_every_message(paper_run):
    run_dir, code, _, output = paper_run
    assert code == 0, output[-3000:]
    bag = run_dir / 'bag'
    with Reader(bag) as reader:
        in_bag = Counter(c.topic for c, _, _ in reader.messages())
    got = Counter()
    with ros_node('replay_listener') as node:
        for topic in graph_topics((1, 2)):
            node.create_subscription(message_class(topic.msgtype), topic.name,
                                     lambda _, name=topic.name: got.update([name]),
                                     deep(topic_qos(topic)))
        # The replay publishes once each of its writers matched this node's reader (a writer
        # drops what it wrote before, for a reader it matches later).
        replay = subprocess.Popen([executable('sat_world_sim', 'replay'), str(bag),
                                   '--rate', '5', '--match-timeout', str(scaled(60))],
                                  stderr=subprocess.PIPE, text=True)
        try:
            spin_until(node, lambda: replay.poll() is not None, 240,
                       'the replay publishing the whole bag')
            stderr = replay.communicate()[1]
            assert replay.returncode == 0, stderr[-3000:]
            assert 'not acknowledged' not in stderr, stderr[-3000:]
            # Every message was acknowledged, so it is in this node's queues.
            spin_until(node, lambda: all(got[t] >= n for t, n in in_bag.items()), 60,
                       'every replayed message taken from the queues')
        finally:
            if replay.poll() is None:
                replay.kill()
                replay.communicate()
    assert got == in_bag


def test_replay_refuses_what_is_not_a_bag(tmp_path):
    result = subprocess.run([sys.executable, '-m', 'sat_world_sim.ros.replay', str(tmp_path),
                             '--offline', '--out', str(tmp_path / 'x')],
                            capture_output=True, text=True)
    assert result.returncode == 2 and 'no metadata.yaml' in result.stderr
