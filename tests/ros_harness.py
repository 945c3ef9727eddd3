"""Helpers for the multi-process ROS 2 tests: start installed executables, always stop them."""

from contextlib import contextmanager
import json
import os
from pathlib import Path
import subprocess
import sys

from ament_index_python.packages import get_package_prefix
import yaml

from sat_world_sim.bringup import stop_group

REPO = Path(__file__).resolve().parents[1]
PARAMS = REPO / 'config' / 'paper.yaml'


def executable(package: str, name: str) -> str:
    """Return the installed lib/<package>/<name>, as `ros2 run` finds it."""
    return str(Path(get_package_prefix(package)) / 'lib' / package / name)


def write_scenario(path: Path, **document) -> Path:
    """Write a scenario YAML (keys as in config/scenarios/paper.yaml)."""
    path.write_text(yaml.safe_dump(document), encoding='utf-8')
    return path


@contextmanager
def started(command, log_path: Path):
    """Run command in its own session with output to log_path; stop it (and its group) after."""
    with open(log_path, 'w', encoding='utf-8') as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                   env=dict(os.environ, PYTHONUNBUFFERED='1'),
                                   start_new_session=True)
        try:
            yield process
        finally:
            stop_group(process, grace=10.0)


def run_swarm(run_dir: Path, scenario: Path, *extra, timeout: float = 600.0,
              params: Path = PARAMS):
    """Run the bring-up (`swarm`) to completion; return (exit code, metrics or None, output)."""
    command = [sys.executable, executable('sat_world_sim', 'swarm'), '--scenario', str(scenario),
               '--params', str(params), '--run-dir', str(run_dir),
               '--domain-id', os.environ['ROS_DOMAIN_ID'], *extra]
    result = subprocess.run(command, capture_output=True, text=True, timeout=timeout)
    metrics_path = run_dir / 'metrics.json'
    metrics = json.loads(metrics_path.read_text()) if metrics_path.is_file() else None
    return result.returncode, metrics, result.stdout + result.stderr
