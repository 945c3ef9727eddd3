"""Figures of the Monte Carlo evaluation (evaluate.py), matplotlib with the Agg backend.

- ``evaluation_time.png``: per setting, the mean over seeds of OSPA and of the area searched %
  at every step, one line per cell of the main table (policies and profiles);
- ``evaluation_detection.png``: per setting, box plots of every target's time to detection
  (steps from birth; a target never detected counts the steps it was alive) per cell;
- ``evaluation_ablation.png`` (when the ablation ran): per setting, the paired difference to
  cooperative SAT-PHD of the detected share and of OSPA with its 95 % CI, per addition
  switched off and for the strict profile;
- ``evaluation_sweeps.png`` (when the sweeps ran): SAT-PHD around the random default, mean ±
  std of OSPA and of the detected share against team size, clutter rate and radio range.
"""

from pathlib import Path
from typing import List, Sequence

import matplotlib

matplotlib.use('Agg')

import matplotlib.pyplot as plt  # noqa: E402 (the backend must be chosen first)
import numpy as np  # noqa: E402

from sat_world_sim.evaluation_tables import by_seed, table_cells  # noqa: E402
from sat_world_sim.paired_statistics import paired_difference, paired_values  # noqa: E402
from sat_world_sim.study_design import default_cell, is_setting_reference  # noqa: E402
from sat_world_sim.study_design import is_persistent_ablation  # noqa: E402
from sat_world_sim.study_design import reference_of, SETTINGS, UNLIMITED  # noqa: E402


def write_figures(cells, results: Sequence[dict], out_dir) -> List[Path]:
    """Write the figures of the cells that ran into out_dir; return their paths."""
    out = Path(out_dir)
    parts = table_cells(cells)
    paths = []
    if parts['main']:
        paths += [_time_figure(parts['main'], results, out / 'evaluation_time.png'),
                  _detection_figure(parts['main'], results, out / 'evaluation_detection.png')]
    if len(parts['ablation']) > 1:
        paths.append(_ablation_figure(parts['ablation'], cells, results,
                                      out / 'evaluation_ablation.png'))
    if parts['sweeps']:
        paths.append(_sweep_figure(parts['sweeps'], cells, results,
                                   out / 'evaluation_sweeps.png'))
    return paths


def _of(results, cell) -> List[dict]:
    return [r for r in results if r['cell'] == cell]


def _settings(cells) -> List[str]:
    return [name for name in SETTINGS if any(c.setting == name for c in cells)]


def _time_figure(cells, results, path: Path) -> Path:
    settings = _settings(cells)
    figure, axes = plt.subplots(len(settings), 2, figsize=(12, 3.6 * len(settings)),
                                sharex=True, squeeze=False)
    for row, setting in enumerate(settings):
        for cell in (c for c in cells if c.setting == setting):
            mine = _of(results, cell)
            ospa = np.mean([r['ospa'] for r in mine], axis=0)
            searched = np.mean([r['searched'] for r in mine], axis=0)
            steps = np.arange(1, len(ospa) + 1)
            axes[row, 0].plot(steps, ospa, label=cell.label, linewidth=1.2)
            axes[row, 1].plot(steps, searched, label=cell.label, linewidth=1.2)
        axes[row, 0].set_ylabel(f'mean OSPA (m)\n{SETTINGS[setting].title}', fontsize=8)
        axes[row, 1].set_ylabel('mean area searched (%)')
        axes[row, 1].legend(loc='lower right', fontsize=7)
    for axis in axes[-1]:
        axis.set_xlabel('step k')
    figure.suptitle('OSPA (c = 10 m, p = 2) and searched area over time, mean over seeds')
    return _save(figure, path)


