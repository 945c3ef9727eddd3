#!/usr/bin/env python3
"""Soak test: a long lock-step run of the ROS graph, watching memory and output growth.

Runs ``--steps`` (default 5,000) steps of ``--agents`` (default 4) agents with random target
births through the bring-up (separate processes; metrics, recorder and logger on), follows the
world's clock on ``/world/step`` and, every ``--sample-every`` steps, samples every process's
resident memory (VmRSS) and the sizes of the bag and of run.rrd. It prints:

- per process: RSS after warm-up and at the end, each the mean over a window of ``--window`` of
  the steps (from ``--warm-up`` of the steps on, and up to the last step: the logger's chunk
  batcher fills and empties in a saw-tooth of ~20 MB, so single samples would mislead), the
  maximum and the growth from warm-up to the end;
- the bag's and run.rrd's size at every 1,000 steps and the increments (linear in steps when the
  increments are equal), and their final sizes per 1,000 steps;
- the wall time, whether any process of the run is still alive after the bring-up returned, and
  a PASS/FAIL line: every process grew by less than ``--max-growth`` % (10) after warm-up and
  nothing was left running (exit code 0 only then).

Not part of `make test`: 5,000 steps take tens of minutes.

    scripts/with_env.sh python scripts/soak.py [--steps 5000] [--agents 4] [--json]
    scripts/with_env.sh python scripts/soak.py --params config/persistent.yaml   # a profile
"""

import argparse
import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

from sat_world_sim.bringup import executable, profile_argument, ros_env
from sat_world_sim.domain_ids import claim_domain_id

ROOT = Path(__file__).resolve().parents[1]
SIZE_EVERY = 1000


def rss_kib(pid: int):
    """Resident set size of a process in KiB, or None once it is gone."""
    try:
        for line in Path(f'/proc/{pid}/status').read_text().splitlines():
            if line.startswith('VmRSS:'):
                return int(line.split()[1])
    except OSError:
        return None
    return None


def alive(pid: int) -> bool:
    """Whether a process exists and is not a zombie."""
    try:
        state = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != 'Z'


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


def output_bytes(run_dir: Path) -> dict:
    """Return the current sizes of the bag (every file in bag/) and of run.rrd, in bytes."""
    bag = run_dir / 'bag'
    rrd = run_dir / 'run.rrd'
    return {'bag': sum(p.stat().st_size for p in bag.glob('*') if p.is_file())
            if bag.is_dir() else 0,
            'rrd': rrd.stat().st_size if rrd.is_file() else 0}


def write_scenario(path: Path, steps: int, agents: int):
    """Write a scenario: agents at random starts, targets born at random (seed 3)."""
    rng = np.random.default_rng(3)
    path.write_text(yaml.safe_dump({
        'name': 'soak', 'seed': 3, 'steps': steps, 'truth_process_noise': 1e-3,
        'agents': [{'id': i + 1, 'start': [float(x), float(y)]}
                   for i, (x, y) in enumerate(rng.uniform(5, 95, (agents, 2)))],
        'random_births': {'rate': 0.02, 'survival': 0.995, 'speed_std': 0.5}}))


