from dataclasses import replace

import numpy as np

from sat_world_sim.evaluate import BIRTH_TIME, cells_of, COSTS, main, METRICS, PER_CELL
from sat_world_sim.evaluate import row_sections, RUNS_CSV, SUMMARY_MD, TABLE_MARKERS
from sat_world_sim.evaluate import TARGET_COLUMNS, TARGET_STEPS, TARGETS_CSV, write_csv
from sat_world_sim.evaluation_plots import write_figures
from sat_world_sim.evaluation_tables import birth_time_table, rivals_table, study_tables
from sat_world_sim.evaluation_tables import table_cells
from sat_world_sim.evaluation_tables import target_phases, target_step_table
from sat_world_sim.study_design import CONFIG_COLUMNS, default_cell, ORACLE, ORACLE_LABEL
from sat_world_sim.study_design import PERSISTENT_LABEL, rivals_of, STRICT_LABEL

SEEDS = range(1, 21)
REFERENCE = default_cell('random')
STRICT = default_cell('random', STRICT_LABEL, profile='paper_strict')
ABLATED = default_cell('random', 'without confirmation',
                       overrides=(('additions.confirmation', False),))
LAWNMOWER = default_cell('random', 'lawnmower', policy='lawnmower')
ORACLE_CELL = default_cell('random', ORACLE_LABEL, policy=ORACLE, planner='none')
CELLS = [REFERENCE, STRICT, ABLATED, LAWNMOWER, ORACLE_CELL]
PERSISTENT = default_cell('random', PERSISTENT_LABEL, profile='persistent')
ELSEWHERE = default_cell('paper_random', 'lawnmower', policy='lawnmower')


def detected(cell, seed):
    """Shares built so that the differences to the reference are known."""
    base = 0.3 + 0.02 * seed
    return {REFERENCE: base, STRICT: base - 0.2, ABLATED: base + (0.01 if seed % 2 else -0.01),
            LAWNMOWER: base, ORACLE_CELL: 2 * base, PERSISTENT: base + 0.1,
            ELSEWHERE: base}[cell]


def result(cell, seed):
    row = dict(cell.columns(), seed=seed, **dict.fromkeys(METRICS, 1.0))
    # The persistent profile's OSPA is 0.5 m lower on every seed but the lawnmower's is higher.
    ospa = 5.0 + 0.1 * seed - 0.5 * (cell == PERSISTENT) + 0.5 * (cell == LAWNMOWER)
    row.update(detected_share=detected(cell, seed), mean_ospa=ospa)
    return {'row': row, 'cell': cell, 'ospa': np.full(10, 5.0), 'searched': np.linspace(0, 50, 10),
            'targets': [{'time_to_detection': seed}]}


RESULTS = [result(cell, seed) for cell in CELLS for seed in SEEDS]


def line(tables, part, label):
    block = tables.split('\n\n')[part]
    return next(row for row in block.splitlines() if f'| {label} |' in row)


def test_tables_mark_paired_differences_with_wilcoxon_p_below_001():
    tables = study_tables(CELLS, [r['row'] for r in RESULTS])
    assert '95 % CI' in tables and 'p < 0.01' in tables
    # Main table: strict detects 20 points fewer on every seed (significant); the lawnmower
    # ties on every seed (p = 1); the oracle is the ceiling: the reference reaches half of it.
    assert '| 51 (ref.) |' in line(tables, 1, 'SAT-PHD (cooperative)')
    assert '| 31 (−20 [−20, −20]*) |' in line(tables, 1, STRICT_LABEL)
    assert '| 51 (+0 [+0, +0]) |' in line(tables, 1, 'lawnmower')
    assert line(tables, 1, 'SAT-PHD (cooperative)').endswith('| 50 % [50, 50] |')
    assert line(tables, 1, ORACLE_LABEL).endswith('| 100 % [100, 100] |')
    # Ablation table: reference, strict and the addition; +-1 point alternating: no mark.
    ablation = tables.split('\n\n')[3]
    assert [row.split(' | ')[1] for row in ablation.splitlines()[2:]] == [
        'SAT-PHD (cooperative)', STRICT_LABEL, 'without confirmation']
    entry = line(tables, 3, 'without confirmation').split(' | ')[3]
    assert entry.startswith('51 (+0 [') and '*' not in entry


def test_cells_are_split_into_the_readmes_tables():
    parts = table_cells(CELLS)
    assert parts['main'] == [REFERENCE, STRICT, LAWNMOWER, ORACLE_CELL]
    assert parts['ablation'] == [REFERENCE, STRICT, ABLATED]
    assert parts['sweeps'] == parts['factorial'] == []


def test_figures_include_the_ablation_when_it_ran(tmp_path):
    paths = write_figures(CELLS, RESULTS, tmp_path)
    assert sorted(p.name for p in paths) == ['evaluation_ablation.png',
                                             'evaluation_detection.png', 'evaluation_time.png']
    for path in paths:
        assert path.read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'


