#!/usr/bin/env python3
"""Benchmark the recorder's bag writer (sat_world_sim/bag_writer.py) against rosbags' own Writer.

Usage: ``python scripts/bench_bag.py [--agents 16 64] [--messages 40000] [--json]``

For each swarm size, in one process and in turns (rosbags' ``Writer`` first, then
``RunBagWriter``, both in the recorder's format: MCAP, zstd chunks): add the run's topics
(sat_world_sim.topics.graph_topics, the recorder's QoS), write ``--messages`` messages of
500 B spread over every topic, close (which writes metadata.yaml), then open the bag with
rosbags' Reader and read it through. Printed: CPU seconds of each stage and CPU microseconds
per message written, for each writer, and the ratios (Writer over RunBagWriter). Adding
topics, closing and reading parse or emit YAML (rosbags uses ruamel.yaml, whose C emitter and
parser come from ruamel.yaml.clib; ``yaml C`` says whether it is installed).

With ``--json`` the last line printed is a JSON object keyed by swarm size with keys topics,
write_us_plain, write_us_run, write_ratio, add_s, close_s, read_s (RunBagWriter's) and
yaml_c.
"""

import argparse
import json
from pathlib import Path
import sys
import tempfile
import time

from rosbags.rosbag2 import Reader, Writer
import ruamel.yaml

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / 'src' / 'sat_agent'), str(REPO / 'src' / 'sat_world_sim')]

from sat_world_sim.bag_types import sat_typestore  # noqa: E402
from sat_world_sim.bag_writer import COMPRESSION, RunBagWriter, STORAGE, VERSION  # noqa: E402
from sat_world_sim.ros.recorder_node import bag_qos  # noqa: E402
from sat_world_sim.ros.replay_support import topic_qos  # noqa: E402
from sat_world_sim.topics import graph_topics  # noqa: E402

PAYLOAD = bytes(range(200)) + bytes(300)


def plain_writer(path: Path) -> Writer:
    """Return rosbags' Writer in the recorder's format (RunBagWriter without the indexed check)."""
    writer = Writer(path, version=VERSION, storage_plugin=STORAGE)
    writer.set_compression(*COMPRESSION)
    return writer


def stages(make, path: Path, topics, messages: int) -> dict:
    """CPU seconds of adding the topics, writing, closing and reading a bag."""
    store = sat_typestore()
    clock = time.process_time
    writer = make(path)
    writer.open()
    start = clock()
    connections = [writer.add_connection(t.name, t.msgtype, typestore=store,
                                         offered_qos_profiles=[bag_qos(topic_qos(t))])
                   for t in topics]
    added = clock()
    for i in range(messages):
        writer.write(connections[i % len(connections)], i, PAYLOAD)
    written = clock()
    writer.close()
    closed = clock()
    with Reader(path) as reader:
        count = sum(1 for _ in reader.messages())
    if count != messages:
        raise SystemExit(f'{path}: read {count} messages of {messages}')
    return {'add_s': added - start, 'write_us': (written - added) / messages * 1e6,
            'close_s': closed - written, 'read_s': clock() - closed}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--agents', type=int, nargs='+', default=[16, 64])
    parser.add_argument('--messages', type=int, default=40000)
    parser.add_argument('--json', action='store_true',
                        help='print a JSON summary as the last line')
    args = parser.parse_args(argv)
    if min(args.agents) < 1 or args.messages < 1:
        parser.error('--agents and --messages: at least 1')
    yaml_c = bool(ruamel.yaml.__with_libyaml__)
    print(f'yaml C: {yaml_c}; {args.messages} messages of {len(PAYLOAD)} B per bag')
    summary = {}
    with tempfile.TemporaryDirectory(prefix='sat_bench_bag_') as tmp:
        for agents in args.agents:
            topics = graph_topics(range(1, agents + 1))
            plain = stages(plain_writer, Path(tmp) / f'plain_{agents}', topics, args.messages)
            run = stages(RunBagWriter, Path(tmp) / f'run_{agents}', topics, args.messages)
            ratio = plain['write_us'] / run['write_us']
            print(f'{agents:3d} agents, {len(topics)} topics: write {plain["write_us"]:.1f} us '
                  f'(Writer) vs {run["write_us"]:.1f} us (RunBagWriter) per message, '
                  f'x{ratio:.2f}; add {plain["add_s"]:.2f} / {run["add_s"]:.2f} s, '
                  f'close {plain["close_s"]:.2f} / {run["close_s"]:.2f} s, '
                  f'read {plain["read_s"]:.2f} / {run["read_s"]:.2f} s CPU')
            summary[agents] = {'topics': len(topics), 'write_us_plain': plain['write_us'],
                               'write_us_run': run['write_us'], 'write_ratio': ratio,
                               'add_s': run['add_s'], 'close_s': run['close_s'],
                               'read_s': run['read_s'], 'yaml_c': yaml_c}
    if args.json:
        print(json.dumps(summary))
    return 0


if __name__ == '__main__':
    sys.exit(main())
