"""Between sat_msgs messages and the core's dataclasses, validating everything that comes in.

Incoming messages are checked before the core sees them: finite numbers, lengths that match,
grid geometry equal to this agent's lattice, sane counts. A bad message raises InvalidMessage
with a short reason (a counter key) and a detail for the log line. Outgoing messages of step k
carry its sim time and their frame in the header (sat_agent.stamps).
"""

from array import array
import importlib

from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Vector3
import numpy as np
from std_msgs.msg import Header

from sat_agent.agent_core import AgentReport, REPORT_KINDS
from sat_agent.density_codec import decode_density, DensityDecodeError
from sat_agent.mode_machine import Mode
from sat_agent.search_density import Lattice
from sat_agent.stamps import agent_frame, MAP_FRAME, step_time
from sat_agent.state_extraction import MultiTargetEstimate, TargetEstimate
from sat_msgs.msg import (AgentMode, GridInfo, MeasurementSet, MultiTargetEstimate as EstimateMsg,
                          RangeBearing, SearchDensity, TargetEstimate as TargetMsg)

# Far more than a square of side a can hold (lambda = 10 clutter + targets); guards memory.
MAX_DETECTIONS = 10000
MAX_TARGETS = 1000
# The message type of each radio topic, radio/{out,in}/<kind>.
RADIO_TYPES = dict(zip(REPORT_KINDS, (SearchDensity, EstimateMsg, AgentMode)))


class InvalidMessage(ValueError):
    """An incoming message the node must drop; ``reason`` names the counter it increments."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f'{reason}: {detail}')
        self.reason = reason
        self.detail = detail


def _finite(reason: str, values, what: str) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if not np.all(np.isfinite(array)):
        raise InvalidMessage(reason, f'{what} has NaN or inf')
    return array


def message_class(msgtype: str):
    """Return the rclpy class of a 'pkg/msg/Name' (or 'pkg/Name') type name."""
    parts = msgtype.split('/')
    if len(parts) not in (2, 3) or (len(parts) == 3 and parts[1] != 'msg'):
        raise ValueError(f'not a message type name: {msgtype!r} (expected pkg/msg/Name)')
    return getattr(importlib.import_module(f'{parts[0]}.msg'), parts[-1])


def header(step: int, dt: float, frame: str = MAP_FRAME) -> Header:
    """Return the header of a message about step k: t_k = k dt and the frame."""
    sec, nanosec = step_time(step, dt)
    return Header(stamp=Time(sec=sec, nanosec=nanosec), frame_id=frame)


def point(xy) -> Point:
    """Return a geometry_msgs/Point at (x, y, 0)."""
    return Point(x=float(xy[0]), y=float(xy[1]), z=0.0)


def xy(p: Point) -> np.ndarray:
    """Return the (2,) array of a Point's x and y."""
    return np.array([p.x, p.y], dtype=float)


# -- measurements ---------------------------------------------------------------------------

def measurements_to_msg(agent_id: int, step: int, pose, measurements, dt: float,
                        deliveries: int = 0):
    """Build the MeasurementSet world_sim sends (measurements: (M, 2) range, bearing).

    Its frame is the agent's: the detections are ranges and bearings from its position.
    """
    z = np.asarray(measurements, dtype=float).reshape(-1, 2)
    return MeasurementSet(
        header=header(step, dt, agent_frame(agent_id)), agent_id=int(agent_id), step=int(step),
        agent_position=point(pose),
        detections=[RangeBearing(range=float(r), bearing=float(b)) for r, b in z],
        radio_deliveries=int(deliveries))


