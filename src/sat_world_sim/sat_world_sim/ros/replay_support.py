"""What the recorder and the replay share: the QoS each topic of the graph is published with."""

from sat_agent.ros.qos import RADIO, STEP, WORLD


def topic_qos(topic):
    """Return the QoS a topic of sat_world_sim.topics is published with (sat_agent.ros.qos)."""
    if topic.latched:
        return WORLD
    return RADIO if '/radio/' in topic.name else STEP
