"""What the observer nodes (metrics, recorder, logger) share: what they read, guarded.

Their parameters are sat_agent.node_params.ObserverParams (LoggerParams for the logger).

**Readiness.** Each observer announces itself once all its subscriptions have a publisher,
and again every second until it takes the run's first message
(sat_agent.ros.readiness.ReadyAnnouncer); world_sim waits for ``observers`` of them, and for
the writers of what they read to have matched them, before step 1, so no observer misses the
run's first messages.

**Input.** Observers take every signed topic raw through signed_io.VerifiedInput, as the
agents do: the size limit of message_limits before anything else, the signature (or, with
authentication off, the step window on the message's own step), deserialization in a try, a
search density's grid checked against the lattice before it is decoded, a status's points and
particle arrays checked before they are scored or drawn. A message refused on
the way is counted per reason on /diagnostics (and in metrics.json's ``dropped``), so no
message can crash an observer, hang it (a truth of step 2^32-1) or make it keep more than the
window's worth of steps (far-future statuses).
"""

from dataclasses import dataclass
from typing import Optional

from sat_agent.agent_core import REPORT_KINDS
from sat_agent.message_auth import StepWindow, WORLD_SENDER
from sat_agent.ros.input_guard import InputGuard
from sat_agent.ros.message_limits import MessageLimits
from sat_agent.ros.msg_conversions import check_grid, check_status
from sat_agent.ros.qos import DEPTH, RADIO, STEP, WORLD
from sat_agent.ros.readiness import ReadyAnnouncer
from sat_agent.ros.signed_io import auth_key, VerifiedInput
from sat_agent.search_density import Lattice
from sat_agent.topic_names import radio_topic
from sat_msgs.msg import AgentStatus, GroundTruth, RadioTraffic, SearchDensity, WorldStep

from sat_world_sim.topics import agent_of

# Observers may fall up to a writer's history (qos.DEPTH steps) behind the world, and the
# world's messages may reach them as late behind a peer's: an agent answers scan k only after
# world_sim sent it, but DDS orders each writer's samples alone, so at an observer world_sim's
# writers can lag an agent's by steps (the recorder once knew step 20 when agent 2's estimate
# of step 22 came, and refused it). Within a writer's history either way; further is garbage.
WINDOW = StepWindow(behind=DEPTH, ahead=DEPTH, world_ahead=DEPTH)
_WORLD_TOPICS = {'/world/step': 'step', '/world/truth': 'truth', '/world/radio': 'traffic'}


def signature_of(topic: str, limits: MessageLimits) -> Optional[dict]:
    """How a topic of the graph is signed: VerifiedInput.subscribe's keywords, None if it is not.

    The world signs its topics and every scan; agent i its cmd, status and radio/out; the
    radio's inboxes carry the sender's block and the relay's seal. Standard-typed topics (the
    clock, views, markers, robot goal) are not signed.
    """
    if topic in _WORLD_TOPICS:
        return {'max_bytes': getattr(limits, _WORLD_TOPICS[topic]), 'sender': WORLD_SENDER}
    owner = agent_of(topic)
    if owner is None:
        return None
    agent, rest = owner
    own = {'measurements': {'max_bytes': limits.scan, 'sender': WORLD_SENDER,
                            'names_sender': False},
           'cmd': {'max_bytes': limits.command, 'sender': agent},
           'status': {'max_bytes': limits.status, 'sender': agent}}
    for kind in REPORT_KINDS:
        own[f'radio/out/{kind}'] = {'max_bytes': limits.radio(kind), 'sender': agent,
                                    'relayed': True}
        own[f'radio/in/{kind}'] = {'max_bytes': limits.radio(kind),
                                   'origin': lambda s, kind=kind: radio_topic(s, 'out', kind)}
    return own.get(rest)


def observer_input(node, params, run):
    """Return (VerifiedInput, MessageLimits) of an observer node.

    params: its SatParams; run: its ObserverParams (the agents it watches, the key file).
    """
    guard = InputGuard(node, node.get_name(), run.diagnostics_period)
    inputs = VerifiedInput(node, guard, auth_key(node, run), run.agent_ids,
                           WINDOW, window_without_key=True)
    return inputs, MessageLimits.compute(params, len(run.agent_ids))


@dataclass
class Watch:
    """An observer's guarded subscriptions (watch_run) and its readiness announcer."""

    inputs: VerifiedInput
    ready: ReadyAnnouncer

    @property
    def dropped(self):
        """Messages refused, per reason (for metrics.json's ``dropped``)."""
        return self.inputs.guard.dropped


def watch_run(node, params, run, add) -> Watch:
    """Subscribe node to what metrics and views of a run read; feed add(topic, msg).

    The topics are the world's step, truth and radio traffic and every agent's status and
    search density (records.route); readiness is announced once they are all matched.
    """
    inputs, limits = observer_input(node, params, run)
    lattice = Lattice.for_area(params.area, params.search.lattice_spacing)

    topics = [('/world/step', WorldStep, WORLD, None), ('/world/truth', GroundTruth, WORLD, None),
              ('/world/radio', RadioTraffic, WORLD, None)]
    for i in run.agent_ids:
        topics += [(f'/agent_{i}/status', AgentStatus, STEP, check_status),
                   (radio_topic(i, 'out', 'search_density'), SearchDensity, RADIO,
                    lambda msg: check_grid(msg.grid, lattice))]
    subscriptions = [inputs.subscribe(cls, topic, lambda msg, topic=topic: add(topic, msg), qos,
                                      content=content, **signature_of(topic, limits))
                     for topic, cls, qos, content in topics]
    return Watch(inputs, ReadyAnnouncer(node, subscriptions, key=inputs.verifier.key,
                                        started=inputs.took_any))
