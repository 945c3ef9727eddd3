"""Radio messages parsed from their serialized bytes, once per distinct message (composed mode)."""

from pathlib import Path

from geometry_msgs.msg import Point
import numpy as np
import pytest
from rclpy.serialization import serialize_message

from sat_agent.agent_core import Agent, REPORT_KINDS
from sat_agent.config import load_params_file, SatParams
from sat_agent.message_auth import (BLOCK_BYTES, MonotonicCounter, Signer, StepWindow,
                                    WORLD_SENDER)
from sat_agent.ros.msg_conversions import (check_status, InvalidMessage, report_part_from_msg,
                                           report_to_msgs)
from sat_agent.ros.radio_parsing import RadioParser
from sat_agent.ros.signed_io import VerifiedInput
from sat_msgs.msg import AgentStatus

PARAMS = SatParams()
CONFIG = Path(__file__).resolve().parent.parent / 'config'


@pytest.fixture(scope='module', params=['paper', 'persistent'])
def report_bytes(request):
    """Return one agent's report after a few steps and its three serialized radio messages.

    Both profiles: the persistent one's density travels in the other layout (density_codec.py).
    """
    agent = Agent(1, load_params_file(CONFIG / f'{request.param}.yaml'), (50.0, 50.0), seed=3)
    # The persistent profile's density carries the nodes' views (none for the paper's).
    assert len(agent.planner.node_views()) == (100 if request.param == 'persistent' else 0)
    rng = np.random.default_rng(3)
    for k in range(1, 4):
        output = agent.step(k, (50.0, 50.0 + k), rng.uniform((0, -3), (7, 3), (4, 2)), [])
    lattice = agent.filter.search.lattice
    msgs = report_to_msgs(output.report, lattice, PARAMS.motion.dt)
    return lattice, output.report, dict(zip(REPORT_KINDS, map(serialize_message, msgs)))


def test_parsed_bytes_give_the_message_and_its_validated_content(report_bytes):
    lattice, report, data = report_bytes
    parser = RadioParser()
    for kind in REPORT_KINDS:
        msg, part = parser.parse(kind, data[kind], lattice)
        assert (msg.agent_id, msg.step) == (1, 3)
        expected = report_part_from_msg(kind, msg, lattice)
        if kind == 'search_density':
            values, views = part
            np.testing.assert_array_equal(values, report.search_values)
            np.testing.assert_array_equal(views, report.node_views)
            # Shared between agents: must stay read-only.
            assert not (values.flags.writeable or views.flags.writeable)
        elif kind == 'estimate':
            assert part.targets and part.cardinality == expected.cardinality
            np.testing.assert_array_equal(part.positions(), report.target_positions())
        else:
            assert part[0] == expected[0] and np.array_equal(part[1], expected[1])


def test_garbage_and_bad_content_come_back_as_the_reason_to_drop(report_bytes):
    lattice, _, data = report_bytes
    parser = RadioParser()
    msg, error = parser.parse('estimate', b'\x00\x01\x00\x00garbage', lattice)
    assert msg is None and isinstance(error, InvalidMessage) and error.reason == 'undecodable'
    # A density message for another lattice is well-formed CDR but not for this agent.
    other = SatParams().with_overrides({'search.lattice_spacing': 2.0})
    msg, error = parser.parse('search_density', data['search_density'],
                              Agent(2, other, (5.0, 5.0)).filter.search.lattice)
    assert msg.agent_id == 1 and error.reason == 'grid_mismatch'


def test_a_shared_parser_parses_each_distinct_message_once(report_bytes):
    lattice, _, data = report_bytes
    shared = RadioParser(max_entries=4)
    first = shared.parse('search_density', data['search_density'], lattice)
    again = shared.parse('search_density', bytes(bytearray(data['search_density'])), lattice)
    assert again is first                   # equal bytes, another object: a cache hit
    # Without a cache every copy is parsed again.
    alone = RadioParser()
    assert alone.parse('mode', data['mode'], lattice) is not alone.parse('mode', data['mode'],
                                                                         lattice)
    # The cache never holds more than max_entries: it is emptied when full.
    for kind in REPORT_KINDS:
        shared.parse(kind, data[kind], lattice)
    body = len(data['mode']) - BLOCK_BYTES     # bytes before the relay's seal
    shared.parse('mode', data['mode'][:body - 1] + b'\x01' + data['mode'][body:], lattice)
    shared.parse('mode', data['mode'][:body - 1] + b'\x02' + data['mode'][body:], lattice)
    assert len(shared._parsed) <= 4
    assert shared.parse('search_density', data['search_density'], lattice) is not first