def test_the_persistent_profile_is_set_against_every_other_policy_of_its_setting():
    # In the default design: every policy and profile at random but the oracle (a ceiling).
    from sat_world_sim.study_design import DESIGNS
    (persistent,) = [c for c in DESIGNS['default'] if c == PERSISTENT]
    assert [c.label for c in rivals_of(persistent, DESIGNS['default'])] == [
        'SAT-PHD (cooperative)', STRICT_LABEL, 'SAT-PHD, no radio', 'lawnmower', 'random walk',
        'SAT-PHD + OR-Tools', 'PHD-Voronoi', 'Thompson-sampling PHD']
    cells = CELLS + [PERSISTENT, ELSEWHERE]
    rows = [result(cell, seed)['row'] for cell in cells for seed in SEEDS]
    table = rivals_table(cells, rows)
    # Not the oracle, the ablation cell, itself nor another setting's cells.
    assert [r.split(' | ')[1] for r in table.splitlines()[2:]] == [
        'SAT-PHD (cooperative)', STRICT_LABEL, 'lawnmower']
    # Its mean, then persistent minus it: +10 and +30 points, -0.5 and -1 m on every seed.
    assert '| lawnmower | 20 | 51 | +10 [+10, +10]* | 6.55 | −1.00 [−1.00, −1.00]* |' in table
    assert '| 31 | +30 [+30, +30]* | 6.05 | −0.50 [−0.50, −0.50]* |' in table
    assert 'persistent − it' in study_tables(cells, rows)
    assert rivals_table(CELLS, [r['row'] for r in RESULTS]) == ''


def test_tables_only_writes_the_tables_of_a_csv_again_without_running(tmp_path, capsys):
    out = tmp_path / 'eval'
    out.mkdir()
    assert main(['--tables-only', '--out', str(out)]) == 2
    assert RUNS_CSV in capsys.readouterr().err
    cells = CELLS + [PERSISTENT]
    rows = [result(cell, seed)['row'] for cell in cells for seed in SEEDS]
    write_csv(rows, out / RUNS_CSV, CONFIG_COLUMNS + ('seed',) + METRICS)
    stale = f'{TABLE_MARKERS[0]}\nold\n{TABLE_MARKERS[1]}'
    (out / SUMMARY_MD).write_text(
        f'# Summary\n\n{stale}\n\n## {PER_CELL}\n\nold\n\n## Cells skipped\n\n- none\n\n'
        f'## {COSTS}\n\nold\n')
    readme = tmp_path / 'README.md'
    readme.write_text(f'# Title\n{stale}\nrest\n')
    assert main(['--tables-only', '--out', str(out), '--readme', str(readme)]) == 0
    tables = study_tables(cells, rows)
    assert capsys.readouterr().out.strip() == tables
    fresh = f'{TABLE_MARKERS[0]}\n{tables}\n{TABLE_MARKERS[1]}'
    assert readme.read_text() == f'# Title\n{fresh}\nrest\n'
    # The summary's sections made from the runs are written again (the target-step one, new
    # since that summary, appended); the cells skipped are not.
    sections = row_sections(cells_of(rows), rows, [])
    assert TARGETS_CSV in sections[TARGET_STEPS]
    assert (out / SUMMARY_MD).read_text() == (
        f'# Summary\n\n{fresh}\n\n## {PER_CELL}\n\n{sections[PER_CELL]}\n\n'
        f'## Cells skipped\n\n- none\n\n## {COSTS}\n\n{sections[COSTS]}\n\n'
        f'## {TARGET_STEPS}\n\n{sections[TARGET_STEPS]}\n')
    # With the runs' targets beside the rows, that section is their table, written in place.
    targets = [target_row(c, seed, 1, '', 11, 21) for c in cells for seed in SEEDS]
    write_csv(targets, out / TARGETS_CSV, TARGET_COLUMNS)
    assert main(['--tables-only', '--out', str(out)]) == 0
    text = (out / SUMMARY_MD).read_text()
    assert text.count(f'## {TARGET_STEPS}') == 1
    assert target_step_table(cells_of(rows), rows, targets) in text


def target_row(cell, seed, born, died, seen, found):
    """Return a row of evaluation_targets.csv ('' where the CSV leaves a step empty)."""
    return {'setting': cell.setting, 'label': cell.label, 'seed': seed, 'id': 1, 'born': born,
            'died': died, 'first_in_view': seen, 'first_detected': found}


def test_a_targets_life_splits_before_first_view_in_view_and_after_detection():
    def target(born, died, seen, found):
        return target_row(REFERENCE, 1, str(born), died, seen, found)
    # Alive over steps 10-30 (21 steps): 5 before the view at 15, 3 in view, 13 after 18.
    assert target_phases(target(10, '30', '15', '18'), 200) == (5, 3, 13)
    # Alive to the run's last step and never in view: all of it before the first view.
    assert target_phases(target(10, '', '', ''), 50) == (41, 0, 0)
    # In view at 15, never detected: the rest of its life in view, none after detection.
    assert target_phases(target(10, '30', '15', ''), 200) == (5, 16, 0)
    # An estimate near it before any square held it is its first detection: no view phase.
    assert target_phases(target(10, '30', '20', '12'), 200) == (2, 0, 19)


