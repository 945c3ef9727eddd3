"""The environment the bring-up gives every process of a run, and the scripts' profile check."""

import argparse
from pathlib import Path
import xml.etree.ElementTree as ElementTree

import pytest

from sat_world_sim.bringup import profile_argument, ros_env
from sat_world_sim.domain_ids import POOL

ROOT = Path(__file__).resolve().parents[1]
FASTDDS = '{http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles}'


def test_a_run_gets_its_own_domain_localhost_discovery_and_the_fast_dds_profile(monkeypatch):
    monkeypatch.delenv('FASTRTPS_DEFAULT_PROFILES_FILE', raising=False)
    monkeypatch.delenv('ROS_AUTOMATIC_DISCOVERY_RANGE', raising=False)
    env = ros_env(7)
    assert env['ROS_DOMAIN_ID'] == '7' and env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'LOCALHOST'
    # Without --domain-id a run claims an id of the pool, one no other run holds.
    assert int(ros_env(None)['ROS_DOMAIN_ID']) in POOL
    # The installed copy of config/fastdds.xml: reliable writers announce unacknowledged
    # samples every 100 ms, so a lost sample is repaired within a step (the file says why).
    profile = Path(env['FASTRTPS_DEFAULT_PROFILES_FILE'])
    writer = ElementTree.parse(profile).getroot().find(f'{FASTDDS}data_writer')
    assert writer.get('is_default_profile') == 'true'
    period = writer.find(f'{FASTDDS}times/{FASTDDS}heartbeatPeriod')
    assert (period.findtext(f'{FASTDDS}sec'), period.findtext(f'{FASTDDS}nanosec')) == (
        '0', '100000000')


def test_a_profile_file_of_the_users_own_wins(monkeypatch, tmp_path):
    own = tmp_path / 'mine.xml'
    monkeypatch.setenv('FASTRTPS_DEFAULT_PROFILES_FILE', str(own))
    assert ros_env(3)['FASTRTPS_DEFAULT_PROFILES_FILE'] == str(own)


def test_a_scripts_profile_argument_is_loaded_before_any_swarm_starts(tmp_path):
    """The soak and bench_swarm scripts take --params through profile_argument."""
    paper = ROOT / 'config' / 'paper.yaml'
    assert profile_argument(str(paper)) == paper.resolve()
    with pytest.raises(argparse.ArgumentTypeError, match='missing.yaml'):
        profile_argument(str(tmp_path / 'missing.yaml'))
    bad = tmp_path / 'bad.yaml'
    bad.write_text('/**:\n  ros__parameters:\n    phd:\n      n_particles: 5\n')
    with pytest.raises(argparse.ArgumentTypeError, match=r'bad\.yaml: unknown parameter'):
        profile_argument(str(bad))