def measurements_from_msg(msg: MeasurementSet):
    """Return (pose (2,), measurements (M, 2)) of a validated MeasurementSet."""
    if len(msg.detections) > MAX_DETECTIONS:
        raise InvalidMessage('too_many_detections',
                             f'{len(msg.detections)} detections (at most {MAX_DETECTIONS})')
    pose = _finite('non_finite', xy(msg.agent_position), 'agent_position')
    z = _finite('non_finite', [(d.range, d.bearing) for d in msg.detections],
                'detections').reshape(-1, 2)
    if np.any(z[:, 0] < 0) or np.any(np.abs(z[:, 1]) > np.pi + 1e-9):
        raise InvalidMessage('out_of_range', 'range < 0 or |bearing| > pi')
    return pose, z


# -- estimates ------------------------------------------------------------------------------

def estimate_to_msg(agent_id: int, step: int, pose, estimate: MultiTargetEstimate,
                    dt: float) -> EstimateMsg:
    """Build a MultiTargetEstimate message (in the map frame)."""
    targets = [TargetMsg(position=point(t.position),
                         velocity=Vector3(x=float(t.velocity[0]), y=float(t.velocity[1]), z=0.0),
                         covariance=np.asarray(t.covariance, dtype=float).ravel().tolist(),
                         weight=float(t.weight))
               for t in estimate.targets]
    return EstimateMsg(header=header(step, dt), agent_id=int(agent_id), step=int(step),
                       agent_position=point(pose),
                       targets=targets, cardinality=float(estimate.cardinality))


def estimate_from_msg(msg: EstimateMsg) -> MultiTargetEstimate:
    """Return the core's MultiTargetEstimate of a validated message."""
    if len(msg.targets) > MAX_TARGETS:
        raise InvalidMessage('too_many_targets',
                             f'{len(msg.targets)} targets (at most {MAX_TARGETS})')
    targets = []
    for t in msg.targets:
        covariance = _finite('non_finite', t.covariance, 'covariance').reshape(4, 4)
        targets.append(TargetEstimate(
            position=_finite('non_finite', xy(t.position), 'target position'),
            velocity=_finite('non_finite', [t.velocity.x, t.velocity.y], 'target velocity'),
            covariance=covariance,
            weight=float(_finite('non_finite', t.weight, 'target weight'))))
    cardinality = float(_finite('non_finite', msg.cardinality, 'cardinality'))
    if cardinality < 0:
        raise InvalidMessage('out_of_range', f'cardinality {cardinality} < 0')
    return MultiTargetEstimate(targets=tuple(targets), cardinality=cardinality)


# -- search density -------------------------------------------------------------------------

def grid_info(lattice: Lattice) -> GridInfo:
    """Describe the shared lattice (origin at the area's corner)."""
    return GridInfo(origin_x=0.0, origin_y=0.0, resolution=float(lattice.spacing),
                    width=int(lattice.nx), height=int(lattice.ny))


def density_to_msg(agent_id: int, step: int, encoded: bytes, lattice: Lattice,
                   dt: float, node_views=()) -> SearchDensity:
    """Build a SearchDensity message from density_codec.encode_density's bytes."""
    return SearchDensity(header=header(step, dt), agent_id=int(agent_id), step=int(step),
                         grid=grid_info(lattice), values_zlib=array('B', encoded),
                         node_views=array('I', np.asarray(node_views, dtype=np.uint32)))


def check_grid(grid: GridInfo, lattice: Lattice):
    """Raise InvalidMessage unless a density's grid is the lattice's (checked before decoding)."""
    expected = grid_info(lattice)
    if (grid.width, grid.height) != (expected.width, expected.height) or \
            (grid.origin_x, grid.origin_y, grid.resolution) != \
            (expected.origin_x, expected.origin_y, expected.resolution):
        raise InvalidMessage('grid_mismatch', f'grid {grid} differs from {expected}')


def density_from_msg(msg: SearchDensity, lattice: Lattice) -> np.ndarray:
    """Return the (ny, nx) float32 values of a validated SearchDensity on this agent's lattice."""
    check_grid(msg.grid, lattice)
    try:
        values = decode_density(msg.values_zlib, (lattice.ny, lattice.nx))
    except DensityDecodeError as error:
        raise InvalidMessage(error.reason, error.detail) from None
    if not np.all(np.isfinite(values)) or values.min() < 0 or values.max() > 1:
        raise InvalidMessage('out_of_range', 'search density values outside [0, 1]')
    return values


