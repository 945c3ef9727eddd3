#!/usr/bin/env python3
"""`make run`: the paper's scenario through the whole ROS 2 graph, into runs/<name>/.

Separate processes for world_sim, metrics and each agent (sat_world_sim.bringup), lock-step
clock, the paper's parameters (config/paper.yaml) and scenario (config/scenarios/paper.yaml).
Extra arguments go to the bring-up (see `swarm --help`), e.g. `--name demo --seed 3`.
The last line printed is the run directory.
"""

import argparse
from datetime import datetime, timezone
from pathlib import Path
import sys

from sat_world_sim import bringup

ROOT = Path(__file__).resolve().parents[1]
# The run's files, relative to the repository (README's `ros2 run` lines use them as they are).
PAPER_ARGS = ('--scenario', 'config/scenarios/paper.yaml', '--params', 'config/paper.yaml')


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--name', default=None,
                        help='run directory name under runs/ (default: paper-<UTC time>)')
    args, rest = parser.parse_known_args()
    name = args.name or datetime.now(timezone.utc).strftime('paper-%Y%m%d-%H%M%S')
    files = [arg if arg.startswith('--') else str(ROOT / arg) for arg in PAPER_ARGS]
    return bringup.main([*files, '--run-dir', str(ROOT / 'runs' / name), *rest])


if __name__ == '__main__':
    sys.exit(main())
