#!/usr/bin/env python3
"""Where the search's time goes: one set of synthetic targets against the squares runs flew.

For each seed of the random default (study_design: the same agent starts per seed) the search
pattern runs in-process: the persistent profile (--pattern profile; by default without the
seed's targets, --with-targets keeps them) or the oracle sweep's strips or tour
(oracle_sweep.py). sat_world_sim/search_coverage.py then scores the squares its agents flew
against one fixed set of synthetic targets drawn as the random default draws its targets: the
share some square held during its life and the mean steps from birth to that square. Means over
the seeds with 95 % t intervals; then the share of the area some square held by step k, where
the area left unseen lies, the area a step brings in that no square held for W steps, and the
longest any cell went without a square (--steps: a longer mission than the scenario's 200
steps; the synthetic targets are still born by step 150). A diagnostic
(docs/persistent_trials.md, session 37): its figures bound what a pattern lets the filter find,
never a reported result.

    scripts/with_env.sh python scripts/search_coverage.py [--pattern profile|strips|tour]
        [--with-targets] [--static] [--set KEY=VALUE ...] [--seeds 8] [--first-seed 1]
        [--params config/persistent.yaml] [--synthetic 20000] [--synthetic-seed 12345]
        [--steps N] [--jobs 2]

e.g. the looks at false alarms: ``--set sensor.clutter_rate=0`` against the default clutter.
"""

import argparse
from dataclasses import replace
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from sat_agent.beyond_paper.overdue_nodes import sweep_steps
from sat_agent.config import load_params_file
from sat_agent.search_map import SearchMap
from sat_world_sim.evaluate import set_values
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.oracle_sweep import run_oracle_sweep
from sat_world_sim.paired_statistics import mean_interval
from sat_world_sim.search_coverage import area_seen, coverage, synthetic_targets
from sat_world_sim.study_design import default_cell, PERSISTENT_LABEL, PERSISTENT_PROFILE
from sat_world_sim.study_design import scenario_for

ROOT = Path(__file__).resolve().parents[1]
PATTERNS = ('profile', 'strips', 'tour')
# The area searched at least once by these steps; the last also splits what is left unseen
# into the strip within BORDER_STRIP m of the border and the rest (session 46).
BY_STEPS = (20, 40, 60, 80, 100, 150)
BORDER_STRIP = 2.0
# The area a step brings in that no square held in this many steps before (session 47): the
# tour's even phasing against the walks' returns to younger area.
FRESH_WINDOWS = (10, 30, 60)


def cell_params(args, values):
    """Return the random default's cell of the profile and its parameters with values set."""
    cell = default_cell('random', PERSISTENT_LABEL, profile=PERSISTENT_PROFILE,
                        overrides=values)
    return cell, cell.params(load_params_file(args.params))


def lone_sweep(params) -> float:
    """Return the steps of a lone agent's walk through every node (overdue_nodes.sweep_steps)."""
    nodes = SearchMap.for_area(params.area, params.search.node_spacing)
    return sweep_steps(params, nodes.size, nodes.spacing)


