#!/usr/bin/env python3
"""How an oracle trades detected for tracked share: the frontier behind issue 15's verdict.

The oracle sweep-and-track (sat_world_sim/oracle_sweep.py: the oracle sweep's strips and
perfect sensor; an agent that sees a target nobody follows follows it) with each follow limit L
(the most steps an agent follows one target before it releases it for good and flies back to
its strip; 0 is the oracle sweep, "none" follows until the target dies), on the evaluation's
scenarios (study_design.scenario_for: the same truth per seed as every cell of make evaluate).
Per limit: mean detected share, tracked share and OSPA over the seeds, and whether issue 15's
floors hold at once (detected >= 90 % of the oracle sweep's, tracked >= 45 %, OSPA <= 6 m).
``--followers F`` lets only the F highest ids follow (the others sweep for ever) and
``--dispatch`` sends a free follower to any target the team has seen, not only one in its square
(oracle_sweep.py's two other readings); ``--coast`` has every agent also report the targets it
saw and no longer sees, moved on at their true velocity (oracle_sweep.py, the oracle reading of
additions.track_coasting); ``--scans N --window W`` counts a target found only once one agent
has had it in view on N of its last W steps (oracle_sweep.py's sensor-limited reading: a
detector that needs N scans; the floors stay those of the perfect sensor's sweep); ``--tour``
has the agents ride evenly phased slots of one closed tour instead of strips (oracle_sweep.py;
the floors stay those of the strips' sweep, issue 8's ceiling). No filter, no radio: a run
costs ~0.2 s. Then, from
an evaluation.csv (``--csv``, make evaluate's by default), the persistent profile's means on
the same metrics and its paired differences to the oracle sweep-and-track cell (follow limit
none, every agent a follower, no dispatch) on the seeds both have, with the tables' 95 %
bootstrap CI and Wilcoxon mark (paired_statistics.py).

    scripts/with_env.sh python scripts/oracle_frontier.py [--setting random] [--seeds 50]
        [--first-seed 1] [--limits 0 15 30 60 100 none] [--followers F] [--dispatch] [--coast]
        [--scans 1 --window 1] [--tour] [--csv docs/evaluation.csv]
"""

import argparse
from pathlib import Path

import numpy as np

from sat_agent.config import load_params_file
from sat_world_sim.evaluate import read_rows, RUNS_CSV
from sat_world_sim.evaluation_tables import by_seed
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.oracle_sweep import run_oracle_sweep
from sat_world_sim.paired_statistics import paired_difference, paired_values
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import default_cell, ORACLE, ORACLE_TRACK, ORACLE_TRACK_LABEL
from sat_world_sim.study_design import PERSISTENT_LABEL, scenario_for, SETTINGS

ROOT = Path(__file__).resolve().parents[1]
# Issue 15's floors at the random default: share of the oracle sweep's detected share, tracked
# share, mean OSPA (m).
CEILING_SHARE, TRACKED_FLOOR, OSPA_FLOOR = 0.9, 0.45, 6.0
METRICS = ('detected_share', 'tracked_share', 'mean_ospa')


def limit_value(text: str):
    """Return a follow limit from the command line: an int >= 0 or None ('none')."""
    if text.lower() == 'none':
        return None
    value = int(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f'follow limit {value}: must be >= 0 or none')
    return value


def frontier_point(setting: str, seeds, limit, followers=None, dispatch: bool = False,
                   coast: bool = False, scans: int = 1, window: int = 1,
                   tour: bool = False) -> dict:
    """Return the mean METRICS of the oracle with one follow limit (0: the sweep).

    followers, dispatch, coast, scans, window, tour: run_oracle_sweep's (None, False, False, 1,
    1, False: the sweep-and-track cell).
    """
    cell = default_cell(setting, 'oracle', policy=ORACLE, planner='none')
    params = cell.params(load_params_file(ROOT / 'config' / f'{cell.profile}.yaml'))
    paper = load_scenario(ROOT / 'config' / 'scenarios' / 'paper.yaml')
    rows = []
    for seed in seeds:
        scenario = scenario_for(cell, seed, params, paper)
        run = run_oracle_sweep(scenario, params, follow=limit != 0, follow_limit=limit,
                               followers=followers, dispatch=dispatch, coast=coast,
                               scans=scans, window=window, tour=tour)
        rows.append(compute_metrics(run.records, scenario.name, seed)['summary'])
    return {name: float(np.mean([row[name] for row in rows])) for name in METRICS}


