"""Faults: an agent killed with SIGKILL and respawned by the bring-up under 30 % radio loss."""

import json
import os
import signal
import subprocess
import time

import pytest
from ros_harness import (announce, bringup, executable, PARAMS, REPO, ros_node, run_swarm,
                         scaled, spin_until, started, wait_matched)

from sat_agent.ros.qos import STEP, WORLD
from sat_msgs.msg import ControlCommand, MeasurementSet, WorldStep

pytestmark = pytest.mark.ros
STEPS = 120
KILL_AT = 30


def child_pid(parent: int, pattern: str):
    """Return the pid of the bring-up's child whose command line matches pattern, or None."""
    result = subprocess.run(['pgrep', '-P', str(parent), '-f', pattern],
                            capture_output=True, text=True)
    pids = [int(p) for p in result.stdout.split()]
    return pids[0] if pids else None


def writer_gids(node, topic: str) -> set:
    """Return the gids of the writers the node's graph knows on topic (dead ones linger)."""
    return {bytes(info.endpoint_gid) for info in node.get_publishers_info_by_topic(topic)}


@pytest.mark.timeout(600)
def test_kill_and_respawn_under_radio_loss_completes_the_run(tmp_path):
    run_dir = tmp_path / 'run'
    command = [executable('sat_world_sim', 'swarm'),
               '--scenario', str(REPO / 'config' / 'scenarios' / 'paper.yaml'),
               '--params', str(PARAMS), '--run-dir', str(run_dir), '--steps', str(STEPS),
               '--respawn', '--radio-loss', '0.3', '--agent-timeout', '3', '--quiet',
               '--domain-id', os.environ['ROS_DOMAIN_ID'], '--timeout', str(scaled(480))]
    steps = []
    with ros_node('fault_injector') as node, bringup(command) as swarm:
        node.create_subscription(WorldStep, '/world/step', lambda m: steps.append(m.step), WORLD)
        spin_until(node, lambda: steps and steps[-1] >= KILL_AT, 180,
                   f'/world/step reaching step {KILL_AT}', (swarm,))
        victim = child_pid(swarm.pid, 'agent_id:=2')
        world = child_pid(swarm.pid, 'lib/sat_world_sim/world_sim')
        assert victim is not None and world is not None, 'no agent_2 or world_sim process'
        old = writer_gids(node, '/agent_2/cmd')
        # The world steps on without an inactive agent, so the run could end before a slow
        # respawn: world_sim is held until the new agent_2 has a command writer on the graph.
        os.kill(world, signal.SIGSTOP)
        try:
            os.kill(victim, signal.SIGKILL)
            spin_until(node, lambda: writer_gids(node, '/agent_2/cmd') - old, 120,
                       'the respawned agent_2 writing /agent_2/cmd', (swarm,))
        finally:
            os.kill(world, signal.SIGCONT)
        out, err = swarm.communicate(timeout=scaled(480))
    assert swarm.returncode == 0, err[-3000:]
    assert out.strip().splitlines()[-1] == str(run_dir)
    assert 'agent_2 exited (-9): respawn 1' in err
    metrics = json.loads((run_dir / 'metrics.json').read_text())
    assert [s['step'] for s in metrics['steps']] == list(range(1, STEPS + 1))
    # The respawned agent rejoined: it reports modes again by the end of the run. That it was
    # away is the bring-up's respawn line and the new writer above: the world was held while
    # it was, so its absence need not cost a step (a fresh clone once saw none missing).
    assert set(metrics['steps'][-1]['modes']) == {'1', '2'}
    # Held, the world did not take agent 1's answers from its queues: on waking it must not
    # let agent 1 go for a silence that was its own (attendance.deadline_after_stall).
    world_log = (run_dir / 'logs' / 'world_sim.log').read_text()
    assert 'world_sim did not tick for' in world_log and 'agents [1] silent' not in world_log
    assert (run_dir / 'bag' / 'metadata.yaml').is_file()