def test_copies_that_differ_only_in_the_relays_seal_are_parsed_once(report_bytes):
    """Composed mode: each receiver's copy has its own seal, the same content before it."""
    lattice, _, data = report_bytes
    shared = RadioParser(max_entries=4)
    sealed = [Signer(bytes(32), WORLD_SENDER).seal(f'/agent_{i}/radio/in/mode', data['mode'], 3)
              for i in (1, 2)]
    assert sealed[0] != sealed[1]
    assert shared.parse('mode', sealed[0], lattice) is shared.parse('mode', sealed[1], lattice)


class Guard:
    """What VerifiedInput needs of a node's InputGuard: the reasons it drops."""

    auth = None

    def __init__(self):
        self.reasons = []

    def drop(self, reason, detail):
        self.reasons.append(reason)


def test_an_insiders_report_refused_for_its_content_does_not_block_the_genuine_one(
        report_bytes):
    # test_attack_observers' insider bomb, arriving before the genuine report it follows (two
    # writers, so DDS does not order them): a density for another grid, signed by agent 1 with
    # the counter just above the genuine one's. It is refused for its grid and must not count
    # as taken, or the genuine report would then be refused as a replay (seen in a full run).
    lattice, _, data = report_bytes
    key, channel = bytes(range(32)), '/agent_1/radio/out/search_density'
    other = Agent(1, SatParams().with_overrides({'search.lattice_spacing': 2.0}), (5.0, 5.0))
    report = other.step(3, (5.0, 5.0), np.zeros((0, 2)), []).report
    msgs = report_to_msgs(report, other.filter.search.lattice, PARAMS.motion.dt)
    bomb = serialize_message(msgs[REPORT_KINDS.index('search_density')])

    def signed(counter, body):
        signer = Signer(key, 1, MonotonicCounter(lambda: counter))
        return signer.sign(channel, body, 3, relayed=True)
    genuine, insider = signed(100, data['search_density']), signed(101, bomb)
    guard = Guard()
    inputs = VerifiedInput(None, guard, key, (1, 2), StepWindow(behind=4, ahead=1, world_ahead=10))
    inputs.verifier.step = 3
    parser, limit = RadioParser(), 1 << 20
    msg, part = inputs.receive_report(parser, 'search_density', channel, insider, lattice, limit,
                                      relayed=True)
    assert isinstance(part, InvalidMessage) and part.reason == 'grid_mismatch'
    msg, part = inputs.receive_report(parser, 'search_density', channel, genuine, lattice, limit,
                                      relayed=True)
    assert msg.agent_id == 1 and not isinstance(part, InvalidMessage)
    # Once the genuine report is taken, both are behind the counter.
    assert inputs.receive_report(parser, 'search_density', channel, genuine, lattice, limit,
                                 relayed=True) is None
    assert guard.reasons == ['replayed']


def test_a_status_refused_for_its_content_does_not_block_the_genuine_one():
    # An insider's status for an observer (metrics, logger) with a NaN position, signed by agent
    # 1 with the counter just above the genuine one's and arriving first. NaN points used to
    # end the metrics node in its OSPA; refused before it is taken, it must leave the counter.
    key, channel = bytes(range(32)), '/agent_1/status'
    genuine = AgentStatus(agent_id=1, step=3, particle_xy=[1.0, 2.0], particle_weights=[0.5])
    bombs = [AgentStatus(agent_id=1, step=3, position=Point(x=float('nan'))),
             AgentStatus(agent_id=1, step=3, particle_xy=[1.0, 2.0, 3.0]),
             AgentStatus(agent_id=1, step=3, mode=7)]

    def signed(counter, msg):
        return Signer(key, 1, MonotonicCounter(lambda: counter)).sign(
            channel, serialize_message(msg), 3)
    guard = Guard()
    inputs = VerifiedInput(None, guard, key, (1, 2), StepWindow(behind=4, ahead=1, world_ahead=10))
    inputs.verifier.step = 3
    for bomb in bombs:
        assert inputs.receive(channel, signed(101, bomb), AgentStatus, 1 << 20, sender=1,
                              content=check_status) is None
    assert guard.reasons == ['non_finite', 'bad_layout', 'unknown_mode']
    taken = inputs.receive(channel, signed(100, genuine), AgentStatus, 1 << 20, sender=1,
                           content=check_status)
    assert taken is not None and list(taken.particle_xy) == [1.0, 2.0]
