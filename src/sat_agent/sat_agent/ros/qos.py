"""The QoS of every topic of the graph, in one place (README.md lists them per topic).

- STEP: one message per agent and step (measurements, cmd, status): reliable, keep last 200.
- RADIO: radio/out and radio/in: reliable, keep last 200 (the radio forwards many senders'
  reports in a burst at the start of a step).
- WORLD: /world/step, /world/truth, /world/radio: reliable and transient-local (latched), keep
  last 200, so an observer that joins late (a logger, a recorder) still gets the recent steps.

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
