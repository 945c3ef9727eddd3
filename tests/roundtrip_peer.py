"""A separate OS process that echoes every sat_msgs type back: ping/<Type> -> pong/<Type>.

Started by test_msgs.py; exits on SIGTERM/SIGINT or after --timeout seconds.
"""

import argparse
import sys

from msg_samples import message_class, sat_msg_names
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

LATCHED = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('--timeout', type=float, default=60.0)
    args = parser.parse_args()
    rclpy.init()
    node = rclpy.create_node('sat_msgs_roundtrip_peer')
    keep = []
    for name in sat_msg_names():
        cls = message_class(f'sat_msgs/{name}')
        pub = node.create_publisher(cls, f'/sat_roundtrip/pong/{name}', LATCHED)
        keep.append(node.create_subscription(
            cls, f'/sat_roundtrip/ping/{name}', lambda msg, pub=pub: pub.publish(msg), LATCHED))
    node.create_timer(args.timeout, lambda: rclpy.try_shutdown())
    try:
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
