"""Monte Carlo evaluation: SAT-PHD against baselines over many seeds, in parallel, no ROS.

Every run is the in-process swarm (inprocess_swarm.run_swarm, the reference loop the ROS graph
reproduces step for step) and is scored by metrics.compute_metrics, the code behind
metrics.json. Every cell of the study runs the same seeds 1..N, so policies meet the same
truth (common random numbers).

Design: a full factorial (4 policies x 3 team sizes x 3 clutter rates x 4 radio ranges) does
not fit 30 minutes on 2 cores, so the study is one-factor-at-a-time around two settings:

- ``paper``: the paper's scenario (config/scenarios/paper.yaml: 2 agents, 2 scripted targets,
  lambda = 10, C_R = 50 m, 200 steps), the seed varying sensor noise, clutter and filter draws;
- ``random``: the default random scenario: 4 agents starting anywhere, 2 to 10 targets
  (uniform) born at uniform steps in [1, 150], living 50-150 steps, moving at constant velocity
  (N(0, 0.5) m/s per axis) as the paper's targets do, lambda = 10, C_R = 50 m, 200 steps.

At both settings, every policy on the same filter (search.policy/planner, comm range):
SAT-PHD cooperative (the paper), SAT-PHD without radio (C_R = 0, non-cooperative), lawnmower,
random walk and SAT-PHD with OR-Tools walks. Around the random default, SAT-PHD alone with one
factor changed: 2 or 8 agents; lambda 0 or 30; C_R 25 m or unlimited (C_R = 0 is the
no-radio baseline). 16 cells, --seeds each (20 by default).

Run from the repository (defaults: config/paper.yaml, config/scenarios/paper.yaml). Outputs in
--out (docs/ by default): evaluation.csv (one row per run), evaluation_targets.csv
(one row per target), evaluation_summary.md (mean +- std and N per cell) and the figures of
evaluation_plots.py. The summary table is printed too.

    evaluate [--seeds 20] [--jobs 2] [--out docs] [--readme README.md] [--quick]
"""

import argparse
from concurrent.futures import as_completed, ProcessPoolExecutor
import csv
from dataclasses import dataclass, replace
import os
from pathlib import Path
import sys
import time
from typing import List, Sequence

import numpy as np
from tqdm import tqdm

from sat_agent.config import load_params_file, SatParams

from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.scenario import load_scenario, Scenario, scenario_from_mapping

STEPS = 200
# C_R standing for "unlimited": above the area's diagonal (141 m), so every pair is in range.
UNLIMITED = 1000.0
# Random scenarios draw from their own stream, apart from the world's and the agents' streams.
SCENARIO_SALT = 0x5A7E
TARGETS = (2, 10)
BORN_LAST = 150
LIFETIME = (50, 150)
SPEED_STD = 0.5
# As in the paper's scenario: near-constant velocity, arriving near the scripted end.
TRUTH_PROCESS_NOISE = 1e-5
# Agents start half a sensing square inside the area, so their first scan is all in the area.
EDGE = 5.0
QUICK_STEPS = 15

POLICY_LABELS = {
    ('sat', 'greedy', True): 'SAT-PHD (cooperative)',
    ('sat', 'greedy', False): 'SAT-PHD, no radio',
    ('lawnmower', 'greedy', True): 'lawnmower',
    ('random_walk', 'greedy', True): 'random walk',
    ('sat', 'ortools', True): 'SAT-PHD + OR-Tools',
}

# Columns of evaluation.csv: the configuration (Cell fields), the seed, then the metrics (names
# of metrics.py's summary, plus the area searched at k = 100 and the run's wall time).
METRICS = ('mean_ospa', 'mean_ospa_loc', 'mean_ospa_card', 'mean_time_to_detection',
           'detected_share', 'tracked_share', 'searched_pct_100', 'final_searched_pct',
           'duplicate_tracking_steps', 'radio_msgs_per_agent_step', 'bytes_per_agent_step',
           'targets_to_detect', 'wall_time_s')
CONFIG_COLUMNS = ('setting', 'label', 'policy', 'planner', 'agents', 'clutter', 'comm_range',
                  'steps')


@dataclass(frozen=True)
class Cell:
    """One configuration of the study; label names it in tables and figures."""

    setting: str            # 'paper' or 'random'
    label: str
    policy: str = 'sat'
    planner: str = 'greedy'
    agents: int = 4
    clutter: float = 10.0
    comm_range: float = 50.0
    steps: int = STEPS

    def params(self, base: SatParams) -> SatParams:
        """Return the base parameters with this cell's policy, planner, clutter and radio range."""
        return base.with_overrides({'search.policy': self.policy,
                                    'search.planner': self.planner,
                                    'sensor.clutter_rate': self.clutter,
                                    'cooperation.comm_range': self.comm_range})


def policy_cells(setting: str, agents: int) -> List[Cell]:
    """Return every policy of the comparison at one setting (module docstring)."""
    return [Cell(setting, label, policy, planner, agents, comm_range=50.0 if radio else 0.0)
            for (policy, planner, radio), label in POLICY_LABELS.items()]


