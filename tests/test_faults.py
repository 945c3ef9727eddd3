"""Faults: an agent killed with SIGKILL and respawned by the bring-up under 30 % radio loss."""

import json
import os
import signal
import subprocess
import time

import pytest
import rclpy
from ros_harness import executable, PARAMS, REPO, run_swarm, started

from sat_agent.ros.qos import STEP, WORLD
from sat_msgs.msg import ControlCommand, WorldStep
from sat_world_sim.ros.observer import ReadyAnnouncer

pytestmark = pytest.mark.ros
STEPS = 120
KILL_AT = 30


def agent_pid(parent: int, agent_id: int):
    """Return the pid of the bring-up's child running agent <agent_id>, or None."""
    result = subprocess.run(['pgrep', '-P', str(parent), '-f', f'agent_id:={agent_id}'],
                            capture_output=True, text=True)
    pids = [int(p) for p in result.stdout.split()]
    return pids[0] if pids else None


@pytest.mark.timeout(600)
def test_kill_and_respawn_under_radio_loss_completes_the_run(tmp_path):
    run_dir = tmp_path / 'run'
    command = [executable('sat_world_sim', 'swarm'),
               '--scenario', str(REPO / 'config' / 'scenarios' / 'paper.yaml'),
               '--params', str(PARAMS), '--run-dir', str(run_dir), '--steps', str(STEPS),
               '--respawn', '--radio-loss', '0.3', '--agent-timeout', '3', '--quiet',
               '--domain-id', os.environ['ROS_DOMAIN_ID']]
    rclpy.init()
    node = rclpy.create_node('fault_injector')
    steps = []
    node.create_subscription(WorldStep, '/world/step', lambda m: steps.append(m.step), WORLD)
    swarm = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             start_new_session=True)
    try:
        deadline = time.monotonic() + 180
        while (not steps or steps[-1] < KILL_AT) and time.monotonic() < deadline:
            rclpy.spin_once(node, timeout_sec=0.05)
        victim = agent_pid(swarm.pid, 2)
        assert steps and victim is not None, 'the run never reached the kill step'
        os.kill(victim, signal.SIGKILL)
        out, err = swarm.communicate(timeout=480)
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
        if swarm.poll() is None:
            os.killpg(swarm.pid, signal.SIGKILL)
            swarm.wait()
    assert swarm.returncode == 0, err[-3000:]
    assert out.strip().splitlines()[-1] == str(run_dir)
    assert 'agent_2 exited (-9): respawn 1' in err
    metrics = json.loads((run_dir / 'metrics.json').read_text())
    assert [s['step'] for s in metrics['steps']] == list(range(1, STEPS + 1))
    # The respawned agent rejoined: it reports modes again by the end of the run.
    assert set(metrics['steps'][-1]['modes']) == {'1', '2'}
    missing = [s['step'] for s in metrics['steps'] if set(s['modes']) != {'1', '2'}]
    assert missing and max(missing) < STEPS, 'agent 2 was never away, or never came back'
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
    world = [executable('sat_world_sim', 'world_sim'), '--ros-args', '--params-file',
             str(PARAMS), '-p', f"scenario:={REPO / 'config' / 'scenarios' / 'paper.yaml'}",
             '-p', 'observers:=1']
    agent = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_1',
             '--params-file', str(PARAMS), '-p', 'agent_id:=1',
             '-p', f'world_timeout:={world_timeout}']
    other = [executable('sat_agent', 'agent'), '--ros-args', '-r', '__ns:=/agent_2',
             '--params-file', str(PARAMS), '-p', 'agent_id:=2']
    rclpy.init()
    node = rclpy.create_node('world_killer')
    commands = []
    watch = node.create_subscription(ControlCommand, '/agent_1/cmd',
                                     lambda m: commands.append((time.monotonic(), m.step)), STEP)
    # world_sim waits for this watcher: a 200-step lock-step run can be over in 2 s, before a
    # late-matched subscription sees any command.
    ReadyAnnouncer(node, [watch])
    try:
        with started(agent, tmp_path / 'agent_1.log') as a1, \
                started(other, tmp_path / 'agent_2.log'), \
                started(world, tmp_path / 'world.log') as w:
            deadline = time.monotonic() + 120
            while (not commands or commands[-1][1] < 10) and time.monotonic() < deadline:
                rclpy.spin_once(node, timeout_sec=0.05)
            assert commands, 'the run never started'
            os.killpg(w.pid, signal.SIGKILL)
            w.wait()
            killed = time.monotonic()
            while a1.poll() is None and time.monotonic() - killed < world_timeout + 20:
                rclpy.spin_once(node, timeout_sec=0.05)
            gone = time.monotonic() - killed
            assert a1.returncode == 0, (tmp_path / 'agent_1.log').read_text()[-2000:]
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    assert world_timeout <= gone <= world_timeout + 10
    # It held: no command after the world died (at most the one of the step in flight).
    assert len([t for t, _ in commands if t > killed + 0.5]) == 0
    assert 'world_sim is gone, exiting' in (tmp_path / 'agent_1.log').read_text()
