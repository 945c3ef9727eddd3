"""Monte Carlo evaluation: SAT-PHD, its profiles, its ablation and baselines over many seeds.

Every run is the in-process swarm (inprocess_swarm.run_swarm, the reference loop the ROS graph
reproduces step for step) or the oracle sweep (oracle_sweep.py), scored by
metrics.compute_metrics, the code behind metrics.json. Every cell runs the same seeds, so
configurations meet the same truth (common random numbers) and are compared seed by seed
(paired_statistics.py). The settings, cells and designs are in study_design.py; the tables in
evaluation_tables.py; the figures in evaluation_plots.py.

Engine: with no ``--scheduler`` the runs go to a local process pool of ``--jobs`` processes
(one BLAS thread each); ``--scheduler local`` starts a Dask LocalCluster (``--jobs`` worker
processes, one thread each); ``--scheduler tcp://HOST:PORT`` submits them to a running Dask
distributed cluster (its workers need this project's environment: ``scripts/with_env.sh dask
worker tcp://HOST:PORT``). The longest runs go first. Before running, the study prints its run
count and a wall-time estimate from measured per-run CPU costs (``--costs``, an earlier
evaluation.csv; ``cost_model``).

Outputs in ``--out`` (docs/ by default): evaluation.csv (one row per run: CONFIG_COLUMNS, seed,
METRICS), evaluation_targets.csv (one row per target), evaluation_summary.md (every table and
how the study was made; with runs longer than STEPS, a long mission's, the targets born after
the first pass) and the figures; ``--readme`` writes the README's tables between its
markers. ``--tables-only`` runs nothing: it writes the tables of ``--out``'s evaluation.csv
again, into that summary (with its sections that come from the rows) and ``--readme`` (after
a change to the tables, or to rows merged from runs made apart).

    evaluate [--design default|full|factorial] [--only SETTING/LABEL ...] [--set KEY=VALUE ...]
             [--seeds 50] [--first-seed 1] [--jobs N] [--scheduler local|tcp://HOST:PORT]
             [--out docs] [--config config] [--readme README.md] [--quick | --steps N]
             [--costs CSV] [--dry-run] [--list] [--tables-only]

A trial (``--set KEY=VALUE``, e.g. the README's dev-seed figures) runs the chosen cells with
further parameters into another --out; ``scripts/compare_runs.py`` then pairs its rows with a
run of the cells as they are, seed by seed (run_comparison.py).
"""

import argparse
from collections import defaultdict
from concurrent.futures import as_completed, ProcessPoolExecutor
from contextlib import contextmanager, ExitStack
import csv
from dataclasses import replace
import logging
import multiprocessing
import os
from pathlib import Path
import sys
import time
from typing import Callable, Dict, Iterator, List, Optional, Sequence, Tuple

import numpy as np
from tqdm import tqdm

from sat_agent.config import SatParams

from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.oracle_sweep import run_oracle_sweep
from sat_world_sim.scenario import load_scenario, Scenario, ScenarioError
from sat_world_sim.study_design import catalogue, Cell, CONFIG_COLUMNS, DESIGNS, ORACLE_TRACK
from sat_world_sim.study_design import ORACLES
from sat_world_sim.study_design import prepare_cells
from sat_world_sim.study_design import scenario_for, SEEDS, select, STEPS, with_steps
from sat_world_sim.study_design import with_values

QUICK_STEPS = 15
# Columns of evaluation.csv after CONFIG_COLUMNS and the seed: metrics.py's summary, the area
# searched at k = 100, the run's wall and CPU time. Every name holds one of the words by which
# each acceptance script tells metrics from configuration (METRIC_WORDS).
METRICS = ('mean_ospa', 'mean_ospa_loc', 'mean_ospa_card', 'mean_time_to_detection',
           'detected_share', 'detectable_share', 'tracked_share', 'searched_pct_100',
           'final_searched_pct', 'duplicate_tracking_steps', 'false_track_steps',
           'radio_msgs_per_agent_step', 'bytes_per_agent_step', 'targets_to_detect',
           'wall_time_s', 'cpu_time_s')
