"""Where a run's target-steps go (sat_world_sim/target_steps.py)."""

from conftest import REPO_ROOT

from sat_agent.config import load_params_file
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.random_scenarios import random_scenario
from sat_world_sim.target_steps import AFTER, BEFORE, CATEGORIES, category, TargetStepLedger

PERSISTENT = load_params_file(REPO_ROOT / 'config' / 'persistent.yaml')


def test_category_takes_the_first_that_holds():
    assert category(False, False, False, False, None) == 'before detection, out of view'
    assert category(False, False, True, True, 'short track') == 'before detection, in view'
    # Tracked at its first detection, and whatever else holds.
    assert category(False, True, False, False, None) == 'tracked'
    assert category(True, True, True, True, 'fit left A') == 'tracked'
    assert category(True, False, True, True, 'fit left A') == 'in view, not reported'
    assert category(True, False, False, True, 'fit left A') == 'a track holds it, reported off it'
    assert category(True, False, False, False, 'report expired') == 'dropped: report expired'
    assert category(True, False, False, False, None) == 'no track ever held it'
    assert set(CATEGORIES) == set(BEFORE) | set(AFTER) and len(CATEGORIES) == 11


def _ledger_of(seed: int, steps: int, params):
    scenario = random_scenario(seed, 4, steps)
    swarm, ledger, records = InProcessSwarm(scenario, params), TargetStepLedger(), []
    for _ in range(scenario.steps):
        records.append(swarm.step())
        ledger.observe(swarm, records[-1])
    return ledger.counts, compute_metrics(records, scenario.name, scenario.seed)


def test_the_ledger_agrees_with_the_metrics_and_names_why_found_targets_go_untracked():
    # Seeds 14 and 38 of the persistent profile: in 150 steps found targets go untracked four
    # ways between them.
    untracked = set()
    for seed in (14, 38):
        counts, metrics = _ledger_of(seed, 150, PERSISTENT)
        assert set(counts) <= set(CATEGORIES)
        assert sum(counts.values()) == sum(step['n_true'] for step in metrics['steps'])
        assert counts['tracked'] == sum(step['n_tracked'] for step in metrics['steps'])
        # Before the first detection: time_to_detection (censored at the steps alive if never).
        assert counts[BEFORE[0]] + counts[BEFORE[1]] == sum(
            target['time_to_detection'] for target in metrics['targets'])
        untracked |= {name for name in AFTER[1:] if counts[name]}
    assert {'a track holds it, reported off it', 'dropped: report expired'} <= untracked
    assert len(untracked) >= 4, untracked


def test_without_coasting_a_found_target_out_of_view_was_never_held():
    params = load_params_file('config/paper.yaml')
    assert not params.additions.track_coasting
    counts, _ = _ledger_of(6, 120, params)
    assert counts['tracked'] > 0
    assert not any(counts[name] for name in AFTER[2:-1])