def _detection_figure(cells, results, path: Path) -> Path:
    settings = _settings(cells)
    figure, axes = plt.subplots(1, len(settings), figsize=(6 * len(settings), 4.8),
                                squeeze=False)
    for axis, setting in zip(axes[0], settings):
        chosen = [c for c in cells if c.setting == setting]
        data = [[t['time_to_detection'] for r in _of(results, c) for t in r['targets']] or [0]
                for c in chosen]
        axis.boxplot(data, showmeans=True)
        axis.set_xticks(range(1, len(chosen) + 1), [c.label for c in chosen], rotation=30,
                        ha='right', fontsize=7)
        axis.set_title(SETTINGS[setting].title, fontsize=9)
        axis.set_ylabel('time to detection (steps from birth)')
    figure.suptitle('Time to first detection per target (never detected: censored at its '
                    'lifetime; triangles: means)', fontsize=10)
    return _save(figure, path)


def _ablation_figure(chosen, cells, results, path: Path) -> Path:
    data = by_seed([r['row'] for r in results])
    settings = _settings(chosen)
    metrics = (('detected_share', 100.0, 'Δ detected (% points)'),
               ('mean_ospa', 1.0, 'Δ OSPA (m)'))
    figure, axes = plt.subplots(len(settings), 2, figsize=(12, 0.4 * len(chosen) + 2.5),
                                squeeze=False)
    for row, setting in enumerate(settings):
        mine = [(c, reference_of(c, cells)) for c in chosen if c.setting == setting]
        mine = [(c, ref) for c, ref in mine if ref is not None]
        for column, (name, scale, unit) in enumerate(metrics):
            axis = axes[row, column]
            for y, (cell, reference) in enumerate(mine):
                d = paired_difference(*paired_values(data[cell.name][name],
                                                     data[reference.name][name]))
                axis.errorbar(scale * d.estimate, y, xerr=[[scale * (d.estimate - d.low)],
                                                           [scale * (d.high - d.estimate)]],
                              marker='o', color='C3' if d.significant else 'C0', capsize=3)
            axis.axvline(0.0, color='grey', linewidth=0.8)
            axis.set_yticks(range(len(mine)), [c.label for c, _ in mine], fontsize=7)
            axis.invert_yaxis()   # top to bottom in the ablation table's order
            axis.set_xlabel(unit)
            axis.set_title(SETTINGS[setting].title, fontsize=9)
    persistent = any(map(is_persistent_ablation, chosen))
    figure.suptitle('Paired difference to SAT-PHD (cooperative'
                    + ("; the persistent profile's ablation: to SAT-PHD persistent"
                       if persistent else '')
                    + '), 95 % bootstrap CI over seeds (red: Wilcoxon p < 0.01)', fontsize=10)
    return _save(figure, path)


def _sweep_figure(sweeps, cells, results, path: Path) -> Path:
    chosen = sweeps + [c for c in cells if c.setting == 'random' and is_setting_reference(c)]
    factors = (('agents', 'agents'), ('clutter', 'clutter rate lambda'),
               ('comm_range', 'radio range C_R (m)'))
    reference = default_cell('random')
    figure, axes = plt.subplots(2, 3, figsize=(12, 6.5))
    for column, (field, name) in enumerate(factors):
        others = [f for f, _ in factors if f != field]
        line = sorted((c for c in chosen if all(getattr(c, f) == getattr(reference, f)
                                                for f in others)),
                      key=lambda c: getattr(c, field))
        labels = [_value_label(field, getattr(c, field)) for c in line]
        for row, (key, scale, unit) in enumerate((('mean_ospa', 1.0, 'mean OSPA (m)'),
                                                  ('detected_share', 100.0, 'detected %'))):
            values = [[scale * r['row'][key] for r in _of(results, c)
                       if r['row'][key] is not None] for c in line]
            axes[row, column].errorbar(range(len(line)), [np.mean(v) for v in values],
                                       yerr=[np.std(v) for v in values], marker='o',
                                       capsize=4)
            axes[row, column].set_xticks(range(len(line)), labels)
            axes[row, column].set_ylabel(unit)
        axes[1, column].set_xlabel(name)
    figure.suptitle('SAT-PHD around the random default (4 agents, lambda 10, C_R 50 m): one '
                    'factor at a time, mean ± std over seeds', fontsize=10)
    return _save(figure, path)


def _value_label(field: str, value: float) -> str:
    if field == 'comm_range' and value >= UNLIMITED:
        return 'unlimited'
    return f'{value:g}'


def _save(figure, path: Path) -> Path:
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)
    return path