def node_views_from_msg(msg: SearchDensity) -> np.ndarray:
    """Return a SearchDensity's node views, read-only (shared between agents: radio_parsing).

    Checked with the whole report (agent_node, overdue_nodes.node_views_defect): their count is
    the receiver's search map's.
    """
    views = np.asarray(msg.node_views, dtype=np.int64)
    views.flags.writeable = False
    return views


# -- mode -----------------------------------------------------------------------------------

def mode_to_msg(agent_id: int, step: int, pose, mode: Mode, dt: float) -> AgentMode:
    """Build an AgentMode message."""
    return AgentMode(header=header(step, dt), agent_id=int(agent_id), step=int(step),
                     mode=int(mode), position=point(pose))


def mode_from_msg(msg: AgentMode) -> Mode:
    """Return the Mode of a validated AgentMode."""
    try:
        return Mode(msg.mode)
    except ValueError:
        raise InvalidMessage('unknown_mode', f'mode {msg.mode}') from None


# -- status (observers) ----------------------------------------------------------------------

def check_status(msg) -> None:
    """Raise InvalidMessage unless an AgentStatus holds what the observers draw and score.

    Signed statuses come from agents, but a key holder can sign anything: NaN points used to end
    the metrics node in the OSPA and odd particle arrays the logger in a reshape (session 73).
    """
    _finite('non_finite', [xy(msg.position)] + [xy(p) for p in msg.plan]
            + [xy(p) for p in msg.coasted], 'position, plan or coasted point')
    mode_from_msg(msg)
    estimate_from_msg(msg.estimate)
    _finite('non_finite', np.concatenate([
        np.asarray(msg.particle_xy, dtype=float), np.asarray(msg.particle_weights, dtype=float),
        [msg.compute_time]]), 'particles or compute time')
    if len(msg.particle_xy) != 2 * len(msg.particle_weights):
        raise InvalidMessage('bad_layout', f'{len(msg.particle_xy)} particle coordinates for '
                                           f'{len(msg.particle_weights)} weights')


# -- whole reports --------------------------------------------------------------------------

def report_to_msgs(report: AgentReport, lattice: Lattice, dt: float):
    """Split a core AgentReport into the three radio messages (density, estimate, mode)."""
    return (density_to_msg(report.agent_id, report.step, report.encoded_search_values,
                           lattice, dt, report.node_views),
            estimate_to_msg(report.agent_id, report.step, report.pose, report.estimate, dt),
            mode_to_msg(report.agent_id, report.step, report.pose, report.mode, dt))


def report_part_from_msg(kind: str, msg, lattice: Lattice):
    """Validate one radio message and return its content for report_from_parts.

    search_density -> ((ny, nx) values, node views); estimate -> MultiTargetEstimate;
    mode -> (Mode, pose).
    """
    if msg.agent_id == 0:
        raise InvalidMessage('unknown_sender', 'agent id 0')
    if kind == 'search_density':
        return density_from_msg(msg, lattice), node_views_from_msg(msg)
    if kind == 'estimate':
        return estimate_from_msg(msg)
    if kind == 'mode':
        return mode_from_msg(msg), _finite('non_finite', xy(msg.position), 'position')
    raise ValueError(f'unknown report kind {kind!r}')


def report_from_parts(sender: int, step: int, parts) -> AgentReport:
    """Join the validated contents of one sender's three messages of one step."""
    mode, pose = parts['mode']
    values, node_views = parts['search_density']
    return AgentReport(agent_id=int(sender), step=int(step), pose=pose, mode=mode,
                       search_values=values, estimate=parts['estimate'], node_views=node_views)