def one_seed(job) -> tuple:
    """Return one seed's figures, in the order main prints them.

    Held share, mean delay, area seen by each BY_STEPS, unseen near the border and farther in,
    the area brought in per agent-step unseen for each FRESH_WINDOWS, then the longest waits
    near the border and farther in and the shares of those cells waiting over a lone sweep.
    """
    args, values, seed = job
    cell, params = cell_params(args, values)
    scenario = scenario_for(cell, seed, params, None)
    if args.steps is not None:
        scenario = replace(scenario, steps=args.steps)
    if args.pattern != 'profile' or not args.with_targets:
        scenario = replace(scenario, targets=(), random_births=None)
    if args.pattern == 'profile':
        run = run_swarm(scenario, params)
    else:
        run = run_oracle_sweep(scenario, params, tour=args.pattern == 'tour')
    targets = synthetic_targets(args.synthetic, args.synthetic_seed, params.area.width,
                                params.area.height, args.static)
    squares = [(r.step, r.agent_poses) for r in run.records]
    found = coverage(targets, squares, params.sensor.square_side)
    seen = area_seen(squares, params.sensor.square_side, params.area.width, params.area.height,
                     windows=FRESH_WINDOWS)
    return ((found.held_share, found.mean_delay) + tuple(seen.share_by(k) for k in BY_STEPS)
            + seen.unseen_by(BY_STEPS[-1], BORDER_STRIP) + seen.fresh
            + seen.waits(BORDER_STRIP, lone_sweep(params)))


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--pattern', choices=PATTERNS, default='profile')
    parser.add_argument('--with-targets', action='store_true',
                        help="profile: run with the seed's own targets (looks and tracking)")
    parser.add_argument('--static', action='store_true',
                        help='synthetic targets that do not move')
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='a parameter of the run (as evaluate --set)')
    parser.add_argument('--seeds', type=int, default=8)
    parser.add_argument('--first-seed', type=int, default=1)
    parser.add_argument('--params', default=str(ROOT / 'config' / 'persistent.yaml'))
    parser.add_argument('--synthetic', type=int, default=20000)
    parser.add_argument('--synthetic-seed', type=int, default=12345)
    parser.add_argument('--steps', type=int, default=None,
                        help="the run's steps (default: the scenario's)")
    parser.add_argument('--jobs', type=int, default=2)
    args = parser.parse_args(argv)
    if min(args.seeds, args.jobs, args.synthetic, 1 if args.steps is None else args.steps) < 1:
        parser.error(f'--seeds {args.seeds}, --jobs {args.jobs}, --synthetic '
                     f'{args.synthetic}, --steps {args.steps}: each must be at least 1')
    if args.with_targets and args.pattern != 'profile':
        parser.error('--with-targets: only the profile looks at and tracks targets')
    try:
        values = set_values(args.set)
    except ValueError as problem:
        parser.error(str(problem))
    jobs = [(args, values, seed) for seed in range(args.first_seed,
                                                   args.first_seed + args.seeds)]
    if args.jobs == 1:
        results = list(map(one_seed, jobs))
    else:
        with Pool(args.jobs) as pool:
            results = pool.map(one_seed, jobs)
    held, delay, *seen = (np.array(part, dtype=float) for part in zip(*results))
    seen, fresh, waits = (seen[:-len(FRESH_WINDOWS) - 4], seen[-len(FRESH_WINDOWS) - 4:-4],
                          seen[-4:])
    run = ' '.join([args.pattern + (' with targets' if args.with_targets else '') + ',',
                    f'random default seeds {jobs[0][2]}-{jobs[-1][2]},', args.params]
                   + [f'--set {key}={value}' for key, value in values])
    kind = 'static synthetic targets' if args.static else 'synthetic targets'
    print(f'{run}\n  {args.synthetic} {kind} (seed {args.synthetic_seed}): held by a square '
          f'{mean_interval(100.0 * held).describe()} %, mean steps from birth to it '
          f'{mean_interval(delay).describe()}')
    print('  area some square held by step k (%): ' + ', '.join(
        f'k = {k} {mean_interval(100.0 * share).describe(1)}'
        for k, share in zip(BY_STEPS, seen)))
    print(f'  unseen by k = {BY_STEPS[-1]} (% of the cells): within {BORDER_STRIP:g} m of the '
          f'border {mean_interval(100.0 * seen[-2]).describe(1)}, farther in '
          f'{mean_interval(100.0 * seen[-1]).describe(1)}')
    print('  area a step brings in that no square held in the W steps before (m^2 per '
          'agent-step): ' + ', '.join(f'W = {window} {mean_interval(area).describe(1)}'
                                      for window, area in zip(FRESH_WINDOWS, fresh)))
    sweep = lone_sweep(cell_params(args, values)[1])
    print(f'  longest wait of a cell without a square (steps, the whole run): within '
          f'{BORDER_STRIP:g} m of the border {mean_interval(waits[0]).describe(0)}, farther in '
          f'{mean_interval(waits[1]).describe(0)}; cells waiting over a lone sweep '
          f'({sweep:.0f} steps), % of each: {mean_interval(100.0 * waits[2]).describe(1)} and '
          f'{mean_interval(100.0 * waits[3]).describe(1)}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
