"""How an observer node (metrics, recorder, logger) tells world_sim it is ready to watch.

world_sim must not start step 1 before every observer receives every topic it needs, or the run's
first messages are lost to it (DDS drops what a writer sends before a reader matched). So each
observer checks that each of its subscriptions has matched a publisher, then announces its name
once on the latched ``/world/observers`` topic; world_sim starts when it has heard ``observers``
distinct names (and every agent is matched).
"""

from pathlib import Path

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String

from sat_agent.ros.node_runner import steady_timer
from sat_agent.ros.qos import RADIO, STEP, WORLD
from sat_msgs.msg import AgentStatus, GroundTruth, RadioTraffic, SearchDensity, WorldStep

TOPIC = '/world/observers'
QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                 durability=DurabilityPolicy.TRANSIENT_LOCAL)


class ReadyAnnouncer:
    """Announce node's name on TOPIC once all the given subscriptions have a publisher."""

    def __init__(self, node, subscriptions, period: float = 0.1):
        self._node = node
        self._subscriptions = list(subscriptions)
        self._publisher = node.create_publisher(String, TOPIC, QOS)
        self._timer = steady_timer(node, period, self._check)

    def _check(self):
        if all(s.get_publisher_count() > 0 for s in self._subscriptions):
            self._publisher.publish(String(data=self._node.get_fully_qualified_name()))
            self._node.destroy_timer(self._timer)


def declare_run(node, what: str):
    """Declare the observer parameters ``run_dir`` (required) and ``agent_ids``.

    Returns (run_dir as a Path, agent ids as ints); what says what goes into run_dir, for the
    error message when it is missing.
    """
    run_dir = node.declare_parameter('run_dir', '').value
    if not run_dir:
        raise ValueError(f"parameter 'run_dir' is required: {what}")
    return Path(run_dir), [int(i) for i in node.declare_parameter('agent_ids', [1, 2]).value]


def watch_run(node, agent_ids, add) -> ReadyAnnouncer:
    """Subscribe node to what metrics and views of a run read; feed add(topic, msg).

    The topics are the world's step, truth and radio traffic and every agent's status and
    search density (records.route); readiness is announced once they are all matched.
    """
    topics = [('/world/step', WorldStep, WORLD), ('/world/truth', GroundTruth, WORLD),
              ('/world/radio', RadioTraffic, WORLD)]
    for i in agent_ids:
        topics += [(f'/agent_{i}/status', AgentStatus, STEP),
                   (f'/agent_{i}/radio/out/search_density', SearchDensity, RADIO)]
    subscriptions = [node.create_subscription(cls, topic,
                                              lambda msg, topic=topic: add(topic, msg), qos)
                     for topic, cls, qos in topics]
    return ReadyAnnouncer(node, subscriptions)
