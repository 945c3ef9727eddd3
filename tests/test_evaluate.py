from dataclasses import field, make_dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from sat_agent.config import load_params_file, SatParams
from sat_world_sim import study_design
from sat_world_sim.evaluate import cost_model, estimate, main, METRIC_WORDS, METRICS
from sat_world_sim.evaluate import QUICK_STEPS, RUNS_CSV, SUMMARY_MD, TABLE_MARKERS, TARGETS_CSV
from sat_world_sim.evaluate import read_rows, write_csv
from sat_world_sim.inprocess_swarm import run_swarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.random_scenarios import long_mission_scenario, paper_random_scenario
from sat_world_sim.random_scenarios import random_scenario
from sat_world_sim.scenario import load_scenario
from sat_world_sim.study_design import ablation_cells, Cell, CONFIG_COLUMNS, default_cell
from sat_world_sim.study_design import DESIGNS, factorial_cells, persistent_ablation_cells
from sat_world_sim.study_design import ORACLE, ORACLE_LABEL, ORACLE_TRACK
from sat_world_sim.study_design import prepare_cells, reference_of, scenario_for

CONFIG = Path(__file__).resolve().parent.parent / 'config'
PAPER = load_scenario(CONFIG / 'scenarios' / 'paper.yaml')


def test_random_scenarios_have_2_to_10_targets_drawn_from_the_seed_alone():
    scenarios = [random_scenario(seed, 4, 200) for seed in range(1, 41)]
    counts = [len(s.targets) for s in scenarios]
    assert min(counts) == 2 and max(counts) == 10
    assert random_scenario(7, 4, 200) == random_scenario(7, 4, 200)
    for scenario in scenarios:
        assert len(scenario.agents) == 4 and scenario.random_births is None
        assert all(1 <= t.born <= 150 and 50 <= t.died - t.born + 1 <= 150
                   for t in scenario.targets)


def test_a_seed_gives_the_same_targets_to_every_team_size():
    two, eight = random_scenario(3, 2, 200), random_scenario(3, 8, 200)
    assert two.targets == eight.targets
    assert two.agents == eight.agents[:2]


def test_randomised_paper_setting_keeps_the_papers_team_and_draws_two_targets():
    scenarios = [paper_random_scenario(seed, PAPER, 200) for seed in range(1, 101)]
    assert paper_random_scenario(9, PAPER, 200) == scenarios[8]
    for scenario in scenarios:
        assert scenario.agents == PAPER.agents
        assert scenario.truth_process_noise == PAPER.truth_process_noise
        assert len(scenario.targets) == 2
        for target in scenario.targets:
            assert 80 <= target.born <= 150 and 30 <= target.died - target.born + 1 <= 80
            assert all(0.0 <= v <= 100.0 for v in target.start + target.end)
    births = [t.born for s in scenarios for t in s.targets]
    assert min(births) < 90 and max(births) > 140
    assert len({s.targets for s in scenarios}) == 100


def test_a_long_mission_keeps_the_random_defaults_team_and_births_targets_throughout():
    scenarios = [long_mission_scenario(seed, 4, 1000) for seed in range(1, 41)]
    assert long_mission_scenario(7, 4, 1000) == scenarios[6]
    births = np.array([t.born for s in scenarios for t in s.targets])
    # Born over steps 1-950, so each lives its shortest life (50 steps) in the mission ...
    assert births.min() >= 1 and births.max() <= 950
    # ... uniformly (each quarter of the span holds about a quarter) ...
    quarters = np.histogram(births, bins=4, range=(1, 951))[0] / births.size
    assert np.all(np.abs(quarters - 0.25) < 0.05)
    # ... at the random default's mean rate: 6 targets over its 150 steps of births, 0.04 a
    # step, 38 a mission (Poisson: the mean of 40 seeds within 3 sd of it).
    assert abs(births.size / 40 - 38) < 3
    for seed, scenario in enumerate(scenarios, start=1):
        assert scenario.agents == random_scenario(seed, 4, 200).agents
        assert all(50 <= t.died - t.born + 1 <= 150 for t in scenario.targets)
    # 200 steps: births over 1-150, as the random default's.
    assert max(t.born for seed in range(1, 41)
               for t in long_mission_scenario(seed, 4, 200).targets) <= 150
    long = replace(default_cell('long'), steps=1000)
    assert scenario_for(long, 3, SatParams(), PAPER) == long_mission_scenario(3, 4, 1000)


