"""The QoS of every topic of the graph, in one place (README.md lists them per topic).

- STEP: one message per agent and step (measurements, cmd, status, robot/goal) and
  /clock: reliable, keep last 200. (rclpy's time source reads /clock best-effort with depth 1,
  which a reliable writer serves.)
- RADIO: radio/out and radio/in: reliable, keep last 200 (the radio forwards many senders'
  reports in a burst at the start of a step).
- WORLD: /world/step, /world/truth, /world/radio and the standard views (OccupancyGrid,
  markers, paths, poses: RViz2's map display asks for a latched map): reliable and
  transient-local (latched), keep last 200, so an observer that joins late (a logger, a
  recorder, RViz2) still gets the recent steps.
- ROBOT: the robot inputs (robot/pose, robot/detections): best effort, keep last 10. A
  best-effort reader matches every writer: sensor drivers publish best effort (rclpy's
  qos_profile_sensor_data), other nodes reliably.

Why so deep: the observers (metrics, recorder, logger) are not part of the lock-step handshake,
so on a loaded machine they can fall many steps behind a fast run. A reliable writer keeping
only the last N samples overwrites what a reader has not acknowledged yet, and the observer
would silently miss steps; 200 steps of slack costs a few MB per writer.
"""

from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

DEPTH = 200
STEP = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE)
RADIO = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE)
WORLD = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                   durability=DurabilityPolicy.TRANSIENT_LOCAL)
ROBOT = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)
