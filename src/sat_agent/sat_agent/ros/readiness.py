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

once every subscription it reads the run through has a publisher, and again whenever a writer's
count changes. A node that writes an agent's commands speaks for that agent, unless it says
``"observer": true`` (a test that attacks a run writes on an agent's topics too, and is one of
the observers world_sim waits for). world_sim starts when every agent and ``observers`` other
nodes have announced and every writer (theirs and its own) has matched at least as many readers
as the announced nodes (and world_sim itself) that read its topic: ``unmet`` says what is
still missing.
A reader that is not announced (``ros2 topic echo``) is not waited for; one that is counted in
its place would let a writer pass with one announced reader unmatched.
The topic is not signed (its readers start before any key could be checked), so world_sim takes
an announcement only through ``parse``: bounded in size, JSON of exactly that shape (a deep or
ill-typed one used to escape the callback and end world_sim, session 73); it keeps at most
EXTRA_ANNOUNCERS nodes besides the agents and observers, and none after the start (each
malformed one is counted as ``bad_announcement``, before or after).
"""

import json
from typing import Iterable, List, Mapping

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from sat_agent.ros.node_runner import steady_timer

TOPIC = '/world/ready'
# Latched: world_sim started after a node still reads that node's last announcements. Each
# node's writer keeps its own history, so the depth counts one node's announcements.
QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)
CHECK_PERIOD_S = 0.1
# An 80-agent recorder announces ~1,200 topics of ~40 characters (~50 KiB): room for more.
MAX_ANNOUNCEMENT_BYTES = 256 * 1024
# Nodes kept besides the agents and the observers world_sim waits for (a test's scripted nodes,
# several nodes of one process); the rest are dropped, so forged names cannot fill memory.
EXTRA_ANNOUNCERS = 64


class AnnouncementError(ValueError):
    """An announcement that is not the JSON of ``announcement`` (the message says why)."""


def parse(text: str) -> dict:
    """Return the announcement in text, checked to have the shape ``announcement`` writes.

    Raises AnnouncementError for text over MAX_ANNOUNCEMENT_BYTES, text that is not JSON (or
    nests too deep for the parser), or JSON of another shape: ``node`` a string, ``reads`` a list
    of strings, ``writes`` a mapping of strings to counts >= 0, ``observer`` (optional) a bool.
    """
    if len(text) > MAX_ANNOUNCEMENT_BYTES:
        raise AnnouncementError(f'{len(text)} characters, more than {MAX_ANNOUNCEMENT_BYTES}')
    try:
        announced = json.loads(text)
    except (ValueError, RecursionError) as error:
        raise AnnouncementError(f'not JSON: {type(error).__name__}') from None
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
    """Announce a node on TOPIC (module docstring) until stop() or, without writers, once.

    subscriptions: those the node reads the run through (each must have a publisher first);
    publishers: the node's writers whose matched readers world_sim checks; observer: the node
    is an observer even if it writes an agent's commands.
    """

    def __init__(self, node, subscriptions, publishers=(), period: float = CHECK_PERIOD_S,
                 observer: bool = False):
        self._node = node
        self._subscriptions = list(subscriptions)
        self._publishers = list(publishers)
        self._observer = observer
        self._announced = None
        self._publisher = node.create_publisher(String, TOPIC, QOS)
        self._timer = steady_timer(node, period, self._check)

    def _check(self):
        if not all(s.get_publisher_count() > 0 for s in self._subscriptions):
            return
        text = announcement(self._node.get_fully_qualified_name(),
                            (s.topic_name for s in self._subscriptions),
                            {p.topic_name: p.get_subscription_count() for p in self._publishers},
                            self._observer)
        if text != self._announced:
            self._publisher.publish(String(data=text))
            self._announced = text
        if not self._publishers:
            self.stop()

    def stop(self):
        """No more announcements (the run started: nobody waits for them any more)."""
        if self._timer is not None:
            self._node.destroy_timer(self._timer)
            self._timer = None
