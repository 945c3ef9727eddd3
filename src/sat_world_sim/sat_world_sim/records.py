"""Per-step records (metrics.StepRecord) from the graph's messages, live or from a bag.

rclpy messages and rosbags' deserialized messages have the same field names, so the live
metrics node and the offline replay of a bag build their records with these same functions:
metrics computed either way are equal.
"""

from typing import Mapping, Optional

import numpy as np

from sat_world_sim.metrics import StepRecord

MODE_NAMES = {0: 'SEARCH', 1: 'TRACK'}


def _xy(points) -> np.ndarray:
    return np.array([[p.x, p.y] for p in points], dtype=float).reshape(-1, 2)


def traffic_by_sender(traffic) -> dict:
    """Cumulative (messages, bytes) sent per agent from a RadioTraffic message."""
    totals = {}
    for sender, messages, nbytes in zip(traffic.sender, traffic.messages, traffic.bytes):
        count, size = totals.get(int(sender), (0, 0))
        totals[int(sender)] = (count + int(messages), size + int(nbytes))
    return totals


def step_record(truth, statuses: Mapping[int, object], traffic=None,
                previous_traffic=None) -> StepRecord:
    """Build the StepRecord of one step from its GroundTruth, AgentStatus per agent and traffic.

    traffic / previous_traffic are the RadioTraffic messages of this step and the one before
    (cumulative counters): their difference is what each agent sent at this step.
    """
    alive = [t for t in truth.targets if t.alive]
    now = traffic_by_sender(traffic) if traffic is not None else {}
    before = traffic_by_sender(previous_traffic) if previous_traffic is not None else {}
    ids = sorted(statuses)
    return StepRecord(
        step=int(truth.step),
        truth_ids=np.array([t.id for t in alive], dtype=int),
        truth_positions=_xy([t.position for t in alive]),
        agent_poses={int(a.id): np.array([a.position.x, a.position.y]) for a in truth.agents},
        modes={a: MODE_NAMES.get(int(statuses[a].mode), 'UNKNOWN') for a in ids},
        estimates={a: _xy([t.position for t in statuses[a].estimate.targets]) for a in ids},
        plans={a: _xy(statuses[a].plan) for a in ids},
        searched_fraction=float(truth.searched_fraction),
        radio_messages={a: now.get(a, (0, 0))[0] - before.get(a, (0, 0))[0] for a in now},
        radio_bytes={a: now.get(a, (0, 0))[1] - before.get(a, (0, 0))[1] for a in now},
        overlap_events=[{'step': int(truth.step), 'agent': a,
                         'left_for': int(statuses[a].yielded_to)}
                        for a in ids if statuses[a].yielded_to],
    )


def density_values(msg) -> Optional[np.ndarray]:
    """(height, width) values of a SearchDensity message."""
    values = np.asarray(msg.values, dtype=float)
    return values.reshape(int(msg.grid.height), int(msg.grid.width))