@pytest.mark.parametrize('script', sorted(METRIC_WORDS))
def test_every_metric_column_is_told_apart_from_the_configuration_by_the_acceptance_words(script):
    # The acceptance script groups runs into cells by every column that holds none of its
    # words: a metric without one would split the cells (issue-6-eval.sh counted 262 cells of
    # the 36 while the column of detectable targets was called 'entered_share').
    words = METRIC_WORDS[script]
    assert [name for name in METRICS if not any(word in name for word in words)] == []
    assert [c for c in CONFIG_COLUMNS if any(word in c for word in words)] == ['steps']


def test_a_csv_written_before_a_column_was_renamed_reads_under_the_new_name(tmp_path):
    path = tmp_path / RUNS_CSV
    path.write_text('setting,seed,entered_share\nrandom,3,0.75\n', encoding='utf-8')
    assert read_rows(path) == [{'setting': 'random', 'seed': '3', 'detectable_share': '0.75'}]


def test_the_default_design_has_every_policy_strict_and_oracle_where_the_issue_asks():
    cells = DESIGNS['default']
    assert len({c.name for c in cells}) == len(cells)
    for setting in ('paper_random', 'random'):
        mine = {(c.profile, c.policy, c.planner, c.comm_range): c for c in cells
                if c.setting == setting}
        assert {('paper', 'sat', 'greedy', 50.0), ('paper_strict', 'sat', 'greedy', 50.0),
                ('paper', 'sat', 'greedy', 0.0), ('paper', 'lawnmower', 'greedy', 50.0),
                ('paper', 'random_walk', 'greedy', 50.0), ('paper', 'oracle_sweep', 'none', 50.0),
                ('persistent', 'sat', 'greedy', 50.0),
                ('paper', 'phd_voronoi', 'greedy', 50.0),
                ('paper', 'thompson', 'greedy', 50.0),
                ('paper', 'sat', 'ortools', 50.0)} <= set(mine)
    # At the paper scenario only the reference, strict and the ceiling; the full design has the
    # other policies there.
    assert not [c for c in cells if c.planner == 'ortools' and c.setting == 'paper']
    assert {c.setting for c in DESIGNS['full'] if c.planner == 'ortools'} == {
        'paper', 'paper_random', 'random', 'long'}
    assert not [c for c in cells if c.setting == 'long']
    paper = {c.label for c in cells if c.setting == 'paper'}
    assert any('strict' in label for label in paper) and any('oracle' in label for label in paper)
    # The acceptance scripts find the oracle at the random default by these columns, and take
    # the first label holding "oracle" in the CSV's (cell) order as the sweep's.
    (oracle,) = [c for c in cells if c.setting == 'random' and c.policy == ORACLE]
    assert (oracle.agents, oracle.clutter, oracle.comm_range) == (4, 10.0, 50.0)
    assert next(c for c in cells if 'oracle' in c.label.lower()).label == ORACLE_LABEL
    # Sweep-and-track (a reference for the tracked share) at every setting of the design.
    assert {c.setting for c in cells if c.policy == ORACLE_TRACK} == {
        'paper', 'paper_random', 'random'}
    assert any('persistent' in c.label for c in cells if c.setting == 'random')


def test_the_factorial_crosses_team_clutter_radio_and_policies():
    cells = factorial_cells()
    policies = len(study_design.FACTORIAL_POLICIES)
    assert len(cells) == 3 * 3 * 4 * policies + 3
    assert len({c.name for c in cells}) == len(cells)
    sat = [c for c in cells if c.is_reference_kind]
    assert sorted({(c.agents, c.clutter, c.comm_range) for c in sat}) == sorted(
        (n, c, r) for n in (2, 4, 8) for c in (0.0, 10.0, 30.0)
        for r in (0.0, 25.0, 50.0, study_design.UNLIMITED))