class Watcher:
    """Follows /world/step from its own node and samples the run's processes and files."""

    def __init__(self, swarm: subprocess.Popen, run_dir: Path, sample_every: int):
        import rclpy
        from sat_agent.ros.qos import WORLD
        from sat_msgs.msg import WorldStep

        self.rclpy = rclpy
        self.swarm, self.run_dir, self.sample_every = swarm, run_dir, sample_every
        self.step = 0
        self.rss = {}        # name -> [(step, KiB)]
        self.sizes = []      # [(step, {'bag': bytes, 'rrd': bytes})] every SIZE_EVERY steps
        self.pids = set()
        rclpy.init()
        self.node = rclpy.create_node('soak_watcher')
        self.node.create_subscription(WorldStep, '/world/step', self._on_step, WORLD)

    def _on_step(self, msg):
        self.step = max(self.step, int(msg.step))

    def run(self):
        """Spin until the bring-up exits, sampling every sample_every steps."""
        next_sample = self.sample_every
        try:
            while self.swarm.poll() is None:
                self.rclpy.spin_once(self.node, timeout_sec=0.5)
                if self.step < next_sample:
                    continue
                step = self.step
                for pid, name in children(self.swarm.pid).items():
                    self.pids.add(pid)
                    size = rss_kib(pid)
                    if size is not None:
                        self.rss.setdefault(name, []).append((step, size))
                if step // SIZE_EVERY > len(self.sizes):
                    self.sizes.append((step, output_bytes(self.run_dir)))
                next_sample = step - step % self.sample_every + self.sample_every
        finally:
            self.node.destroy_node()
            self.rclpy.try_shutdown()


def rss_figures(rss: dict, warm_up: int, window: int, last: int) -> dict:
    """Mean RSS over [warm_up, warm_up + window) and (last - window, last] steps, growth, max."""
    figures = {}
    for name, samples in sorted(rss.items()):
        early = [v for s, v in samples if warm_up <= s < warm_up + window] or [samples[-1][1]]
        late = [v for s, v in samples if s > last - window] or [samples[-1][1]]
        reference, end = float(np.mean(early)), float(np.mean(late))
        figures[name] = {'after_warm_up_kib': round(reference), 'end_kib': round(end),
                         'max_kib': max(v for _, v in samples),
                         'growth_pct': round((end - reference) / reference * 100, 1)}
    return figures


def size_figures(sizes: list, final: dict, steps: int) -> dict:
    rows, previous = [], {'bag': 0, 'rrd': 0}
    for step, size in sizes:
        rows.append({'step': step, **size,
                     'bag_increment': size['bag'] - previous['bag'],
                     'rrd_increment': size['rrd'] - previous['rrd']})
        previous = size
    per_thousand = {f'{k}_bytes_per_1000_steps': round(v / max(steps, 1) * 1000)
                    for k, v in final.items()}
    return {'at': rows, 'final': final, **per_thousand}


