#!/usr/bin/env python3
"""What perfect triage of the false alarms would give: the profile paired with its oracle.

For each seed of the setting, the persistent profile's cell of make evaluate runs twice
in-process (evaluate's engine): as it is, and with sat_world_sim/triage_oracle.py's triage of
--kinds by the truth: the looks see only the newborn spots ('spots') or tentative peaks
('peaks') that a true target lies within --radius of; the agents' scans hold no false alarm
('scans'). Both cells go into OUT/evaluation.csv (evaluate's columns, so compare_runs reads
it) and their paired comparison prints (bootstrap 95 % CIs, Wilcoxon p). A diagnostic
(docs/persistent_trials.md, sessions 41-42): its figures bound what a triage could give, never
a reported result.

    scripts/with_env.sh python scripts/triage_oracle.py --out DIR [--kinds spots,peaks|scans]
        [--radius 3] [--setting random] [--seeds 100] [--first-seed 9851] [--jobs 2]
        [--profile EVALUATION_CSV]

--profile takes the profile's rows from an evaluate run of its cell on these seeds (its
evaluation.csv) instead of running them again.
"""

import argparse
from functools import partial
from pathlib import Path
import sys

from sat_world_sim.evaluate import METRICS, read_rows, run_study, RUNS_CSV, write_csv
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.run_comparison import compare_runs, comparison_table
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import CONFIG_COLUMNS, default_cell, PERSISTENT_LABEL
from sat_world_sim.study_design import PERSISTENT_PROFILE, prepare_cells, SETTINGS
from sat_world_sim.triage_oracle import check_kinds, DEFAULT_RADIUS, LOOK_KINDS
from sat_world_sim.triage_oracle import run_with_oracle_triage, TRIAGE_KINDS

ROOT = Path(__file__).resolve().parents[1]


def profile_rows(path, setting: str, seeds: range):
    """Return the profile's rows of setting for seeds from an evaluation.csv, in seed order."""
    rows = {int(row['seed']): row for row in read_rows(path)
            if row['label'] == PERSISTENT_LABEL and row['setting'] == setting}
    missing = [seed for seed in seeds if seed not in rows]
    if missing:
        raise ValueError(f'--profile {path}: no {setting}/{PERSISTENT_LABEL} row for seeds '
                         f'{missing[:5]}{" ..." if len(missing) > 5 else ""}')
    return [rows[seed] for seed in seeds]


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--out', required=True, help='directory for evaluation.csv')
    parser.add_argument('--kinds', default=','.join(LOOK_KINDS),
                        help=f'comma-separated, of {TRIAGE_KINDS}')
    parser.add_argument('--radius', type=float, default=DEFAULT_RADIUS,
                        help='a candidate is real within this of a true target (m)')
    parser.add_argument('--setting', choices=sorted(SETTINGS), default='random')
    parser.add_argument('--seeds', type=int, default=100)
    parser.add_argument('--first-seed', type=int, default=9851)
    parser.add_argument('--jobs', type=int, default=2)
    parser.add_argument('--config', default=str(ROOT / 'config'),
                        help='directory of the profiles and scenarios/paper.yaml')
    parser.add_argument('--profile', help="the profile's rows: an evaluation.csv holding its "
                        'cell on every seed (default: run them)')
    args = parser.parse_args(argv)
    kinds = tuple(k for k in args.kinds.split(',') if k)
    try:
        check_kinds(kinds)
    except ValueError as error:
        parser.error(f'--kinds {args.kinds!r}: {error}')
    if not kinds:
        parser.error(f'--kinds {args.kinds!r}: one or more of {TRIAGE_KINDS}')
    if min(args.seeds, args.jobs) < 1 or args.radius <= 0:
        parser.error(f'--seeds {args.seeds}, --jobs {args.jobs}: each at least 1; '
                     f'--radius {args.radius}: positive')
    oracle_label = f'{PERSISTENT_LABEL}, oracle triage ({"+".join(kinds)})'
    cells = [default_cell(args.setting, label, profile=PERSISTENT_PROFILE)
             for label in (PERSISTENT_LABEL, oracle_label)]
    runnable, skipped = prepare_cells(cells, args.config)
    if skipped:
        print('; '.join(f'error: {cell.name}: {why}' for cell, why in skipped), file=sys.stderr)
        return 2
    paper = load_scenario(Path(args.config) / 'scenarios' / 'paper.yaml')
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    swarms = (run_swarm, partial(run_with_oracle_triage, kinds=kinds, radius=args.radius))
    if args.profile:
        try:
            rows = profile_rows(args.profile, args.setting, seeds)
        except ValueError as error:
            parser.error(str(error))
        runnable, swarms = runnable[1:], swarms[1:]
    else:
        rows = []
    rows += [result['row'] for job, swarm in zip(runnable, swarms)
             for result in run_study([job], seeds, paper, args.jobs, swarm=swarm,
                                     progress=sys.stderr.isatty())]
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(rows, out / RUNS_CSV, CONFIG_COLUMNS + ('seed',) + METRICS)
    print(f'{args.setting}, seeds {seeds[0]}-{seeds[-1]}: {oracle_label} (B) against the '
          f'profile (A); rows in {out / RUNS_CSV}')
    # Read back, so the profile's rows from --profile and the runs' rows compare as one kind.
    rows = read_rows(out / RUNS_CSV)
    print(comparison_table(compare_runs(rows, rows, PERSISTENT_LABEL, oracle_label)))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
