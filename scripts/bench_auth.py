#!/usr/bin/env python3
"""Benchmark message authentication: cost per message to sign and verify, against serializing.

Usage: ``scripts/with_env.sh python scripts/bench_auth.py [--steps 120] [--repeat 2000]``

Messages of the sizes a run exchanges: agent 1's search densities (100 x 100 lattice, zlib)
and estimates taken from the in-process paper run at three steps, a status with the
logger's 300 particles, and scans of 10, 100 and 1000 detections. For each, in one process:
rclpy ``serialize_message`` and ``deserialize_message``, ``Signer.sign`` (sender), and
``MessageVerifier.verify`` (receiver); for the radio's types also ``Signer.seal`` (the relay,
once per receiver) and ``verify_delivery`` (the receiver of a relayed message). Each is the
median over --repeat calls, in microseconds, and as a ratio to serializing the same message.

sat_msgs has no auth field yet, so the signed bytes are the serialized message plus the zero
block(s) the field will add (48 bytes each, 8-aligned): the HMAC covers the same bytes.
"""

import argparse
from pathlib import Path
import statistics
import sys
import time

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / 'src' / 'sat_agent'), str(REPO / 'src' / 'sat_world_sim')]

from sat_agent.agent_core import REPORT_KINDS  # noqa: E402
from sat_agent.config import load_params_file  # noqa: E402
from sat_agent.message_auth import (BLOCK_BYTES, MessageVerifier, Signer,  # noqa: E402
                                    StepWindow, WORLD_SENDER)
from sat_agent.ros.msg_conversions import (measurements_to_msg, point,  # noqa: E402
                                           report_to_msgs)
from sat_msgs.msg import AgentStatus  # noqa: E402
from sat_world_sim.inprocess_swarm import InProcessSwarm  # noqa: E402
from sat_world_sim.scenario import load_scenario  # noqa: E402

KEY = bytes(range(32))
WINDOW = StepWindow(behind=10**9, ahead=10**9, world_ahead=10**9)
RELAYED = {'search_density', 'estimate', 'mode'}


def paper_reports(steps: int, at):
    """Return {step: agent 1's radio messages} from the in-process paper run."""
    params = load_params_file(REPO / 'config' / 'paper.yaml')
    scenario = load_scenario(REPO / 'config' / 'scenarios' / 'paper.yaml', params.area.width,
                             params.area.height)
    swarm = InProcessSwarm(scenario, params)
    lattice = swarm.agents[1].filter.search.lattice
    reports = {}
    for _ in range(steps):
        k = swarm.world.step
        swarm.step()
        if k in at:
            reports[k] = dict(zip(REPORT_KINDS,
                                  report_to_msgs(swarm.last_outputs[1].report, lattice,
                                                 params.motion.dt)))
    return reports


def status(rng) -> AgentStatus:
    """Return a status as the agent node builds it: a plan, 300 particles, an estimate."""
    xy = rng.uniform(0, 100, (300, 2))
    return AgentStatus(agent_id=1, step=100, position=point((10, 60)),
                       plan=[point(p) for p in rng.uniform(0, 100, (8, 2))], group=[1, 2],
                       particle_xy=xy.astype(np.float32).ravel(),
                       particle_weights=np.full(300, 1 / 300, np.float32))


def signable(data: bytes, relayed: bool) -> bytes:
    """Return data as the message with its auth field(s) would serialize (zero tail)."""
    return data + bytes(-(len(data) - 4) % 8) + bytes(BLOCK_BYTES * (2 if relayed else 1))


def median_us(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        function()
        times.append(time.perf_counter() - started)
    return statistics.median(times) * 1e6


def measure(name: str, msg, relayed: bool, repeat: int) -> dict:
    data = serialize_message(msg)
    plain = signable(data, relayed)
    signer, relay = Signer(KEY, 1), Signer(KEY, WORLD_SENDER)
    figures = {'bytes': len(plain),
               'serialize': median_us(lambda: serialize_message(msg), repeat),
               'deserialize': median_us(lambda: deserialize_message(data, type(msg)), repeat),
               'sign': median_us(lambda: signer.sign('/agent_1/out', plain, 5, relayed), repeat)}
    # verify refuses replays: give it freshly signed messages, prepared outside the timing.
    signed = iter([signer.sign('/agent_1/out', plain, 5, relayed) for _ in range(repeat)])
    verifier = MessageVerifier(KEY, [1], WINDOW)
    verifier.step = 5
    figures['verify'] = median_us(lambda: verifier.verify('/agent_1/out', next(signed),
                                                          relayed), repeat)
    if relayed:
        one = signer.sign('/agent_1/out', plain, 5, relayed)
        figures['seal'] = median_us(lambda: relay.seal('/agent_2/in', one, 5), repeat)
        sealed = iter([relay.seal('/agent_2/in', one, 5) for _ in range(repeat)])
        figures['verify_delivery'] = median_us(lambda: verifier.verify_delivery(
            '/agent_2/in', next(sealed), lambda _: '/agent_1/out'), repeat)
    return figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--steps', type=int, default=120, help='in-process paper steps to run')
    parser.add_argument('--repeat', type=int, default=2000, help='calls per figure')
    args = parser.parse_args(argv)
    rng = np.random.default_rng(0)
    at = (2, args.steps // 2, args.steps - 1)
    cases = []
    for k, messages in paper_reports(args.steps, at).items():
        cases += [(f'{kind} k={k}', msg, kind in RELAYED) for kind, msg in messages.items()
                  if kind != 'mode' or k == at[0]]
    cases.append(('status (300 particles)', status(rng), False))
    for n in (10, 100, 1000):
        z = np.column_stack([rng.uniform(0, 10, n), rng.uniform(-np.pi, np.pi, n)])
        cases.append((f'scan of {n} detections', measurements_to_msg(1, 5, (50, 50), z, 1.0),
                      False))
    columns = ('serialize', 'deserialize', 'sign', 'verify', 'seal', 'verify_delivery')
    print(f"{'message':28s} {'bytes':>6s} " + ' '.join(f'{c:>15s}' for c in columns)
          + '   sign/ser verify/ser')
    for name, msg, relayed in cases:
        f = measure(name, msg, relayed, args.repeat)
        cells = ' '.join(f'{f[c]:12.1f} us' if c in f else 15 * ' ' for c in columns)
        print(f"{name:28s} {f['bytes']:6d} {cells}   {f['sign'] / f['serialize']:8.2f} "
              f"{f['verify'] / f['serialize']:10.2f}")
    return 0


if __name__ == '__main__':
    sys.exit(main())
