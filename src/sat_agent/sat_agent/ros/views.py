"""The standard views: what RViz2 and Foxglove draw of an agent and of the world's truth.

Next to the Rerun view (sat_world_sim.rerun_view), each agent publishes under its namespace, at
``view_rate`` per second of sim time (node_params.SteppingParams), everything in the ``map``
frame and stamped with its step's sim time (sat_agent.stamps):

- ``view/search_density`` nav_msgs/OccupancyGrid: its fused search density, 100 where never
  searched, 0 where just searched (view_geometry.occupancy);
- ``view/estimates`` visualization_msgs/MarkerArray: a flat cylinder per estimated target over
  its 2-sigma position ellipse and a text with the estimate's index and PHD mass;
- ``view/estimate_poses`` geometry_msgs/PoseArray: the estimates, heading along their velocity;
- ``view/plan`` nav_msgs/Path: the nodes left on its search walk (empty in TRACK), sent when
  they change (latched, so a viewer always has the current walk): a Path of a hundred
  PoseStamped costs ~8 ms to build and serialise in rclpy, ten times the rest of the views;
- ``view/pose`` geometry_msgs/PoseStamped: its position (no TF here: this is the agent_<i>
  frame's pose in map).

world_sim publishes ``/world/truth_markers`` (MarkerArray): the area, the targets with their
ids, the agents with their sensing squares. Every MarkerArray starts with a DELETEALL, so
markers of targets that died or were lost disappear. The grids and markers are built with
numpy (one eigen-decomposition for all ellipses, one int8 array for the grid).
"""

from array import array

from geometry_msgs.msg import Point, Pose, PoseArray, PoseStamped, Quaternion, Vector3
from nav_msgs.msg import MapMetaData, OccupancyGrid, Path
import numpy as np
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

from sat_agent.search_density import Lattice
from sat_agent.state_extraction import MultiTargetEstimate
from sat_agent.view_geometry import (agent_colour, occupancy, sigma_ellipses, TRUTH_COLOUR,
                                     yaw_quaternions)

# Drawing sizes (m): flat ellipses, labels above what they name.
ELLIPSE_HEIGHT = 0.1
MIN_ELLIPSE_AXIS = 0.05
TEXT_HEIGHT = 2.0
TEXT_LIFT = 2.5
TARGET_DIAMETER = 1.5
AGENT_SIZE = 1.5
LINE_WIDTH = 0.3


def _colour(rgb, alpha: float = 1.0) -> ColorRGBA:
    return ColorRGBA(r=rgb[0] / 255.0, g=rgb[1] / 255.0, b=rgb[2] / 255.0, a=float(alpha))


def _point(x, y, z: float = 0.0) -> Point:
    return Point(x=float(x), y=float(y), z=float(z))


def _pose(xy, quaternion=(0.0, 0.0, 0.0, 1.0), z: float = 0.0) -> Pose:
    x, y, qz, qw = float(xy[0]), float(xy[1]), float(quaternion[2]), float(quaternion[3])
    return Pose(position=_point(x, y, z), orientation=Quaternion(x=0.0, y=0.0, z=qz, w=qw))


def pose_stamped(xy, header, yaw: float = 0.0) -> PoseStamped:
    """Return a PoseStamped at xy (z = 0) heading yaw."""
    return PoseStamped(header=header, pose=_pose(xy, yaw_quaternions(yaw)[0]))


def occupancy_grid(values, lattice: Lattice, header) -> OccupancyGrid:
    """Return the (ny, nx) search density values as an OccupancyGrid on the shared lattice."""
    cells = occupancy(values)
    info = MapMetaData(map_load_time=header.stamp, resolution=float(lattice.spacing),
                       width=int(lattice.nx), height=int(lattice.ny), origin=_pose((0.0, 0.0)))
    # Row-major from the origin cell, x along a row: the lattice's own layout.
    return OccupancyGrid(header=header, info=info, data=array('b', cells.tobytes()))


def plan_path(points, header) -> Path:
    """Return the walk's (K, 2) points as a Path."""
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    return Path(header=header, poses=[PoseStamped(header=header, pose=_pose(p)) for p in points])


def estimate_poses(estimate: MultiTargetEstimate, header) -> PoseArray:
    """Return the estimated targets as poses heading along their velocities."""
    targets = estimate.targets
    if not targets:
        return PoseArray(header=header)
    velocities = np.array([t.velocity for t in targets], dtype=float).reshape(-1, 2)
    quaternions = yaw_quaternions(np.arctan2(velocities[:, 1], velocities[:, 0]))
    return PoseArray(header=header, poses=[_pose(t.position, q)
                                           for t, q in zip(targets, quaternions)])


def _delete_all(header, ns: str) -> Marker:
    return Marker(header=header, ns=ns, action=Marker.DELETEALL)


