#!/usr/bin/env python3
r"""Compare two evaluation runs seed by seed (sat_world_sim/run_comparison.py).

Usage: scripts/with_env.sh python scripts/compare_runs.py A/evaluation.csv B/evaluation.csv
       [--label-a LABEL] [--label-b LABEL] [--metric NAME ...]

Example, a trial on the dev seeds against the profile as it is:
    evaluate --only "random/SAT-PHD persistent" --first-seed 2001 --seeds 100 --out /tmp/base
    evaluate --only "random/SAT-PHD persistent" --first-seed 2001 --seeds 100 \
             --set phd.birth_velocity_std=0.5 --out /tmp/trial
    compare_runs.py /tmp/base/evaluation.csv /tmp/trial/evaluation.csv
"""

import sys

from sat_world_sim.run_comparison import main

if __name__ == '__main__':
    sys.exit(main())
