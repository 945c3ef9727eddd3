"""One end of test_netns.py's exchange: signed std_msgs bytes between two hosts.

``talk``: publishes a std_msgs/UInt8MultiArray every 0.1 s, serialized, then signed
(sat_agent.message_auth: its data ends with a zero block the signature fills, 8-aligned as an
Auth field would be), as raw bytes.
``listen``: takes the topic raw, verifies each sample's exact bytes and prints one line per
verified message; exits 0 after --count of them, 1 after --timeout seconds without.
``serve``: only a participant (the discovery server, given its profile), until stopped.
"""

import argparse
import sys
import time

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.serialization import serialize_message
from std_msgs.msg import UInt8MultiArray

from sat_agent.message_auth import (AuthError, BLOCK_BYTES, load_key, MessageVerifier, Signer,
                                    StepWindow, WORLD_SENDER)

TOPIC = '/netns_probe'


def signable(content: bytes) -> bytes:
    """Serialize a message whose data ends with a zero block, 8-aligned as an Auth field."""
    while True:
        data = serialize_message(UInt8MultiArray(data=content + bytes(BLOCK_BYTES)))
        if (len(data) - 4) % 8 == 0:
            return data
        content += b'.'


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument('role', choices=('talk', 'listen', 'serve'))
    parser.add_argument('--key-file')
    parser.add_argument('--count', type=int, default=5)
    parser.add_argument('--timeout', type=float, default=30.0)
    args = parser.parse_args()
    key = load_key(args.key_file) if args.key_file else None
    rclpy.init()
    node = rclpy.create_node(f'netns_{args.role}')
    verified = []
    if args.role == 'talk':
        publisher = node.create_publisher(UInt8MultiArray, TOPIC, 10)
        signer = Signer(key, WORLD_SENDER)

        def talk():
            step = len(verified) + 1
            verified.append(step)
            publisher.publish(signer.sign(TOPIC, signable(b'hello over udp'), step))
        node.create_timer(0.1, talk)
    elif args.role == 'listen':
        verifier = MessageVerifier(key, (), StepWindow(behind=10, ahead=0, world_ahead=10))

        def listen(data: bytes):
            try:
                signed = verifier.verify(TOPIC, data)
            except AuthError as error:
                print(f'refused: {error}', flush=True)
                return
            verified.append(signed.step)
            print(f'verified step {signed.step} ({len(data)} bytes)', flush=True)
        node.create_subscription(UInt8MultiArray, TOPIC, listen, 10, raw=True)
    deadline = time.monotonic() + args.timeout
    try:
        while time.monotonic() < deadline and not (args.role == 'listen'
                                                   and len(verified) >= args.count):
            rclpy.spin_once(node, timeout_sec=0.1)
    except (KeyboardInterrupt, ExternalShutdownException):    # stopped by the test
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0 if args.role != 'listen' or len(verified) >= args.count else 1


if __name__ == '__main__':
    sys.exit(main())