def report(figures: dict, max_growth: float) -> bool:
    """Print the figures; return whether the soak passed."""
    window = figures['rss_window']
    print(f'RSS means over steps {window[0]}-{window[1]} (after warm-up) and '
          f'{window[2]}-{window[3]} (end):')
    for name, f in figures['rss'].items():
        print(f"{name:12s} after warm-up {f['after_warm_up_kib'] / 1024:7.1f} MiB, end "
              f"{f['end_kib'] / 1024:7.1f} MiB, max {f['max_kib'] / 1024:7.1f} MiB, "
              f"growth {f['growth_pct']:+.1f} %")
    names = sorted(figures['rss'])
    print('RSS (MiB) from the first sample at or after every 1,000 steps:')
    print('   step ' + ' '.join(f'{n:>10s}' for n in names))
    for mark in range(SIZE_EVERY, figures['steps'] + 1, SIZE_EVERY):
        row = [next((v for s, v in figures['rss_samples'][n] if s >= mark), None) for n in names]
        print(f'{mark:7d} ' + ' '.join(f'{v / 1024:10.1f}' if v else f'{"-":>10s}' for v in row))
    print('   step   bag MB  (+per 1k)   rrd MB  (+per 1k)')
    for row in figures['sizes']['at']:
        print(f"{row['step']:7d} {row['bag'] / 1e6:8.1f} {row['bag_increment'] / 1e6:+9.1f} "
              f"{row['rrd'] / 1e6:9.1f} {row['rrd_increment'] / 1e6:+9.1f}")
    sizes = figures['sizes']
    print(f"final: bag {sizes['final']['bag'] / 1e6:.1f} MB "
          f"({sizes['bag_bytes_per_1000_steps'] / 1e6:.1f} MB per 1,000 steps), run.rrd "
          f"{sizes['final']['rrd'] / 1e6:.1f} MB "
          f"({sizes['rrd_bytes_per_1000_steps'] / 1e6:.1f} MB per 1,000 steps)")
    print(f"{figures['steps']} steps, {figures['agents']} agents ({figures['params']}) in "
          f"{figures['wall_s']:.0f} s, bring-up exit code {figures['exit_code']}")
    grown = [n for n, f in figures['rss'].items() if f['growth_pct'] >= max_growth]
    left = figures['left_running']
    print(f"left running after the bring-up returned: {', '.join(map(str, left)) or 'nothing'}")
    passed = not grown and not left and figures['exit_code'] == 0 and bool(figures['rss'])
    print(f"{'PASS' if passed else 'FAIL'}: RSS growth after warm-up < {max_growth:g} % for "
          f"every process{'' if not grown else ' except ' + ', '.join(grown)}; "
          f"{'no' if not left else len(left)} process(es) left running")
    return passed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--steps', type=int, default=5000)
    parser.add_argument('--agents', type=int, default=4)
    parser.add_argument('--params', type=profile_argument, default=ROOT / 'config' / 'paper.yaml',
                        help="the agents' profile (default: config/paper.yaml)")
    parser.add_argument('--warm-up', type=float, default=0.1,
                        help='share of the steps after which the reference RSS is taken')
    parser.add_argument('--window', type=float, default=0.1,
                        help='share of the steps the reference and end RSS are averaged over')
    parser.add_argument('--sample-every', type=int, default=50, help='steps between samples')
    parser.add_argument('--max-growth', type=float, default=10.0,
                        help='allowed RSS growth after warm-up (%%)')
    parser.add_argument('--run-dir', type=Path, default=None,
                        help='keep the run here (default: a temporary directory, removed)')
    parser.add_argument('--json', action='store_true', help='last line: JSON of the figures')
    args = parser.parse_args()
    if args.run_dir is not None and args.run_dir.exists():
        parser.error(f'--run-dir {args.run_dir} exists already')
    # The watcher joins the run's private domain, localhost only, like the bring-up's children;
    # this process holds the claim (domain_ids) until it exits, after the swarm.
    domain = claim_domain_id()
    os.environ.update(ros_env(domain))
    warm_up, window = round(args.warm_up * args.steps), max(1, round(args.window * args.steps))
    with tempfile.TemporaryDirectory(prefix='sat_soak_') as tmp:
        tmp = Path(tmp)
        scenario = tmp / 'soak.yaml'
        write_scenario(scenario, args.steps, args.agents)
        run_dir = args.run_dir or tmp / 'run'
        started = time.monotonic()
        swarm = subprocess.Popen(
            [executable('sat_world_sim', 'swarm'), '--scenario', str(scenario),
             '--params', str(args.params), '--run-dir', str(run_dir),
             '--domain-id', str(domain), '--quiet', '--timeout', str(args.steps * 2 + 600)],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        watcher = Watcher(swarm, run_dir, args.sample_every)
        try:
            watcher.run()
        finally:
            swarm.wait()
        wall = time.monotonic() - started
        metrics_path = run_dir / 'metrics.json'
        steps = len(json.loads(metrics_path.read_text())['steps']) if metrics_path.is_file() else 0
        figures = {'steps': steps, 'agents': args.agents, 'params': str(args.params),
                   'wall_s': round(wall, 1),
                   'exit_code': swarm.returncode,
                   'rss': rss_figures(watcher.rss, warm_up, window, args.steps),
                   'rss_window': [warm_up, warm_up + window - 1, args.steps - window + 1,
                                  args.steps],
                   'rss_samples': watcher.rss,
                   'sizes': size_figures(watcher.sizes, output_bytes(run_dir), steps),
                   'left_running': sorted(p for p in watcher.pids if alive(p))}
    passed = report(figures, args.max_growth)
    if args.json:
        print(json.dumps(figures))
    return 0 if passed else 1


if __name__ == '__main__':
    sys.exit(main())
