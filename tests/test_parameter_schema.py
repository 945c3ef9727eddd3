"""The parameter schema: one definition gives checks, ROS descriptors, docs and live-ness."""

import subprocess
import sys

from conftest import REPO_ROOT
import pytest

from sat_agent.agent_core import Agent
from sat_agent.beyond_paper.investigation import Investigation
from sat_agent.config import load_params_file, ParameterError, SatParams
from sat_agent.node_params import (AgentNodeParams, LIVE_SWITCH, LoggerParams, NODE_SCHEMAS,
                                   ObserverParams, WorldNodeParams)
from sat_agent.parameter_schema import build, leaves, live_names
from sat_agent.ros import agent_node
from sat_agent.ros.ros_params import descriptor
from sat_world_sim.ros import world_sim_node

PAPER = REPO_ROOT / 'config' / 'paper.yaml'


def spec_of(schema, wanted):
    return next(spec for name, spec, _ in leaves(schema) if name == wanted)


def profile(tmp_path, body: str):
    path = tmp_path / 'profile.yaml'
    path.write_text(PAPER.read_text() + body)
    return path


@pytest.mark.parametrize('body, message', [
    ('    view_rate: -1.0\n', "profile.yaml: parameter 'view_rate' = -1.0: allowed range is [0,"),
    ('    radio:\n      loss: 1.0\n', "parameter 'radio.loss' = 1.0: allowed range is [0, 1)"),
    ('    input_source: drone\n', "'input_source' = 'drone': allowed values are ['world_sim',"),
    ('    sink: 3\n', "parameter 'sink' = 3: must be a string"),
])
def test_a_profile_with_a_bad_node_setting_fails_at_load(tmp_path, body, message):
    with pytest.raises(ParameterError) as refused:
        load_params_file(profile(tmp_path, body))
    assert message in str(refused.value)


def test_a_profile_with_a_bad_sat_parameter_names_the_file_the_parameter_and_the_range(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(PAPER.read_text().replace('p_detect: 0.99', 'p_detect: 1.5'))
    with pytest.raises(ParameterError) as refused:
        load_params_file(bad)
    assert str(refused.value) == (f"{bad}: parameter 'sensor.p_detect' = 1.5: allowed range is "
                                  '(0, 1]')
    # Node-level keys a node takes are fine in a profile; unknown ones are the nodes' affair.
    fine = profile(tmp_path, '    view_rate: 2\n    use_sim_time: true\n')
    assert load_params_file(fine) == SatParams()


def test_a_bound_given_by_another_parameter_is_checked_and_named():
    with pytest.raises(ParameterError, match=r"'phd.max_particles' = 10: allowed range is "
                                             r'\[min_particles = 2000, 1e\+07\]'):
        SatParams().with_overrides({'phd.max_particles': 10})


def test_descriptors_carry_the_description_the_range_and_read_only():
    p_detect = descriptor(spec_of(SatParams, 'sensor.p_detect'), live=False)
    assert p_detect.read_only and p_detect.description.startswith('p_D^max')
    assert (p_detect.floating_point_range[0].from_value,
            p_detect.floating_point_range[0].to_value) == (0.0, 1.0)
    assert p_detect.additional_constraints.startswith('a number in (0, 1]; read-only')
    budget = descriptor(spec_of(SatParams, 'search.investigate_steps'), live=True)
    assert not budget.read_only and 'live' in budget.additional_constraints
    assert (budget.integer_range[0].from_value, budget.integer_range[0].to_value) == (1, 10000)
    policy = descriptor(spec_of(SatParams, 'search.policy'), live=False)
    assert "'phd_voronoi'" in policy.additional_constraints and not policy.floating_point_range


def test_every_live_parameter_is_applied_by_a_node_and_nodes_apply_only_live_ones():
    schemas = (SatParams, *NODE_SCHEMAS)
    live = {name for schema in schemas for name in live_names(schema)}
    applied = set(agent_node.LIVE) | set(world_sim_node.LIVE)
    assert live == applied
    assert {'cooperation.comm_range', 'search.investigate_steps', 'view_rate'} <= applied
    # The switch that lets them change is a read-only flag, off by default, of both nodes.
    for schema, given in ((AgentNodeParams, {'agent_id': 1}), (WorldNodeParams, {})):
        switch = spec_of(schema, LIVE_SWITCH)
        assert switch.kind == 'bool' and not switch.live
        assert getattr(build(schema, given), LIVE_SWITCH) is False


def test_every_parameter_has_a_description_and_the_defaults_pass_but_required_ones():
    for schema in (SatParams, *NODE_SCHEMAS):
        assert all(spec.description for _, spec, _ in leaves(schema)), schema
    assert build(SatParams, {}) == SatParams() and build(WorldNodeParams, {}).seed == -1
    assert build(AgentNodeParams, {'agent_id': 3}).agent_id == 3
    assert build(LoggerParams, {'run_dir': 'runs/x'}).agent_ids == (1, 2)
    with pytest.raises(ParameterError, match="'agent_id' = -1: allowed range is"):
        build(AgentNodeParams, {})
    with pytest.raises(ParameterError, match="'run_dir' is required"):
        build(ObserverParams, {})


def test_the_core_takes_live_values_and_refuses_the_others():
    params = SatParams()
    agent = Agent(1, params, [10.0, 10.0], seed=0)
    assert isinstance(agent.investigation, Investigation)
    agent.retune(params.with_overrides({'search.investigate_steps': 9}))
    assert agent.investigation.params.search.investigate_steps == 9
    assert agent.params.search.investigate_steps == 9
    with pytest.raises(ParameterError, match=r"\['sensor.p_detect'\] are read-only"):
        agent.retune(params.with_overrides({'sensor.p_detect': 0.5}))


def test_the_parameters_page_is_generated_from_the_schema():
    result = subprocess.run([sys.executable, str(REPO_ROOT / 'scripts' / 'parameter_docs.py'),
                             '--check'], capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    page = (REPO_ROOT / 'docs' / 'parameters.md').read_text()
    assert '| `cooperation.comm_range` | `50.0` | a number in [0, inf) | world_sim |' in page
