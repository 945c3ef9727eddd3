#!/usr/bin/env python3
"""Benchmark the radio's two search-density layouts (sat_agent/density_codec.py).

Usage: ``python scripts/bench_codec.py [--seeds 3] [--first-seed 9741] [--json]``

1. Whole runs: the random default (4 agents) with the persistent profile (config/persistent.yaml,
   whose regrowing density travels in the SMOOTH layout), each seed run in-process twice in
   turns, its reports encoded in the PATCHES layout (as before session 39) and in SMOOTH. Every
   report is encoded once a step for the evaluation's radio accounting (inprocess_swarm.py,
   the payload sent to the agents in range: bytes_per_agent_step). The two runs of a seed are
   the same run (both layouts are lossless and the agents use the values, not the bytes), so
   their wall times pair up; printed: the radio payload per agent and step and the wall time
   of each, and their ratios.
2. Single densities: agent 1's density at steps SAMPLE_STEPS of those runs and of the paper
   profile's (config/paper.yaml, PATCHES) on the same seeds, each encoded and decoded in both
   layouts (medians of REPEATS): bytes, milliseconds and ratios.

With ``--json`` the last line printed is a JSON object with keys seeds,
persistent_kb_per_agent_step_patches, persistent_kb_per_agent_step_smooth, run_time_ratio
(PATCHES over SMOOTH, median over seeds), persistent_bytes_ratio and persistent_encode_ratio
(PATCHES over SMOOTH, medians over the sampled densities), paper_bytes_ratio (SMOOTH over
PATCHES: the paper's density keeps PATCHES).
"""

import argparse
import hashlib
import json
from pathlib import Path
import sys
import time

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO / 'src' / 'sat_agent'), str(REPO / 'src' / 'sat_world_sim')]

from sat_agent.config import load_params_file  # noqa: E402
from sat_agent.density_codec import (  # noqa: E402
    decode_density, encode_density, ENCODINGS, PATCHES, SMOOTH)
from sat_world_sim.inprocess_swarm import InProcessSwarm  # noqa: E402
from sat_world_sim.study_design import (  # noqa: E402
    default_cell, PERSISTENT_LABEL, PERSISTENT_PROFILE, REFERENCE_LABEL, scenario_for)

SAMPLE_STEPS = (20, 100, 200)
REPEATS = 20
PROFILES = {PERSISTENT_PROFILE: PERSISTENT_LABEL, 'paper': REFERENCE_LABEL}


def run(profile: str, seed: int, encoding=None):
    """Run one seed of the random default.

    Return (wall s, bytes per agent-step, sampled densities, a digest of the agents' poses and
    estimates at every step). encoding: the layout every agent's reports take (None: its
    density model's own).
    """
    cell = default_cell('random', PROFILES[profile], profile=profile)
    params = cell.params(load_params_file(REPO / 'config' / f'{profile}.yaml'))
    scenario = scenario_for(cell, seed, params, None)
    swarm = InProcessSwarm(scenario, params)
    if encoding is not None:
        for agent in swarm.agents.values():
            agent.filter.search.model.wire_encoding = encoding
    first = min(swarm.agents)
    payload, samples, path = 0, [], hashlib.sha256()
    start = time.perf_counter()
    for _ in range(scenario.steps):
        record = swarm.step()
        payload += sum(record.radio_bytes.values())
        for agent in sorted(record.agent_poses):
            for array in (record.agent_poses[agent], record.estimates[agent]):
                path.update(np.ascontiguousarray(array, dtype=float).tobytes())
        if record.step in SAMPLE_STEPS:
            samples.append(swarm.last_outputs[first].report.search_values)
    wall = time.perf_counter() - start
    return wall, payload / (scenario.steps * len(swarm.agents)), samples, path.hexdigest()


