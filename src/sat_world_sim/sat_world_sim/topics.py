"""Every topic of a run's graph: its name, message type and whether it is latched.

Transport-free, so the recorder, the replay and tests agree on one list. Names follow
SPEC.md: agent topics live under the agent's namespace ``/agent_<i>``. Latched (transient
local): the world's topics and the standard views. The standard-typed topics' names come from
sat_agent.topic_names; the robot inputs are not part of a simulated run's graph.
"""

from dataclasses import dataclass
from typing import Iterable, List, Optional, Tuple

from sat_agent.agent_core import REPORT_KINDS
from sat_agent.topic_names import AGENT_VIEWS, CLOCK, ROBOT_GOAL, TRUTH_MARKERS, VIEW_PREFIX

REPORT_TYPES = tuple(zip(REPORT_KINDS, ('SearchDensity', 'MultiTargetEstimate', 'AgentMode')))


@dataclass(frozen=True)
class Topic:
    """One topic: absolute name, ``sat_msgs/msg/<Name>`` type, latched (transient local)."""

    name: str
    msgtype: str
    latched: bool = False


def world_topics() -> List[Topic]:
    """Return the world's topics: sim time, step, ground truth (also as markers), radio."""
    return [Topic(*CLOCK),
            Topic('/world/step', 'sat_msgs/msg/WorldStep', True),
            Topic('/world/truth', 'sat_msgs/msg/GroundTruth', True),
            Topic(*TRUTH_MARKERS, True),
            Topic('/world/radio', 'sat_msgs/msg/RadioTraffic', True)]


def agent_topics(agent_id: int) -> List[Topic]:
    """Return one agent's topics: scans, commands, goal, status, views, radio out and in."""
    ns = f'/agent_{agent_id}'
    topics = [Topic(f'{ns}/measurements', 'sat_msgs/msg/MeasurementSet'),
              Topic(f'{ns}/cmd', 'sat_msgs/msg/ControlCommand'),
              Topic(f'{ns}/{ROBOT_GOAL[0]}', ROBOT_GOAL[1]),
              Topic(f'{ns}/status', 'sat_msgs/msg/AgentStatus')]
    topics += [Topic(f'{ns}/{VIEW_PREFIX}{name}', msgtype, True)
               for name, msgtype in AGENT_VIEWS.items()]
    for direction in ('out', 'in'):
        topics += [Topic(f'{ns}/radio/{direction}/{kind}', f'sat_msgs/msg/{name}')
                   for kind, name in REPORT_TYPES]
    return topics


def graph_topics(agent_ids: Iterable[int]) -> List[Topic]:
    """Return all topics of a run with these agents."""
    topics = world_topics()
    for agent_id in sorted(agent_ids):
        topics += agent_topics(agent_id)
    return topics


def agent_of(topic: str) -> Optional[Tuple[int, str]]:
    """Split '/agent_<i>/<rest>' into (i, rest); None for other topics."""
    head, _, rest = topic.lstrip('/').partition('/')
    if not head.startswith('agent_') or not rest:
        return None
    try:
        return int(head[len('agent_'):]), rest
    except ValueError:
        return None