# The files evaluate writes into --out: one row per run, one row per target of every run (the
# run, then metrics.json's per-target entry), the summary.
RUNS_CSV = 'evaluation.csv'
TARGETS_CSV = 'evaluation_targets.csv'
SUMMARY_MD = 'evaluation_summary.md'
TARGET_COLUMNS = ('setting', 'label', 'seed', 'id', 'born', 'died', 'first_in_view',
                  'first_detected', 'detection_delay', 'time_to_detection')
# Per script in /work/shared/acceptance that groups evaluation.csv's rows into cells by every
# column holding none of its words: a metric without one would make each run a cell of its own.
_ISSUE_6_WORDS = ('ospa', 'time', 'pct', 'detect', 'bytes', 'msgs', 'steps', 'tracked', 'dup')
METRIC_WORDS = {'issue-6-eval.sh': _ISSUE_6_WORDS,
                'issue-8-science.sh': _ISSUE_6_WORDS + ('share', 'wall', 'false', 'ceiling')}
# Columns renamed since an evaluation.csv was first written (old name: new name), so read_rows
# still reads a file of before: 'entered_share' held no word of issue-6-eval.sh's (2026-12-06).
RENAMED_COLUMNS = {'entered_share': 'detectable_share'}
# Threads of the numerical libraries in each worker (unless set already): runs are parallel
# across processes, and OpenBLAS's own threads on top of them made a run ~1.2x costlier in CPU
# and ~1.4-2x in wall time (random default, seeds 1-3, one process on 2 cores).
SINGLE_THREAD = dict.fromkeys(('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'), '1')


def run_one(cell: Cell, seed: int, params: SatParams, paper: Scenario,
            swarm: Callable = run_swarm) -> dict:
    """Run one seed of one cell; return its CSV row, per-target rows and time series.

    swarm(scenario, params) -> SwarmRun runs the cells that are not oracles (a diagnostic may
    pass a variant of run_swarm, e.g. triage_oracle.run_with_oracle_triage).
    """
    started = time.process_time()
    scenario = scenario_for(cell, seed, params, paper)
    if cell.is_oracle:
        run = run_oracle_sweep(scenario, params, follow=cell.policy == ORACLE_TRACK)
    else:
        run = swarm(scenario, params)
    metrics = compute_metrics(run.records, scenario.name, seed)
    steps = metrics['steps']
    summary = dict(metrics['summary'], wall_time_s=run.seconds,
                   searched_pct_100=steps[min(100, len(steps)) - 1]['searched_pct'],
                   cpu_time_s=time.process_time() - started)
    row = dict(cell.columns(), seed=int(seed), **{name: summary[name] for name in METRICS})
    return {'row': row, 'cell': cell,
            'targets': [dict(setting=cell.setting, label=cell.label, seed=int(seed), **t)
                        for t in metrics['targets']],
            'ospa': np.array([s['ospa'] for s in steps]),
            'searched': np.array([s['searched_pct'] for s in steps])}


# ---------------------------------------------------------------- costs and estimates

def cost_model(rows: Sequence[dict]):
    """Return cost(cell) -> estimated CPU seconds of one run, from measured rows.

    A cell measured before costs its mean measured cost. Otherwise its agents x steps times
    the measured CPU seconds per agent-step of the first of these groups with measured runs:
    the same setting, policy, planner and clutter; the same setting, policy and planner; the
    setting's SAT-PHD with greedy walks (profiles, the ablation and policies not measured yet
    count as costing what SAT-PHD costs); the same policy and planner anywhere; every run.
    Rows carry ``cpu_time_s`` (older studies: ``wall_time_s``). With no rows, the cost is None.
    """
    per_run, per_agent_step = defaultdict(list), defaultdict(list)
    for row in rows:
        seconds = row.get('cpu_time_s') or row.get('wall_time_s')
        if seconds in (None, ''):
            continue
        per_run[_cell_key(row)].append(float(seconds))
        rate = float(seconds) / (float(row['agents']) * float(row['steps']))
        for key in _rate_keys(row, measured=True):
            per_agent_step[key].append(rate)

    def cost(cell: Cell) -> Optional[float]:
        columns = cell.columns()
        if _cell_key(columns) in per_run:
            return float(np.mean(per_run[_cell_key(columns)]))
        for key in _rate_keys(columns, measured=False):
            if key in per_agent_step:
                return float(np.mean(per_agent_step[key])) * cell.agents * cell.steps
        return None
    return cost


