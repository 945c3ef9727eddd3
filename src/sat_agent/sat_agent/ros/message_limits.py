"""The largest valid payload of every topic of the graph, computed once at start-up.

A raw subscription still receives the whole DDS sample, but a payload above its topic's limit
is refused before it is hashed or deserialized (signed_io.VerifiedInput), with authentication
on or off: rclpy builds the Python objects of a typed message before any check could run
(10 scans of 10^6 detections: 358 MB deserialized against 131 MB raw). Each limit is the
serialized size of the largest message a valid sender can send, so it follows the message
definitions and the parameters by construction: every list at its bound (MAX_DETECTIONS,
MAX_TARGETS, the roster, the lattice, the search map's nodes, STATUS_PARTICLES), every string
at MAX_NAME characters.

MessageLimits covers the signed sat_msgs topics; standard_limits the unsigned standard-typed
ones (sat_agent.topic_names), whose largest messages are built by the publishers' own builders
(sat_agent.ros.views) in the map frame every view is drawn in, so a view that grows grows
its limit with it. The recorder refuses larger ones (sat_world_sim.unsigned_input): anyone on
the domain can publish there. The largest genuine view is an estimates MarkerArray of
MAX_TARGETS estimates (0.8 MB), the truth markers next (0.28 MB with 4 agents).
"""

from dataclasses import dataclass
import sys
from typing import Collection, Dict

from geometry_msgs.msg import Point
import numpy as np
from rclpy.serialization import serialize_message
from rosgraph_msgs.msg import Clock
from std_msgs.msg import Header

from sat_agent import state_extraction
from sat_agent.density_codec import max_encoded_bytes
from sat_agent.ros import views
from sat_agent.ros.msg_conversions import MAX_DETECTIONS, MAX_TARGETS
from sat_agent.search_density import Lattice
from sat_agent.search_map import SearchMap
from sat_agent.stamps import MAP_FRAME
from sat_agent.topic_names import CLOCK, ROBOT_GOAL, TRUTH_MARKERS, VIEW_PREFIX
from sat_msgs.msg import (AgentMode, AgentStatus, AgentTruth, ControlCommand, GroundTruth,
                          MeasurementSet, MultiTargetEstimate, RadioTraffic,
                          RangeBearing, SearchDensity, TargetEstimate, TargetTruth, WorldStep)

# Particles an agent shows the observers per step (AgentStatus): enough to see the cloud.
STATUS_PARTICLES = 300
# Characters of the longest string field (frame ids, the scenario's name) accepted.
MAX_NAME = 256
# A list before the Auth block may be followed by up to 7 bytes of padding (8-alignment).
_PADDING = 8
# The weight whose label text ('{:.2f}', views.estimate_markers) is the longest a float has.
_LONGEST_WEIGHT = -sys.float_info.max
# The largest target id (uint32 in GroundTruth): the longest label of views.truth_markers.
_LARGEST_TARGET_ID = 2 ** 32 - 1


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


def standard_limits(params, agent_ids: Collection[int]) -> Dict[str, int]:
    """Bytes allowed per standard-typed topic, by its name in sat_agent.topic_names.

    Keys: /clock, /world/truth_markers and, relative to an agent's namespace, robot/goal and
    view/<name> for each of topic_names.AGENT_VIEWS. params: sat_agent.config's; agent_ids:
    the roster.
    """
    lattice = Lattice.for_area(params.area, params.search.lattice_spacing)
    nodes = SearchMap.for_area(params.area, params.search.node_spacing).size
    # Every view is drawn in the map frame (sat_agent.stamps): no MAX_NAME frame ids here.
    header = Header(frame_id=MAP_FRAME)
    estimate = _view_estimate()
    # The id with the most digits gives the longest namespaces and labels.
    longest_id = max(agent_ids, key=lambda i: len(str(i)), default=0)
    pose = _size(views.pose_stamped((0.0, 0.0), header))
    view = {'search_density': views.occupancy_grid(np.zeros((lattice.ny, lattice.nx)),
                                                   lattice, header),
            'estimates': views.estimate_markers(longest_id, estimate, header),
            'estimate_poses': views.estimate_poses(estimate, header),
            # The walk's nodes and its return to the start (as AgentStatus.plan).
            'plan': views.plan_path(np.zeros((nodes + 1, 2)), header)}
    limits = {VIEW_PREFIX + name: _size(msg) for name, msg in view.items()}
    limits[VIEW_PREFIX + 'pose'] = limits[ROBOT_GOAL[0]] = pose
    limits[CLOCK[0]] = _size(Clock())
    limits[TRUTH_MARKERS[0]] = _size(views.truth_markers(
        [_LARGEST_TARGET_ID] * MAX_TARGETS, np.zeros((MAX_TARGETS, 2)),
        dict.fromkeys(agent_ids, (0.0, 0.0)), (params.area.width, params.area.height),
        params.sensor.square_side, header))
    return limits


def _view_estimate() -> state_extraction.MultiTargetEstimate:
    """MAX_TARGETS estimates, each with the longest label (what a view can draw at most)."""
    target = state_extraction.TargetEstimate(position=np.zeros(2), velocity=np.zeros(2),
                                             covariance=np.zeros((4, 4)),
                                             weight=_LONGEST_WEIGHT)
    return state_extraction.MultiTargetEstimate(targets=(target,) * MAX_TARGETS,
                                                cardinality=0.0)
