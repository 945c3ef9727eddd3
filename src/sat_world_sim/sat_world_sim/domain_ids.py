"""ROS_DOMAIN_ID for one run: an id that no other run on this machine holds while it lives.

Runs on one machine discover each other over the loopback, so two runs in one domain see each
other's topics (a test's world_sim would step another run's agents). Ids come from a pool of
lock files, ``<temp dir>/sat-swarm-domains/<id>.lock``: a run takes the first id whose lock it
gets (``fcntl.flock``, without waiting) and keeps it until its process ends, however it ends
(the kernel drops the lock). An id whose first participants' discovery ports are bound by a
process outside the pool (a manual run, an older checkout) is skipped as well.

The pool is 1..89: 0 is ROS's default domain and 90..99 are left to developers' manual runs.
"""

import errno
import fcntl
from pathlib import Path
import socket
import tempfile
from typing import List, Optional

POOL = range(1, 90)
LOCK_DIR = Path(tempfile.gettempdir()) / 'sat-swarm-domains'
# Fast DDS's default port mapping (RTPS 2.x, section 9.6.1.1): participant p of domain d takes
# the metatraffic unicast port PB + DG d + d1 + PG p.
PORT_BASE, DOMAIN_GAIN, PARTICIPANT_GAIN, UNICAST_OFFSET = 7400, 250, 2, 10
# Participants of one run on one machine take the lowest free participant ids; a run of ours
# has at most a few dozen processes.
PROBED_PARTICIPANTS = 32

# Open lock files of the ids this process holds: closing one would release its id.
_held: List[object] = []


class NoFreeDomain(RuntimeError):
    """Every id of the pool is held by another run."""


def discovery_port(domain_id: int, participant: int) -> int:
    """UDP port of the metatraffic unicast locator of a participant (Fast DDS default)."""
    return PORT_BASE + DOMAIN_GAIN * domain_id + UNICAST_OFFSET + PARTICIPANT_GAIN * participant


def in_use_outside_pool(domain_id: int) -> bool:
    """Whether a participant of domain_id runs on this machine (one of its ports is bound)."""
    for participant in range(PROBED_PARTICIPANTS):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
            try:
                probe.bind(('0.0.0.0', discovery_port(domain_id, participant)))
            except OSError as error:
                if error.errno == errno.EADDRINUSE:
                    return True
                raise
    return False


def claim_domain_id(lock_dir: Optional[Path] = None) -> int:
    """Return a free id of POOL and hold it for the rest of this process's life."""
    lock_dir = Path(lock_dir or LOCK_DIR)
    lock_dir.mkdir(parents=True, exist_ok=True)
    for domain_id in POOL:
        try:
            lock = open(lock_dir / f'{domain_id}.lock', 'a')
        except PermissionError:     # another user's lock file: that user may hold the id
            continue
        try:
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            lock.close()
            continue
        if in_use_outside_pool(domain_id):
            lock.close()
            continue
        _held.append(lock)
        return domain_id
    raise NoFreeDomain(f'every ROS_DOMAIN_ID in {POOL.start}..{POOL.stop - 1} is held by another '
                       f'run (lock files in {lock_dir}); export ROS_DOMAIN_ID to choose one')