def _cell_key(columns) -> tuple:
    return (columns['setting'], columns['label'], float(columns['agents']),
            float(columns['clutter']), float(columns['comm_range']), float(columns['steps']))


def _rate_keys(columns, measured: bool) -> List[tuple]:
    """Return the groups of cost_model, most specific first (of a measured row or a cell)."""
    setting, policy, planner = columns['setting'], columns['policy'], columns['planner']
    keys = [('clutter', setting, policy, planner, float(columns['clutter'])),
            ('kind', setting, policy, planner)]
    if not measured and policy not in ORACLES:
        keys.append(('kind', setting, 'sat', 'greedy'))
    return keys + [('policy', policy, planner), ('all',)]


def read_rows(path) -> List[dict]:
    """Rows of one of the CSV files evaluate writes (none if the file does not exist)."""
    if not Path(path).exists():
        return []
    with open(path, newline='', encoding='utf-8') as stream:
        return [{RENAMED_COLUMNS.get(k, k): v for k, v in row.items()}
                for row in csv.DictReader(stream)]


def estimate(cells: Sequence[Cell], seeds: int, jobs: int, cost) -> Tuple[int, Optional[float],
                                                                          List[str]]:
    """Return (runs, wall seconds estimated on `jobs` workers or None, unmeasured cells)."""
    costs = {cell.name: cost(cell) for cell in cells}
    unknown = [name for name, value in costs.items() if value is None]
    known = [value for value in costs.values() if value is not None]
    if not known:
        return len(cells) * seeds, None, unknown
    # Unmeasured cells are counted at the costliest measured cell's cost per run.
    total = seeds * (sum(known) + len(unknown) * max(known))
    return len(cells) * seeds, max(total / jobs, max(known)), unknown


# ---------------------------------------------------------------- engine