def test_ablation_cells_follow_the_fields_of_the_additions_group(monkeypatch):
    group = make_dataclass('AdditionParams', [('confirmation', bool, True),
                                              ('track_standoff', bool, True),
                                              ('persistent_planning', bool, False),
                                              ('extraction_margin_m', float, 5.0)], frozen=True)
    with_additions = make_dataclass('WithAdditions', [
        ('additions', group, field(default_factory=group))], bases=(SatParams,), frozen=True)
    monkeypatch.setattr(study_design, 'SatParams', with_additions)
    cells = ablation_cells('random')
    assert [c.label for c in cells] == ['without confirmation', 'without track_standoff']
    assert [c.overrides for c in cells] == [(('additions.confirmation', False),),
                                            (('additions.track_standoff', False),)]
    assert all(reference_of(c, cells + [default_cell('random')]) == default_cell('random')
               for c in cells)
    # The additions off by default are the persistent profile's: its ablation switches each
    # both ways, and building the cells drops the way the profile already is.
    without, with_ = persistent_ablation_cells('random')
    assert [(c.profile, c.overrides) for c in (without, with_)] == [
        ('persistent', (('additions.persistent_planning', False),)),
        ('persistent', (('additions.persistent_planning', True),))]


def test_the_persistent_ablation_skips_the_way_the_profile_already_is():
    cells = persistent_ablation_cells('random')
    runnable, skipped = prepare_cells(cells, CONFIG)
    profile = load_params_file(CONFIG / 'persistent.yaml').additions
    names = study_design.addition_names(default=False)
    assert len(runnable) == len(skipped) == len(names) > 0
    for cell, params in runnable:
        ((key, value),) = cell.overrides
        name = key.split('.')[1]
        assert value is not getattr(profile, name)
        assert cell.label.endswith(f"{'with' if value else 'without'} {name}")
        assert getattr(params.additions, name) is value
    assert all('already so' in reason for _, reason in skipped)


def test_cells_that_cannot_be_built_yet_are_skipped_with_the_reason(tmp_path):
    (tmp_path / 'paper.yaml').write_text((CONFIG / 'paper.yaml').read_text())
    cells = [default_cell('random'), default_cell('random', 'strict', profile='paper_strict'),
             default_cell('random', 'spiral', policy='spiral'),
             default_cell('random', 'no-op', overrides=(('search.decay', 0.999),))]
    runnable, skipped = prepare_cells(cells, tmp_path)
    assert [c for c, _ in runnable] == cells[:1]
    reasons = {c.label: reason for c, reason in skipped}
    assert 'paper_strict.yaml does not exist' in reasons['strict']
    assert "'search.policy' = 'spiral'" in reasons['spiral']
    assert 'already so' in reasons['no-op']
    params = runnable[0][1]
    assert (params.sensor.clutter_rate, params.cooperation.comm_range) == (10.0, 50.0)


def test_each_cell_is_compared_with_cooperative_sat_phd_of_its_setting():
    cells = DESIGNS['default'] + DESIGNS['factorial']
    for cell in DESIGNS['default']:
        reference = reference_of(cell, cells)
        if cell == default_cell(cell.setting):
            assert reference is None
        else:
            assert reference == default_cell(cell.setting)
    lawnmower = next(c for c in DESIGNS['factorial'] if c.policy == 'lawnmower'
                     and (c.agents, c.clutter, c.comm_range) == (8, 30.0, 25.0))
    reference = reference_of(lawnmower, cells)
    assert reference.is_reference_kind and (reference.agents, reference.clutter,
                                            reference.comm_range) == (8, 30.0, 25.0)


