"""Two evaluation runs compared seed by seed: a trial against the cells as they are.

``evaluate --set KEY=VALUE --out DIR`` runs a trial (the cells with further parameters); this
pairs its rows with another evaluation.csv's (the same cells without them, made on the same
seeds), setting by setting: for each metric the two means, the mean paired difference B - A
with its 95 % bootstrap CI and the Wilcoxon signed-rank p (paired_statistics.py, as the study's
tables). Only seeds both files hold (and where both values are defined) are paired; shares
print in percent. ``main`` is scripts/compare_runs.py.
"""

import argparse
from dataclasses import dataclass
import sys
from typing import Dict, List, Optional, Sequence

import numpy as np

from sat_world_sim.evaluate import read_rows
from sat_world_sim.paired_statistics import paired_difference, PairedDifference
from sat_world_sim.paired_statistics import paired_values

METRICS = ('detected_share', 'detectable_share', 'tracked_share', 'mean_ospa',
           'false_track_steps', 'searched_pct_100')


@dataclass(frozen=True)
class MetricComparison:
    """One metric of one setting: means of A and B over the paired seeds, and B - A."""

    setting: str
    metric: str
    mean_a: float
    mean_b: float
    difference: PairedDifference


def _cell_rows(rows: Sequence[dict], setting: str, label: Optional[str], name: str) -> Dict:
    """Return {seed: row} of the setting's one cell (or the labelled one) in rows."""
    labels = sorted({r['label'] for r in rows if r['setting'] == setting})
    if label is None and len(labels) > 1:
        raise ValueError(f'{name} holds {len(labels)} cells at {setting} ({labels}): '
                         f'choose one with --label-{name.lower()}')
    chosen = labels[0] if label is None else label
    if chosen not in labels:
        raise ValueError(f'{name} has no cell {setting}/{chosen}; it has {labels}')
    return {int(r['seed']): r for r in rows if r['setting'] == setting and r['label'] == chosen}


def _value(row: dict, metric: str) -> float:
    text = row.get(metric, '')
    scale = 100.0 if metric.endswith('_share') else 1.0
    return float(text) * scale if text not in ('', 'None') else np.nan


def compare_runs(rows_a: Sequence[dict], rows_b: Sequence[dict],
                 label_a: Optional[str] = None, label_b: Optional[str] = None,
                 metrics: Sequence[str] = METRICS) -> List[MetricComparison]:
    """Pair B's rows with A's, setting by setting (the settings both hold), per metric.

    ValueError when the files share no setting or seed, or a file holds several cells at a
    setting and no label picks one.
    """
    settings = sorted({r['setting'] for r in rows_a} & {r['setting'] for r in rows_b})
    if not settings:
        raise ValueError('the two runs share no setting')
    found = []
    for setting in settings:
        a = _cell_rows(rows_a, setting, label_a, 'A')
        b = _cell_rows(rows_b, setting, label_b, 'B')
        if not set(a) & set(b):
            raise ValueError(f'the two runs share no seed at {setting}')
        for metric in metrics:
            # Seeds where either value is undefined (no time to detection: no target) drop out.
            y, x = paired_values({s: _value(r, metric) for s, r in b.items()},
                                 {s: _value(r, metric) for s, r in a.items()})
            means = [float(np.mean(v)) if v.size else np.nan for v in (x, y)]
            found.append(MetricComparison(setting, metric, *means, paired_difference(y, x)))
    return found


def comparison_table(comparisons: Sequence[MetricComparison]) -> str:
    """Markdown table of the comparisons (* marks p < 0.01)."""
    lines = ['| setting | metric | A | B | B - A [95 % CI] | Wilcoxon p | seeds |',
             '| --- | --- | --- | --- | --- | --- | --- |']
    for c in comparisons:
        d = c.difference
        star = '*' if d.significant else ''
        lines.append(f'| {c.setting} | {c.metric} | {c.mean_a:.2f} | {c.mean_b:.2f} | '
                     f'{d.estimate:+.2f}{star} [{d.low:+.2f}, {d.high:+.2f}] | {d.p_value:.3f} | '
                     f'{d.n} |')
    return '\n'.join(lines)


def main(argv=None) -> int:
    """Print the paired comparison of B against A; exit 2 on files that cannot be paired."""
    parser = argparse.ArgumentParser(description='Compare two evaluation runs seed by seed.')
    parser.add_argument('a', help='the reference run (evaluation.csv)')
    parser.add_argument('b', help='the run compared with it (evaluation.csv)')
    parser.add_argument('--label-a', help="A's cell when it holds several at a setting")
    parser.add_argument('--label-b', help="B's cell when it holds several at a setting")
    parser.add_argument('--metric', action='append',
                        help=f'a column to compare (repeatable; default: {", ".join(METRICS)})')
    args = parser.parse_args(argv)
    try:
        rows_a, rows_b = read_rows(args.a), read_rows(args.b)
        for path, rows in ((args.a, rows_a), (args.b, rows_b)):
            if not rows:
                raise ValueError(f'{path}: no rows (missing or empty)')
        columns = [name for name in rows_a[0] if name in rows_b[0]]
        unknown = sorted(set(args.metric or ()) - set(columns))
        if unknown:
            raise ValueError(f'--metric {unknown}: not a column of both runs; they share '
                             f'{columns}')
        print(comparison_table(compare_runs(rows_a, rows_b, args.label_a, args.label_b,
                                            args.metric or METRICS)))
    except ValueError as error:
        print(f'error: {error}', file=sys.stderr)
        return 2
    return 0
