"""The largest valid payload of every signed topic, computed once at start-up.

A raw subscription still receives the whole DDS sample, but a payload above its topic's limit
is refused before it is hashed or deserialized (signed_io.VerifiedInput), with authentication
on or off: rclpy builds the Python objects of a typed message before any check could run
(10 scans of 10^6 detections: 358 MB deserialized against 131 MB raw). Each limit is the
serialized size of the largest message a valid sender can send, so it follows the message
definitions and the parameters by construction: every list at its bound (MAX_DETECTIONS,
MAX_TARGETS, the roster, the lattice, the search map's nodes, STATUS_PARTICLES), every string
at MAX_NAME characters.
"""

from dataclasses import dataclass

from geometry_msgs.msg import Point
from rclpy.serialization import serialize_message
from std_msgs.msg import Header

from sat_agent.density_codec import max_encoded_bytes
from sat_agent.ros.msg_conversions import MAX_DETECTIONS, MAX_TARGETS
from sat_agent.search_density import Lattice
from sat_agent.search_map import SearchMap
from sat_msgs.msg import (AgentMode, AgentStatus, AgentTruth, ControlCommand, GroundTruth,
                          MeasurementSet, MultiTargetEstimate, RadioTraffic,
                          RangeBearing, SearchDensity, TargetEstimate, TargetTruth, WorldStep)

# Particles an agent shows the observers per step (AgentStatus): enough to see the cloud.
STATUS_PARTICLES = 300
# Characters of the longest string field (frame ids, the scenario's name) accepted.
MAX_NAME = 256
# A list before the Auth block may be followed by up to 7 bytes of padding (8-alignment).
_PADDING = 8


def _size(msg) -> int:
    return len(serialize_message(msg))


def _header() -> Header:
    return Header(frame_id='x' * MAX_NAME)


def _estimate() -> MultiTargetEstimate:
    return MultiTargetEstimate(header=_header(), targets=[TargetEstimate()] * MAX_TARGETS)


@dataclass(frozen=True)
class MessageLimits:
    """Bytes allowed per signed topic kind, for one lattice, search map and roster size."""

    scan: int
    command: int
    density: int
    estimate: int
    mode: int
    status: int
    step: int
    truth: int
    traffic: int

    @classmethod
    def compute(cls, params, agents: int) -> 'MessageLimits':
        """Limits for these parameters (sat_agent.config) and a roster of `agents` agents."""
        lattice = Lattice.for_area(params.area, params.search.lattice_spacing)
        nodes = SearchMap.for_area(params.area, params.search.node_spacing).size
        pairs = agents * max(agents - 1, 0)
        ids = list(range(agents))
        return cls(
            scan=_size(MeasurementSet(header=_header(),
                                      detections=[RangeBearing()] * MAX_DETECTIONS)),
            command=_size(ControlCommand(header=_header())),
            density=_size(SearchDensity(header=_header(), node_views=[0] * nodes)) + _PADDING
            + max_encoded_bytes(lattice.nx * lattice.ny),
            estimate=_size(_estimate()),
            mode=_size(AgentMode(header=_header())),
            status=_size(AgentStatus(
                header=_header(), plan=[Point()] * (nodes + 1), group=ids, estimate=_estimate(),
                coasted=[Point()] * MAX_TARGETS,
                particle_xy=[0.0] * (2 * STATUS_PARTICLES),
                particle_weights=[0.0] * STATUS_PARTICLES)),
            step=_size(WorldStep(header=_header(), scenario='x' * MAX_NAME)),
            truth=_size(GroundTruth(header=_header(), targets=[TargetTruth()] * MAX_TARGETS,
                                    agents=[AgentTruth()] * agents)),
            traffic=_size(RadioTraffic(header=_header(), link_a=[0] * pairs, link_b=[0] * pairs,
                                       sender=[0] * pairs, receiver=[0] * pairs,
                                       messages=[0] * pairs, bytes=[0] * pairs,
                                       drop_sender=ids, dropped=[0] * agents)))

    def radio(self, kind: str) -> int:
        """Return the limit of a radio report kind (agent_core.REPORT_KINDS)."""
        return {'search_density': self.density, 'estimate': self.estimate,
                'mode': self.mode}[kind]