def test_the_estimate_uses_measured_costs_per_agent_step():
    rows = [dict(Cell('random', 'SAT-PHD (cooperative)').columns(), seed=s, cpu_time_s=4.0)
            for s in (1, 2)]
    rows += [dict(Cell('random', 'lawnmower', policy='lawnmower').columns(), seed=1,
                  cpu_time_s=2.0)]
    cost = cost_model(rows)
    assert cost(Cell('random', 'SAT-PHD (cooperative)')) == 4.0
    # Not measured as a cell: SAT-PHD's 4 s / (4 agents x 200 steps) per agent-step.
    assert cost(Cell('random', '8 agents', agents=8)) == pytest.approx(8.0)
    assert cost(Cell('paper_random', 'walk', policy='lawnmower', agents=2)) == pytest.approx(1.0)
    # Not measured at all: counted as SAT-PHD at the same setting.
    runs, wall, unmeasured = estimate([Cell('random', 'SAT-PHD (cooperative)'),
                                       Cell('random', 'x', policy='random_walk')], 10, 2, cost)
    assert (runs, unmeasured) == (20, [])
    assert wall == pytest.approx(10 * (4.0 + 4.0) / 2)
    assert cost_model([])(Cell('random', 'x')) is None


ONLY = ['random/SAT-PHD (cooperative)', 'random/lawnmower', 'random/oracle sweep',
        'paper/SAT-PHD (cooperative)', 'paper_random/SAT-PHD (cooperative)']


@pytest.mark.timeout(300)
def test_quick_study_writes_rows_tables_readme_and_figures(tmp_path, capsys):
    out = tmp_path / 'eval'
    readme = tmp_path / 'README.md'
    readme.write_text(f'# Title\n{TABLE_MARKERS[0]}\nold table\n{TABLE_MARKERS[1]}\nrest\n')
    args = ['--quick', '--seeds', '2', '--first-seed', '1001', '--jobs', '2', '--out', str(out),
            '--readme', str(readme), '--config', str(CONFIG), '--costs', str(tmp_path / 'no')]
    assert main(args + sum((['--only', name] for name in ONLY), [])) == 0
    rows = read_rows(out / RUNS_CSV)
    assert list(rows[0]) == list(CONFIG_COLUMNS) + ['seed'] + list(METRICS)
    assert [(r['setting'] + '/' + r['label'], r['seed']) for r in rows] == [
        (name, seed) for name in ONLY for seed in ('1001', '1002')]
    # The paper cell's row is metrics.json's summary of the same run.
    run = run_swarm(PAPER.with_seed(1001), load_params_file(CONFIG / 'paper.yaml'), QUICK_STEPS)
    summary = compute_metrics(run.records, 'paper', 1001)['summary']
    (row,) = [r for r in rows if r['setting'] == 'paper' and r['seed'] == '1001']
    assert float(row['mean_ospa']) == pytest.approx(summary['mean_ospa'])
    assert float(row['final_searched_pct']) == pytest.approx(summary['final_searched_pct'])
    printed = capsys.readouterr()
    assert '5 cells x 2 seeds = 10 runs of 15 steps' in printed.err
    tables = printed.out.strip()
    assert 'p < 0.01' in tables and '95 % CI' in tables
    assert tables.count('(ref.)') == 3 * 6   # three settings' references, six metrics each
    assert readme.read_text() == (f'# Title\n{TABLE_MARKERS[0]}\n{tables}\n'
                                  f'{TABLE_MARKERS[1]}\nrest\n')
    assert tables in (out / SUMMARY_MD).read_text()
    for name in ('evaluation_time.png', 'evaluation_detection.png'):
        assert (out / name).read_bytes()[:8] == b'\x89PNG\r\n\x1a\n'
    targets = read_rows(out / TARGETS_CSV)
    assert {t['seed'] for t in targets} <= {'1001', '1002'}


@pytest.mark.timeout(600)
def test_the_dask_cluster_writes_the_same_rows_as_the_process_pool(tmp_path):
    args = ['--quick', '--seeds', '2', '--jobs', '2', '--config', str(CONFIG),
            '--costs', str(tmp_path / 'no')] + sum((['--only', name] for name in ONLY[:3]), [])
    assert main(args + ['--out', str(tmp_path / 'pool')]) == 0
    assert main(args + ['--out', str(tmp_path / 'dask'), '--scheduler', 'local']) == 0
    timing = ('wall_time_s', 'cpu_time_s')
    pool, dask = (read_rows(tmp_path / name / RUNS_CSV) for name in ('pool', 'dask'))
    assert len(pool) == 6
    assert [{k: v for k, v in r.items() if k not in timing} for r in pool] == \
        [{k: v for k, v in r.items() if k not in timing} for r in dask]
    assert all(float(r['cpu_time_s']) > 0 for r in dask)


