"""Hosts on one machine: Linux network namespaces on a private veth bridge (root only).

Each host is a network namespace with one interface, ``eth0``, holding its own address on a
bridge; the bridge lives in a namespace of its own, so nothing is added to the machine's own
network and traffic flows only between the hosts. Processes run on a host through
``ip netns exec``. ROS-free: this module only runs ``ip``.

    with NetnsBridge(['world', 'agent_1', 'agent_2']) as net:
        subprocess.Popen(net.command('agent_1', ['python', 'peer.py']), env=...)

Names are unique per run (``sat<pid>x<token>-<index>``), so runs in parallel do not collide, and
removal always runs: on leaving the ``with`` block, at interpreter exit, and for the namespaces
of earlier runs whose process is gone (a run killed with SIGKILL) when the next one starts.
Deleting a namespace deletes its end of every veth pair and, for the bridge's namespace, the
bridge; a process still running in a namespace would keep it alive, so removal kills what the
run left running there (processes this run started, found with ``ip netns pids``).

Loss and delay cannot be emulated here (this kernel has no netem qdisc): they stay the radio's
settings (world_sim's ``radio.loss`` and ``radio.delay_steps``).
"""

import atexit
import ipaddress
import os
import re
import secrets
import shutil
import signal
import subprocess
from typing import Dict, List, Optional, Sequence

DEFAULT_SUBNET = '10.23.0.0/24'
PREFIX = 'sat'
# Namespaces this module made: 'sat<pid>x<token>-<index>' (index 'br' for the bridge's).
_NAME = re.compile(rf'^{PREFIX}(\d+)x[0-9a-f]+-(\w+)$')


class NetnsError(RuntimeError):
    """An `ip` command failed; the message has the command and what it printed."""


def _ip(*args: str, check: bool = True) -> str:
    result = subprocess.run(['ip', *args], capture_output=True, text=True)
    if check and result.returncode != 0:
        raise NetnsError(f"ip {' '.join(args)}: {result.stderr.strip() or result.returncode}")
    return result.stdout


def unavailable() -> Optional[str]:
    """Return why namespaces cannot be made here (for a test's skip), or None if they can."""
    if os.geteuid() != 0:
        return 'network namespaces need root'
    if shutil.which('ip') is None:
        return "no 'ip' command (iproute2)"
    probe = f'{PREFIX}{os.getpid()}x{secrets.token_hex(3)}-probe'
    result = subprocess.run(['ip', 'netns', 'add', probe], capture_output=True, text=True)
    if result.returncode != 0:
        return f'ip netns add failed: {result.stderr.strip()}'
    _ip('netns', 'del', probe, check=False)
    return None


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _our_namespaces() -> List[str]:
    names = [line.split()[0] for line in _ip('netns', 'list').splitlines() if line.strip()]
    return [name for name in names if _NAME.match(name)]


def _delete(namespace: str):
    """Kill what still runs in namespace (ours: only this module's namespaces), delete it."""
    for pid in _ip('netns', 'pids', namespace, check=False).split():
        try:
            os.kill(int(pid), signal.SIGKILL)
        except ProcessLookupError:
            pass
    _ip('netns', 'del', namespace, check=False)


def remove_orphans():
    """Delete the namespaces of earlier runs whose process no longer exists."""
    for name in _our_namespaces():
        if not _pid_alive(int(_NAME.match(name).group(1))):
            _delete(name)


class NetnsBridge:
    """Hosts (network namespaces) with their own address on one private bridge (module doc)."""

    def __init__(self, hosts: Sequence[str], subnet: str = DEFAULT_SUBNET):
        if len(set(hosts)) != len(hosts) or not hosts:
            raise ValueError(f'hosts {list(hosts)}: need distinct names, at least one')
        network = ipaddress.ip_network(subnet)
        if network.num_addresses - 3 < len(hosts):
            raise ValueError(f'subnet {subnet}: too small for {len(hosts)} hosts')
        run = f'{PREFIX}{os.getpid()}x{secrets.token_hex(3)}'
        self.namespace: Dict[str, str] = {h: f'{run}-{i}' for i, h in enumerate(hosts)}
        # .1 stays free (a gateway on real networks); hosts take .2, .3, ...
        self.address: Dict[str, str] = {h: str(network.network_address + 2 + i)
                                        for i, h in enumerate(hosts)}
        self.prefixlen = network.prefixlen
        self.bridge_namespace = f'{run}-br'
        self._made: List[str] = []

    def __enter__(self) -> 'NetnsBridge':
        try:
            self.create()
        except BaseException:
            self.remove()
            raise
        return self

    def __exit__(self, *exc):
        self.remove()

    def create(self):
        """Make the bridge's namespace, the bridge, and each host with its veth and address."""
        remove_orphans()
        atexit.register(self.remove)
        self._add_namespace(self.bridge_namespace)
        br = ['-n', self.bridge_namespace]
        _ip(*br, 'link', 'add', 'br0', 'type', 'bridge')
        _ip(*br, 'link', 'set', 'br0', 'up')
        for index, (host, namespace) in enumerate(self.namespace.items()):
            self._add_namespace(namespace)
            port = f'p{index}'
            # Made inside the bridge's namespace with the peer end put straight into the host's:
            # the root namespace never sees either end, so interface names cannot collide.
            _ip(*br, 'link', 'add', port, 'type', 'veth', 'peer', 'name', 'eth0',
                'netns', namespace)
            _ip(*br, 'link', 'set', port, 'master', 'br0')
            _ip(*br, 'link', 'set', port, 'up')
            _ip('-n', namespace, 'addr', 'add', f'{self.address[host]}/{self.prefixlen}',
                'dev', 'eth0')
            _ip('-n', namespace, 'link', 'set', 'eth0', 'up')
            _ip('-n', namespace, 'link', 'set', 'lo', 'up')

    def _add_namespace(self, namespace: str):
        _ip('netns', 'add', namespace)
        self._made.append(namespace)

    def remove(self):
        """Delete every namespace this bridge made (and with them the links); idempotent."""
        while self._made:
            _delete(self._made.pop())
        atexit.unregister(self.remove)

    def command(self, host: str, argv: Sequence[str]) -> List[str]:
        """Return argv run on host (inside its namespace)."""
        return ['ip', 'netns', 'exec', self.namespace[host], *argv]

    def peers_of(self, host: str) -> List[str]:
        """Addresses of the other hosts."""
        return [address for name, address in self.address.items() if name != host]
