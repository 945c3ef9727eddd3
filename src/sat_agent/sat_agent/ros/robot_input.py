"""The robot-facing inputs of an agent: a real drone's localisation and detector, validated.

With ``input_source:=robot`` the agent takes, instead of world_sim's MeasurementSet:

- ``robot/pose`` geometry_msgs/PoseStamped in the ``map`` frame: the drone's position (x, y)
  and heading (the yaw of its orientation; roll, pitch and z are not used: the model is planar).
- ``robot/detections`` sensor_msgs/PointCloud2: one message per scan, the detected points
  (float32 or float64 fields ``x`` and ``y``; more fields, like a confidence, are ignored) in
  the ``map`` frame or in the agent's own frame ``agent_<i>`` (at the drone, axes along its
  heading). An empty cloud is a scan that saw nothing, which the filter needs as well (its
  missed-detection term). The stamp says which step the scan is: the nearest k to t / dt.

Why PointCloud2: what a real detector gives is points. A radar driver publishes PointCloud2
directly; a camera detector's boxes become points once projected to the ground. It is the
type every ROS tool draws, records and transforms (tf2_sensor_msgs), it carries a scan of any
size with its stamp and frame in one message, and it reads into numpy at once. Each point
becomes a range and a bearing from the drone's position (sat_agent.sensor_model's
measurement space). The filter's likelihood then uses the range-dependent noise of the
sensor.* parameters: sigma_r = sigma_range_0 + sigma_range_slope d^2 and sigma_b =
sigma_bearing_0 + sigma_bearing_slope d. Set those, and sensor.p_detect, sensor.clutter_rate
and sensor.square_side (the area each scan covers), to the measured figures of the detector;
per-point covariances are not read.
"""

from typing import NamedTuple

import numpy as np
from sensor_msgs.msg import PointCloud2, PointField

from sat_agent.ros.msg_conversions import InvalidMessage, MAX_DETECTIONS
from sat_agent.stamps import agent_frame, MAP_FRAME

FIELD_TYPES = {PointField.FLOAT32: 'f4', PointField.FLOAT64: 'f8'}


class RobotPose(NamedTuple):
    """The drone's position (2,) in map and heading (rad)."""

    xy: np.ndarray
    yaw: float


def pose_from_msg(msg) -> RobotPose:
    """Return the RobotPose of a validated PoseStamped (frame map, finite, unit quaternion)."""
    if msg.header.frame_id != MAP_FRAME:
        raise InvalidMessage('unknown_frame',
                             f"pose in frame {msg.header.frame_id!r}: must be '{MAP_FRAME}'")
    p, q = msg.pose.position, msg.pose.orientation
    values = np.array([p.x, p.y, q.x, q.y, q.z, q.w], dtype=float)
    if not np.all(np.isfinite(values)):
        raise InvalidMessage('non_finite', 'pose has NaN or inf')
    if abs(np.linalg.norm(values[2:]) - 1.0) > 1e-3:
        raise InvalidMessage('out_of_range', 'pose orientation is not a unit quaternion')
    yaw = np.arctan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
    return RobotPose(values[:2].copy(), float(yaw))


def cloud_xy(msg: PointCloud2) -> np.ndarray:
    """Return the (N, 2) x, y of a validated PointCloud2 (any layout rclpy can describe)."""
    fields = {f.name: f for f in msg.fields}
    for name in ('x', 'y'):
        field = fields.get(name)
        if field is None or field.datatype not in FIELD_TYPES or field.count != 1:
            raise InvalidMessage('bad_layout', f"no float32/float64 field '{name}'")
    count = int(msg.width) * int(msg.height)
    if count > MAX_DETECTIONS:
        raise InvalidMessage('too_many_detections',
                             f'{count} detections (at most {MAX_DETECTIONS})')
    order = '>' if msg.is_bigendian else '<'
    formats = [np.dtype(order + FIELD_TYPES[fields[n].datatype]) for n in ('x', 'y')]
    field_end = max(fields[n].offset + f.itemsize for n, f in zip(('x', 'y'), formats))
    needed = (msg.height - 1) * msg.row_step + msg.width * msg.point_step
    if count and (msg.point_step < field_end or msg.row_step < msg.width * msg.point_step
                  or len(msg.data) < needed):
        raise InvalidMessage('bad_layout', 'point_step, row_step and data do not agree')
    if not count:
        return np.zeros((0, 2))
    dtype = np.dtype({'names': ['x', 'y'], 'formats': formats,
                      'offsets': [fields['x'].offset, fields['y'].offset],
                      'itemsize': int(msg.point_step)})
    # One strided view over the buffer: rows may be padded beyond width * point_step.
    points = np.ndarray((msg.height, msg.width), dtype=dtype, buffer=memoryview(msg.data),
                        strides=(msg.row_step, msg.point_step))
    xy = np.stack([points['x'].ravel(), points['y'].ravel()], axis=1).astype(float)
    if not np.all(np.isfinite(xy)):
        raise InvalidMessage('non_finite', 'detections have NaN or inf')
    return xy


def detections_from_msg(msg: PointCloud2, pose: RobotPose, agent_id: int) -> np.ndarray:
    """Return the (N, 2) range and bearing (map frame angle) of a scan's points from the pose."""
    frame = msg.header.frame_id
    if frame not in (MAP_FRAME, agent_frame(agent_id)):
        raise InvalidMessage('unknown_frame', f'detections in frame {frame!r}: must be '
                             f"'{MAP_FRAME}' or '{agent_frame(agent_id)}' (no TF here)")
    xy = cloud_xy(msg)
    if frame == MAP_FRAME:
        offsets = xy - pose.xy
    else:
        c, s = np.cos(pose.yaw), np.sin(pose.yaw)
        offsets = xy @ np.array([[c, s], [-s, c]])
    return np.stack([np.hypot(offsets[:, 0], offsets[:, 1]),
                     np.arctan2(offsets[:, 1], offsets[:, 0])], axis=1)
