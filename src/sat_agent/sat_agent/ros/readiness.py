"""The start-up handshake of a run: world_sim starts step 1 once no first message can be lost.

DDS hands a reliable, volatile sample to a reader only if the *writer* had matched that reader
when the sample was written: Fast DDS marks what a writer holds as irrelevant for a reader it
matches later. The reader's side does not matter, a reader that matches a little later gets the
sample repaired. Discovery is not symmetric either: one process can see a match long before the
other does (a lost discovery message is repaired only after the builtin heartbeat period, ~3 s),
so no process can tell from its own view that the others' writers see it.

So every node of a run (agents, observers such as metrics, recorder and logger, and a test's
scripted nodes) announces on the latched TOPIC, as JSON, what it reads and, for each topic it
writes, how many readers its writer has matched::

    {"node": "/agent_1/agent", "reads": ["/agent_1/measurements", ...],
     "writes": {"/agent_1/cmd": 2, "/agent_1/status": 3, ...}}

once every subscription it reads the run through has a publisher, again whenever a writer's
count changes, and again every RESEND_S until the node sees the run start: a flood of
TOPIC deeper than world_sim's reader pushes samples out before they are taken, and a node
that announced once would then hold the start until the start-up timeout. A node that writes
an agent's commands speaks for that agent, unless it says ``"observer": true`` (a test that
attacks a run writes on an agent's topics too, and is one of the observers world_sim waits
for). world_sim starts when every agent and ``observers`` other
nodes have announced and every writer (theirs and its own) has matched at least as many readers
as the announced nodes (and world_sim itself) that read its topic: ``unmet`` says what is
still missing.
A reader that is not announced (``ros2 topic echo``) is not waited for; one that is counted in
its place would let a writer pass with one announced reader unmatched.
The topic is a standard type (std_msgs/String), so with the run's key a node publishes its
announcement in an envelope (``seal``): ``{"signed": <the announcement's JSON>, "counter": n,
"mac": <hex>}``, the MAC (message_auth.text_mac) over the topic, the node's counter (a
MonotonicCounter, increasing across restarts) and the text. world_sim with a key takes only
envelopes whose MAC verifies (``unseal``), and from each node only a counter above the last it
took: a forged announcement could otherwise start the run before an observer was ready (its
metrics would then lack a step and the run exit non-zero), and a replayed older one, with
fewer matched readers, hold the start until the start-up timeout. Without a key announcements
are the plain JSON, and anyone's is taken. Either way world_sim reads the announcement only
through ``parse``: bounded in size, JSON of exactly that shape (a deep or ill-typed one used to
escape the callback and end world_sim, session 73); it keeps at most EXTRA_ANNOUNCERS nodes
besides the agents and observers, and none after the start. Each refused one is counted under
its reason (``bad_announcement``, ``unsigned``, ``bad_signature``, ``replayed``), before the
start or after.
"""

import hmac
import json
import math
import re
import time
from typing import Callable, Iterable, List, Mapping, Optional, Tuple

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from sat_agent.message_auth import MonotonicCounter, text_mac
from sat_agent.ros.node_runner import steady_timer

TOPIC = '/world/ready'
# Latched: world_sim started after a node still reads that node's last announcement. world_sim's
# reader keeps 100 (several nodes' announcements can wait in it); a node's writer keeps its
# newest only (WRITER_QOS), which supersedes the rest: a reader that matches late gets one.
QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
WRITER_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                        durability=DurabilityPolicy.TRANSIENT_LOCAL)
CHECK_PERIOD_S = 0.1
# An unchanged announcement is sent again after this long, until the run starts.
RESEND_S = 1.0
# An 80-agent recorder announces ~1,200 topics of ~40 characters (~50 KiB): room for more.
MAX_ANNOUNCEMENT_BYTES = 256 * 1024
# Nodes kept besides the agents and the observers world_sim waits for (a test's scripted nodes,
# several nodes of one process); the rest are dropped, so forged names cannot fill memory.
EXTRA_ANNOUNCERS = 64
# The longest unverified text whose claimed node name a refusal's log line gives.
CLAIMED_NAME_TEXT_BYTES = 4096
# An envelope's MAC: message_auth.text_mac's hex digest.
_HEX_MAC = re.compile('[0-9a-f]{64}')


class AnnouncementError(ValueError):
    """An announcement world_sim refuses: the reason it is counted under, and why."""

    def __init__(self, detail: str, reason: str = 'bad_announcement'):
        super().__init__(detail)
        self.reason = reason


