#!/usr/bin/env python3
"""Where the persistent profile's mean OSPA goes: the what-ifs of docs/persistent_trials.md.

For each seed, the profile's cell of make evaluate (study_design: the same truth per seed) runs
in-process, and sat_world_sim/ospa_breakdown.py scores it again with its swarm estimate changed:
false estimates removed, matched ones moved onto their targets, the targets it had found and
lost kept; then its false reports by source (an agent's own estimate, or a coasted track whose
target died, whose target is elsewhere, or that never had one) with the mean OSPA without each.
Then the mean OSPA split by how a step's reports compare in number with its targets
(ospa_regimes), and where the target-steps go (sat_world_sim/target_steps.py: before the first
detection, and why a found target goes untracked). Means over the seeds with 95 % t intervals.
A diagnostic: its figures are the profile's on the seeds given, never a reported result.

    scripts/with_env.sh python scripts/ospa_breakdown.py [--setting random] [--seeds 40]
        [--first-seed 6761] [--params config/persistent.yaml] [--steps 200] [--jobs 2]

--steps: a longer run (the long mission's, e.g. ``--setting long --steps 1000``).
"""

import argparse
from dataclasses import replace
from multiprocessing import Pool
from pathlib import Path

import numpy as np

from sat_agent.config import load_params_file
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.ospa_breakdown import false_sources, ospa_regimes, REGIMES, SOURCES
from sat_world_sim.ospa_breakdown import what_if_ospa, WHAT_IFS
from sat_world_sim.paired_statistics import mean_interval
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import default_cell, PERSISTENT_LABEL, PERSISTENT_PROFILE
from sat_world_sim.study_design import scenario_for, SETTINGS, STEPS
from sat_world_sim.target_steps import AFTER, BEFORE, CATEGORIES, TargetStepLedger

ROOT = Path(__file__).resolve().parents[1]


def one_seed(job) -> tuple:
    """Return a seed's figures, in the order main prints them.

    What-if OSPAs; false report-steps per source and the OSPA without each; per regime the
    share of steps and its part of the OSPA; target-steps per category.
    """
    setting, params_path, steps, seed = job
    cell = replace(default_cell(setting, PERSISTENT_LABEL, profile=PERSISTENT_PROFILE),
                   steps=steps)
    params = cell.params(load_params_file(params_path))
    scenario = scenario_for(cell, seed, params,
                            load_scenario(ROOT / 'config' / 'scenarios' / 'paper.yaml'))
    ledger = TargetStepLedger()
    found = false_sources(InProcessSwarm(scenario, params), scenario.steps, ledger=ledger)
    what_ifs = what_if_ospa(found.records)
    regimes = ospa_regimes(found.records)
    return ([what_ifs[name] for name in WHAT_IFS], [found.counts[s] for s in SOURCES],
            [found.mean_ospa_without[s] for s in SOURCES],
            [regimes[name][0] for name in REGIMES], [regimes[name][1] for name in REGIMES],
            [ledger.counts[name] for name in CATEGORIES])


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--setting', choices=sorted(s for s in SETTINGS if s != 'paper'),
                        default='random')
    parser.add_argument('--seeds', type=int, default=40)
    parser.add_argument('--first-seed', type=int, default=6761)
    parser.add_argument('--params', default=str(ROOT / 'config' / 'persistent.yaml'))
    parser.add_argument('--steps', type=int, default=STEPS)
    parser.add_argument('--jobs', type=int, default=2)
    args = parser.parse_args(argv)
    if min(args.seeds, args.jobs, args.steps) < 1:
        parser.error(f'--seeds {args.seeds}, --jobs {args.jobs}, --steps {args.steps}: each '
                     f'must be at least 1')
    jobs = [(args.setting, args.params, args.steps, seed)
            for seed in range(args.first_seed, args.first_seed + args.seeds)]
    with Pool(args.jobs) as pool:
        what_ifs, counts, without, shares, parts, steps = (
            np.array(part, dtype=float) for part in zip(*pool.map(one_seed, jobs)))
    print(f'{args.setting}, {args.steps} steps, seeds {jobs[0][-1]}-{jobs[-1][-1]}, '
          f'{args.params}')
    print('what-if: mean OSPA (m) [95 % t interval], change against reported')
    for column, name in enumerate(WHAT_IFS):
        change = what_ifs[:, column] - what_ifs[:, 0]
        print(f'  {name:26s} {mean_interval(what_ifs[:, column]).describe(3)}'
              f'  {change.mean():+.3f}')
    print('false reports (> c from every target): report-steps per run; mean OSPA without them')
    for column, name in enumerate(SOURCES):
        change = without[:, column] - what_ifs[:, 0]
        print(f'  {name:26s} {mean_interval(counts[:, column]).describe(3)}  '
              f'{mean_interval(without[:, column]).describe(3)}'
              f'  {change.mean():+.3f}')
    print('by the reports against the targets in number: % of the steps; part of the mean OSPA')
    for column, name in enumerate(REGIMES):
        print(f'  {name:26s} {mean_interval(100.0 * shares[:, column]).describe(1)}  '
              f'{mean_interval(parts[:, column]).describe(3)}')
    print('target-steps: per run; % of all; % of those at or after the first detection')
    after = steps[:, len(BEFORE):].sum()
    for column, name in enumerate(CATEGORIES):
        share_after = ('' if name not in AFTER
                       else f'  {100.0 * steps[:, column].sum() / after:5.1f} %')
        print(f'  {name:34s} {mean_interval(steps[:, column]).describe(1)}'
              f'  {100.0 * steps[:, column].sum() / steps.sum():5.1f} %{share_after}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
