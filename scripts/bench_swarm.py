#!/usr/bin/env python3
"""Benchmark the swarm as a ROS 2 graph: paper run wall time and the largest real-time swarm.

1. The paper's scenario in lock-step through the bring-up (separate processes): wall time for
   200 steps including start-up (target <= 30 s on a 2-core machine).
2. The largest swarm that keeps a 1 Hz real-time clock without one late command, with every agent
   its own process and with all agents composed in one process (targets 16 and 64): agents start
   spread over the area (a random-births scenario), run ``--rt-steps`` steps; a size passes when
   the world counted no command that missed its step (``late_commands`` in metrics.json). Also
   prints messages and bytes each agent sent per step (radio payload, counted per receiver).
   The recorder, the Rerun logger and the metrics run too. Composed sizes are tried once more
   without the recorder and the logger (``--bare``): their load grows with the radio traffic,
   as the square of the swarm's size, and on 2 cores it is what stops the largest swarms.

``--params`` picks the agents' profile for every run (default ``config/paper.yaml``): the
persistent profile's regrowing density is a larger radio payload than the paper's.
``--no-auth`` runs every swarm without message authentication (the bring-up's flag), to measure
what signing and verifying cost.

Run from the repository after `make test` (the workspace must be built)::

    scripts/with_env.sh python scripts/bench_swarm.py [--json] [--params P] [--no-auth] \
        [--sizes 4 8 16 24 32] [--composed 16 24 32 48 64] [--bare 48 64]

With --json the last line is a JSON object with every figure.
"""

import argparse
import json
from pathlib import Path
import sys
import tempfile
import time

import numpy as np
import yaml

from sat_world_sim import bringup

ROOT = Path(__file__).resolve().parents[1]
PARAMS = ROOT / 'config' / 'paper.yaml'
PAPER = ROOT / 'config' / 'scenarios' / 'paper.yaml'


def run(scenario: Path, common: list, run_dir: Path, *extra) -> tuple:
    """Run the bring-up; return (exit code, wall seconds, metrics dict or None).

    common: the options of every run (the profile, authentication).
    """
    started = time.perf_counter()
    code = bringup.main(['--scenario', str(scenario), *common,
                         '--run-dir', str(run_dir), '--quiet', *extra])
    wall = time.perf_counter() - started
    path = run_dir / 'metrics.json'
    return code, wall, json.loads(path.read_text()) if path.is_file() else None


def spread_scenario(path: Path, agents: int, steps: int, seed: int = 11) -> Path:
    """N agents at seeded random starts, targets born at random (a busy but fair swarm)."""
    rng = np.random.default_rng(seed)
    starts = rng.uniform(5.0, 95.0, size=(agents, 2))
    path.write_text(yaml.safe_dump({
        'name': f'spread_{agents}', 'seed': seed, 'steps': steps, 'truth_process_noise': 1e-4,
        'agents': [{'id': i + 1, 'start': [float(x), float(y)]}
                   for i, (x, y) in enumerate(starts)],
        'random_births': {'rate': 0.05, 'survival': 0.99, 'speed_std': 0.5}}))
    return path


def per_agent_step(metrics: dict) -> tuple:
    """Mean radio messages and bytes one agent sent per step."""
    steps = max(1, len(metrics['steps']))
    radio = metrics['radio'].values()
    agents = max(1, len(radio))
    return (sum(r['messages'] for r in radio) / agents / steps,
            sum(r['bytes'] for r in radio) / agents / steps)


