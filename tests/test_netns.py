"""Hosts as network namespaces on a veth bridge, DDS between them over UDP only.

Two rclpy processes in two namespaces exchange signed std_msgs messages (tests/netns_peer.py)
through static peers or a discovery server; with discovery on localhost only they do not find
each other. Skipped where namespaces cannot be made (not root, no `ip`).
"""

import os
from pathlib import Path
import subprocess
import sys
import xml.etree.ElementTree as ET

import pytest
from ros_harness import scaled

from sat_agent.message_auth import create_key_file
from sat_world_sim import netns
from sat_world_sim.dds_udp import (discovery_server_env, discovery_server_xml, NAMESPACE,
                                   udp_env, udp_profile_xml)
from sat_world_sim.netns import NetnsBridge

TESTS_DIR = Path(__file__).resolve().parent
REPO = TESTS_DIR.parent
PEER = [sys.executable, str(TESTS_DIR / 'netns_peer.py')]
UNAVAILABLE = netns.unavailable()
needs_netns = pytest.mark.skipif(UNAVAILABLE is not None, reason=str(UNAVAILABLE))


def tag(name: str) -> str:
    return f'{{{NAMESPACE}}}{name}'


# -- the profile and environment (no namespaces needed) -------------------------------------

def test_the_udp_profile_has_udpv4_only_unicast_discovery_and_the_projects_writer_profile():
    root = ET.fromstring(udp_profile_xml(REPO / 'config' / 'fastdds.xml'))
    assert [t.text for t in root.iter(tag('type'))] == ['UDPv4']
    participant = root.find(tag('participant'))
    assert participant.get('is_default_profile') == 'true'
    assert participant.find(f"{tag('rtps')}/{tag('useBuiltinTransports')}").text == 'false'
    builtin = participant.find(f"{tag('rtps')}/{tag('builtin')}")
    assert builtin.find(f"{tag('metatrafficUnicastLocatorList')}/{tag('locator')}") is not None
    assert builtin.find(tag('metatrafficMulticastLocatorList')) is None
    assert root.find(f"{tag('data_writer')}/{tag('times')}/{tag('heartbeatPeriod')}") is not None


def test_the_discovery_server_profile_listens_on_its_address_as_server_0():
    root = ET.fromstring(discovery_server_xml('10.1.2.3', 12000))
    assert root.find(f".//{tag('discoveryProtocol')}").text == 'SERVER'
    assert root.find(f".//{tag('udpv4')}/{tag('address')}").text == '10.1.2.3'
    assert root.find(f".//{tag('udpv4')}/{tag('port')}").text == '12000'


def test_each_process_discovers_by_unicast_through_peers_or_a_server_never_both():
    env = udp_env({'ROS_LOCALHOST_ONLY': '1', 'ROS_DOMAIN_ID': '7'}, Path('/p.xml'),
                  peers=['10.0.0.2', '10.0.0.3'])
    assert env['ROS_STATIC_PEERS'] == '127.0.0.1;10.0.0.2;10.0.0.3'
    # SUBNET: under LOCALHOST rmw_fastrtps would replace the profile's transports.
    assert env['ROS_AUTOMATIC_DISCOVERY_RANGE'] == 'SUBNET'
    assert env['FASTRTPS_DEFAULT_PROFILES_FILE'] == '/p.xml' and env['ROS_DOMAIN_ID'] == '7'
    assert 'ROS_LOCALHOST_ONLY' not in env
    server = udp_env({}, Path('/p.xml'), discovery_server='10.0.0.2:11811')
    assert server['ROS_DISCOVERY_SERVER'] == '10.0.0.2:11811' and 'ROS_STATIC_PEERS' not in server
    for bad in ({}, {'peers': ['a'], 'discovery_server': 'b:1'}):
        with pytest.raises(ValueError, match='peers or a discovery server'):
            udp_env({}, Path('/p.xml'), **bad)


