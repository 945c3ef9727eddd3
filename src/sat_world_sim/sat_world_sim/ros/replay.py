"""The ``replay`` command: re-publish a recorded run's bag on a live graph, or replay it offline.

Live::

    replay runs/<name>/bag [--rate 2.0] [--loop] [--topics /world/truth /agent_1/status]

publishes every recorded message (its original CDR bytes) on its topic with the recorded QoS
profile and the original timing divided by ``--rate``; any subscriber (the logger, a test) sees
the run again. The recorded ``/clock`` is published like any topic, so nodes with
``use_sim_time`` follow the run's sim time. Topics recorded with a definition other than the
installed one (a bag of an older version) are left out, named on stderr: today's nodes would
misread their bytes, and a signed message cannot be rewritten without breaking its signature.
The offline replay reads them with the bag's own definitions.

Offline (``--offline --out DIR``, no ROS graph): sat_world_sim.bag_replay.replay_offline.
The last line printed is the output directory.
"""

import argparse
from pathlib import Path
import sys
import time
from typing import Optional, Sequence

import rclpy
from rclpy.duration import Duration
from rclpy.qos import QoSProfile
from rosbags.highlevel import AnyReaderError

from sat_agent.config import load_params_file, ParameterError, SatParams
from sat_agent.ros.msg_conversions import message_class

from sat_world_sim.bag_replay import (bag_agent_ids, open_bag, outdated, raw_messages,
                                      replay_offline, selected)
from sat_world_sim.ros.replay_support import topic_qos
from sat_world_sim.topics import graph_topics, Topic

REPLAY_DEPTH = 1000
ACK_TIMEOUT_S = 10.0


def deep(profile):
    """Copy of a QoS profile with REPLAY_DEPTH history.

    A replay at a high rate publishes in bursts; a reliable writer that keeps only the recorded
    depth would overwrite samples a slow reader has not acknowledged yet.
    """
    return QoSProfile(depth=max(profile.depth, REPLAY_DEPTH), reliability=profile.reliability,
                      durability=profile.durability)


def _wait_for_subscribers(node, publishers, timeout: float):
    """Spin until every publisher has a subscriber, or timeout seconds.

    DDS drops what is published before a reader matched, so publishing at once would lose the
    first messages of topics whose subscribers are still being discovered.
    """
    end = time.monotonic() + timeout
    while time.monotonic() < end and any(p.get_subscription_count() == 0 for p in publishers):
        _spin_for(node, 0.1)


def replay_live(bag: Path, rate: float, loop: bool, topics: Optional[Sequence[str]],
                match_timeout: float = 5.0) -> int:
    """Publish the bag onto the live graph (module docstring); return the messages sent."""
    with open_bag(bag) as reader:
        connections = live_connections(reader, selected(reader, topics))
        return _publish(reader, connections, rate, loop, match_timeout)


def live_connections(reader, connections):
    """Return the connections today's nodes read as recorded; say which are left out, and why."""
    stale = outdated(reader, connections)
    if stale and len(stale) == len(connections):
        raise ValueError(f'every selected topic was recorded with a definition other than the '
                         f'installed one ({sorted({t for _, t in stale})}): replay it --offline, '
                         f"which reads the bag's own definitions")
    if stale:
        print(f'replay: leaving out {len(stale)} topics recorded with a definition other than '
              f'the installed one (an older version; --offline reads them): '
              f'{[topic for topic, _ in stale]}', file=sys.stderr)
    left_out = set(stale)
    return [c for c in connections if (c.topic, c.msgtype) not in left_out]


def _publish(reader, connections, rate: float, loop: bool, match_timeout: float) -> int:
    """Publish the connections' messages at the recorded pace / rate; return how many."""
    rclpy.init()
    node = rclpy.create_node('bag_replay')
    sent = 0
    try:
        latched = {t.name for t in graph_topics(bag_agent_ids(reader)) if t.latched}
        publishers = {c.id: node.create_publisher(
            message_class(c.msgtype), c.topic,
            deep(topic_qos(Topic(c.topic, c.msgtype, c.topic in latched))))
            for c in connections}
        _wait_for_subscribers(node, publishers.values(), match_timeout)
        while True:
            start_wall, start_bag = time.monotonic(), None
            for connection, stamp, raw in raw_messages(reader, connections):
                start_bag = stamp if start_bag is None else start_bag
                due = start_wall + (stamp - start_bag) / 1e9 / rate
                _spin_for(node, due - time.monotonic())
                publishers[connection.id].publish(bytes(raw))
                sent += 1
            if not loop:
                break
        # A reliable writer drops what readers have not acknowledged when it is destroyed.
        unacked = [p.topic_name for p in publishers.values()
                   if not p.wait_for_all_acked(Duration(seconds=ACK_TIMEOUT_S))]
        if unacked:
            print(f'replay: messages on {unacked} not acknowledged by every reader after '
                  f'{ACK_TIMEOUT_S} s', file=sys.stderr)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return sent


def _spin_for(node, seconds: float):
    end = time.monotonic() + max(0.0, seconds)
    while True:
        left = end - time.monotonic()
        if left <= 0:
            return
        rclpy.spin_once(node, timeout_sec=min(left, 0.05))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog='replay', description=__doc__.split('\n')[0])
    parser.add_argument('bag', type=Path, help='rosbag2 directory (runs/<name>/bag)')
    parser.add_argument('--rate', type=float, default=1.0, help='speed factor (live)')
    parser.add_argument('--loop', action='store_true', help='replay again and again (live)')
    parser.add_argument('--topics', nargs='*', default=None, help='only these topics (live)')
    parser.add_argument('--match-timeout', type=float, default=5.0,
                        help='seconds to wait for subscribers of every topic (live)')
    parser.add_argument('--offline', action='store_true',
                        help='write metrics/plots instead of publishing')
    parser.add_argument('--out', type=Path, default=None, help='output directory (offline)')
    parser.add_argument('--params', type=Path, default=None,
                        help='parameter file of the run (offline; default: the paper defaults)')
    args = parser.parse_args(argv)
    if args.rate <= 0:
        parser.error(f'--rate = {args.rate}: must be > 0')
    if not (args.bag / 'metadata.yaml').is_file():
        parser.error(f'{args.bag} is not a rosbag2 directory (no metadata.yaml)')
    try:
        if args.offline:
            if args.out is None:
                parser.error('--offline needs --out DIR')
            params = load_params_file(args.params) if args.params else SatParams()
            replay_offline(args.bag, args.out, params)
            print(args.out)
        else:
            sent = replay_live(args.bag, args.rate, args.loop, args.topics, args.match_timeout)
            print(f'replayed {sent} messages from {args.bag}', file=sys.stderr)
    except (ParameterError, ValueError, AnyReaderError) as error:
        print(f'replay: {error}', file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        return 130
    return 0


if __name__ == '__main__':
    sys.exit(main())