def study_cells(steps: int = STEPS) -> List[Cell]:
    """Return the 16 cells of the study (module docstring)."""
    default = Cell('random', POLICY_LABELS[('sat', 'greedy', True)])
    sweeps = [replace(default, label=f'{n} agents', agents=n) for n in (2, 8)]
    sweeps += [replace(default, label=f'clutter {c:g}', clutter=float(c)) for c in (0, 30)]
    sweeps += [replace(default, label='C_R 25 m', comm_range=25.0),
               replace(default, label='C_R unlimited', comm_range=UNLIMITED)]
    cells = policy_cells('paper', 2) + policy_cells('random', 4) + sweeps
    return [replace(cell, steps=steps) for cell in cells]


def random_scenario(seed: int, agents: int, steps: int, width: float = 100.0,
                    height: float = 100.0) -> Scenario:
    """Draw a scenario of random births and deaths (module docstring) from the seed alone."""
    rng = np.random.default_rng(np.random.SeedSequence([SCENARIO_SALT, int(seed)]))
    low, high = (EDGE, EDGE), (width - EDGE, height - EDGE)
    starts = rng.uniform(low, high, size=(agents, 2))
    count = int(rng.integers(TARGETS[0], TARGETS[1] + 1))
    targets = []
    for target_id in range(1, count + 1):
        born = int(rng.integers(1, min(BORN_LAST, steps) + 1))
        died = born + int(rng.integers(LIFETIME[0], LIFETIME[1] + 1)) - 1
        start = rng.uniform((0.0, 0.0), (width, height))
        end = np.clip(start + rng.normal(0.0, SPEED_STD, 2) * (died - born),
                      (0.0, 0.0), (width, height))
        targets.append({'id': target_id, 'born': born, 'died': died,
                        'start': start.tolist(), 'end': end.tolist()})
    return scenario_from_mapping({
        'name': 'random', 'seed': int(seed), 'steps': int(steps),
        'truth_process_noise': TRUTH_PROCESS_NOISE,
        'agents': [{'id': i + 1, 'start': p.tolist()} for i, p in enumerate(starts)],
        'targets': targets}, width, height)


def scenario_for(cell: Cell, seed: int, base: SatParams, paper: Scenario) -> Scenario:
    """Return the cell's scenario for one seed (paper: the paper's scenario, read once)."""
    if cell.setting == 'paper':
        return replace(paper.with_seed(seed), steps=cell.steps)
    return random_scenario(seed, cell.agents, cell.steps, base.area.width, base.area.height)


def run_one(cell: Cell, seed: int, base: SatParams, paper: Scenario) -> dict:
    """Run one seed of one cell; return its CSV row, per-target rows and time series."""
    scenario = scenario_for(cell, seed, base, paper)
    run = run_swarm(scenario, cell.params(base))
    metrics = compute_metrics(run.records, scenario.name, seed)
    steps = metrics['steps']
    summary = dict(metrics['summary'], wall_time_s=run.seconds,
                   searched_pct_100=steps[min(100, len(steps)) - 1]['searched_pct'])
    row = {name: getattr(cell, name) for name in CONFIG_COLUMNS}
    row.update(seed=int(seed), **{name: summary[name] for name in METRICS})
    return {'row': row, 'cell': cell,
            'targets': [dict(t, label=cell.label, setting=cell.setting, seed=int(seed))
                        for t in metrics['targets']],
            'ospa': np.array([s['ospa'] for s in steps]),
            'searched': np.array([s['searched_pct'] for s in steps])}


def _cost(job) -> float:
    """Rough relative cost of a job (agents x steps), to start the longest first."""
    cell, _ = job
    return cell.agents * cell.steps * (1.0 + cell.clutter / 30.0)


def run_study(cells: Sequence[Cell], seeds: Sequence[int], base: SatParams, paper: Scenario,
              jobs: int, progress: bool = True) -> List[dict]:
    """Run every (cell, seed) over `jobs` processes; results in cell then seed order."""
    work = sorted(((cell, seed) for cell in cells for seed in seeds), key=_cost, reverse=True)
    results = []
    with ProcessPoolExecutor(max_workers=jobs) as pool:
        futures = [pool.submit(run_one, cell, seed, base, paper) for cell, seed in work]
        for future in tqdm(as_completed(futures), total=len(futures), disable=not progress,
                           desc='runs', unit='run'):
            results.append(future.result())
    order = {cell: index for index, cell in enumerate(cells)}
    return sorted(results, key=lambda r: (order[r['cell']], r['row']['seed']))


def write_csv(rows: Sequence[dict], path: Path) -> None:
    """Write dict rows with the keys of the first row as header."""
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


# The summary table: (header, CSV column, scale, decimals).
TABLE = (('OSPA (m)', 'mean_ospa', 1.0, 2), ('loc. (m)', 'mean_ospa_loc', 1.0, 2),
         ('card. (m)', 'mean_ospa_card', 1.0, 2),
         ('time to detection (steps)', 'mean_time_to_detection', 1.0, 1),
         ('detected %', 'detected_share', 100.0, 0), ('tracked %', 'tracked_share', 100.0, 0),
         ('searched % k=100', 'searched_pct_100', 1.0, 1),
         ('searched % final', 'final_searched_pct', 1.0, 1),
         ('duplicate steps', 'duplicate_tracking_steps', 1.0, 1),
         ('msgs/agent/step', 'radio_msgs_per_agent_step', 1.0, 2),
         ('kB/agent/step', 'bytes_per_agent_step', 1e-3, 1))