def _json(text: str):
    """Return the JSON value of text, bounded in size and depth (AnnouncementError if not).

    Its strings must be text: JSON can escape a lone surrogate (U+D800 alone), which no UTF-8
    encoder and so no rclpy log line takes (a node name logged would end world_sim).
    """
    if len(text) > MAX_ANNOUNCEMENT_BYTES:
        raise AnnouncementError(f'{len(text)} characters, more than {MAX_ANNOUNCEMENT_BYTES}')
    try:
        value = json.loads(text)
        json.dumps(value, ensure_ascii=False).encode()
    except (ValueError, RecursionError) as error:   # UnicodeEncodeError is a ValueError
        raise AnnouncementError(f'not JSON text: {type(error).__name__}') from None
    return value


def _is_envelope(value) -> bool:
    return (isinstance(value, dict) and set(value) == {'signed', 'counter', 'mac'}
            and isinstance(value['signed'], str)
            and isinstance(value['mac'], str) and _HEX_MAC.fullmatch(value['mac']) is not None
            and isinstance(value['counter'], int) and not isinstance(value['counter'], bool)
            and 0 <= value['counter'] < 2 ** 64)


def seal(text: str, key: Optional[bytes], counter: MonotonicCounter) -> str:
    """Return what a node publishes for announcement text: its envelope, or text without a key."""
    if key is None:
        return text
    taken = counter.take()
    return json.dumps({'signed': text, 'counter': taken,
                       'mac': text_mac(key, TOPIC, text, taken)})


def unseal(data: str, key: Optional[bytes]) -> Tuple[str, Optional[int]]:
    """Return (announcement text, counter) of what a node published (counter None: no key).

    Raises AnnouncementError: ``unsigned`` for anything but an envelope when there is a key,
    ``bad_signature`` for an envelope whose MAC does not verify, ``bad_announcement`` for text
    too long or not JSON. Without a key nothing can be verified: an envelope (from nodes that
    have a key, world_sim not) gives its text, anything else is the text.
    """
    envelope = _json(data)
    if key is None:
        return (envelope['signed'] if _is_envelope(envelope) else data), None
    if not _is_envelope(envelope):
        raise AnnouncementError('not a signed announcement', 'unsigned')
    text, counter = envelope['signed'], envelope['counter']
    if not hmac.compare_digest(envelope['mac'], text_mac(key, TOPIC, text, counter)):
        raise AnnouncementError(f'the MAC of {_claimed_name(text)} does not verify (a node of '
                                'another key or run id?)', 'bad_signature')
    return text, counter


def _claimed_name(text: str) -> str:
    """Name the node an unverified announcement claims to be, for a log line (bounded).

    Only a short text is parsed: a forged one costs its sender's bytes, not world_sim's time.
    """
    if len(text) > CLAIMED_NAME_TEXT_BYTES:
        return 'an announcement'
    try:
        name = parse(text)['node']
    except AnnouncementError:
        return 'an announcement'
    return f'the announcement of {name[:80]!r} (unverified)'


def parse(text: str) -> dict:
    """Return the announcement in text, checked to have the shape ``announcement`` writes.

    Raises AnnouncementError for text over MAX_ANNOUNCEMENT_BYTES, text that is not JSON (or
    nests too deep for the parser), or JSON of another shape: ``node`` a string, ``reads`` a list
    of strings, ``writes`` a mapping of strings to counts >= 0, ``observer`` (optional) a bool.
    """
    announced = _json(text)
    if not isinstance(announced, dict) or not isinstance(announced.get('node'), str):
        raise AnnouncementError('not a mapping with a string "node"')
    reads, writes = announced.get('reads'), announced.get('writes')
    if not isinstance(reads, list) or not all(isinstance(topic, str) for topic in reads):
        raise AnnouncementError('"reads" is not a list of topic names')
    if not isinstance(writes, dict) or not all(
            isinstance(count, int) and not isinstance(count, bool) and count >= 0
            for count in writes.values()):
        raise AnnouncementError('"writes" is not a mapping of topic names to counts')
    if not isinstance(announced.get('observer', False), bool):
        raise AnnouncementError('"observer" is not true or false')
    return announced


def announcement(node_name: str, reads: Iterable[str], writes: Mapping[str, int],
                 observer: bool = False) -> str:
    """Return the JSON text a node announces (module docstring)."""
    text = {'node': node_name, 'reads': sorted(set(reads)), 'writes': dict(sorted(writes.items()))}
    return json.dumps(dict(text, observer=True) if observer else text)