@pytest.mark.timeout(600)
def test_heavy_loss_and_latency_keep_the_swarm_working(tmp_path):
    run_dir = tmp_path / 'run'
    code, metrics, output = run_swarm(run_dir, REPO / 'config' / 'scenarios' / 'paper.yaml',
                                      '--steps', '80', '--radio-loss', '0.5', '--radio-delay',
                                      '3', '--quiet')
    assert code == 0, output[-3000:]
    steps = metrics['steps']
    assert [s['step'] for s in steps] == list(range(1, 81))
    assert all(set(s['modes']) == {'1', '2'} for s in steps), 'an agent stopped stepping'
    # Both keep searching: coverage grows all along.
    searched = [s['searched_pct'] for s in steps]
    assert searched[39] > searched[0] and searched[-1] > searched[39]
    # Nothing invalid crossed the radio, and late reports were taken, not dropped as stale.
    for name in ('agent_1', 'agent_2'):
        log = (run_dir / 'logs' / f'{name}.log').read_text()
        assert 'Traceback' not in log and 'stale_step' not in log, log[-2000:]


@pytest.mark.timeout(300)
def test_agents_hold_then_exit_cleanly_when_world_sim_dies(tmp_path):
    world_timeout = 4.0
    # More steps than the test ever lets the world run, so the world never finishes by itself
    # and the resuming scan's step is beyond every scan the world can have sent.
    world_steps = 1000
    resume_step = world_steps + 1
    world = [executable('sat_world_sim', 'world_sim'), '--ros-args', '--params-file',
             str(PARAMS), '-p', f"scenario:={REPO / 'config' / 'scenarios' / 'paper.yaml'}",
             '-p', 'observers:=1', '-p', f'steps:={world_steps}']
    agent = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_1',
             '--params-file', str(PARAMS), '-p', 'agent_id:=1',
             '-p', f'world_timeout:={world_timeout}']
    other = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_2',
             '--params-file', str(PARAMS), '-p', 'agent_id:=2']
    commands = []
    with ros_node('world_killer') as node:
        watch = node.create_subscription(ControlCommand, '/agent_1/cmd', commands.append, STEP)
        # The test plays the world once after world_sim died: one scan, to which agent 1 must
        # answer once (it resumes when scans come again).
        scan = node.create_publisher(MeasurementSet, '/agent_1/measurements', STEP)
        # world_sim waits for this watcher: a lock-step run can outpace a late-matched reader.
        announce(node, [watch])
        with started(agent, tmp_path / 'agent_1.log') as a1, \
                started(other, tmp_path / 'agent_2.log') as a2, \
                started(world, tmp_path / 'world.log') as w:
            spin_until(node, lambda: commands and commands[-1].step >= 10, 120,
                       "agent 1's commands up to step 10", (a1, a2, w))
            os.killpg(w.pid, signal.SIGKILL)
            w.wait()
            wait_matched(node, [scan], 30, "the test's scan writer matching agent 1")
            position = commands[-1].target_position
            sent_at = time.monotonic()
            scan.publish(MeasurementSet(agent_id=1, step=resume_step, agent_position=position))
            spin_until(node, lambda: any(c.step == resume_step for c in commands), 30,
                       'agent 1 answering the scan sent after world_sim died', (a1,))
            spin_until(node, lambda: a1.poll() is not None, world_timeout + 10,
                       f'agent 1 exiting {world_timeout} s after its last scan')
            gone = time.monotonic() - sent_at
            log = (tmp_path / 'agent_1.log').read_text()
            assert a1.returncode == 0, log[-2000:]
    assert 'world_sim is gone, exiting' in log
    # It waited world_timeout after its last scan (received after sent_at), and not much more.
    assert world_timeout <= gone <= world_timeout + scaled(10)
    # It only ever answered scans, once each: no command while no scan came, none twice.
    steps = [c.step for c in commands]
    assert steps == sorted(set(steps)), steps
    assert steps[-1] == resume_step, 'agent 1 sent commands after its last scan'
