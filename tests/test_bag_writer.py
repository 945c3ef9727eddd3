"""The run's bag writer: rosbags' format and checks, with the connection test by id.

No ROS graph runs: the bag is written and read here with rosbags alone.
"""

from msg_samples import samples
import pytest
from rclpy.serialization import serialize_message
from rosbags.rosbag2 import Reader, Writer, WriterError
import yaml

from sat_world_sim.bag_replay import deserialized
from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.bag_writer import RunBagWriter
from sat_world_sim.topics import graph_topics

TOPICS = graph_topics([1, 2, 3])


def message_bytes(topic):
    """CDR bytes of the sample message of a topic's type."""
    return serialize_message(samples()[topic.msgtype.rsplit('/', 1)[1]])


@pytest.fixture
def bag_of_every_topic(tmp_path):
    """Write each sat_msgs topic of a 3-agent run three times, in round-robin order."""
    store = sat_typestore()
    bag = tmp_path / 'bag'
    topics = [t for t in TOPICS if t.msgtype.startswith('sat_msgs/')]
    sent = []
    with RunBagWriter(bag) as writer:
        connections = [writer.add_connection(t.name, t.msgtype, typestore=store) for t in topics]
        for stamp in range(3 * len(topics)):
            index = stamp % len(topics)
            data = message_bytes(topics[index])
            writer.write(connections[index], stamp, data)
            sent.append((topics[index].name, stamp, data))
    return bag, sent


def test_every_message_reads_back_in_order_with_its_bytes(bag_of_every_topic):
    bag, sent = bag_of_every_topic
    with Reader(bag) as reader:
        read = [(c.topic, stamp, bytes(data)) for c, stamp, data in reader.messages()]
    assert read == sent
    assert len(dict(deserialized(bag))) == len({name for name, _, _ in sent})


def test_the_bag_is_one_mcap_file_with_compressed_chunks_only(tmp_path):
    bag = tmp_path / 'bag'
    topic = next(t for t in TOPICS if t.name.endswith('radio/out/search_density'))
    with RunBagWriter(bag) as writer:
        connection = writer.add_connection(topic.name, topic.msgtype, typestore=sat_typestore())
        for stamp in range(200):
            writer.write(connection, stamp, bytes(4000))
    info = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert info['version'] == 9 and info['storage_identifier'] == 'mcap'
    # No bag-level compression: any MCAP reader opens the file as it is.
    assert (info['compression_mode'], info['compression_format']) == ('', '')
    assert sorted(p.name for p in bag.iterdir()) == ['bag.mcap', 'metadata.yaml']
    assert info['message_count'] == 200
    # 800 kB of zeros in zstd chunks.
    assert (bag / 'bag.mcap').stat().st_size < 50_000


def test_write_refuses_a_connection_the_bag_does_not_hold(tmp_path):
    store = sat_typestore()
    first, second = TOPICS[5], TOPICS[6]
    with RunBagWriter(tmp_path / 'other') as other:
        foreign = other.add_connection(second.name, second.msgtype, typestore=store)
        with RunBagWriter(tmp_path / 'bag') as writer:
            held = writer.add_connection(first.name, first.msgtype, typestore=store)
            assert held.id == foreign.id == 1
            # Same id, another topic and owner: refused as rosbags' own Writer refuses it.
            with pytest.raises(WriterError, match='unknown connection'):
                writer.write(foreign, 1, message_bytes(second))
            with pytest.raises(WriterError, match='unknown connection'):
                writer.write(held._replace(id=2), 1, message_bytes(first))
            # An equal copy is the same connection, as for rosbags' Writer.
            writer.write(held._replace(), 1, message_bytes(first))
            assert writer.connections == [held]
            assert object() not in writer.connections


def test_it_answers_as_rosbags_own_writer_does(tmp_path):
    """The same calls on rosbags' Writer and RunBagWriter: same connections, same refusals."""
    store = sat_typestore()
    outcomes = []
    for make, name in ((lambda path: Writer(path, version=9), 'plain'), (RunBagWriter, 'run')):
        with make(tmp_path / name) as writer:
            connections = [writer.add_connection(t.name, t.msgtype, typestore=store)
                           for t in TOPICS[:8]]
            foreign = connections[0]._replace(topic='/elsewhere')
            refused = []
            for candidate in (*connections, foreign, connections[3]._replace(msgcount=7)):
                try:
                    writer.write(candidate, 1, b'\0' * 8)
                    refused.append(False)
                except WriterError:
                    refused.append(True)
            outcomes.append(([(c.id, c.topic, c.msgtype) for c in writer.connections], refused))
    assert outcomes[0] == outcomes[1]
    assert outcomes[1][1] == [False] * 8 + [True, True]
