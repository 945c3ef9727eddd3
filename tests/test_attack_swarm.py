"""Attacks on a live signed swarm's commands, scans and radio (issue 17), and what they change.

One short lock-step run of two agents in radio range, with a key, attacked from the test
process (hostile.py) at the steps it sees agent 1's scans: a command hijack (unsigned, with
a wrong key, and replays of agent 1's genuine commands), a step jump (scans of step k + 999),
phantom scans (ten forged detections near a fake target, from a wrong key, and signed with the
key file's key itself, as a run without a run id signs: a node that ignored its run id would
take them, session 75), agent 2's genuine
reports published straight on agent 1's inbox, an unknown agent 99 (without the key, and as
an insider with a valid world seal), replays of a genuine /world/step and of a genuine
delivery, and malformed start-up announcements on /world/ready (JSON nested past the parser's
recursion limit, ill-typed, oversized), which ended world_sim before session 73, and a
well-formed one for a fake observer, unsigned and signed with a wrong key (session 74).
Every attack must fail and be counted under its reason by the node it targets (/diagnostics,
metrics.json's ``dropped``), and the run must be the unattacked one: its metrics equal the
in-process swarm's for the same scenario and seed.
"""

from collections import Counter

from geometry_msgs.msg import Point
from hostile import (attack_setup, Diagnostics, forge, Hostile, LATCHED,
                     read_metrics, RELIABLE, run_attacked)
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from ros_harness import ros_node
from std_msgs.msg import String
from test_swarm_ros import inprocess_metrics

from sat_agent.message_auth import (AuthError, load_key, MessageVerifier, MonotonicCounter,
                                    Signer, StepWindow, WORLD_SENDER)
from sat_agent.ros import readiness
from sat_agent.topic_names import radio_topic
from sat_msgs.msg import AgentMode, ControlCommand, MeasurementSet, RangeBearing, WorldStep

pytestmark = pytest.mark.ros
STEPS = 40
HIJACK = range(3, 13)       # steps whose scan triggers the attacks on commands
PHANTOM = range(6, 16)
WORLD, AGENT_1, METRICS = '/world_sim', '/agent_1/agent', '/metrics'


def hijack(hostile, sent, k, key):
    """Commands for agent 1's step k: unsigned, signed with another key, a replay of k - 1."""
    cmd = ControlCommand(agent_id=1, step=k, action_index=1, target_position=Point())
    hostile.send('/agent_1/cmd', ControlCommand, forge(cmd, '/agent_1/cmd', k, 1, None))
    hostile.send('/agent_1/cmd', ControlCommand,
                 forge(cmd, '/agent_1/cmd', k, 1, bytes(32)))
    sent[(WORLD, 'unsigned')] += 1
    sent[(WORLD, 'bad_signature')] += 1
    genuine = hostile.captured['/agent_1/cmd']
    if genuine:
        hostile.send('/agent_1/cmd', ControlCommand, genuine[-1])
        sent[(WORLD, 'replayed')] += 1


def scan(step, detections=()):
    return MeasurementSet(agent_id=1, step=step, agent_position=Point(x=44.0, y=50.0),
                          detections=[RangeBearing(range=r, bearing=b) for r, b in detections])


