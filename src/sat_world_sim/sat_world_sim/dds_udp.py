"""DDS between hosts: the Fast DDS profile and environment each process of a swarm needs.

On one host the swarm's processes find each other on localhost and move data through shared
memory. Across hosts (separate machines, or the network namespaces of sat_world_sim.netns)
each process gets:

- a Fast DDS XML profile (``FASTRTPS_DEFAULT_PROFILES_FILE``, udp_profile_xml): UDPv4 as the
  only transport, the built-in transports (shared memory, UDPv4) off, discovery by unicast only
  (a default unicast metatraffic locator and no multicast one), and the project's writer
  profile (config/fastdds.xml) kept;
- ``ROS_AUTOMATIC_DISCOVERY_RANGE=SUBNET`` (under which rmw_fastrtps leaves the profile's
  transports alone) and either static peers, ``ROS_STATIC_PEERS`` = 127.0.0.1 (the processes
  of the same host) and the other hosts' addresses, or a Fast DDS discovery server,
  ``ROS_DISCOVERY_SERVER=<address>:<port>``, with one server running
  (``fast-discovery-server -i 0 -l <address> -p <port>``, or any participant with the
  discovery_server_xml profile and discovery_server_env).

Traps (rmw_fastrtps 8.4, Fast DDS 2.14 of the Jazzy wheels):

- ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`` replaces the profile's transports with shared
  memory + UDPv4: processes in namespaces of one machine (which share /dev/shm) could then
  move data through shared memory, not over the network. ``OFF`` ignores the static peers.
- Each participant of a peer host is probed at the ports of participant ids 0 ..
  ``maxInitialPeersRange`` - 1 (Fast DDS's default: 4). With more processes per host than
  that, two late participants on different hosts never announce to each other, so the profile
  raises the range (MAX_PARTICIPANTS_PER_HOST).
- Over UDP a payload is padded to a multiple of 4 bytes (sat_agent/message_auth.py says why
  that matters).
- The wheels' ``fastdds discovery`` CLI does not find its tool, and ``fast-discovery-server``
  only starts with ``LD_LIBRARY_PATH=<venv>/lib:<venv>/lib/python3.11/site-packages/
  ros_fastrtps.libs`` (its RPATH points inside the wheel); a discovery server under a
  LOCALHOST discovery range fails ("wasn't able to allocate the specified listening port").
"""

from pathlib import Path
from typing import Mapping, Optional, Sequence
import xml.etree.ElementTree as ET

NAMESPACE = 'http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles'
# ROS processes on one host (world_sim, metrics, recorder, logger and agents in composed mode).
MAX_PARTICIPANTS_PER_HOST = 32
DISCOVERY_SERVER_PORT = 11811
# The well-known GUID prefix of discovery server 0 (what ROS_DISCOVERY_SERVER's first entry
# means to Fast DDS 2.x clients).
SERVER_0_PREFIX = '44.53.00.5f.45.50.52.4f.53.49.4d.41'


def _tag(name: str) -> str:
    return f'{{{NAMESPACE}}}{name}'


def _sub(parent, name: str, text: Optional[str] = None):
    element = ET.SubElement(parent, _tag(name))
    if text is not None:
        element.text = text
    return element


def _profiles(base_profile: Optional[Path]):
    """Return the base profile's <profiles> (its writer profile kept), or an empty one."""
    ET.register_namespace('', NAMESPACE)
    if base_profile is None:
        return ET.Element(_tag('profiles'))
    return ET.parse(base_profile).getroot()


def _udp_participant(profiles, name: str):
    transports = _sub(profiles, 'transport_descriptors')
    descriptor = _sub(transports, 'transport_descriptor')
    _sub(descriptor, 'transport_id', 'sat_udp')
    _sub(descriptor, 'type', 'UDPv4')
    _sub(descriptor, 'maxInitialPeersRange', str(MAX_PARTICIPANTS_PER_HOST))
    participant = _sub(profiles, 'participant')
    participant.set('profile_name', name)
    participant.set('is_default_profile', 'true')
    rtps = _sub(participant, 'rtps')
    _sub(_sub(rtps, 'userTransports'), 'transport_id', 'sat_udp')
    _sub(rtps, 'useBuiltinTransports', 'false')
    return rtps


def _unicast_locator(builtin, address: Optional[str] = None, port: Optional[int] = None):
    """Add a metatraffic unicast locator: it keeps Fast DDS from adding a multicast one.

    Without address and port: every interface, at the participant's default port.
    """
    udp = _sub(_sub(_sub(builtin, 'metatrafficUnicastLocatorList'), 'locator'), 'udpv4')
    if address is not None:
        _sub(udp, 'address', address)
        _sub(udp, 'port', str(port))


def udp_profile_xml(base_profile: Optional[Path]) -> str:
    """Return the XML profile of a process talking to other hosts over UDPv4 only."""
    profiles = _profiles(base_profile)
    _unicast_locator(_sub(_udp_participant(profiles, 'sat_swarm_udp'), 'builtin'))
    return ET.tostring(profiles, encoding='unicode', xml_declaration=True)


def discovery_server_xml(address: str, port: int = DISCOVERY_SERVER_PORT) -> str:
    """Return the XML profile of a participant acting as discovery server 0 on address:port."""
    profiles = _profiles(None)
    rtps = _udp_participant(profiles, 'sat_discovery_server')
    _sub(rtps, 'prefix', SERVER_0_PREFIX)
    builtin = _sub(rtps, 'builtin')
    _sub(_sub(builtin, 'discovery_config'), 'discoveryProtocol', 'SERVER')
    _unicast_locator(builtin, address, port)
    return ET.tostring(profiles, encoding='unicode', xml_declaration=True)


def udp_env(env: Mapping[str, str], profile: Path, peers: Sequence[str] = (),
            discovery_server: Optional[str] = None) -> dict:
    """Return env for one process on one host: the UDP profile and how it discovers the others.

    peers: the other hosts' addresses (static peers); discovery_server: '<address>:<port>' of
    the discovery server instead. ROS_DOMAIN_ID and RMW_IMPLEMENTATION are left as in env.
    """
    if bool(peers) == bool(discovery_server):
        raise ValueError('give the other hosts as peers or a discovery server (one of them)')
    out = _subnet_env(env, profile)
    if peers:
        out['ROS_STATIC_PEERS'] = ';'.join(['127.0.0.1', *peers])
    else:
        out['ROS_DISCOVERY_SERVER'] = discovery_server
    return out


def discovery_server_env(env: Mapping[str, str], profile: Path) -> dict:
    """Return env for the participant that is the discovery server (discovery_server_xml)."""
    return _subnet_env(env, profile)


def _subnet_env(env: Mapping[str, str], profile: Path) -> dict:
    out = {name: value for name, value in env.items() if name not in (
        'ROS_LOCALHOST_ONLY', 'ROS_STATIC_PEERS', 'ROS_DISCOVERY_SERVER')}
    out['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(profile)
    out['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'SUBNET'
    return out
