"""The swarm across hosts (issue 17): world_sim and each agent in its own network namespace.

`swarm --netns` puts world_sim and the observers on one namespace and each agent on its own,
DDS over UDP between them (no shared memory), discovery through static peers: the lock-step
run must be the one-host run (the in-process swarm's metrics), and with 30 % radio loss and
authentication on it must still complete.
"""

import pytest
from ros_harness import REPO, run_swarm
from test_swarm_ros import inprocess_metrics

from sat_world_sim.netns import unavailable

UNAVAILABLE = unavailable()
pytestmark = [pytest.mark.ros,
              pytest.mark.skipif(UNAVAILABLE is not None, reason=str(UNAVAILABLE))]
PAPER = REPO / 'config' / 'scenarios' / 'paper.yaml'


@pytest.mark.timeout(300)
def test_three_namespaces_give_the_one_host_metrics(tmp_path):
    code, metrics, output = run_swarm(tmp_path / 'run', PAPER, '--netns', '--no-view')
    assert code == 0, output[-3000:]
    assert metrics == inprocess_metrics(PAPER)
    logs = tmp_path / 'run' / 'logs'
    # Over UDP between namespaces: the profile has no shared memory, and the agents were
    # really elsewhere (their own namespace, their own address).
    assert 'SHM' not in (tmp_path / 'run' / 'dds' / 'udp.xml').read_text()
    assert 'authentication is OFF' not in (logs / 'agent_1.log').read_text()


@pytest.mark.timeout(300)
def test_a_lossy_radio_across_namespaces_with_authentication_completes(tmp_path):
    code, metrics, output = run_swarm(tmp_path / 'run', PAPER, '--netns', '--no-view',
                                      '--no-record', '--radio-loss', '0.3')
    assert code == 0, output[-3000:]
    assert [s['step'] for s in metrics['steps']] == list(range(1, 201))
    assert metrics['dropped'] == {}


def test_netns_where_namespaces_cannot_be_made_stops_with_the_reason(monkeypatch):
    from sat_world_sim import bringup

    monkeypatch.setattr(bringup.netns, 'unavailable', lambda: 'network namespaces need root')
    options = bringup.parse_args(['--netns', '--run-dir', '/tmp/unused'])
    with pytest.raises(bringup.netns.NetnsError, match='--netns: network namespaces need root'):
        bringup.check_netns(options)