def test_dry_run_prints_the_run_count_and_estimate_without_running(tmp_path, capsys):
    costs = tmp_path / 'costs.csv'
    rows = [dict(Cell('random', 'SAT-PHD (cooperative)').columns(), seed=1, cpu_time_s=6.0)]
    write_csv(rows, costs, list(rows[0]))
    assert main(['--design', 'factorial', '--dry-run', '--costs', str(costs),
                 '--config', str(CONFIG), '--jobs', '2', '--out', str(tmp_path / 'x')]) == 0
    err = capsys.readouterr().err
    runnable = len(prepare_cells(factorial_cells(), CONFIG)[0])
    assert f'{runnable} cells x 50 seeds = {runnable * 50} runs of 200 steps' in err
    assert 'min' in err and not (tmp_path / 'x').exists()


def test_bad_arguments_are_refused_with_exit_code_2(tmp_path, capsys):
    assert main(['--seeds', '0', '--out', str(tmp_path)]) == 2
    assert '--seeds = 0' in capsys.readouterr().err
    assert main(['--config', str(tmp_path), '--out', str(tmp_path)]) == 2
    assert 'paper.yaml' in capsys.readouterr().err
    assert main(['--only', 'random/nothing', '--out', str(tmp_path)]) == 2
    assert 'no such cell' in capsys.readouterr().err
    readme = tmp_path / 'README.md'
    readme.write_text('# no markers\n')
    assert main(['--readme', str(readme), '--out', str(tmp_path)]) == 2
    assert 'markers' in capsys.readouterr().err


def test_a_trial_adds_its_values_to_every_cell_and_names_them_in_the_label():
    cell = default_cell('random', 'SAT-PHD persistent', profile='persistent',
                        overrides=(('phd.birth_velocity_std', 2.0),))
    (trial,) = study_design.with_values([cell], (('phd.birth_velocity_std', 0.5),
                                                 ('search.replan_period', 5)))
    assert trial.label == ('SAT-PHD persistent with phd.birth_velocity_std=0.5; '
                           'search.replan_period=5')
    params = trial.params(load_params_file(CONFIG / 'persistent.yaml'))
    assert params.phd.birth_velocity_std == 0.5 and params.search.replan_period == 5
    assert study_design.with_values([cell], ()) == [cell]


def test_a_trial_runs_under_its_own_label_into_its_own_directory(tmp_path):
    base = ['--quick', '--seeds', '1', '--jobs', '1', '--config', str(CONFIG),
            '--costs', str(tmp_path / 'no'), '--only', 'paper/SAT-PHD (cooperative)']
    assert main(base + ['--set', 'phd.birth_velocity_std=0.5', '--out', str(tmp_path)]) == 0
    (row,) = read_rows(tmp_path / RUNS_CSV)
    assert row['label'] == 'SAT-PHD (cooperative) with phd.birth_velocity_std=0.5'
    assert row['overrides'] == 'phd.birth_velocity_std=0.5'


def test_a_trial_is_refused_bad_values_and_the_committed_study(tmp_path, capsys):
    out = ['--out', str(tmp_path)]
    for item, told in (('phd.nothing=1', 'unknown parameter'),
                       ('phd.birth_velocity_std=-1', 'allowed range is [0, 100]'),
                       ('phd.birth_velocity_std', 'expected KEY=VALUE'),
                       ('phd.birth_velocity_std=[1', 'not YAML')):
        assert main(['--set', item] + out) == 2
        assert told in capsys.readouterr().err
    assert main(['--set', 'phd.birth_velocity_std=0.5', '--dry-run']) == 2
    assert 'not docs/' in capsys.readouterr().err
    assert main(['--set', 'phd.birth_velocity_std=0.5', '--readme', 'README.md'] + out) == 2
    assert 'no --readme' in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