class Announcements(dict):
    """world_sim's record of the announcements: node name -> its last one (parsed JSON).

    It keeps at most ``room`` nodes, so forged names cannot fill memory, and with a key a node's
    announcement only if its counter is above the last one taken from that node.
    """

    def __init__(self, room: int):
        super().__init__()
        self.room = room
        self._counters = {}      # node name -> counter of its last announcement taken

    def take(self, announced: Mapping, counter: Optional[int]) -> Optional[Tuple[str, str]]:
        """Keep an announcement (``parse``d; counter None without a key), or return why not.

        Returns (reason, detail) for one refused: ``replayed`` (a counter not above the node's
        last), ``too_many_announcers`` (a new node past ``room``).
        """
        name = announced['node']
        if counter is not None and counter <= self._counters.get(name, -1):
            return 'replayed', f'{name} counter {counter}, last {self._counters[name]}'
        if name not in self and len(self) >= self.room:
            return 'too_many_announcers', f'{name} past {self.room} nodes'
        self[name] = announced
        self._counters[name] = -1 if counter is None else counter
        return None


def is_agent(announced: Mapping, agent_id: int) -> bool:
    """Whether an announcement speaks for agent agent_id (it writes its commands, module doc)."""
    return (f'/agent_{agent_id}/cmd' in announced['writes']
            and announced.get('observer') is not True)


def unmet(announcements: Mapping[str, Mapping], own_reads: Iterable[str],
          own_writes: Mapping[str, int], agent_ids: Iterable[int], observers: int) -> List[str]:
    """Return what keeps world_sim from starting; empty when the run can start.

    announcements: the last announcement of each node, by node name (parsed JSON);
    own_reads, own_writes: world_sim's own subscriptions' topics and writers' matched counts.
    """
    missing = []
    agent_ids = list(agent_ids)
    for i in agent_ids:
        if not any(is_agent(a, i) for a in announcements.values()):
            missing.append(f'agent {i} has not announced itself')
    others = [name for name, a in announcements.items()
              if not any(is_agent(a, i) for i in agent_ids)]
    if len(others) < observers:
        missing.append(f'{len(others)} of {observers} observers announced ({sorted(others)})')
    readers = dict.fromkeys(own_reads, 1)
    for a in announcements.values():
        for topic in a['reads']:
            readers[topic] = readers.get(topic, 0) + 1
    writers = [('world_sim', own_writes)] + [(name, a['writes'])
                                             for name, a in announcements.items()]
    for name, writes in writers:
        for topic, matched in sorted(writes.items()):
            if matched < readers.get(topic, 0):
                missing.append(f'{name} writes {topic} to {matched} of {readers[topic]} readers')
    return missing


class ReadyAnnouncer:
    """Announce a node on TOPIC (module docstring) until stop() or started() says the run began.

    subscriptions: those the node reads the run through (each must have a publisher first);
    publishers: the node's writers whose matched readers world_sim checks; observer: the node
    is an observer even if it writes an agent's commands; key: the run's key, to sign with;
    started: whether the node has taken a message of the run (world_sim sends none before
    step 1; None: announce until stop()).
    """

    def __init__(self, node, subscriptions, publishers=(), period: float = CHECK_PERIOD_S,
                 observer: bool = False, key: Optional[bytes] = None,
                 started: Optional[Callable[[], bool]] = None):
        self._node = node
        self._key = key
        self._counter = MonotonicCounter()
        self._subscriptions = list(subscriptions)
        self._publishers = list(publishers)
        self._observer = observer
        self._started = started
        self._announced = None
        self._sent_at = -math.inf
        self._publisher = node.create_publisher(String, TOPIC, WRITER_QOS)
        self._timer = steady_timer(node, period, self._check)

    def _check(self):
        if self._started is not None and self._started():
            self.stop()
            return
        now = time.monotonic()
        due = now - self._sent_at >= RESEND_S
        # Without writers a node announces the same text each time: build it only when due.
        if not (due or self._publishers):
            return
        if not all(s.get_publisher_count() > 0 for s in self._subscriptions):
            return
        text = announcement(self._node.get_fully_qualified_name(),
                            (s.topic_name for s in self._subscriptions),
                            {p.topic_name: p.get_subscription_count() for p in self._publishers},
                            self._observer)
        if text != self._announced or due:
            self._publisher.publish(String(data=seal(text, self._key, self._counter)))
            self._announced, self._sent_at = text, now

    def stop(self):
        """No more announcements (the run started: nobody waits for them any more)."""
        if self._timer is not None:
            self._node.destroy_timer(self._timer)
            self._timer = None