def _text(header, ns: str, marker_id: int, xy, text: str, rgb) -> Marker:
    return Marker(header=header, ns=ns, id=int(marker_id), type=Marker.TEXT_VIEW_FACING,
                  action=Marker.ADD, pose=_pose(xy, z=TEXT_LIFT),
                  scale=Vector3(x=0.0, y=0.0, z=TEXT_HEIGHT), color=_colour(rgb), text=text)


def estimate_markers(agent_id: int, estimate: MultiTargetEstimate, header) -> MarkerArray:
    """Return a 2-sigma ellipse and an id label per estimated target (module docstring)."""
    ns = f'agent_{int(agent_id)}'
    rgb = agent_colour(agent_id)
    markers = [_delete_all(header, ns)]
    targets = estimate.targets
    if targets:
        covariances = np.array([np.asarray(t.covariance, dtype=float).reshape(4, 4)
                                [np.ix_((0, 2), (0, 2))] for t in targets])
        semi, yaw = sigma_ellipses(covariances)
        diameters = np.maximum(2.0 * semi, MIN_ELLIPSE_AXIS)
        for index, (target, size, quaternion) in enumerate(
                zip(targets, diameters, yaw_quaternions(yaw))):
            markers.append(Marker(
                header=header, ns=f'{ns}/ellipses', id=index, type=Marker.CYLINDER,
                action=Marker.ADD, pose=_pose(target.position, quaternion),
                scale=Vector3(x=float(size[0]), y=float(size[1]), z=ELLIPSE_HEIGHT),
                color=_colour(rgb, 0.5)))
            markers.append(_text(header, f'{ns}/ids', index, target.position,
                                 f'{agent_id}.{index} ({float(target.weight):.2f})', rgb))
    return MarkerArray(markers=markers)


def _square_edges(centres, side: float) -> np.ndarray:
    """(8 n, 2) end points of the 4 edges of each square of side around each centre."""
    corners = 0.5 * side * np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]], dtype=float)
    edges = np.stack([corners, np.roll(corners, -1, axis=0)], axis=1).reshape(8, 2)
    return (np.asarray(centres, dtype=float).reshape(-1, 1, 2) + edges).reshape(-1, 2)


def truth_markers(target_ids, target_xy, agents, area, square_side: float,
                  header) -> MarkerArray:
    """Return the world's truth as markers: area, targets with ids, agents with squares.

    agents: {agent id: (x, y)}; area: (width, height).
    """
    target_xy = np.asarray(target_xy, dtype=float).reshape(-1, 2)
    agent_ids = sorted(agents)
    agent_xy = np.array([agents[i] for i in agent_ids], dtype=float).reshape(-1, 2)
    colours = [_colour(agent_colour(i)) for i in agent_ids]
    width, height = area
    line = Vector3(x=LINE_WIDTH, y=0.0, z=0.0)
    markers = [
        _delete_all(header, 'world'),
        Marker(header=header, ns='world/area', id=0, type=Marker.LINE_STRIP, action=Marker.ADD,
               pose=_pose((0.0, 0.0)), scale=line, color=_colour((200, 200, 200)),
               points=[_point(x, y) for x, y in
                       ((0, 0), (width, 0), (width, height), (0, height), (0, 0))]),
        Marker(header=header, ns='world/targets', id=0, type=Marker.SPHERE_LIST,
               action=Marker.ADD, pose=_pose((0.0, 0.0)),
               scale=Vector3(x=TARGET_DIAMETER, y=TARGET_DIAMETER, z=TARGET_DIAMETER),
               color=_colour(TRUTH_COLOUR), points=[_point(x, y) for x, y in target_xy]),
        Marker(header=header, ns='world/agents', id=0, type=Marker.CUBE_LIST,
               action=Marker.ADD, pose=_pose((0.0, 0.0)),
               scale=Vector3(x=AGENT_SIZE, y=AGENT_SIZE, z=AGENT_SIZE),
               color=_colour((255, 255, 255)), points=[_point(x, y) for x, y in agent_xy],
               colors=colours),
        Marker(header=header, ns='world/squares', id=0, type=Marker.LINE_LIST,
               action=Marker.ADD, pose=_pose((0.0, 0.0)), scale=line,
               color=_colour((255, 255, 255)),
               points=[_point(x, y) for x, y in _square_edges(agent_xy, square_side)],
               colors=[c for c in colours for _ in range(8)]),
    ]
    markers += [_text(header, 'world/target_ids', i, xy, f'target {i}', TRUTH_COLOUR)
                for i, xy in zip(target_ids, target_xy)]
    markers += [_text(header, 'world/agent_ids', i, xy, f'agent {i}', agent_colour(i))
                for i, xy in zip(agent_ids, agent_xy)]
    return MarkerArray(markers=markers)
