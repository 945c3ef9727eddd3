"""Any bytes on a verified subscription (issue 17): refused and counted, never an exception.

What every node's raw subscriptions run (sat_agent.ros.signed_io.VerifiedInput.receive) is fed
hypothesis-drawn payloads: random bytes, truncated and bit-flipped genuine messages, with and
without a key. Nothing may raise; with a key every one is refused, and a refused payload is
counted once under a reason.
"""

from collections import Counter

from hypothesis import given, settings, strategies as st
import pytest
from rclpy.serialization import serialize_message

from sat_agent.message_auth import Signer, StepWindow, WORLD_SENDER
from sat_agent.ros.signed_io import VerifiedInput
from sat_msgs.msg import AgentStatus, GroundTruth, TargetTruth, WorldStep
from sat_world_sim.ros.observer import WINDOW

KEY = bytes(range(32))
TOPIC = '/world/truth'
LIMIT = 4096


class Guard:
    """InputGuard's counting, without a node."""

    def __init__(self):
        self.dropped = Counter()
        self.auth = None

    def drop(self, reason, detail):
        self.dropped[reason] += 1


def genuine(step=1) -> bytes:
    truth = GroundTruth(step=step, targets=[TargetTruth(id=1, alive=True)])
    return Signer(KEY, WORLD_SENDER).sign(TOPIC, serialize_message(truth), step)


def receive(data: bytes, key):
    guard = Guard()
    inputs = VerifiedInput(None, guard, key, [1, 2], StepWindow(10, 1, 1),
                           window_without_key=True)
    msg = inputs.receive(TOPIC, data, GroundTruth, LIMIT, sender=WORLD_SENDER)
    # A node stops announcing itself once it took a message (readiness.ReadyAnnouncer):
    # nothing refused may count, with or without a key.
    assert inputs.took_any() == (msg is not None)
    return msg, guard


payloads = st.one_of(
    st.binary(max_size=LIMIT + 64),
    st.binary(max_size=200).map(lambda tail: b'\x00\x01\x00\x00' + tail),
    st.integers(0, len(genuine()) - 1).map(lambda n: genuine()[:n]),
    st.tuples(st.integers(0, len(genuine()) * 8 - 1)).map(
        lambda bit: bytes(b ^ (1 << (bit[0] % 8)) if i == bit[0] // 8 else b
                          for i, b in enumerate(genuine()))))


@settings(max_examples=400, deadline=None)
@given(data=payloads, signed=st.booleans())
def test_no_payload_raises_and_each_refusal_is_counted_once(data, signed):
    msg, guard = receive(data, KEY if signed else None)
    if signed:
        # Random, truncated or altered: nothing here carries a valid signature.
        assert msg is None
    if msg is None:
        assert sum(guard.dropped.values()) == 1
    else:
        assert not guard.dropped and isinstance(msg, GroundTruth)


def test_a_genuine_message_passes_and_a_forged_one_is_refused_before_deserialization():
    assert receive(genuine(), KEY)[0].targets[0].id == 1
    forged = serialize_message(GroundTruth(step=1))
    msg, guard = receive(forged, KEY)
    assert msg is None and guard.dropped == {'unsigned': 1}


@pytest.mark.parametrize('key', [KEY, None])
def test_a_payload_above_the_limit_is_refused_with_or_without_a_key(key):
    msg, guard = receive(b'\x00\x01\x00\x00' + bytes(LIMIT), key)
    assert msg is None and guard.dropped == {'too_large': 1}


def test_without_a_key_a_world_message_far_ahead_is_held_to_the_window():
    guard = Guard()
    inputs = VerifiedInput(None, guard, None, [1, 2], StepWindow(10, 1, 1),
                           window_without_key=True)
    data = lambda step: serialize_message(WorldStep(step=step))  # noqa: E731
    assert inputs.receive('/world/step', data(5), WorldStep, LIMIT, sender=0).step == 5
    assert inputs.receive('/world/step', data(2 ** 32 - 1), WorldStep, LIMIT, sender=0) is None
    assert guard.dropped == {'out_of_window': 1}


def test_an_observer_takes_an_answer_that_outruns_the_world_messages_of_its_step():
    # CI once lost agent 2's answers of step 22 in the bag: the recorder knew step 20 (DDS
    # orders each writer alone). An observer takes them up to a writer's history ahead.
    guard = Guard()
    inputs = VerifiedInput(None, guard, KEY, [1, 2], WINDOW)
    assert inputs.receive(TOPIC, genuine(20), GroundTruth, LIMIT, sender=WORLD_SENDER)

    def status(step):
        topic = '/agent_2/status'
        data = serialize_message(AgentStatus(agent_id=2, step=step))
        return inputs.receive(topic, Signer(KEY, 2).sign(topic, data, step), AgentStatus, LIMIT,
                              sender=2)
    assert status(22).step == 22 and status(20 + WINDOW.ahead).step == 20 + WINDOW.ahead
    assert status(21 + WINDOW.ahead) is None and guard.dropped == {'out_of_window': 1}