def persistent_against_the_oracle(setting: str, csv_path) -> list:
    """Return lines: the persistent profile's means and its paired Δ to sweep-and-track."""
    data = by_seed(read_rows(csv_path))
    mine = data.get(f'{setting}/{PERSISTENT_LABEL}')
    oracle = data.get(f'{setting}/{ORACLE_TRACK_LABEL}')
    if not mine or not oracle:
        return [f'{csv_path}: no {PERSISTENT_LABEL} or {ORACLE_TRACK_LABEL} ({ORACLE_TRACK}) '
                f'rows at {setting}']
    lines = [f'{PERSISTENT_LABEL} against {ORACLE_TRACK_LABEL} ({csv_path}, paired by seed):']
    for name in METRICS:
        values, reference = paired_values(mine[name], oracle[name])
        difference = paired_difference(values, reference)
        mark = '*' if difference.significant else ''
        lines.append(f'  {name}: {values.mean():.3f} against {reference.mean():.3f}, '
                     f'difference {difference.estimate:+.3f} [{difference.low:+.3f}, '
                     f'{difference.high:+.3f}]{mark} (p = {difference.p_value:.2g}) over '
                     f'{len(values)} seeds')
    return lines


def main(argv=None) -> int:
    """Command-line entry point (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--setting', choices=sorted(SETTINGS), default='random')
    parser.add_argument('--seeds', type=int, default=50)
    parser.add_argument('--first-seed', type=int, default=1)
    parser.add_argument('--limits', type=limit_value, nargs='+',
                        default=[0, 15, 30, 60, 100, None])
    parser.add_argument('--followers', type=int, default=None,
                        help='how many agents may follow, the highest ids (default: all)')
    parser.add_argument('--dispatch', action='store_true',
                        help='free followers take any target the team has seen')
    parser.add_argument('--coast', action='store_true',
                        help='agents also report the targets they saw, moved on at true velocity')
    parser.add_argument('--scans', type=int, default=1,
                        help='scans of a target one agent needs within --window to find it')
    parser.add_argument('--window', type=int, default=None,
                        help='steps within which the --scans count (default: --scans)')
    parser.add_argument('--tour', action='store_true',
                        help='agents ride evenly phased slots of one closed tour, not strips')
    parser.add_argument('--csv', default=str(ROOT / 'docs' / RUNS_CSV),
                        help='evaluation.csv with the persistent and sweep-and-track cells')
    args = parser.parse_args(argv)
    if args.seeds < 1:
        parser.error(f'--seeds {args.seeds}: must be >= 1')
    if args.followers is not None and args.followers < 0:
        parser.error(f'--followers {args.followers}: must be >= 0')
    window = args.scans if args.window is None else args.window
    if not 1 <= args.scans <= window:
        parser.error(f'--scans {args.scans} --window {window}: need 1 <= scans <= window')
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    sweep = frontier_point(args.setting, seeds, 0)
    print(f'{args.setting}, seeds {seeds.start}-{seeds.stop - 1}; floors: detected >= '
          f'{CEILING_SHARE * sweep["detected_share"]:.1%} ({CEILING_SHARE:.0%} of the sweep), '
          f'tracked >= {TRACKED_FLOOR:.0%}, OSPA <= {OSPA_FLOOR:g} m; followers: '
          f'{"all" if args.followers is None else args.followers}'
          f'{", dispatched to any target seen" if args.dispatch else ""}'
          f'{", coasting what they saw" if args.coast else ""}'
          f'{f", found on {args.scans} scans in {window} steps" if args.scans > 1 else ""}'
          f'{"; riding one tour" if args.tour else ""}')
    print('| follow limit (steps) | detected % | tracked % | OSPA (m) | all floors |')
    print('| --- | --- | --- | --- | --- |')
    for limit in args.limits:
        try:
            point = (sweep if limit == 0 and not (args.coast or args.tour) and args.scans == 1
                     else frontier_point(args.setting, seeds, limit, args.followers,
                                         args.dispatch, args.coast, args.scans, window,
                                         args.tour))
        except ValueError as error:
            parser.error(f'--followers {args.followers}: {error}')
        met = (point['detected_share'] >= CEILING_SHARE * sweep['detected_share']
               and point['tracked_share'] >= TRACKED_FLOOR and point['mean_ospa'] <= OSPA_FLOOR)
        name = 'none (until it dies)' if limit is None else str(limit)
        print(f'| {name} | {100 * point["detected_share"]:.1f} | '
              f'{100 * point["tracked_share"]:.1f} | {point["mean_ospa"]:.2f} | '
              f'{"yes" if met else "no"} |')
    print('\n'.join(persistent_against_the_oracle(args.setting, args.csv)))
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
