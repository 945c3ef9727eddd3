import numpy as np
import pytest

from sat_world_sim.evaluate import write_csv
from sat_world_sim.run_comparison import compare_runs, comparison_table, main


def rows(label, seeds, detected, ospa, setting='random'):
    return [{'setting': setting, 'label': label, 'seed': str(s), 'detected_share': str(d),
             'mean_ospa': str(o)} for s, d, o in zip(seeds, detected, ospa)]


SEEDS = list(range(2001, 2021))
RNG = np.random.default_rng(3)
DETECTED = RNG.uniform(0.3, 0.9, len(SEEDS))
OSPA = RNG.uniform(5.0, 8.0, len(SEEDS))
# A trial that detects 5 points more (give or take 1) on every seed, with the same OSPA.
GAIN = 0.05 + RNG.normal(0.0, 0.01, len(SEEDS))
BASE = rows('SAT-PHD persistent', SEEDS, DETECTED, OSPA)
TRIAL = rows('SAT-PHD persistent with x=1', SEEDS, DETECTED + GAIN, OSPA)


def test_a_trial_is_paired_seed_by_seed_with_shares_in_percent():
    detected, ospa = compare_runs(BASE, TRIAL, metrics=('detected_share', 'mean_ospa'))
    assert detected.setting == 'random' and detected.difference.n == len(SEEDS)
    assert detected.mean_a == pytest.approx(100 * DETECTED.mean())
    assert detected.difference.estimate == pytest.approx(100 * GAIN.mean())
    assert detected.difference.low < 100 * GAIN.mean() < detected.difference.high
    assert detected.difference.significant   # 20 positive differences: Wilcoxon p ~ 2e-6
    assert ospa.difference.estimate == 0.0 and ospa.difference.p_value == 1.0
    table = comparison_table([detected, ospa])
    assert f'| random | detected_share | {100 * DETECTED.mean():.2f} |' in table
    assert f'{100 * GAIN.mean():+.2f}* [' in table and '| 0.000 | 20 |' in table


def test_only_the_seeds_both_runs_hold_are_paired():
    (detected,) = compare_runs(BASE[:15], TRIAL[5:], metrics=('detected_share',))
    assert detected.difference.n == 10
    assert detected.mean_a == pytest.approx(100 * DETECTED[5:15].mean())


def test_a_run_with_several_cells_at_a_setting_needs_a_label():
    both = BASE + rows('lawnmower', SEEDS, DETECTED / 2, OSPA + 1)
    with pytest.raises(ValueError, match=r"A holds 2 cells at random \(\['SAT-PHD persistent', "
                                         r"'lawnmower'\]\): choose one with --label-a"):
        compare_runs(both, TRIAL)
    (detected,) = compare_runs(both, TRIAL, label_a='lawnmower', metrics=('detected_share',))
    assert detected.mean_a == pytest.approx(50 * DETECTED.mean())
    with pytest.raises(ValueError, match='B has no cell random/nothing'):
        compare_runs(BASE, TRIAL, label_b='nothing')


def test_runs_that_share_no_setting_or_seed_are_refused():
    with pytest.raises(ValueError, match='share no setting'):
        compare_runs(BASE, rows('x', SEEDS, DETECTED, OSPA, setting='paper'))
    with pytest.raises(ValueError, match='share no seed at random'):
        compare_runs(BASE[:5], TRIAL[5:])


def test_the_script_prints_the_table_and_refuses_what_it_cannot_pair(tmp_path, capsys):
    a, b = str(tmp_path / 'a.csv'), str(tmp_path / 'b.csv')
    write_csv(BASE, a, list(BASE[0]))
    write_csv(TRIAL, b, list(TRIAL[0]))
    assert main([a, b, '--metric', 'detected_share']) == 0
    out = capsys.readouterr().out
    assert out.startswith('| setting | metric | A | B | B - A [95 % CI] | Wilcoxon p | seeds |')
    assert out.count('\n| random |') == 1
    assert main([a, b, '--metric', 'nothing']) == 2
    assert "--metric ['nothing']: not a column of both runs" in capsys.readouterr().err
    assert main([a, str(tmp_path / 'missing.csv')]) == 2
    assert 'missing.csv: no rows' in capsys.readouterr().err
