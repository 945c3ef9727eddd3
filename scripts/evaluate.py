#!/usr/bin/env python3
"""Run the Monte Carlo evaluation (sat_world_sim/evaluate.py); `make evaluate` runs this.

Usage: scripts/with_env.sh python scripts/evaluate.py [--design default|full|factorial]
       [--only SETTING/LABEL ...] [--set KEY=VALUE ...] [--seeds N] [--first-seed N] [--jobs N]
       [--scheduler local|tcp://HOST:PORT] [--out DIR] [--quick | --steps N] [--dry-run]
"""

import sys

from sat_world_sim.evaluate import main

if __name__ == '__main__':
    sys.exit(main())