@contextmanager
def executor(scheduler: Optional[str], jobs: int) -> Iterator:
    """Yield a concurrent.futures executor: a process pool, a Dask LocalCluster or a cluster."""
    if scheduler is None:
        for name, value in SINGLE_THREAD.items():   # read by the spawned workers' numpy
            os.environ.setdefault(name, value)
        with ProcessPoolExecutor(max_workers=jobs,
                                 mp_context=multiprocessing.get_context('spawn')) as pool:
            yield pool
        return
    from distributed import Client, LocalCluster

    with ExitStack() as stack:
        if scheduler == 'local':
            # Dask's nanny sets one BLAS thread per worker process (pre-spawn-environ).
            cluster = stack.enter_context(LocalCluster(
                n_workers=jobs, threads_per_worker=1, processes=True, dashboard_address=None,
                silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
        else:
            client = stack.enter_context(Client(scheduler))
        yield client.get_executor(pure=False)


def run_study(jobs_list: Sequence[Tuple[Cell, SatParams]], seeds: Sequence[int],
              paper: Scenario, jobs: int, scheduler: Optional[str] = None, cost=None,
              progress: bool = True, swarm: Callable = run_swarm) -> List[dict]:
    """Run every (cell, seed) on the executor; results in cell then seed order (swarm: run_one)."""
    work = [(cell, params, seed) for cell, params in jobs_list for seed in seeds]
    if cost is not None:
        work.sort(key=lambda job: -(cost(job[0]) or 0.0))
    results = []
    with executor(scheduler, jobs) as pool:
        futures = [pool.submit(run_one, cell, seed, params, paper, swarm)
                   for cell, params, seed in work]
        for future in tqdm(as_completed(futures), total=len(futures), disable=not progress,
                           desc='runs', unit='run'):
            results.append(future.result())
    order = {cell: index for index, (cell, _) in enumerate(jobs_list)}
    return sorted(results, key=lambda r: (order[r['cell']], r['row']['seed']))


# ---------------------------------------------------------------- outputs

def write_csv(rows: Sequence[dict], path: Path, columns: Sequence[str]) -> None:
    """Write dict rows under the given header."""
    with open(path, 'w', newline='', encoding='utf-8') as stream:
        writer = csv.DictWriter(stream, fieldnames=list(columns))
        writer.writeheader()
        writer.writerows(rows)


def cost_table(cells: Sequence[Cell], rows: Sequence[dict]) -> str:
    """Markdown: per cell, mean CPU and wall seconds per run (what the next estimate uses)."""
    lines = ['| setting | configuration | runs | CPU s/run | wall s/run |', '| --- | --- | --- '
             '| --- | --- |']
    for cell in cells:
        mine = [r for r in rows if r['setting'] == cell.setting and r['label'] == cell.label]
        # float(): rows read back from a CSV (--tables-only) hold strings.
        lines.append(f'| {cell.setting} | {cell.label} | {len(mine)} | '
                     f"{np.mean([float(r['cpu_time_s']) for r in mine]):.2f} | "
                     f"{np.mean([float(r['wall_time_s']) for r in mine]):.2f} |")
    return '\n'.join(lines)


# The summary's sections computed from the rows, which --tables-only writes again too.
PER_CELL, COSTS = 'Mean ± std per cell', 'Cost per run'
TARGET_STEPS = 'Where the target-steps go'
# The summary's text before the target-step table (evaluation_tables.target_step_table).
TARGET_STEPS_NOTE = ('Per cell, pooled over its seeds (sums over runs divided by sums): the '
                     "share of the targets' steps alive before any sensing square held the "
                     'target, in view but not yet detected, and after the first detection; the '
                     'share tracked, of all and of those after a first detection; and the '
                     'targets missed, never in a square or in one but never detected.')
BIRTH_TIME = 'Targets born after the first pass'
BIRTH_TIME_NOTE = (f'Runs longer than {STEPS} steps (a long mission): the targets born by step '
                   f'{STEPS} and those born later, counted and their detected share pooled '
                   "over the seeds; the later-born's detected share per seed as a fraction of "
                   "the oracle sweep's, and the persistent profile minus each rival on it, "
                   'paired by seed (95 % bootstrap CI; * Wilcoxon p < 0.01).')


def row_sections(cells: Sequence[Cell], rows: Sequence[dict],
                 targets: Sequence[dict]) -> Dict[str, str]:
    """Return the bodies of the summary's sections that come from the runs' rows and targets."""
    from sat_world_sim.evaluation_tables import birth_time_table, summary_table
    from sat_world_sim.evaluation_tables import target_step_table

    steps = target_step_table(cells, rows, targets)
    sections = {PER_CELL: summary_table(cells, rows), COSTS: cost_table(cells, rows),
                TARGET_STEPS: f'{TARGET_STEPS_NOTE}\n\n{steps}' if steps
                else f"{TARGETS_CSV} holds none of these runs' targets."}
    births = birth_time_table(cells, rows, targets)
    if births:
        sections[BIRTH_TIME] = f'{BIRTH_TIME_NOTE}\n\n{births}'
    return sections


def write_summary(cells: Sequence[Cell], rows: Sequence[dict], targets: Sequence[dict],
                  path: Path, tables: str, skipped: Sequence[Tuple[Cell, str]], seconds: float,
                  command: str) -> None:
    """Write evaluation_summary.md: how the study was made, every table, what was skipped."""
    skipped_text = ''.join(f'- {cell.name}: {reason}\n' for cell, reason in skipped) or '- none\n'
    sections = row_sections(cells, rows, targets)
    rest = ''.join(f'## {title}\n\n{body}\n\n' for title, body in sections.items()
                   if title != PER_CELL)
    path.write_text(
        '# Evaluation summary\n\n'
        f'{len(rows)} runs in {seconds / 60:.1f} min on {os.cpu_count()} cores, made by '
        f'`{command}` (`make evaluate` regenerates the default study); one row per run in '
        f'{RUNS_CSV}, the design in `sat_world_sim/study_design.py`.\n\n'
        f'{TABLE_MARKERS[0]}\n{tables}\n{TABLE_MARKERS[1]}\n\n'
        f'## {PER_CELL}\n\n{sections[PER_CELL]}\n\n'
        f'## Cells skipped\n\n{skipped_text}\n{rest.rstrip()}\n', encoding='utf-8')


def replace_section(text: str, title: str, body: str) -> str:
    """Return text with the body of its section '## title' (up to the next one) replaced.

    A section the text does not have yet (a summary written before it existed) is appended.
    """
    head = f'## {title}\n\n'
    start = text.find(head)
    if start < 0:
        return text.rstrip('\n') + f'\n\n{head}{body}\n'
    start += len(head)
    end = text.find('\n\n## ', start)
    end = len(text.rstrip('\n')) if end < 0 else end
    return text[:start] + body + text[end:]


# Around the tables in the README and in evaluation_summary.md.
TABLE_MARKERS = ('<!-- evaluation table: start (written by evaluate --readme) -->',
                 '<!-- evaluation table: end -->')


def _readme_parts(path: Path) -> tuple:
    """Split a file around its tables: (text up to the start marker, text from the end one)."""
    text = path.read_text(encoding='utf-8')
    start, end = (text.find(marker) for marker in TABLE_MARKERS)
    if start < 0 or end < start:
        raise ValueError(f'{path}: the markers {TABLE_MARKERS} are missing (in this order)')
    return text[:start + len(TABLE_MARKERS[0])], text[end:]


def update_readme(path: Path, tables: str) -> None:
    """Replace the text between TABLE_MARKERS in path, so it shows the last study's tables."""
    head, tail = _readme_parts(path)
    path.write_text(f'{head}\n{tables}\n{tail}', encoding='utf-8')


def cells_of(rows: Sequence[dict]) -> List[Cell]:
    """Return the catalogue's cells that rows ran, in catalogue order, at the rows' length."""
    ran = {(r['setting'], r['label']): int(r['steps']) for r in rows}
    return [replace(cell, steps=ran[cell.setting, cell.label]) for cell in catalogue()
            if (cell.setting, cell.label) in ran]


def rewrite_tables(out: Path, readme: Optional[str]) -> str:
    """Write the tables of out/evaluation.csv into its summary and the README (--tables-only).

    In the summary, the sections that come from the rows (row_sections) are written again too;
    how the study was made and the cells skipped stay as they are.
    """
    from sat_world_sim.evaluation_tables import study_tables

    rows = read_rows(out / RUNS_CSV)
    targets = read_rows(out / TARGETS_CSV)
    if not rows:
        raise ValueError(f'{out / RUNS_CSV}: no runs to tabulate')
    cells = cells_of(rows)
    tables = study_tables(cells, rows)
    for path in [out / SUMMARY_MD] + ([Path(readme)] if readme else []):
        update_readme(path, tables)
    summary = out / SUMMARY_MD
    text = summary.read_text(encoding='utf-8')
    for title, body in row_sections(cells, rows, targets).items():
        text = replace_section(text, title, body)
    summary.write_text(text, encoding='utf-8')
    return tables


# ---------------------------------------------------------------- command line

def set_values(items: Sequence[str]) -> Tuple[Tuple[str, object], ...]:
    """Parse ``--set KEY=VALUE`` items (VALUE is YAML) and check them against the schema.

    ValueError (ParameterError: which parameter, what value, what is allowed) for a malformed
    item or a value the core refuses.
    """
    import yaml

    values = []
    for item in items:
        key, sep, text = item.partition('=')
        if not sep or not key.strip():
            raise ValueError(f'--set {item!r}: expected KEY=VALUE, e.g. '
                             'phd.birth_velocity_std=0.5')
        try:
            values.append((key.strip(), yaml.safe_load(text)))
        except yaml.YAMLError as problem:
            raise ValueError(f'--set {item!r}: the value is not YAML: {problem}') from None
    if values:
        SatParams().with_overrides(dict(values))
    return tuple(values)


def trial_values(items: Sequence[str], out, readme) -> Tuple[Tuple[str, object], ...]:
    """Parse a trial's ``--set`` items (``set_values``).

    ValueError also for an --out of docs/ or a --readme, which hold the committed study.
    """
    values = set_values(items)
    if values and (Path(out).resolve() == Path('docs').resolve() or readme):
        raise ValueError('--set makes trial cells, not the committed study: give --out DIR '
                         '(not docs/) and no --readme')
    return values


def _arguments(argv):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--design', choices=sorted(DESIGNS), default='default',
                        help='which cells (study_design.py; default: the make evaluate study)')
    parser.add_argument('--only', action='append', default=[], metavar='SETTING/LABEL',
                        help="run this cell only (repeatable; any design's cell)")
    parser.add_argument('--set', action='append', default=[], metavar='KEY=VALUE',
                        help='a trial: run the cells with this dotted parameter too, e.g. '
                             'phd.birth_velocity_std=0.5 (repeatable; labels gain "with '
                             'KEY=VALUE"; needs an --out other than docs)')
    parser.add_argument('--list', action='store_true', help='list every cell and exit')
    parser.add_argument('--tables-only', action='store_true',
                        help="run nothing: write the tables of --out's evaluation.csv again "
                             'into its evaluation_summary.md and --readme')
    parser.add_argument('--dry-run', action='store_true',
                        help='print the run count and the wall-time estimate, run nothing')
    parser.add_argument('--seeds', type=int, default=SEEDS, help=f'seeds per cell ({SEEDS})')
    parser.add_argument('--first-seed', type=int, default=1,
                        help='first seed (default 1; held-out seeds: 1001)')
    parser.add_argument('--jobs', type=int, default=os.cpu_count() or 1,
                        help='worker processes (default: every core)')
    parser.add_argument('--scheduler', default=None,
                        help="Dask scheduler address tcp://HOST:PORT, or 'local' for a "
                             'LocalCluster of --jobs workers (default: a process pool)')
    parser.add_argument('--out', default='docs', help='output directory (default: docs)')
    parser.add_argument('--config', default='config',
                        help='directory of the profiles (<profile>.yaml) and scenarios/paper.yaml')
    parser.add_argument('--readme', default=None,
                        help='also write the tables into this README (between markers)')
    parser.add_argument('--costs', default=f'docs/{RUNS_CSV}',
                        help='an earlier evaluation.csv whose measured run costs give the '
                             'wall-time estimate')
    length = parser.add_mutually_exclusive_group()
    length.add_argument('--quick', action='store_const', const=QUICK_STEPS, dest='steps',
                        help=f'smoke test: {QUICK_STEPS} steps per run')
    length.add_argument('--steps', type=int, help=f'steps per run ({STEPS})')
    parser.set_defaults(steps=STEPS)
    return parser.parse_args(argv)


def _estimate_line(ran: Sequence[Cell], skipped: Sequence[Cell], args, cost) -> str:
    runs, wall, unmeasured = estimate(ran, args.seeds, args.jobs, cost)
    where = 'workers' if args.scheduler else 'processes'
    if wall is None:
        return (f'{len(ran)} cells x {args.seeds} seeds = {runs} runs of {args.steps} steps on '
                f'{args.jobs} {where}; no measured run costs in {args.costs} for an estimate')
    unmeasured = f'; {len(unmeasured)} cells unmeasured, counted as the costliest' \
        if unmeasured else ''
    line = (f'{len(ran)} cells x {args.seeds} seeds = {runs} runs of {args.steps} steps on '
            f'{args.jobs} {where}: about {wall / 60:.0f} min (run costs measured in '
            f'{args.costs}{unmeasured})')
    if skipped:
        _, wall_all, _ = estimate(list(ran) + list(skipped), args.seeds, args.jobs, cost)
        line += f'; about {wall_all / 60:.0f} min once the {len(skipped)} skipped cells can run'
    return line


def main(argv=None) -> int:
    """Command-line entry point (module docstring)."""
    args = _arguments(argv)
    if args.list:
        print('\n'.join(f'{cell.name}  [{", ".join(n for n, cs in DESIGNS.items() if cell in cs)}]'
                        for cell in catalogue()))
        return 0
    if args.tables_only:
        try:
            print(rewrite_tables(Path(args.out), args.readme))
        except (ValueError, OSError) as error:
            print(f'error: {error}', file=sys.stderr)
            return 2
        return 0
    problems = [f'{name} = {value}: must be >= {low}' for name, value, low in (
        ('--seeds', args.seeds, 1), ('--jobs', args.jobs, 1), ('--first-seed', args.first_seed, 0),
        ('--steps', args.steps, 1))
        if value < low]
    try:
        if problems:
            raise ValueError('; '.join(problems))
        cells = with_steps(select(args.only) if args.only else DESIGNS[args.design], args.steps)
        cells = with_values(cells, trial_values(args.set, args.out, args.readme))
        paper = load_scenario(Path(args.config) / 'scenarios' / 'paper.yaml')
        if args.readme:
            _readme_parts(Path(args.readme))   # refuse a README without markers before the runs
    except (ValueError, OSError, ScenarioError) as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    runnable, skipped = prepare_cells(cells, args.config)
    for cell, reason in skipped:
        print(f'skipped {cell.name}: {reason}', file=sys.stderr)
    if not runnable:
        print('error: no cell can run (see the skipped cells above)', file=sys.stderr)
        return 2
    ran = [cell for cell, _ in runnable]
    cost = cost_model(read_rows(args.costs))
    print(_estimate_line(ran, [cell for cell, _ in skipped], args, cost), file=sys.stderr)
    if args.dry_run:
        return 0
    # Imported here: the figures need matplotlib, the worker processes do not.
    from sat_world_sim.evaluation_plots import write_figures
    from sat_world_sim.evaluation_tables import study_tables

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    results = run_study(runnable, seeds, paper, args.jobs, args.scheduler, cost,
                        progress=sys.stderr.isatty())
    rows = [r['row'] for r in results]
    write_csv(rows, out / RUNS_CSV, CONFIG_COLUMNS + ('seed',) + METRICS)
    targets = [t for r in results for t in r['targets']]
    write_csv(targets, out / TARGETS_CSV, TARGET_COLUMNS)
    figures = write_figures(ran, results, out)
    tables = study_tables(ran, rows)
    seconds = time.perf_counter() - started
    given = sys.argv[1:] if argv is None else list(argv)
    write_summary(ran, rows, targets, out / SUMMARY_MD, tables, skipped, seconds,
                  ' '.join(['evaluate'] + given))
    if args.readme:
        update_readme(Path(args.readme), tables)
    print(tables)
    print(f'{len(rows)} runs in {seconds:.0f} s; wrote {out / RUNS_CSV}, '
          f'{out / SUMMARY_MD} and {len(figures)} figures', file=sys.stderr)
    return 0


if __name__ == '__main__':
    sys.exit(main())
