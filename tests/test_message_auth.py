"""message_auth: signatures, relay seals, the receiver's policy, key files, the CDR tail layout.

Most tests sign synthetic CDR payloads (the module is bytes in, bytes out); the layout tests at
the end check on rclpy's serializer that the tail lands where message_auth reads it.
"""

import hashlib
import hmac
import os
import stat
import struct

from hypothesis import given, settings, strategies as st
import pytest

from sat_agent import message_auth as auth
from sat_agent.message_auth import (AuthError, BLOCK_BYTES, create_key_file, KeyFileError,
                                    load_key, MessageVerifier, MonotonicCounter, Signer,
                                    StepWindow, WORLD_SENDER)

KEY = bytes(range(32))
ROSTER = (1, 2, 3)
WINDOW = StepWindow(behind=4, ahead=1, world_ahead=1000)
CDR_LE = b'\x00\x01\x00\x00'


def outbox(sender: int) -> str:
    return f'/agent_{sender}/radio/out/estimate'


def inbox(receiver: int) -> str:
    return f'/agent_{receiver}/radio/in/estimate'


def payload(body: bytes = b'content', relayed: bool = False) -> bytes:
    """Return a CDR payload as rclpy would serialize a type ending in zero auth block(s)."""
    body += bytes(-len(body) % 8)    # CDR aligns the uint64 counter to 8 from the body's start
    return CDR_LE + body + bytes(BLOCK_BYTES * (2 if relayed else 1))


def verifier(step=None, key=KEY, senders=ROSTER, window=WINDOW) -> MessageVerifier:
    v = MessageVerifier(key, senders, window)
    v.step = step
    return v


def refused(call, reason: str):
    with pytest.raises(AuthError) as error:
        call()
    assert error.value.reason == reason, error.value


# -- signatures -----------------------------------------------------------------------------

@settings(max_examples=200, deadline=None)
@given(body=st.binary(max_size=300), sender=st.sampled_from(ROSTER),
       step=st.integers(10, 2**32 - 1), relayed=st.booleans())
def test_a_signed_message_verifies_and_says_who_when_and_which_counter(
        body, sender, step, relayed):
    signer = Signer(KEY, sender)
    data = signer.sign(outbox(sender), payload(body, relayed), step, relayed=relayed)
    assert len(data) == len(payload(body, relayed))
    assert data[:-BLOCK_BYTES * (2 if relayed else 1)] == payload(body, relayed)[
        :-BLOCK_BYTES * (2 if relayed else 1)]
    signed = verifier(step).verify(outbox(sender), data, relayed=relayed)
    assert (signed.sender, signed.step, signed.counter) == (sender, step, signer.counter._last)