def layout_figures(values: np.ndarray) -> dict:
    """Bytes and median encode / decode ms of one density in each layout."""
    figures = {}
    for encoding in ENCODINGS:
        encoded = encode_density(values, encoding)
        encode_ms, decode_ms = [], []
        for _ in range(REPEATS):
            start = time.perf_counter()
            encode_density(values, encoding)
            middle = time.perf_counter()
            decoded = decode_density(encoded, values.shape)
            encode_ms.append((middle - start) * 1e3)
            decode_ms.append((time.perf_counter() - middle) * 1e3)
        np.testing.assert_array_equal(decoded, values.astype(np.float32))
        figures[encoding] = (len(encoded), float(np.median(encode_ms)),
                             float(np.median(decode_ms)))
    return figures


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seeds', type=int, default=3)
    parser.add_argument('--first-seed', type=int, default=9741)
    parser.add_argument('--json', action='store_true',
                        help='print a JSON summary as the last line')
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error(f'--seeds {args.seeds}: at least 1')
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    print(f'random default, seeds {seeds[0]}-{seeds[-1]}; persistent profile, each seed with '
          'each layout in turns')
    payloads = {encoding: [] for encoding in ENCODINGS}
    ratios, densities = [], {profile: [] for profile in PROFILES}
    for seed in seeds:
        walls, digests = {}, set()
        for encoding in (PATCHES, SMOOTH):
            walls[encoding], payload, samples, digest = run(PERSISTENT_PROFILE, seed, encoding)
            payloads[encoding].append(payload)
            digests.add(digest)
        if len(digests) != 1:
            raise SystemExit(f'seed {seed}: the two layouts gave different runs (lossless?)')
        densities[PERSISTENT_PROFILE] += samples
        densities['paper'] += run('paper', seed)[2]
        ratios.append(walls[PATCHES] / walls[SMOOTH])
        print(f'  seed {seed}: ' + ', '.join(
            f'{encoding} {walls[encoding]:.2f} s, {payloads[encoding][-1] / 1e3:.2f} kB/agent/step'
            for encoding in (PATCHES, SMOOTH)) + f'; time ratio x{ratios[-1]:.2f}')
    print(f'run time {PATCHES} / {SMOOTH}: median x{np.median(ratios):.2f} '
          f'(min x{min(ratios):.2f}, max x{max(ratios):.2f})')
    summary = {'seeds': len(seeds), 'run_time_ratio': float(np.median(ratios))}
    for encoding in ENCODINGS:
        summary[f'persistent_kb_per_agent_step_{encoding}'] = float(np.mean(payloads[encoding])
                                                                    / 1e3)
    print(f'single densities at steps {SAMPLE_STEPS}: bytes, encode ms, decode ms (medians of '
          f'{REPEATS})')
    for profile, samples in densities.items():
        figures = [layout_figures(values) for values in samples]
        for encoding in ENCODINGS:
            size, encode, decode = (np.median([f[encoding][i] for f in figures])
                                    for i in range(3))
            print(f'  {profile:<10} {encoding:<8} {size:8.0f} B  {encode:6.2f} ms  '
                  f'{decode:6.2f} ms')
        bytes_ratio = [f[PATCHES][0] / f[SMOOTH][0] for f in figures]
        encode_ratio = [f[PATCHES][1] / f[SMOOTH][1] for f in figures]
        print(f'  {profile:<10} {PATCHES} / {SMOOTH}: bytes x{np.median(bytes_ratio):.2f} '
              f'[{min(bytes_ratio):.2f}, {max(bytes_ratio):.2f}], encode time '
              f'x{np.median(encode_ratio):.2f}')
        if profile == PERSISTENT_PROFILE:
            summary['persistent_bytes_ratio'] = float(np.median(bytes_ratio))
            summary['persistent_encode_ratio'] = float(np.median(encode_ratio))
        else:
            summary['paper_bytes_ratio'] = float(np.median(1.0 / np.array(bytes_ratio)))
    if args.json:
        print(json.dumps(summary))
    return 0


if __name__ == '__main__':
    sys.exit(main())
