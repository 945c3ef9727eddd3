"""ROS_DOMAIN_ID allocation (sat_world_sim.domain_ids): one id per run on a machine."""

import errno
import fcntl
import socket
import subprocess
import sys

import pytest

from sat_world_sim.domain_ids import (claim_domain_id, discovery_port, NoFreeDomain, POOL)

HOLDER = '''
import sys
from sat_world_sim.domain_ids import claim_domain_id
print(claim_domain_id(sys.argv[1]), flush=True)
sys.stdin.read()       # holds the id until the test closes stdin
'''


def test_the_pool_leaves_0_and_the_manual_ids_90_to_99_out():
    assert list(POOL) == list(range(1, 90))


def test_two_runs_at_once_get_different_ids_and_an_ended_run_frees_its_id(tmp_path):
    holder = subprocess.Popen([sys.executable, '-c', HOLDER, str(tmp_path)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    try:
        held = int(holder.stdout.readline())
        mine = claim_domain_id(tmp_path)
        assert mine != held and {mine, held} <= set(POOL)
    finally:
        holder.stdin.close()
        holder.wait()
    # The holder ended: the kernel dropped its lock, the id is free for the next run.
    with open(tmp_path / f'{held}.lock', 'a') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)


def test_an_id_whose_discovery_port_is_bound_outside_the_pool_is_skipped(tmp_path):
    first = claim_domain_id(tmp_path / 'a')
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as squatter:
        try:
            squatter.bind(('0.0.0.0', discovery_port(first, 0)))
        except OSError as error:     # a real run took that domain meanwhile: bound all the same
            assert error.errno == errno.EADDRINUSE
        assert claim_domain_id(tmp_path / 'b') != first


def test_a_full_pool_says_so(tmp_path):
    locks = []
    try:
        for domain_id in POOL:
            lock = open(tmp_path / f'{domain_id}.lock', 'a')
            fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
            locks.append(lock)
        with pytest.raises(NoFreeDomain, match='export ROS_DOMAIN_ID'):
            claim_domain_id(tmp_path)
    finally:
        for lock in locks:
            lock.close()