def summary_table(cells: Sequence[Cell], rows: Sequence[dict]) -> str:
    """Markdown table: one line per cell, mean +- std of each metric and N seeds."""
    header = ['setting', 'configuration', 'N'] + [name for name, *_ in TABLE]
    lines = ['| ' + ' | '.join(header) + ' |', '|' + ' --- |' * len(header)]
    for cell in cells:
        mine = [r for r in rows if r['setting'] == cell.setting and r['label'] == cell.label]
        values = [cell.setting, cell.label, str(len(mine))]
        for _, column, scale, decimals in TABLE:
            data = np.array([r[column] for r in mine if r[column] is not None], dtype=float)
            values.append(_mean_std(scale * data, decimals))
        lines.append('| ' + ' | '.join(values) + ' |')
    return '\n'.join(lines)


def _mean_std(data: np.ndarray, decimals: int) -> str:
    if not data.size:
        return 'n/a'
    return f'{np.mean(data):.{decimals}f} ± {np.std(data):.{decimals}f}'


def write_summary(cells: Sequence[Cell], rows: Sequence[dict], path: Path, seconds: float,
                  command: str) -> str:
    """Write evaluation_summary.md (table and how it was made); return the table."""
    table = summary_table(cells, rows)
    path.write_text(
        '# Evaluation summary\n\n'
        f'Mean ± std over N seeds per configuration; {len(rows)} runs in {seconds / 60:.1f} min '
        f'on {os.cpu_count()} cores, made by `{command}` (`make evaluate` regenerates the whole '
        'study); one row per run in evaluation.csv, the design in '
        '`sat_world_sim/evaluate.py`.\n\n'
        f'{table}\n', encoding='utf-8')
    return table


README_MARKERS = ('<!-- evaluation table: start (written by evaluate --readme) -->',
                  '<!-- evaluation table: end -->')


def _readme_parts(path: Path) -> tuple:
    """Split a README around its table: (text up to the start marker, text from the end one)."""
    text = path.read_text(encoding='utf-8')
    start, end = (text.find(marker) for marker in README_MARKERS)
    if start < 0 or end < start:
        raise ValueError(f'{path}: the markers {README_MARKERS} are missing (in this order)')
    return text[:start + len(README_MARKERS[0])], text[end:]


def update_readme(path: Path, table: str) -> None:
    """Replace the table between README_MARKERS in path, so the README shows the last study."""
    head, tail = _readme_parts(path)
    path.write_text(f'{head}\n{table}\n{tail}', encoding='utf-8')


def main(argv=None) -> int:
    """Command-line entry point (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--seeds', type=int, default=20, help='seeds per cell (1..N)')
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1,
                        help='worker processes (default: every core)')
    parser.add_argument('--out', default='docs', help='output directory (default: docs)')
    parser.add_argument('--params', default='config/paper.yaml',
                        help='ROS 2 parameter file of the base parameters')
    parser.add_argument('--scenario', default='config/scenarios/paper.yaml',
                        help="the paper's scenario file")
    parser.add_argument('--readme', default=None,
                        help='also write the summary table into this README (between markers)')
    parser.add_argument('--quick', action='store_true',
                        help=f'smoke test: {QUICK_STEPS} steps per run (every cell, --seeds)')
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.jobs < 1:
        print(f'error: --seeds = {args.seeds} and --jobs = {args.jobs}: both must be >= 1',
              file=sys.stderr)
        return 2
    try:
        base = load_params_file(args.params)
        paper = load_scenario(args.scenario, base.area.width, base.area.height)
        if args.readme:
            _readme_parts(Path(args.readme))   # refuse a README without markers before the runs
    except (ValueError, OSError) as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    # Imported here: the figures need matplotlib, the worker processes do not.
    from sat_world_sim.evaluation_plots import write_figures

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    cells = study_cells(QUICK_STEPS if args.quick else STEPS)
    started = time.perf_counter()
    results = run_study(cells, range(1, args.seeds + 1), base, paper, args.jobs,
                        progress=sys.stderr.isatty())
    rows = [r['row'] for r in results]
    write_csv(rows, out / 'evaluation.csv')
    write_csv([t for r in results for t in r['targets']], out / 'evaluation_targets.csv')
    figures = write_figures(cells, results, out)
    seconds = time.perf_counter() - started
    given = sys.argv[1:] if argv is None else list(argv)
    command = ' '.join(['evaluate'] + given)

    table = write_summary(cells, rows, out / 'evaluation_summary.md', seconds, command)
    if args.readme:
        update_readme(Path(args.readme), table)
    print(table)
    print(f'{len(rows)} runs in {seconds:.0f} s; wrote {out / "evaluation.csv"}, '
          f'{out / "evaluation_summary.md"} and {len(figures)} figures', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