def test_target_step_table_pools_the_seeds_and_says_why_targets_were_missed():
    cell = REFERENCE
    rows = [dict(cell.columns(), seed=seed, tracked_share=share)
            for seed, share in ((1, 0.5), (2, 0.0))]
    targets = [
        # Seed 1: 100 target-steps (1-100), 20 before view, 10 in view, 70 after detection;
        # tracked 50 % of 100.
        target_row(cell, 1, 1, '100', 21, 31),
        # Seed 2: one never in view (steps 101-200, the run's end) and one seen, never
        # detected (steps 1-100, in view from 51): 150 before view, 50 in view.
        target_row(cell, 2, 101, '', '', ''),
        target_row(cell, 2, 1, '100', 51, ''),
        # Another cell's target does not count.
        target_row(replace(cell, label='other'), 1, 1, '', 1, 1)]
    table = target_step_table([cell], rows, targets)
    # 300 target-steps: 170 before view, 60 in view, 70 after; 50 tracked, 71.4 % of after.
    assert line(table, 0, cell.label) == (
        f'| random | {cell.label} | 300 | 56.7 | 20.0 | 23.3 | 16.7 | 71.4 | 3 | 1 | 1 |')
    assert target_step_table([cell], rows, []) == ''


def test_birth_time_table_tells_the_targets_born_after_the_first_pass():
    persistent, rival, oracle = (replace(cell, setting='long', steps=1000)
                                 for cell in (PERSISTENT, REFERENCE, ORACLE_CELL))
    cells = [persistent, rival, oracle]
    rows = [dict(cell.columns(), seed=seed, **dict.fromkeys(METRICS, 1.0))
            for cell in cells for seed in (1, 2, 3)]
    targets = []
    for seed in (1, 2, 3):
        for cell in cells:
            # Born during the first pass and found; born later: one found by every cell, one
            # found by the oracle always, by the persistent profile but on seed 3, never by
            # the rival.
            last = {persistent: 710 if seed != 3 else '', rival: '', oracle: 705}[cell]
            targets += [target_row(cell, seed, 100, '180', 120, 130),
                        target_row(cell, seed, 500, '600', 505, 510),
                        target_row(cell, seed, 700, '', 705, last)]
    table = birth_time_table(cells, rows, targets)
    # Later-born shares per seed: persistent 1, 1, 1/2; the rival 1/2 each; the oracle 1.
    assert line(table, 0, persistent.label).startswith(
        f'| long | {persistent.label} | 3 | 3 | 100 | 6 | 83 | 83 % [')
    assert line(table, 0, persistent.label).endswith('|  |')
    rival_line = line(table, 0, rival.label)
    assert rival_line.startswith(f'| long | {rival.label} | 3 | 3 | 100 | 6 | 50 | 50 %')
    assert rival_line.split(' | ')[-1].startswith('+33 [')   # (1/2 + 1/2 + 0) / 3
    assert line(table, 0, oracle.label).split(' | ')[7] == 'n/a'
    # Runs no longer than the first pass: no table, and no section in the summary.
    short = [replace(cell, steps=200) for cell in cells]
    assert birth_time_table(short, rows, targets) == ''
    assert BIRTH_TIME in row_sections(cells, rows, targets)
    assert BIRTH_TIME not in row_sections(short, rows, targets)


def test_the_persistent_ablation_is_paired_with_the_persistent_profile(tmp_path):
    from sat_world_sim.study_design import persistent_ablation_cells, reference_of
    ablated = persistent_ablation_cells('random')
    assert all(reference_of(c, [REFERENCE, PERSISTENT] + ablated) == PERSISTENT
               for c in ablated)
    # Without the persistent profile among the cells there is nothing to pair them with.
    assert reference_of(ablated[0], [REFERENCE] + ablated) is None
    first = ablated[0]
    rows = ([result(PERSISTENT, seed)['row'] for seed in SEEDS]
            + [dict(result(PERSISTENT, seed)['row'], label=first.label,
                    overrides=first.columns()['overrides'],
                    detected_share=detected(PERSISTENT, seed) - 0.05) for seed in SEEDS])
    tables = study_tables([PERSISTENT, first], rows)
    assert 'Δ to the persistent profile' in tables
    assert line(tables, 3, first.label).split(' | ')[3].startswith('56 (−5 [−5, −5]*')
    # Only the ablation ran (evaluate --only): its figure, no main-table figures, no error.
    results = [{'row': row, 'cell': first, 'ospa': np.full(10, 5.0),
                'searched': np.linspace(0, 50, 10), 'targets': []}
               for row in rows if row['label'] == first.label]
    assert write_figures([first], results, tmp_path) == []
