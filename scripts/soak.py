#!/usr/bin/env python3
"""Soak test: a long lock-step run of the ROS graph, watching memory and output growth.

Runs ``--steps`` (default 5,000) steps of ``--agents`` (default 4) agents with random target
births through the bring-up (separate processes, recorder on), samples every process's resident
memory (VmRSS) and the bag's size while it runs, and prints per process the RSS after warm-up
and at the end (growth must stay under 10 %) and the bag's growth per 1,000 steps (it should be
linear in steps). Not part of `make test`: it takes many minutes.

    scripts/with_env.sh python scripts/soak.py [--steps 5000] [--agents 4] [--json]
"""

import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

from sat_world_sim.bringup import executable

ROOT = Path(__file__).resolve().parents[1]
SAMPLE_S = 5.0


def rss_kib(pid: int):
    """Resident set size of a process in KiB, or None once it is gone."""
    try:
        for line in Path(f'/proc/{pid}/status').read_text().splitlines():
            if line.startswith('VmRSS:'):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def children(pid: int) -> dict:
    """Return the bring-up's children: {pid: name from the command line}."""
    out = subprocess.run(['pgrep', '-P', str(pid)], capture_output=True, text=True).stdout
    named = {}
    for child in map(int, out.split()):
        try:
            cmd = Path(f'/proc/{child}/cmdline').read_bytes().split(b'\0')
        except OSError:
            continue
        words = [w.decode() for w in cmd if w]
        # Console scripts run as '<venv>/bin/python3 <install>/lib/<pkg>/<exe> ...'.
        script = words[1] if len(words) > 1 and 'python' in Path(words[0]).name else words[0]
        exe = Path(script).name
        agent = next((w.split('=')[1] for w in words if w.startswith('agent_id:=')), None)
        named[child] = f'agent_{agent}' if exe == 'agent' and agent else exe
    return named


def bag_bytes(run_dir: Path) -> int:
    return sum(p.stat().st_size for p in (run_dir / 'bag').glob('*') if p.is_file())


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--steps', type=int, default=5000)
    parser.add_argument('--agents', type=int, default=4)
    parser.add_argument('--warm-up', type=float, default=0.1,
                        help='share of the samples before the reference RSS is taken')
    parser.add_argument('--json', action='store_true', help='last line: JSON of the figures')
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix='sat_soak_') as tmp:
        tmp = Path(tmp)
        rng = np.random.default_rng(3)
        scenario = tmp / 'soak.yaml'
        scenario.write_text(yaml.safe_dump({
            'name': 'soak', 'seed': 3, 'steps': args.steps, 'truth_process_noise': 1e-3,
            'agents': [{'id': i + 1, 'start': [float(x), float(y)]}
                       for i, (x, y) in enumerate(rng.uniform(5, 95, (args.agents, 2)))],
            'random_births': {'rate': 0.02, 'survival': 0.995, 'speed_std': 0.5}}))
        run_dir = tmp / 'run'
        swarm = subprocess.Popen(
            [executable('sat_world_sim', 'swarm'), '--scenario', str(scenario),
             '--params', str(ROOT / 'config' / 'paper.yaml'), '--run-dir', str(run_dir),
             '--quiet', '--timeout', str(args.steps * 2 + 600)],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        samples, bag = {}, []
        started = time.monotonic()
        while swarm.poll() is None:
            time.sleep(SAMPLE_S)
            for pid, name in children(swarm.pid).items():
                size = rss_kib(pid)
                if size is not None:
                    samples.setdefault(name, []).append(size)
            if (run_dir / 'bag').is_dir():
                bag.append((time.monotonic() - started, bag_bytes(run_dir)))
        wall = time.monotonic() - started
        metrics_path = run_dir / 'metrics.json'
        steps = len(json.loads(metrics_path.read_text())['steps']) if metrics_path.is_file() else 0
        final_bag = bag_bytes(run_dir) if (run_dir / 'bag').is_dir() else 0
    figures = {'steps': steps, 'agents': args.agents, 'wall_s': round(wall, 1),
               'exit_code': swarm.returncode, 'bag_bytes': final_bag,
               'bag_bytes_per_1000_steps': round(final_bag / max(steps, 1) * 1000),
               'rss_kib': {}}
    for name, values in sorted(samples.items()):
        reference = values[min(len(values) - 1, int(len(values) * args.warm_up))]
        growth = (values[-1] - reference) / reference * 100
        figures['rss_kib'][name] = {'after_warm_up': reference, 'end': values[-1],
                                    'max': max(values), 'growth_pct': round(growth, 1)}
        print(f'{name:12s} RSS after warm-up {reference / 1024:7.1f} MiB, end '
              f'{values[-1] / 1024:7.1f} MiB, growth {growth:+.1f} %')
    if len(bag) >= 4:
        half = len(bag) // 2
        rates = [(b1 - b0) / (t1 - t0) for (t0, b0), (t1, b1) in
                 ((bag[1], bag[half]), (bag[half], bag[-1]))]
        figures['bag_rate_first_half_Bps'], figures['bag_rate_second_half_Bps'] = map(round, rates)
        print(f'bag growth {rates[0] / 1e6:.2f} MB/s in the first half, '
              f'{rates[1] / 1e6:.2f} MB/s in the second (linear when equal)')
    per_thousand = figures['bag_bytes_per_1000_steps'] / 1e6
    print(f'{steps} steps, {args.agents} agents in {wall:.0f} s, exit {swarm.returncode}, bag '
          f'{final_bag / 1e6:.1f} MB ({per_thousand:.1f} MB per 1,000 steps)')
    if args.json:
        print(json.dumps(figures))
    return 0 if swarm.returncode == 0 else 1


if __name__ == '__main__':
    sys.exit(main())
