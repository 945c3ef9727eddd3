"""sat_msgs: every type crosses DDS between two OS processes and rosbags <-> rclpy intact."""

import signal
import subprocess
import sys

from conftest import TESTS_DIR
from msg_samples import message_class, plain, samples, sat_msg_names
import pytest
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from ros_harness import ros_node, scaled, spin_until

from sat_world_sim.bag_types import sat_typestore

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)
EXPECTED_TYPES = {'AgentMode', 'AgentStatus', 'AgentTruth', 'ControlCommand', 'GridInfo',
                  'GroundTruth', 'MeasurementSet', 'MultiTargetEstimate', 'RangeBearing',
                  'RadioTraffic', 'SearchDensity', 'TargetEstimate', 'TargetTruth', 'WorldStep'}


def test_every_designed_type_is_built():
    assert set(sat_msg_names()) == EXPECTED_TYPES
    for name in EXPECTED_TYPES:
        assert message_class(f'sat_msgs/{name}')().get_fields_and_field_types()


def test_mode_and_clock_constants():
    agent_mode = message_class('sat_msgs/AgentMode')
    status = message_class('sat_msgs/AgentStatus')
    assert (agent_mode.MODE_SEARCH, agent_mode.MODE_TRACK) == (0, 1)
    assert (status.MODE_SEARCH, status.MODE_TRACK) == (0, 1)
    world_step = message_class('sat_msgs/WorldStep')
    assert (world_step.CLOCK_LOCK_STEP, world_step.CLOCK_REAL_TIME) == (0, 1)
    assert message_class('sat_msgs/ControlCommand').ACTION_STAY == 0


def test_samples_fill_every_field():
    """Guard for the tests below: a default-valued field could not reveal a lost field."""
    for name, msg in samples().items():
        default = plain(message_class(f'sat_msgs/{name}')())
        for field, value in plain(msg).items():
            assert value != default[field], f'{name}.{field} kept its default'


@pytest.mark.timeout(120)
def test_two_processes_round_trip_every_type_over_dds():
    sent = samples()
    peer = subprocess.Popen([sys.executable, str(TESTS_DIR / 'roundtrip_peer.py'),
                             '--timeout', str(scaled(90))])
    received = {}
    try:
        with ros_node('sat_msgs_roundtrip_test') as node:
            publishers = []
            for name, msg in sent.items():
                cls = type(msg)
                node.create_subscription(
                    cls, f'/sat_roundtrip/pong/{name}',
                    lambda m, name=name: received.setdefault(name, m), LATCHED)
                publishers.append(node.create_publisher(cls, f'/sat_roundtrip/ping/{name}',
                                                        LATCHED))
                publishers[-1].publish(msg)
            # Latched both ways: what was published before the peer matched reaches it anyway.
            spin_until(node, lambda: len(received) == len(sent), 60, 'an echo of every type',
                       (peer,))
            assert peer.poll() is None, f'peer exited early with {peer.returncode}'
    finally:
        peer.send_signal(signal.SIGINT)
        try:
            peer.wait(timeout=scaled(10))
        except subprocess.TimeoutExpired:
            peer.kill()
            peer.wait()
    assert set(received) == set(sent), f'no echo for {sorted(set(sent) - set(received))}'
    for name, msg in sent.items():
        assert plain(received[name]) == plain(msg), name


@pytest.mark.parametrize('name', sorted(EXPECTED_TYPES))
def test_rclpy_and_rosbags_read_each_others_bytes(name):
    store = sat_typestore()
    typename = f'sat_msgs/msg/{name}'
    msg = samples()[name]
    expected = plain(msg)
    # rclpy -> rosbags
    from_rclpy = store.deserialize_cdr(serialize_message(msg), typename)
    assert plain(from_rclpy) == expected
    # rosbags -> rclpy (bytes may differ in padding, so compare values, never bytes)
    back = deserialize_message(bytes(store.serialize_cdr(from_rclpy, typename)), type(msg))
    assert plain(back) == expected
