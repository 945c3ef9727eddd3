#!/usr/bin/env python3
"""What perfect triage of the looks would give: the profile paired with its oracle-triaged looks.

For each seed of the setting, the persistent profile's cell of make evaluate runs twice
in-process (evaluate's engine): as it is, and with sat_world_sim/look_oracle.py's looks, which
see only the candidates of --kinds that a true target lies within --radius of. Both cells go
into OUT/evaluation.csv (evaluate's columns, so compare_runs reads it) and their paired
comparison prints (bootstrap 95 % CIs, Wilcoxon p). A diagnostic (docs/persistent_trials.md,
session 41): its figures bound what a triage of the looks could give, never a reported result.

    scripts/with_env.sh python scripts/look_oracle.py --out DIR [--kinds spots,peaks]
        [--radius 3] [--setting random] [--seeds 100] [--first-seed 9851] [--jobs 2]
"""

import argparse
from functools import partial
from pathlib import Path
import sys

from sat_world_sim.evaluate import METRICS, run_study, RUNS_CSV, write_csv
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.look_oracle import DEFAULT_RADIUS, run_with_oracle_looks, TRIAGE_KINDS
from sat_world_sim.run_comparison import compare_runs, comparison_table
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import CONFIG_COLUMNS, default_cell, PERSISTENT_LABEL
from sat_world_sim.study_design import PERSISTENT_PROFILE, prepare_cells, SETTINGS

ROOT = Path(__file__).resolve().parents[1]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', required=True, help='directory for evaluation.csv')
    parser.add_argument('--kinds', default=','.join(TRIAGE_KINDS),
                        help=f'comma-separated, of {TRIAGE_KINDS}')
    parser.add_argument('--radius', type=float, default=DEFAULT_RADIUS,
                        help='a candidate is real within this of a true target (m)')
    parser.add_argument('--setting', choices=sorted(SETTINGS), default='random')
    parser.add_argument('--seeds', type=int, default=100)
    parser.add_argument('--first-seed', type=int, default=9851)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--config', default=str(ROOT / 'config'),
                        help='directory of the profiles and scenarios/paper.yaml')
    args = parser.parse_args(argv)
    kinds = tuple(k for k in args.kinds.split(',') if k)
    if not kinds or not set(kinds) <= set(TRIAGE_KINDS):
        parser.error(f'--kinds {args.kinds!r}: one or more of {TRIAGE_KINDS}')
    if min(args.seeds, args.jobs) < 1 or args.radius <= 0:
        parser.error(f'--seeds {args.seeds}, --jobs {args.jobs}: each at least 1; '
                     f'--radius {args.radius}: positive')
    oracle_label = f'{PERSISTENT_LABEL}, oracle looks ({"+".join(kinds)})'
    cells = [default_cell(args.setting, label, profile=PERSISTENT_PROFILE)
             for label in (PERSISTENT_LABEL, oracle_label)]
    runnable, skipped = prepare_cells(cells, args.config)
    if skipped:
        print('; '.join(f'error: {cell.name}: {why}' for cell, why in skipped), file=sys.stderr)
        return 2
    paper = load_scenario(Path(args.config) / 'scenarios' / 'paper.yaml')
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    swarms = (run_swarm, partial(run_with_oracle_looks, kinds=kinds, radius=args.radius))
    rows = [result['row'] for job, swarm in zip(runnable, swarms)
            for result in run_study([job], seeds, paper, args.jobs, swarm=swarm,
                                    progress=sys.stderr.isatty())]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / RUNS_CSV, CONFIG_COLUMNS + ('seed',) + METRICS)
    print(f'{args.setting}, seeds {seeds[0]}-{seeds[-1]}: {oracle_label} (B) against the '
          f'profile (A); rows in {out / RUNS_CSV}')
    print(comparison_table(compare_runs(rows, rows, PERSISTENT_LABEL, oracle_label)))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