def attack(hostile, sent, k, key, bare_key):
    """Everything sent at agent 1's scan of step k (bare_key: the key file's, no run id)."""
    topic = '/agent_1/measurements'
    if k in HIJACK:
        hijack(hostile, sent, k, key)
    if k == 5:
        hostile.send(topic, MeasurementSet, forge(scan(k + 999), topic, k + 999, 0, None))
        sent[(AGENT_1, 'unsigned')] += 1
    if k in PHANTOM:
        phantom = scan(k + 1, [(2.0 + 0.01 * i, 0.5) for i in range(10)])
        hostile.send(topic, MeasurementSet, forge(phantom, topic, k + 1, 0, bytes(32)))
        hostile.send(topic, MeasurementSet, forge(phantom, topic, k + 1, 0, bare_key))
        sent[(AGENT_1, 'bad_signature')] += 2
    if k == 7:
        # Agent 2's genuine reports of the last step, straight on agent 1's inbox: no seal.
        for kind, cls in (('mode', AgentMode),):
            own = hostile.captured[radio_topic(2, 'out', kind)]
            if own:
                hostile.send(radio_topic(1, 'in', kind), cls, own[-1])
                sent[(AGENT_1, 'unsigned')] += 1
    if k == 8:
        mode = AgentMode(agent_id=99, step=k, mode=0, position=Point(x=50.0, y=50.0))
        inbox = radio_topic(1, 'in', 'mode')
        # Without the key: no seal at all. As an insider: signed as 99, sealed by "the world".
        hostile.send(inbox, AgentMode, forge(mode, radio_topic(99, 'out', 'mode'), k, 99, None,
                                             relayed=True))
        sent[(AGENT_1, 'unsigned')] += 1
        signed = forge(mode, radio_topic(99, 'out', 'mode'), k, 99, key, relayed=True)
        hostile.send(inbox, AgentMode, Signer(key, WORLD_SENDER).seal(inbox, signed, k))
        sent[(AGENT_1, 'unknown_sender')] += 1
    if k == 9:
        # The run is signed: an announcement must come in an envelope whose MAC verifies.
        forged = readiness.announcement('/fake_observer', [], {}, observer=True)
        for text, reason in (
                ('[' * 1000, 'bad_announcement'),
                (' ' * (readiness.MAX_ANNOUNCEMENT_BYTES + 1), 'bad_announcement'),
                ('{"node": "/x", "reads": [["/t"]], "writes": {}}', 'unsigned'),
                (forged, 'unsigned'),
                (readiness.seal(forged, bytes(32), MonotonicCounter()), 'bad_signature'),
                # Each of these ended world_sim before its MAC was checked (session 74's review).
                ('{"signed": "\\ud800", "counter": 1, "mac": "' + '0' * 64 + '"}',
                 'bad_announcement'),
                ('{"signed": "x", "counter": 1, "mac": "\u00e9"}', 'unsigned')):
            hostile.send(readiness.TOPIC, String, serialize_message(String(data=text)),
                         readiness.QOS)
            sent[(WORLD, reason)] += 1
    if k == 10:
        old_step = hostile.captured['/world/step'][1]
        hostile.send('/world/step', WorldStep, old_step, LATCHED)
        sent[(METRICS, 'replayed')] += 1
        sent[(AGENT_1, 'replayed')] += 1
        deliveries = hostile.captured[radio_topic(1, 'in', 'mode')]
        hostile.send(radio_topic(1, 'in', 'mode'), AgentMode, deliveries[0])
        sent[(AGENT_1, 'replayed')] += 1


@pytest.fixture(scope='module')
def attacked(tmp_path_factory):
    """Run the attacked swarm once; return (metrics, expected metrics, sent, diagnostics)."""
    tmp_path, scenario, key_file, key = attack_setup(tmp_path_factory, 'attacked', 3, STEPS)
    bare_key = load_key(key_file)
    sent = Counter()
    with ros_node('hostile') as node:
        hostile = Hostile(node)
        diagnostics = Diagnostics(node)

        def watch(_):
            # Before the start, unsigned: a fake observer that world_sim would count among the
            # observers it waits for, and so start before one of them is ready.
            early = readiness.announcement('/early_observer', [], {}, observer=True)
            hostile.send(readiness.TOPIC, String, serialize_message(String(data=early)),
                         readiness.QOS)
            sent[(WORLD, 'unsigned')] += 1
            return [hostile.capture('/agent_1/measurements', MeasurementSet, RELIABLE,
                                    lambda data: genuine_scan(data, key)
                                    and attack(hostile, sent, scan_step(data), key,
                                               bare_key)),
                    hostile.capture('/agent_1/cmd', ControlCommand,
                                    keep=lambda data: genuine(data, key, '/agent_1/cmd', 1)),
                    hostile.capture(radio_topic(2, 'out', 'mode'), AgentMode),
                    hostile.capture(radio_topic(1, 'in', 'mode'), AgentMode),
                    hostile.capture('/world/step', WorldStep, LATCHED)]
        # Every topic the attacks publish on is matched before world_sim starts step 1.
        targets = [('/agent_1/cmd', ControlCommand, RELIABLE),
                   ('/agent_1/measurements', MeasurementSet, RELIABLE),
                   (radio_topic(1, 'in', 'mode'), AgentMode, RELIABLE),
                   ('/world/step', WorldStep, LATCHED),
                   (readiness.TOPIC, String, readiness.QOS)]
        codes = run_attacked(node, hostile, tmp_path, scenario, STEPS, key_file, targets, watch,
                             diagnostics, (WORLD, AGENT_1, '/agent_2/agent'))
    assert codes == dict.fromkeys(codes, 0), codes
    return read_metrics(tmp_path), inprocess_metrics(scenario), sent, diagnostics


