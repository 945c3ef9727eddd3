import csv
from pathlib import Path

import pytest

from sat_agent.config import load_params_file
from sat_world_sim.evaluate import (
    CONFIG_COLUMNS, main, METRICS, QUICK_STEPS, random_scenario, README_MARKERS, study_cells)
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.scenario import load_scenario

CONFIG = Path(__file__).resolve().parent.parent / 'config'


def test_random_scenarios_have_2_to_10_targets_drawn_from_the_seed_alone():
    scenarios = [random_scenario(seed, 4, 200) for seed in range(1, 41)]
    counts = [len(s.targets) for s in scenarios]
    assert min(counts) == 2 and max(counts) == 10
    assert random_scenario(7, 4, 200) == random_scenario(7, 4, 200)
    for scenario in scenarios:
        assert len(scenario.agents) == 4 and scenario.random_births is None
        assert all(1 <= t.born <= 150 and 50 <= t.died - t.born + 1 <= 150
                   for t in scenario.targets)


def test_the_design_has_every_policy_at_both_settings_and_one_factor_sweeps():
    cells = study_cells()
    assert len(cells) == len(set(cells)) == 16
    for setting in ('paper', 'random'):
        mine = {(c.policy, c.planner, c.comm_range) for c in cells if c.setting == setting}
        assert {('sat', 'greedy', 50.0), ('sat', 'greedy', 0.0), ('lawnmower', 'greedy', 50.0),
                ('random_walk', 'greedy', 50.0), ('sat', 'ortools', 50.0)} <= mine
    sat = [c for c in cells if c.setting == 'random' and c.policy == 'sat' and
           c.planner == 'greedy']
    assert sorted({c.agents for c in sat}) == [2, 4, 8]
    assert sorted({c.clutter for c in sat}) == [0.0, 10.0, 30.0]
    assert sorted({c.comm_range for c in sat}) == [0.0, 25.0, 50.0, 1000.0]


@pytest.mark.timeout(300)
def test_quick_study_writes_one_row_per_run_through_the_metrics_json_code(tmp_path, capsys):
    out = tmp_path / 'eval'
    readme = tmp_path / 'README.md'
    readme.write_text(f'# Title\n{README_MARKERS[0]}\nold table\n{README_MARKERS[1]}\nrest\n')
    assert main(['--quick', '--seeds', '1', '--jobs', '2', '--out', str(out),
                 '--readme', str(readme),
                 '--params', str(CONFIG / 'paper.yaml'),
                 '--scenario', str(CONFIG / 'scenarios' / 'paper.yaml')]) == 0
    with open(out / 'evaluation.csv', encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert list(rows[0]) == list(CONFIG_COLUMNS) + ['seed'] + list(METRICS)
    assert len(rows) == 16 and {r['seed'] for r in rows} == {'1'}
    # The row of the paper's cooperative run is metrics.json's summary of the same run.
    params = load_params_file(CONFIG / 'paper.yaml')
    run = run_swarm(load_scenario(CONFIG / 'scenarios' / 'paper.yaml').with_seed(1), params,
                    QUICK_STEPS)
    summary = compute_metrics(run.records, 'paper', 1)['summary']
    (row,) = [r for r in rows if r['setting'] == 'paper' and r['label'].startswith('SAT-PHD (')]
    assert float(row['mean_ospa']) == pytest.approx(summary['mean_ospa'])
    assert float(row['final_searched_pct']) == pytest.approx(summary['final_searched_pct'])
    table = (out / 'evaluation_summary.md').read_text()
    assert table.count('\n| paper |') == 5 and table.count('\n| random |') == 11
    printed = capsys.readouterr().out.strip()
    assert printed.startswith('| setting |') and printed in table
    assert readme.read_text() == (f'# Title\n{README_MARKERS[0]}\n{printed}\n'
                                  f'{README_MARKERS[1]}\nrest\n')
    for name in ('evaluation_time.png', 'evaluation_detection.png', 'evaluation_sweeps.png'):
        assert (out / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    assert (out / 'evaluation_targets.csv').stat().st_size > 0


def test_bad_arguments_are_refused_with_exit_code_2(tmp_path, capsys):
    assert main(['--seeds', '0', '--out', str(tmp_path)]) == 2
    assert '--seeds = 0' in capsys.readouterr().err
    assert main(['--params', str(tmp_path / 'missing.yaml'), '--out', str(tmp_path)]) == 2
    assert 'missing.yaml' in capsys.readouterr().err
    readme = tmp_path / 'README.md'
    readme.write_text('# no markers\n')
    assert main(['--readme', str(readme), '--out', str(tmp_path)]) == 2
    assert 'markers' in capsys.readouterr().err
