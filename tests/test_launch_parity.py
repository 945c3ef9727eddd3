"""Launch parity: the launch file, the bring-up and README's `ros2 run` lines are one run.

The launch file's launch arguments are the bring-up's run options and its processes come from
the bring-up's process_list. The paper scenario launched through the launch description
(launch's Python API when launch and launch_ros are importable; otherwise the launch file's
process list, checked against the bring-up's, run as launch_ros would start it) gives the
bring-up's metrics.json, byte for byte.
"""

import importlib.util
import json
import os
from pathlib import Path
import re
import subprocess
import sys

from ament_index_python.packages import get_package_share_directory
import pytest
from ros_harness import PARAMS, PATIENT_AGENT_TIMEOUT_S, REPO, scaled

from sat_world_sim import bringup

LAUNCH_FILE = Path(get_package_share_directory('sat_world_sim')) / 'launch' / 'swarm.launch.py'
PAPER = REPO / 'config' / 'scenarios' / 'paper.yaml'
README_BLOCK = re.compile(r'<!-- ros2 run lines: start.*?-->\n```bash\n(.*?)```\n'
                          r'<!-- ros2 run lines: end -->', re.S)


def load_module(path: Path, name: str):
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def launch_importable() -> bool:
    return all(importlib.util.find_spec(name) for name in ('launch', 'launch_ros'))


def test_every_run_option_is_a_launch_argument():
    names = [name for name, _, _ in bringup.launch_arguments()]
    assert {'seed', 'clock', 'period', 'steps', 'record', 'view', 'fastdds_profile', 'scenario',
            'params', 'run_dir', 'composed', 'respawn', 'view_rate'} <= set(names)
    assert not set(names) & set(bringup.SUPERVISION_OPTIONS)


def test_launch_argument_values_give_the_bring_up_processes_and_environment(tmp_path):
    launch = load_module(LAUNCH_FILE, 'swarm_launch')
    values = {'scenario': str(PAPER), 'params': str(PARAMS), 'run_dir': str(tmp_path / 'run'),
              'seed': '3', 'clock': 'real_time', 'period': '0.5', 'steps': '7',
              'radio_loss': '0.2', 'radio_delay': '1', 'composed': 'true', 'respawn': 'true',
              'record': 'false', 'view': 'none', 'view_rate': '0.5',
              'fastdds_profile': '/profiles/mine.xml', 'domain_id': '42'}
    processes, env = launch.processes(values)
    options = bringup.parse_args([
        '--scenario', str(PAPER), '--params', str(PARAMS), '--run-dir', str(tmp_path / 'run'),
        '--seed', '3', '--clock', 'real_time', '--period', '0.5', '--steps', '7',
        '--radio-loss', '0.2', '--radio-delay', '1', '--composed', '--respawn', '--no-record',
        '--no-view', '--view-rate', '0.5', '--fastdds-profile', '/profiles/mine.xml',
        '--domain-id', '42'])
    assert processes == bringup.load_run(options)
    assert [p.name for p in processes] == ['world_sim', 'metrics', 'agents']
    assert env == {'FASTRTPS_DEFAULT_PROFILES_FILE': '/profiles/mine.xml', 'ROS_DOMAIN_ID': '42'}
    world = processes[0].ros_arguments
    assert 'seed:=3' in world and 'steps:=7' in world and 'use_sim_time:=true' in world


def test_launch_defaults_are_the_bring_up_defaults():
    launch = load_module(LAUNCH_FILE, 'swarm_launch')
    defaults = {name: value for name, value, _ in bringup.launch_arguments()}
    processes, env = launch.processes({**defaults, 'run_dir': 'runs/x'})
    assert processes == bringup.load_run(bringup.parse_args(['--run-dir', 'runs/x']))
    assert env == {'FASTRTPS_DEFAULT_PROFILES_FILE': bringup.default_fastdds_profile()}
    # The scenario's seed goes to world_sim and to every agent.
    seeded = [p.name for p in processes if 'seed:=1' in p.ros_arguments]
    assert seeded == ['world_sim', 'agent_1', 'agent_2']


def test_readme_ros2_run_lines_are_make_runs_processes():
    run_paper = load_module(REPO / 'scripts' / 'run_paper.py', 'run_paper')
    result = subprocess.run(
        [sys.executable, '-m', 'sat_world_sim.bringup', *run_paper.PAPER_ARGS, '--run-dir',
         'runs/paper', '--fastdds-profile', 'config/fastdds.xml', '--print-ros2-run'],
        cwd=REPO, capture_output=True, text=True, timeout=scaled(60))
    assert result.returncode == 0, result.stderr
    block = README_BLOCK.search((REPO / 'README.md').read_text(encoding='utf-8'))
    assert block, 'README.md has no ros2 run block'
    assert block.group(1) == result.stdout


def launch_with_the_python_api(values: dict) -> int:
    """Run the launch file as `ros2 launch` does; return the launch service's exit code."""
    from launch import LaunchDescription, LaunchService
    from launch.actions import IncludeLaunchDescription
    from launch.launch_description_sources import PythonLaunchDescriptionSource

    service = LaunchService()
    service.include_launch_description(LaunchDescription([IncludeLaunchDescription(
        PythonLaunchDescriptionSource(str(LAUNCH_FILE)), launch_arguments=values.items())]))
    return service.run()


def launch_the_process_list(values: dict, run_dir: Path) -> int:
    """Start the launch file's processes with its environment, as launch_ros's Node would."""
    processes, extra = load_module(LAUNCH_FILE, 'swarm_launch').processes(values)
    options = bringup.options_from_launch(values)
    assert processes == bringup.load_run(options)
    env = {**os.environ, **extra, 'PYTHONUNBUFFERED': '1'}
    return bringup.run(processes, env, run_dir, timeout=scaled(500.0), echo=False)


@pytest.mark.ros
@pytest.mark.slow
@pytest.mark.timeout(600)
def test_the_paper_run_through_the_launch_file_gives_the_bring_ups_metrics(paper_run, tmp_path):
    bringup_dir, code, _, output = paper_run
    assert code == 0, output[-3000:]
    run_dir = tmp_path / 'launched'
    # The agent timeout paper_run's bring-up had (run_swarm): a slow step on a loaded machine
    # must not mark an agent inactive in one run and not in the other.
    values = {'scenario': str(PAPER), 'params': str(PARAMS), 'run_dir': str(run_dir),
              'domain_id': os.environ['ROS_DOMAIN_ID'],
              'agent_timeout': str(scaled(PATIENT_AGENT_TIMEOUT_S))}
    if launch_importable():
        code = launch_with_the_python_api(values)
    else:
        code = launch_the_process_list(values, run_dir)
    assert code == 0
    launched = (run_dir / 'metrics.json').read_text()
    assert launched == (bringup_dir / 'metrics.json').read_text()
    assert json.loads(launched)['seed'] == 1