def real_time_sizes(sizes, composed: bool, steps: int, common: list, work: Path,
                    observers: bool = True) -> list:
    """Try each swarm size at 1 Hz; return one result dict per size.

    observers=False runs without the recorder and the Rerun logger (metrics still run).
    """
    results = []
    label = ('composed' if composed else 'processes') + ('' if observers else ', bare')
    for size in sizes:
        scenario = spread_scenario(work / f'rt_{size}.yaml', size, steps)
        extra = ['--clock', 'real_time', '--period', '1.0', '--timeout', str(steps * 3 + 180)]
        if composed:
            extra.append('--composed')
        if not observers:
            extra += ['--no-record', '--no-view']
        name = f'rt_{"c" if composed else "p"}{"" if observers else "b"}_{size}'
        code, wall, metrics = run(scenario, common, work / name, *extra)
        late = metrics['late_commands'] if metrics else None
        messages, nbytes = per_agent_step(metrics) if metrics else (None, None)
        ok = code == 0 and late == 0
        results.append({'agents': size, 'composed': composed, 'observers': observers, 'ok': ok,
                        'late_commands': late, 'wall_s': round(wall, 1),
                        'msgs_per_agent_step': messages, 'bytes_per_agent_step': nbytes})
        print(f'{label} {size:3d} agents: '
              f"{'ok' if ok else 'OVERRUN'} (late commands {late}, exit {code}), "
              f'{messages if messages is None else round(messages, 1)} msgs and '
              f'{nbytes if nbytes is None else round(nbytes)} B per agent per step',
              flush=True)
        if not ok:
            break
    return results


def largest(results) -> int:
    passed = [r['agents'] for r in results if r['ok']]
    return max(passed) if passed else 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--json', action='store_true', help='last line: JSON of all figures')
    parser.add_argument('--params', type=bringup.profile_argument, default=PARAMS,
                        help="the agents' profile for every run (default: config/paper.yaml)")
    parser.add_argument('--no-auth', action='store_true',
                        help='run every swarm without message authentication')
    parser.add_argument('--sizes', type=int, nargs='*', default=[4, 8, 16, 24, 32],
                        help='swarm sizes to try as separate processes (ascending)')
    parser.add_argument('--composed', type=int, nargs='*', default=[16, 24, 32, 48, 64],
                        help='swarm sizes to try composed in one process (ascending)')
    parser.add_argument('--bare', type=int, nargs='*', default=[48, 64],
                        help='composed sizes to try without recorder and logger (ascending)')
    parser.add_argument('--rt-steps', type=int, default=20, help='real-time steps per size')
    args = parser.parse_args()
    common = ['--params', str(args.params)] + (['--no-auth'] if args.no_auth else [])
    print(f"profile: {args.params}, authentication {'off' if args.no_auth else 'on'}",
          flush=True)
    with tempfile.TemporaryDirectory(prefix='sat_bench_swarm_') as tmp:
        work = Path(tmp)
        code, wall, metrics = run(PAPER, common, work / 'paper')
        messages, nbytes = per_agent_step(metrics) if metrics else (None, None)
        print(f'paper scenario, lock-step, 200 steps incl. start-up: {wall:.1f} s '
              f'(target <= 30 s), exit {code}; {messages} msgs and {nbytes} B per agent per step',
              flush=True)
        processes = real_time_sizes(args.sizes, False, args.rt_steps, common, work)
        composed = real_time_sizes(args.composed, True, args.rt_steps, common, work)
        bare = real_time_sizes(args.bare, True, args.rt_steps, common, work, observers=False)
    summary = {'params': str(args.params), 'authentication': not args.no_auth,
               'paper_lock_step_wall_s': round(wall, 1), 'paper_exit_code': code,
               'paper_msgs_per_agent_step': messages, 'paper_bytes_per_agent_step': nbytes,
               'largest_real_time_processes': largest(processes),
               'largest_real_time_composed': largest(composed),
               'largest_real_time_composed_bare': largest(bare),
               'real_time_runs': processes + composed + bare}
    print(f"largest 1 Hz swarm: {summary['largest_real_time_processes']} agents as processes "
          f"(target 16), {summary['largest_real_time_composed']} composed (target 64), "
          f"{summary['largest_real_time_composed_bare']} composed without recorder and logger")
    if args.json:
        print(json.dumps(summary))
    return 0


if __name__ == '__main__':
    sys.exit(main())