@settings(max_examples=300, deadline=None)
@given(body=st.binary(max_size=100), bit=st.integers(0, 10**6), relayed=st.booleans())
def test_any_flipped_bit_is_refused_and_nothing_is_accepted(body, bit, relayed):
    data = bytearray(Signer(KEY, 2).sign(outbox(2), payload(body, relayed), 10, relayed))
    # The seal block of a relayed type is the relay's to fill (the delivery test below).
    bit %= 8 * (len(data) - (BLOCK_BYTES if relayed else 0))
    data[bit // 8] ^= 1 << (bit % 8)
    v = verifier(10)
    with pytest.raises(AuthError) as error:
        v.verify(outbox(2), bytes(data), relayed=relayed)
    # Which check catches the flip depends on the field it hits; none lets it through.
    assert error.value.reason in {'bad_signature', 'unsigned', 'unknown_sender', 'malformed'}
    assert v.refused == {error.value.reason: 1} and not v.accepted


def test_a_message_signed_for_one_topic_is_refused_on_another_and_with_another_key():
    data = Signer(KEY, 2).sign('/agent_2/cmd', payload(), 10)
    refused(lambda: verifier(10).verify('/agent_3/cmd', data), 'bad_signature')
    refused(lambda: verifier(10, key=bytes(32)).verify('/agent_2/cmd', data), 'bad_signature')


def test_unsigned_short_and_foreign_payloads_are_refused_with_their_reason():
    v = verifier(10)
    refused(lambda: v.verify('/agent_2/cmd', payload()), 'unsigned')
    refused(lambda: v.verify('/agent_2/cmd', CDR_LE + b'tiny'), 'unsigned')
    refused(lambda: v.verify('/agent_2/cmd', b'\x00\x03' + payload()[2:]), 'malformed')
    refused(lambda: v.verify('/agent_2/cmd', b''), 'malformed')
    assert v.refused == {'unsigned': 2, 'malformed': 2}


def test_a_big_endian_payload_is_signed_and_read_in_its_byte_order():
    data = Signer(KEY, 3).sign('/agent_3/cmd', b'\x00\x00\x00\x00' + payload()[4:], 11)
    counter, sender, step, _ = struct.unpack('>QII32s', data[-BLOCK_BYTES:])
    assert (sender, step) == (3, 11)
    assert verifier(11).verify('/agent_3/cmd', data).counter == counter


def test_signing_a_message_whose_tail_is_not_zero_is_a_programming_error():
    with pytest.raises(ValueError, match='zero auth'):
        Signer(KEY, 2).sign('/agent_2/cmd', payload(b'x')[:-1] + b'\x01', 10)


def test_a_payload_above_the_size_limit_is_refused_before_hashing(monkeypatch):
    data = Signer(KEY, 2).sign('/agent_2/cmd', payload(bytes(1000)), 10)
    monkeypatch.setattr(auth, '_mac', lambda *a: pytest.fail('hashed an oversized payload'))
    refused(lambda: verifier(10).verify('/agent_2/cmd', data, max_bytes=500), 'too_large')


def test_the_size_limit_holds_with_authentication_off_too():
    refused(lambda: verifier(10, key=None).verify('/agent_2/cmd', bytes(600), max_bytes=500),
            'too_large')


# -- replays, senders, steps ----------------------------------------------------------------

def test_a_replayed_or_older_message_is_refused_per_signer_and_channel():
    signer = Signer(KEY, 2)
    first, second = (signer.sign('/agent_2/cmd', payload(), 10) for _ in range(2))
    v = verifier(10)
    v.verify('/agent_2/cmd', second)
    refused(lambda: v.verify('/agent_2/cmd', second), 'replayed')
    refused(lambda: v.verify('/agent_2/cmd', first), 'replayed')
    # The same counter on another channel is that channel's first message.
    v.verify('/agent_2/status', signer.sign('/agent_2/status', payload(), 10))
    assert v.refused == {'replayed': 2}
    assert v.accepted == {'/agent_2/cmd': 1, '/agent_2/status': 1}


def test_a_refused_message_does_not_advance_the_replay_counter():
    signer = Signer(KEY, 2)
    early = signer.sign('/agent_2/cmd', payload(), 12)
    on_time = signer.sign('/agent_2/cmd', payload(), 11)
    v = verifier(10)
    refused(lambda: v.verify('/agent_2/cmd', early), 'out_of_window')
    assert v.verify('/agent_2/cmd', on_time).step == 11


def test_a_message_refused_after_its_signature_leaves_the_replay_counter_where_it_was():
    # An insider's signed message with a counter just above a genuine one arrives first (DDS
    # does not order two writers) and its receiver refuses its content: it is never committed.
    genuine = Signer(KEY, 2, MonotonicCounter(lambda: 100)).sign('/agent_2/cmd', payload(), 10)
    insider = Signer(KEY, 2, MonotonicCounter(lambda: 101)).sign('/agent_2/cmd', payload(), 10)
    v = verifier(10)
    assert v.verify('/agent_2/cmd', insider, commit=False).counter == 101
    assert v.verify('/agent_2/cmd', genuine, commit=False).counter == 100
    v.commit('/agent_2/cmd')
    assert v.accepted == {'/agent_2/cmd': 1}
    refused(lambda: v.verify('/agent_2/cmd', genuine), 'replayed')
    # Taken, a counter is a bound like any other; a commit without a pending message is a no-op.
    v.verify('/agent_2/cmd', insider, commit=False)
    v.commit('/agent_2/cmd')
    v.commit('/agent_2/cmd')
    refused(lambda: v.verify('/agent_2/cmd', insider), 'replayed')
    assert v.accepted == {'/agent_2/cmd': 2} and v.refused == {'replayed': 2}


def test_a_world_message_teaches_the_step_only_once_taken():
    v = verifier(None)
    v.verify('/world/step', Signer(KEY, WORLD_SENDER).sign('/world/step', payload(), 50),
             commit=False)
    assert v.step is None
    v.commit('/world/step')
    assert v.step == 50


def test_a_delivery_refused_after_its_seal_leaves_the_inbox_counter_where_it_was():
    relay = Signer(KEY, WORLD_SENDER, MonotonicCounter(lambda: 7))
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    first = relay_to(1, report, relay=relay)
    later = relay_to(1, report, relay=Signer(KEY, WORLD_SENDER, MonotonicCounter(lambda: 8)))
    v = verifier(10)
    v.verify_delivery(inbox(1), later, outbox, commit=False)
    v.verify_delivery(inbox(1), first, outbox)
    refused(lambda: v.verify_delivery(inbox(1), first, outbox), 'replayed')


def test_a_respawned_sender_is_not_taken_for_a_replay():
    v = verifier(10)
    old = Signer(KEY, 2)
    for _ in range(50):
        v.verify('/agent_2/cmd', old.sign('/agent_2/cmd', payload(), 10))
    respawned = Signer(KEY, 2)     # a new process: a new counter, from the wall clock
    assert v.verify('/agent_2/cmd', respawned.sign('/agent_2/cmd', payload(), 10))
    assert not v.refused


def test_the_counter_increases_strictly_even_when_the_clock_stands_still_or_goes_back():
    clock = iter([100, 100, 100, 50, 200])
    counter = MonotonicCounter(clock=lambda: next(clock))
    assert [counter.take() for _ in range(5)] == [100, 101, 102, 103, 200]


def test_a_sender_off_the_roster_is_refused_even_with_a_valid_signature():
    data = Signer(KEY, 99).sign('/agent_99/cmd', payload(), 10)
    refused(lambda: verifier(10).verify('/agent_99/cmd', data), 'unknown_sender')


def test_a_channel_only_its_sender_may_sign_refuses_another_roster_member():
    """E.g. scans: only world_sim signs /agent_1/measurements."""
    forged = Signer(KEY, 2).sign('/agent_1/measurements', payload(), 10)
    refused(lambda: verifier(10).verify('/agent_1/measurements', forged, sender=WORLD_SENDER),
            'wrong_sender')
    genuine = Signer(KEY, WORLD_SENDER).sign('/agent_1/measurements', payload(), 10)
    assert verifier(10).verify('/agent_1/measurements', genuine, sender=WORLD_SENDER)


def test_a_message_whose_fields_disagree_with_its_signature_is_refused():
    v = verifier(10)
    signed = v.verify('/agent_2/cmd', Signer(KEY, 2).sign('/agent_2/cmd', payload(), 10))
    v.confirm(signed, step=10, sender=2)
    refused(lambda: v.confirm(signed, step=11, sender=2), 'mismatch')
    refused(lambda: v.confirm(signed, step=10, sender=3), 'mismatch')
    v.confirm(None, step=99)     # authentication off: nothing to compare
    assert v.refused == {'mismatch': 2}


@given(known=st.integers(100, 10**6), offset=st.integers(-20, 20))
def test_peers_are_accepted_only_within_the_window_around_the_known_step(known, offset):
    v = verifier(known)
    data = Signer(KEY, 2).sign('/agent_2/cmd', payload(), known + offset)
    if -WINDOW.behind <= offset <= WINDOW.ahead:
        assert v.verify('/agent_2/cmd', data).step == known + offset
    else:
        refused(lambda: v.verify('/agent_2/cmd', data), 'out_of_window')


def test_a_new_receiver_learns_the_step_only_from_a_signed_world_message():
    v = verifier(None)
    world = Signer(KEY, WORLD_SENDER)
    peer = Signer(KEY, 2)
    refused(lambda: v.verify('/agent_2/cmd', peer.sign('/agent_2/cmd', payload(), 7)),
            'step_unknown')
    # A forged world message does not teach the step.
    forged = Signer(bytes(32), WORLD_SENDER).sign('/world/step', payload(), 2**32 - 1)
    refused(lambda: v.verify('/world/step', forged), 'bad_signature')
    assert v.step is None
    v.verify('/world/step', world.sign('/world/step', payload(), 7))
    assert v.step == 7
    assert v.verify('/agent_2/cmd', peer.sign('/agent_2/cmd', payload(), 7)).step == 7


def test_world_messages_may_run_ahead_up_to_world_ahead_and_never_move_the_step_back():
    v = verifier(100)
    world = Signer(KEY, WORLD_SENDER)
    refused(lambda: v.verify('/world/step', world.sign('/world/step', payload(), 1101)),
            'out_of_window')
    v.verify('/world/step', world.sign('/world/step', payload(), 1100))
    v.verify('/world/truth', world.sign('/world/truth', payload(), 1097))
    assert v.step == 1100


# -- the relay ------------------------------------------------------------------------------

def relay_to(receiver: int, data: bytes, step: int = 10, relay=None) -> bytes:
    """Do what world_sim does with agent 2's estimate: verify it, seal it for one receiver."""
    verifier(step).verify(outbox(2), data, relayed=True)
    return (relay or Signer(KEY, WORLD_SENDER)).seal(inbox(receiver), data, step)


def test_a_delivery_sealed_for_its_receiver_verifies_with_the_senders_block():
    report = Signer(KEY, 2).sign(outbox(2), payload(b'estimate', relayed=True), 10, relayed=True)
    delivered = relay_to(1, report)
    v = verifier(10)
    signed = v.verify_delivery(inbox(1), delivered, outbox)
    assert (signed.sender, signed.step) == (2, 10)
    refused(lambda: v.verify_delivery(inbox(1), delivered, outbox), 'replayed')


def test_a_delivery_is_refused_on_another_receivers_inbox():
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    refused(lambda: verifier(10).verify_delivery(inbox(3), relay_to(1, report), outbox),
            'bad_signature')


def test_a_genuine_report_published_straight_on_an_inbox_is_refused():
    """The range-gate bypass: agent 2's own signed report, not through the radio."""
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    refused(lambda: verifier(10).verify_delivery(inbox(1), report, outbox), 'unsigned')


def test_a_seal_made_by_an_agent_is_refused_as_not_relayed():
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    delivered = relay_to(1, report, relay=Signer(KEY, 2))
    refused(lambda: verifier(10).verify_delivery(inbox(1), delivered, outbox), 'not_relayed')


@settings(max_examples=300, deadline=None)
@given(body=st.binary(max_size=100), bit=st.integers(0, 10**6))
def test_any_flipped_bit_of_a_delivery_is_refused(body, bit):
    report = Signer(KEY, 2).sign(outbox(2), payload(body, relayed=True), 10, relayed=True)
    delivered = bytearray(relay_to(1, report))
    bit %= 8 * len(delivered)
    delivered[bit // 8] ^= 1 << (bit % 8)
    v = verifier(10)
    with pytest.raises(AuthError) as error:
        v.verify_delivery(inbox(1), bytes(delivered), outbox)
    assert error.value.reason in {'bad_signature', 'unsigned', 'unknown_sender', 'malformed',
                                  'not_relayed'}
    assert not v.accepted


def test_a_delivery_of_an_unknown_sender_is_refused():
    report = Signer(KEY, 99).sign(outbox(99), payload(relayed=True), 10, relayed=True)
    delivered = Signer(KEY, WORLD_SENDER).seal(inbox(1), report, 10)
    refused(lambda: verifier(10).verify_delivery(inbox(1), delivered, outbox), 'unknown_sender')


def test_an_old_delivery_replayed_later_is_refused():
    relay = Signer(KEY, WORLD_SENDER)
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    old = relay_to(1, report, relay=relay)
    v = verifier(10)
    v.verify_delivery(inbox(1), old, outbox)
    report = Signer(KEY, 2).sign(outbox(2), payload(relayed=True), 11, relayed=True)
    v.verify_delivery(inbox(1), relay_to(1, report, step=11, relay=relay), outbox)
    refused(lambda: v.verify_delivery(inbox(1), old, outbox), 'replayed')


# -- runs -----------------------------------------------------------------------------------

def test_a_recording_of_one_run_does_not_verify_in_another_run_under_the_same_key():
    # A key reused across runs: each run's receivers start with fresh replay counters, so only
    # the run's own key (run_key) keeps another run's recorded messages and seals out.
    run_a, run_b = auth.run_key(KEY, 'mission-a'), auth.run_key(KEY, 'mission-b')
    assert len({KEY, run_a, run_b}) == 3 and auth.run_key(KEY, '') == KEY
    # Pinned: nodes of two versions must derive the same run key.
    assert run_a == hmac.new(KEY, b'sat-swarm run v1\x00mission-a', hashlib.sha256).digest()
    recorded = Signer(run_a, 2).sign('/agent_2/cmd', payload(), 10)
    assert verifier(10, key=run_a).verify('/agent_2/cmd', recorded).sender == 2
    refused(lambda: verifier(10, key=run_b).verify('/agent_2/cmd', recorded), 'bad_signature')
    refused(lambda: verifier(10).verify('/agent_2/cmd', recorded), 'bad_signature')
    report = Signer(run_a, 2).sign(outbox(2), payload(relayed=True), 10, relayed=True)
    delivery = Signer(run_a, WORLD_SENDER).seal(inbox(1), report, 10)
    refused(lambda: verifier(10, key=run_b).verify_delivery(inbox(1), delivery, outbox),
            'bad_signature')
    assert auth.text_mac(run_a, '/world/ready', '{}', 1) != \
        auth.text_mac(run_b, '/world/ready', '{}', 1)


def test_a_key_parameter_gives_its_runs_key_and_no_file_gives_none(tmp_path):
    path = tmp_path / 'swarm.key'
    path.write_bytes(KEY)
    path.chmod(0o600)
    assert auth.key_from_parameter(str(path)) == KEY
    assert auth.key_from_parameter(str(path), 'mission-a') == auth.run_key(KEY, 'mission-a')
    assert auth.key_from_parameter('', 'mission-a') is None


# -- off ------------------------------------------------------------------------------------

def test_without_a_key_nothing_is_signed_and_everything_is_accepted_and_counted():
    data = Signer(None, 2).sign('/agent_2/cmd', payload(), 10)
    assert data == payload()
    v = verifier(None, key=None)
    assert not v.enabled
    assert v.verify('/agent_2/cmd', data) is None
    assert v.verify_delivery(inbox(1), payload(relayed=True), outbox) is None
    assert v.accepted == {'unauthenticated': 2} and not v.refused
    assert auth.key_from_parameter('') is None


def test_step_window_rejects_negative_or_fractional_bounds():
    with pytest.raises(ValueError, match='StepWindow.ahead'):
        StepWindow(behind=1, ahead=-1, world_ahead=1)


# -- key files ------------------------------------------------------------------------------

def test_a_created_key_file_is_owner_only_even_with_an_open_umask(tmp_path):
    previous = os.umask(0)
    try:
        path = create_key_file(tmp_path / 'swarm.key')
    finally:
        os.umask(previous)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    key = load_key(path)
    assert len(key) == auth.KEY_BYTES and key != load_key(create_key_file(tmp_path / 'b.key'))
    assert auth.key_from_parameter(str(path)) == key


def test_creating_a_key_file_refuses_an_existing_file_or_a_planted_symlink(tmp_path):
    (tmp_path / 'k').write_bytes(b'old')
    (tmp_path / 'link').symlink_to(tmp_path / 'elsewhere')
    for name in ('k', 'link'):
        with pytest.raises(KeyFileError, match=f'{tmp_path / name}.*must not exist'):
            create_key_file(tmp_path / name)
    assert not (tmp_path / 'elsewhere').exists()


def key_file(path, data=bytes(32), mode=0o600):
    path.write_bytes(data)
    path.chmod(mode)
    return path


@pytest.mark.parametrize('make, message', [
    (lambda p: p, 'cannot open it'),
    (lambda p: key_file(p, bytes(31)), '31 bytes; allowed: 32 to'),
    (lambda p: key_file(p, bytes(5000)), '4097 bytes; allowed'),
    (lambda p: key_file(p, mode=0o644), 'mode 0644 lets other users'),
    (lambda p: key_file(p, mode=0o620), 'mode 0620 lets other users'),
    (lambda p: p.mkdir() or p, 'not a regular file'),
    (lambda p: os.mkfifo(p, 0o600) or p, 'not a regular file'),
])
def test_a_bad_key_file_is_named_with_its_problem(tmp_path, make, message):
    path = make(tmp_path / 'swarm.key')
    with pytest.raises(KeyFileError, match=message) as error:
        load_key(path)
    assert str(path) in str(error.value)


@pytest.mark.skipif(os.geteuid() == 0, reason='root reads any file, whatever its mode')
def test_an_unreadable_key_file_is_named(tmp_path):
    path = key_file(tmp_path / 'swarm.key', mode=0o000)
    with pytest.raises(KeyFileError, match=f'{path}: cannot open it'):
        load_key(path)


@pytest.mark.skipif(os.geteuid() != 0, reason='only root can give a file to another user')
def test_a_key_file_of_another_user_is_refused(tmp_path, monkeypatch):
    # Mode 0600 protects the key from everyone but its owner, who could rewrite it.
    path = key_file(tmp_path / 'swarm.key')
    os.chown(path, 65534, 65534)
    with pytest.raises(KeyFileError, match=f'{path}: owned by uid 65534, neither this process'):
        load_key(path)
    # Root's key, read by another user's process (root can rewrite anything anyway).
    os.chown(path, 0, 0)
    monkeypatch.setattr(os, 'geteuid', lambda: 65534)
    assert load_key(path) == bytes(32)


# -- where the tail lands in rclpy's CDR ----------------------------------------------------

def test_rclpy_adds_no_padding_after_the_last_field():
    """A uint8[] last field of any length is the payload's last bytes (so is an Auth block)."""
    from array import array

    from rclpy.serialization import serialize_message
    from std_msgs.msg import UInt8MultiArray

    for n in range(0, 20):
        values = bytes(range(1, n + 1))
        data = serialize_message(UInt8MultiArray(data=array('B', values)))
        assert data[:4] == CDR_LE and data[len(data) - n:] == values


def test_rclpy_aligns_a_uint64_to_8_bytes_from_the_body_whatever_came_before():
    """So an Auth block (uint64 first, 48 bytes) ends 8-aligned: no padding after it."""
    from rclpy.serialization import serialize_message
    from sat_msgs.msg import WorldStep

    for name in ('', 'a', 'ab', 'abc', 'abcd', 'abcde', 'abcdefghi'):
        data = serialize_message(WorldStep(scenario=name, late_commands=0x0102030405060708))
        assert (len(data) - 4) % 8 == 0
        assert data[-8 - BLOCK_BYTES:-BLOCK_BYTES] == (0x0102030405060708).to_bytes(8, 'little')


def signed_types():
    """sat_msgs types that carry an ``auth`` field (issue 17's wiring adds them)."""
    import sat_msgs.msg

    types = [getattr(sat_msgs.msg, name) for name in dir(sat_msgs.msg)
             if isinstance(getattr(sat_msgs.msg, name), type)]
    return [t for t in types if 'auth' in getattr(t, 'get_fields_and_field_types', dict)()]


def test_the_auth_fields_of_every_signed_sat_msgs_type_are_the_bytes_message_auth_writes():
    from rclpy.serialization import deserialize_message, serialize_message

    types = signed_types()
    if not types:
        pytest.skip('no sat_msgs type has an auth field yet (issue 17: the lead adds them); '
                    'checked on throwaway types meanwhile (report of issue 17 part 1)')
    for msg_type in types:
        relayed = 'relay' in msg_type.get_fields_and_field_types()
        signer = Signer(KEY, 3)
        data = signer.sign('/c', serialize_message(msg_type()), 9, relayed=relayed)
        if relayed:
            data = Signer(KEY, WORLD_SENDER).seal('/r', data, 10)
        back = deserialize_message(data, msg_type)
        end = len(data) - (BLOCK_BYTES if relayed else 0)
        assert (back.auth.counter, back.auth.sender, back.auth.step) == \
            (signer.counter._last, 3, 9), msg_type
        assert bytes(back.auth.mac) == data[end - auth.MAC_BYTES:end], msg_type
        if relayed:
            assert (back.relay.sender, back.relay.step) == (WORLD_SENDER, 10)
            assert bytes(back.relay.mac) == data[-auth.MAC_BYTES:], msg_type
