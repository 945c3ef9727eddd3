"""Radio messages parsed from their serialized bytes, once per distinct message (composed mode)."""

import numpy as np
import pytest
from rclpy.serialization import serialize_message

from sat_agent.agent_core import Agent, REPORT_KINDS
from sat_agent.config import SatParams
from sat_agent.ros.msg_conversions import InvalidMessage, report_part_from_msg, report_to_msgs
from sat_agent.ros.radio_parsing import RadioParser

PARAMS = SatParams()


@pytest.fixture(scope='module')
def report_bytes():
    """Return one agent's report after a few steps and its three serialized radio messages."""
    agent = Agent(1, PARAMS, (50.0, 50.0), seed=3)
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
            np.testing.assert_array_equal(part, report.search_values)
            assert not part.flags.writeable     # shared between agents: must stay read-only
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
    shared.parse('mode', data['mode'][:-1] + b'\x01', lattice)
    shared.parse('mode', data['mode'][:-1] + b'\x02', lattice)
    assert len(shared._parsed) <= 4
    assert shared.parse('search_density', data['search_density'], lattice) is not first
