"""Test-wide isolation: a private ROS 2 domain for this run, discovery limited to this host."""

import os
from pathlib import Path
import sys

import pytest

# Chosen before any rclpy import so every node and child process of this run shares it and no
# other run on the machine sees it. Domain ids 1..100 stay clear of Fast DDS's port limits.
os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 100))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')

TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent
# The processes the tests start get the Fast DDS profile the bring-up gives a run.
os.environ.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(REPO_ROOT / 'config' / 'fastdds.xml'))
# Test helpers (msg_samples, peers) live beside the tests.
sys.path.insert(0, str(TESTS_DIR))


@pytest.fixture(scope='session')
def paper_run(tmp_path_factory):
    """Run the paper's scenario through the ROS graph (bring-up) once per test session.

    Returns (run_dir, exit code, metrics dict, output); several test modules read its metrics,
    bag and recording.
    """
    from ros_harness import REPO, run_swarm

    run_dir = tmp_path_factory.mktemp('paper') / 'run'
    code, metrics, output = run_swarm(run_dir, REPO / 'config' / 'scenarios' / 'paper.yaml')
    return run_dir, code, metrics, output
