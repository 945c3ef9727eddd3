"""Test-wide isolation and timing: this run's own ROS 2 domain, discovery on this host only.

pytest-timeout's limits are scaled by SAT_TEST_TIMEOUT_SCALE like every wait of ros_harness.
"""

import os
from pathlib import Path
import sys

from hypothesis import HealthCheck, settings
import pytest

from sat_world_sim.domain_ids import claim_domain_id

# Set before anything starts rclpy, so every node and child process of this run shares the
# domain. One exported by the user is kept; otherwise this run claims an id of the pool (1..89)
# that no other run on the machine holds, for as long as pytest lives (domain_ids.py).
DOMAIN_SOURCE = 'from the environment' if 'ROS_DOMAIN_ID' in os.environ else 'claimed'
if DOMAIN_SOURCE == 'claimed':
    os.environ['ROS_DOMAIN_ID'] = str(claim_domain_id())
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('RMW_IMPLEMENTATION', 'rmw_fastrtps_cpp')

TESTS_DIR = Path(__file__).resolve().parent
REPO_ROOT = TESTS_DIR.parent
# The processes the tests start get the Fast DDS profile the bring-up gives a run.
os.environ.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(REPO_ROOT / 'config' / 'fastdds.xml'))
# Test helpers (msg_samples, peers) live beside the tests.
sys.path.insert(0, str(TESTS_DIR))

# Hypothesis: the suite draws the same examples every run (a red run is the code's, never the
# draw's), with no per-example deadline and no data-generation speed check: both are wall-clock
# guesses a loaded machine breaks (speed lives in benchmarks). `--hypothesis-profile=explore`
# draws new examples each run.
settings.register_profile('suite', derandomize=True, database=None, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile('explore', deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile('suite')


def pytest_report_header(config):
    from ros_harness import SCALE, SCALE_VARIABLE
    return (f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']} ({DOMAIN_SOURCE}), "
            f'{SCALE_VARIABLE}={SCALE:g}')


def pytest_collection_modifyitems(config, items):
    """Scale every test's pytest-timeout limit (its marker, else pytest.ini's) by SCALE."""
    from ros_harness import SCALE
    if SCALE == 1:
        return
    from pytest_timeout import get_env_settings
    default = get_env_settings(config).timeout
    for item in items:
        marker = item.get_closest_marker('timeout')
        limit = (marker.args[0] if marker.args else marker.kwargs.get('timeout')) if marker \
            else default
        if limit:
            item.add_marker(pytest.mark.timeout(float(limit) * SCALE), append=False)


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
