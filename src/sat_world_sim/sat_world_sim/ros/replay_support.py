"""Helpers shared by the recorder and the replay: message classes and QoS of the graph's topics."""

import importlib

from sat_agent.ros.qos import RADIO, STEP, WORLD


def message_class(msgtype: str):
    """Return the rclpy class of a 'pkg/msg/Name' (or 'pkg/Name') type name."""
    parts = msgtype.split('/')
    if len(parts) not in (2, 3) or (len(parts) == 3 and parts[1] != 'msg'):
        raise ValueError(f'not a message type name: {msgtype!r} (expected pkg/msg/Name)')
    return getattr(importlib.import_module(f'{parts[0]}.msg'), parts[-1])


def topic_qos(topic):
    """Return the QoS a topic of sat_world_sim.topics is published with (sat_agent.ros.qos)."""
    if topic.latched:
        return WORLD
    return RADIO if '/radio/' in topic.name else STEP
