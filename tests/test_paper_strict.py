"""config/paper_strict.yaml, the paper as written: in-process and through the ROS graph."""

from dataclasses import replace
import json
from pathlib import Path

import pytest

from sat_agent.config import load_params_file
from sat_world_sim.inprocess_swarm import run_swarm as run_inprocess
from sat_world_sim.metrics import compute_metrics
from sat_world_sim.scenario import load_scenario

CONFIG = Path(__file__).resolve().parent.parent / 'config'
STRICT = CONFIG / 'paper_strict.yaml'
PAPER = CONFIG / 'scenarios' / 'paper.yaml'


def inprocess_metrics(params_file, steps=None):
    """metrics.json of the in-process paper run, as read back from JSON, and the records."""
    scenario = load_scenario(PAPER)
    run = run_inprocess(replace(scenario, steps=steps or scenario.steps),
                        load_params_file(params_file))
    metrics = compute_metrics(run.records, scenario.name, scenario.seed)
    return json.loads(json.dumps(metrics)), run.records


def test_the_strict_profile_runs_the_paper_scenario_and_tracks_on_the_first_estimate():
    metrics, records = inprocess_metrics(STRICT)
    assert [s['step'] for s in metrics['steps']] == list(range(1, 201))
    assert not any(record.refused_actions for record in records)
    left = {(e['step'], e['agent']) for e in metrics['overlap_events']}
    estimated = [(r.step, a) for r in records for a, e in r.estimates.items() if len(e)]
    assert estimated, 'the strict agents estimated no target at all'
    # No confirmation and no rejoin cooldown: an agent with an estimate tracks, unless it has
    # just left an overlap.
    assert all(records[k - 1].modes[a] == 'TRACK' for k, a in estimated if (k, a) not in left)
    # The switches act in the whole loop: the default profile's run differs.
    assert metrics['steps'] != inprocess_metrics(CONFIG / 'paper.yaml')[0]['steps']


@pytest.mark.ros
@pytest.mark.timeout(300)
def test_the_strict_profile_runs_through_the_ros_graph_as_in_process(tmp_path):
    # The paper's first 120 steps, through target 1's birth at k = 104: the nodes read the
    # switches from the parameter file as the in-process loop does.
    from ros_harness import run_swarm

    code, metrics, output = run_swarm(tmp_path / 'run', PAPER, '--steps', '120', '--no-record',
                                      '--no-view', params=STRICT)
    assert code == 0, output[-3000:]
    expected, _ = inprocess_metrics(STRICT, steps=120)
    assert len(expected['steps']) == 120
    assert metrics == expected
