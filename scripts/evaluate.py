#!/usr/bin/env python3
"""Run the Monte Carlo evaluation (sat_world_sim/evaluate.py); `make evaluate` runs this.

Usage: scripts/with_env.sh python scripts/evaluate.py [--seeds N] [--jobs N] [--out DIR] [--quick]
"""

import sys

from sat_world_sim.evaluate import main

if __name__ == '__main__':
    sys.exit(main())
