"""What the observer nodes (metrics, recorder, logger) share: what they read.

Their parameters are sat_agent.node_params.ObserverParams (LoggerParams for the logger).
Each observer announces itself once all its subscriptions have a publisher
(sat_agent.ros.readiness.ReadyAnnouncer); world_sim waits for ``observers`` of them, and for
the writers of what they read to have matched them, before step 1, so no observer misses the
run's first messages.
"""

from sat_agent.ros.qos import RADIO, STEP, WORLD
from sat_agent.ros.readiness import ReadyAnnouncer
from sat_msgs.msg import AgentStatus, GroundTruth, RadioTraffic, SearchDensity, WorldStep


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
