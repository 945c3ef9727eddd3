"""Figures of the Monte Carlo evaluation (evaluate.py), matplotlib with the Agg backend.

- ``evaluation_time.png``: per setting, the mean over seeds of OSPA and of the area searched %
  at every step, one line per policy;
- ``evaluation_detection.png``: per setting, box plots of every target's time to detection
  (steps from birth; a target never detected counts the steps it was alive) per policy;
- ``evaluation_sweeps.png``: SAT-PHD around the random default, mean +- std of OSPA and of
  the time to detection against team size, clutter rate and radio range.
"""

from pathlib import Path
from typing import List, Sequence

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402 (the backend must be chosen first)
import numpy as np  # noqa: E402

SETTINGS = (('paper', "paper's scenario (2 agents, 2 targets)"),
            ('random', 'random default (4 agents, 2-10 targets)'))


def write_figures(cells, results: Sequence[dict], out_dir) -> List[Path]:
    """Write the three PNGs into out_dir; return their paths."""
    out = Path(out_dir)
    return [_time_figure(cells, results, out / 'evaluation_time.png'),
            _detection_figure(cells, results, out / 'evaluation_detection.png'),
            _sweep_figure(cells, results, out / 'evaluation_sweeps.png')]


def _of(results, cell) -> List[dict]:
    return [r for r in results if r['cell'] == cell]


def _policy_cells(cells, setting):
    """Pick a setting's policy comparison: its cells with the default agents and clutter."""
    first = next(c for c in cells if c.setting == setting)
    return [c for c in cells if c.setting == setting and c.agents == first.agents
            and c.clutter == first.clutter and c.comm_range in (0.0, first.comm_range)]


def _time_figure(cells, results, path: Path) -> Path:
    figure, axes = plt.subplots(2, 2, figsize=(12, 8), sharex=True)
    for row, (setting, title) in enumerate(SETTINGS):
        for cell in _policy_cells(cells, setting):
            mine = _of(results, cell)
            ospa = np.mean([r['ospa'] for r in mine], axis=0)
            searched = np.mean([r['searched'] for r in mine], axis=0)
            steps = np.arange(1, len(ospa) + 1)
            axes[row, 0].plot(steps, ospa, label=cell.label, linewidth=1.2)
            axes[row, 1].plot(steps, searched, label=cell.label, linewidth=1.2)
        axes[row, 0].set_ylabel(f'mean OSPA (m)\n{title}')
        axes[row, 1].set_ylabel('mean area searched (%)')
    axes[0, 1].legend(loc='lower right', fontsize=8)
    for axis in axes[1]:
        axis.set_xlabel('step k')
    figure.suptitle('OSPA (c = 10 m, p = 2) and searched area over time, mean over seeds')
    return _save(figure, path)


def _detection_figure(cells, results, path: Path) -> Path:
    figure, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for axis, (setting, title) in zip(axes, SETTINGS):
        chosen = _policy_cells(cells, setting)
        data = [[t['time_to_detection'] for r in _of(results, c) for t in r['targets']]
                for c in chosen]
        axis.boxplot(data, showmeans=True)
        axis.set_xticks(range(1, len(chosen) + 1), [c.label for c in chosen], rotation=20,
                        ha='right', fontsize=8)
        axis.set_title(title, fontsize=10)
        axis.set_ylabel('time to detection (steps from birth)')
    figure.suptitle('Time to first detection per target (never detected: censored at its '
                    'lifetime; triangles: means)', fontsize=10)
    return _save(figure, path)


def _sweep_figure(cells, results, path: Path) -> Path:
    default = _policy_cells(cells, 'random')[0]
    factors = (('agents', 'agents'), ('clutter', 'clutter rate lambda'),
               ('comm_range', 'radio range C_R (m)'))
    figure, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    for column, (field, name) in enumerate(factors):
        others = [f for f, _ in factors if f != field]
        chosen = [c for c in cells if c.setting == 'random' and c.policy == default.policy
                  and c.planner == default.planner
                  and all(getattr(c, f) == getattr(default, f) for f in others)]
        chosen.sort(key=lambda c: getattr(c, field))
        labels = [_value_label(field, getattr(c, field)) for c in chosen]
        for row, (key, unit) in enumerate((('mean_ospa', 'mean OSPA (m)'),
                                           ('mean_time_to_detection',
                                            'time to detection (steps)'))):
            values = [[r['row'][key] for r in _of(results, c)] for c in chosen]
            axes[row, column].errorbar(range(len(chosen)), [np.mean(v) for v in values],
                                       yerr=[np.std(v) for v in values], marker='o',
                                       capsize=4)
            axes[row, column].set_xticks(range(len(chosen)), labels)
            axes[row, column].set_ylabel(unit)
        axes[1, column].set_xlabel(name)
    figure.suptitle('SAT-PHD around the random default (4 agents, lambda 10, C_R 50 m): one '
                    'factor at a time, mean ± std over seeds', fontsize=10)
    return _save(figure, path)


def _value_label(field: str, value: float) -> str:
    if field == 'comm_range' and value > 200:
        return 'unlimited'
    return f'{value:g}'


def _save(figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