# -- namespaces -----------------------------------------------------------------------------

def namespaces():
    return subprocess.run(['ip', 'netns', 'list'], capture_output=True, text=True).stdout


@needs_netns
def test_namespaces_and_links_are_removed_even_when_the_block_fails():
    with pytest.raises(RuntimeError, match='inside'):
        with NetnsBridge(['a', 'b']) as net:
            made = [*net.namespace.values(), net.bridge_namespace]
            assert all(name in namespaces() for name in made)
            address = subprocess.run(net.command('a', ['ip', '-4', 'addr', 'show', 'eth0']),
                                     capture_output=True, text=True).stdout
            assert f"{net.address['a']}/24" in address
            raise RuntimeError('inside')
    assert not any(name in namespaces() for name in made)


@needs_netns
def test_namespaces_left_by_a_dead_run_are_removed_by_the_next():
    finished = subprocess.Popen(['true'])
    finished.wait()
    orphan = f'{netns.PREFIX}{finished.pid}x0-0'
    subprocess.run(['ip', 'netns', 'add', orphan], check=True)
    with NetnsBridge(['a']):
        assert orphan not in namespaces()


def exchange(tmp_path, discovery: str, listen_timeout: float):
    """Talker on host a, listener on b; return (listener result, talker's memory maps)."""
    key = create_key_file(tmp_path / 'swarm.key')
    profile = tmp_path / 'udp.xml'
    profile.write_text(udp_profile_xml(REPO / 'config' / 'fastdds.xml'))
    with NetnsBridge(['server', 'a', 'b']) as net:
        def env(host):
            if discovery == 'static_peers':
                return udp_env(os.environ, profile, peers=net.peers_of(host))
            if discovery == 'discovery_server':
                return udp_env(os.environ, profile,
                               discovery_server=f"{net.address['server']}:11811")
            # The project's one-host setting: localhost discovery, the default transports.
            return dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')

        started = []
        if discovery == 'discovery_server':
            server_profile = tmp_path / 'server.xml'
            server_profile.write_text(discovery_server_xml(net.address['server']))
            started.append(subprocess.Popen(
                net.command('server', [*PEER, 'serve', '--timeout', str(scaled(120))]),
                env=discovery_server_env(os.environ, server_profile)))
        talker = subprocess.Popen(net.command('a', [*PEER, 'talk', '--key-file', str(key),
                                                    '--timeout', str(scaled(120))]),
                                  env=env('a'))
        started.append(talker)
        try:
            listener = subprocess.run(
                net.command('b', [*PEER, 'listen', '--key-file', str(key), '--timeout',
                                  str(listen_timeout)]),
                env=env('b'), capture_output=True, text=True,
                timeout=listen_timeout + scaled(30))
            maps = Path(f'/proc/{talker.pid}/maps').read_text()
        finally:
            for process in started:
                process.terminate()
                process.wait(timeout=scaled(10))
    return listener, maps


@needs_netns
@pytest.mark.ros
@pytest.mark.timeout(180)
@pytest.mark.parametrize('discovery', ['static_peers', 'discovery_server'])
def test_two_namespaces_exchange_verified_messages_over_udp(tmp_path, discovery):
    listener, talker_maps = exchange(tmp_path, discovery, listen_timeout=scaled(60))
    assert listener.returncode == 0, listener.stdout + listener.stderr
    assert listener.stdout.count('verified step') >= 5 and 'refused' not in listener.stdout
    # The data went over the veth: the talker never mapped Fast DDS's shared memory.
    assert '/dev/shm/fastrtps' not in talker_maps


@needs_netns
@pytest.mark.ros
@pytest.mark.timeout(120)
def test_with_localhost_discovery_only_the_namespaces_do_not_find_each_other(tmp_path):
    listener, _ = exchange(tmp_path, 'localhost', listen_timeout=scaled(10))
    assert listener.returncode == 1 and 'verified' not in listener.stdout
