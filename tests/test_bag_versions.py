"""A bag recorded by an older version: read with its own definitions, left out of a live replay.

The bag is written here with the SearchDensity of before session 63 (no node_views), beside an
AgentMode whose definition did not change; no ROS graph runs.
"""

import dataclasses
import shutil

from msg_samples import samples
import pytest
from rclpy.serialization import serialize_message
from rosbags.serde import SerdeError

from sat_world_sim.bag_replay import deserialized, open_bag, outdated
from sat_world_sim.bag_types import find_msg_dir, sat_typestore
from sat_world_sim.bag_writer import RunBagWriter
from sat_world_sim.ros.replay import live_connections, main

DENSITY = ('/agent_1/radio/out/search_density', 'sat_msgs/msg/SearchDensity')
MODE = ('/agent_1/radio/out/mode', 'sat_msgs/msg/AgentMode')


def older_store(tmp_path):
    """Return the installed sat_msgs with SearchDensity as it was before node_views."""
    msg_dir = tmp_path / 'msg'
    shutil.copytree(find_msg_dir(), msg_dir)
    path = msg_dir / 'SearchDensity.msg'
    lines = path.read_text().splitlines()
    assert 'uint32[] node_views' in lines
    path.write_text('\n'.join(line for line in lines if line != 'uint32[] node_views') + '\n')
    return sat_typestore(msg_dir)


def as_recorded(store, name):
    """Return the sample message of `name` in the layout of `store` (the fields it has)."""
    typename = f'sat_msgs/msg/{name}'
    current = sat_typestore().deserialize_cdr(serialize_message(samples()[name]), typename)
    cls = store.types[typename]
    return cls(**{f.name: getattr(current, f.name) for f in dataclasses.fields(cls)})


@pytest.fixture
def old_bag(tmp_path):
    store = older_store(tmp_path)
    bag = tmp_path / 'bag'
    written = {}
    with RunBagWriter(bag) as writer:
        for stamp, (topic, typename) in enumerate((DENSITY, MODE), start=1):
            connection = writer.add_connection(topic, typename, typestore=store)
            msg = as_recorded(store, typename.rsplit('/', 1)[1])
            writer.write(connection, stamp, store.serialize_cdr(msg, typename))
            written[topic] = msg
    return bag, written


def test_an_older_bag_reads_with_its_own_definitions(old_bag):
    bag, written = old_bag
    read = dict(deserialized(bag))
    assert set(read) == set(written)
    density = read[DENSITY[0]]
    assert not hasattr(density, 'node_views')
    sent = written[DENSITY[0]]
    assert (density.agent_id, density.step) == (sent.agent_id, sent.step)
    assert bytes(density.values_zlib) == bytes(sent.values_zlib)
    # The signature block is the message's last bytes: it arrives whole only if the layout is
    # the recorded one.
    assert (density.auth.counter, bytes(density.auth.mac), bytes(density.relay.mac)) == (
        sent.auth.counter, bytes(sent.auth.mac), bytes(sent.relay.mac))
    assert read[MODE[0]].mode == written[MODE[0]].mode


def test_the_installed_definitions_cannot_read_the_older_density(old_bag):
    bag, _ = old_bag
    with open_bag(bag) as reader:
        raw = next(r for c, _, r in reader.messages() if c.topic == DENSITY[0])
    # The auth block's first bytes are taken for node_views' length.
    with pytest.raises(SerdeError, match='Invalid sequence length'):
        sat_typestore().deserialize_cdr(raw, DENSITY[1])


def test_a_live_replay_leaves_out_what_was_recorded_with_another_definition(old_bag, capsys):
    bag, _ = old_bag
    with open_bag(bag) as reader:
        assert outdated(reader, reader.connections) == [DENSITY]
        kept = live_connections(reader, reader.connections)
        assert [(c.topic, c.msgtype) for c in kept] == [MODE]
        assert DENSITY[0] in capsys.readouterr().err
        only_density = [c for c in reader.connections if c.topic == DENSITY[0]]
        with pytest.raises(ValueError, match='--offline'):
            live_connections(reader, only_density)
    # Before any ROS node starts: exit 2 with the reason.
    assert main([str(bag), '--topics', DENSITY[0]]) == 2
    assert '--offline' in capsys.readouterr().err


def test_a_bag_of_this_version_is_not_outdated(tmp_path):
    store = sat_typestore()
    bag = tmp_path / 'bag'
    with RunBagWriter(bag) as writer:
        for topic, typename in (DENSITY, MODE):
            writer.add_connection(topic, typename, typestore=store)
    with open_bag(bag) as reader:
        assert outdated(reader, reader.connections) == []