def scan_step(data):
    return deserialize_message(data, MeasurementSet).step


def genuine(data, key, topic: str, sender: int) -> bool:
    """Whether data is signed by sender (the test's node also receives its own forgeries)."""
    verifier = MessageVerifier(key, None, StepWindow(2 ** 32, 2 ** 32, 2 ** 32))
    verifier.step = 2 ** 31    # any step: only the signature is asked about
    try:
        verifier.verify(topic, data, sender=sender)
    except AuthError:
        return False
    return True


def genuine_scan(data, key) -> bool:
    """Whether a scan of agent 1 is world_sim's."""
    return genuine(data, key, '/agent_1/measurements', WORLD_SENDER)


def without_dropped(metrics):
    return {k: v for k, v in metrics.items() if k != 'dropped'}


def test_the_attacked_run_is_the_unattacked_one(attacked):
    metrics, expected, _, _ = attacked
    assert metrics['late_commands'] == 0
    assert [s['step'] for s in metrics['steps']] == list(range(1, STEPS + 1))
    assert without_dropped(metrics) == without_dropped(expected)


def test_a_hijacked_command_is_refused_and_no_real_one_dropped_as_duplicate(attacked):
    _, _, sent, diagnostics = attacked
    for reason in ('unsigned', 'bad_signature', 'replayed'):
        assert diagnostics.dropped(WORLD, reason) == sent[(WORLD, reason)] > 0, reason
    assert diagnostics.dropped(WORLD, 'duplicate') == 0


def test_a_scan_from_the_far_future_is_refused_and_the_agent_keeps_stepping(attacked):
    metrics, _, sent, diagnostics = attacked
    assert sent[(AGENT_1, 'unsigned')] >= 1
    assert diagnostics.dropped(AGENT_1, 'unsigned') >= 1
    assert diagnostics.dropped(AGENT_1, 'future_step') == 0
    assert metrics['late_commands'] == 0


def test_phantom_scans_are_refused_and_leave_no_phantom_estimate(attacked):
    # Each phantom comes twice: with a wrong key, and with the key file's key itself.
    metrics, expected, sent, diagnostics = attacked
    assert diagnostics.dropped(AGENT_1, 'bad_signature') == sent[(AGENT_1, 'bad_signature')] \
        == 2 * len(PHANTOM)
    assert metrics['steps'] == expected['steps']


def test_forged_and_unknown_senders_on_an_inbox_are_refused(attacked):
    _, _, sent, diagnostics = attacked
    assert diagnostics.dropped(AGENT_1, 'unsigned') == sent[(AGENT_1, 'unsigned')] >= 3
    assert diagnostics.dropped(AGENT_1, 'unknown_sender') == 1


def test_replayed_world_steps_and_deliveries_are_refused(attacked):
    metrics, _, sent, diagnostics = attacked
    assert metrics['dropped'] == {'replayed': sent[(METRICS, 'replayed')]}
    assert diagnostics.dropped(AGENT_1, 'replayed') == sent[(AGENT_1, 'replayed')] == 2


def test_every_refusal_is_an_attack(attacked):
    """The nodes dropped exactly what was sent to them (a genuine message never was)."""
    _, _, sent, diagnostics = attacked
    for node in (WORLD, AGENT_1):
        expected = {reason: n for (name, reason), n in sent.items() if name == node}
        assert diagnostics.dropped_all(node) == expected, node
    # The replayed /world/step reaches agent 2 as well.
    assert diagnostics.dropped_all('/agent_2/agent') == {'replayed': 1}
