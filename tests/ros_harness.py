"""Helpers for the multi-process ROS 2 tests: start executables, wait on events, always stop.

Waiting discipline: a test never sleeps for a guessed time. It waits for the event it needs (a
writer matched its readers, world_sim's handshake, a step on /world/step, a log line, a process
exit) with an upper bound that fails naming what was awaited. Every bound, and pytest-timeout's
per-test limits (conftest.py), is multiplied by SAT_TEST_TIMEOUT_SCALE (default 1), the one knob
for a slow machine.
"""

from contextlib import contextmanager
import json
import os
from pathlib import Path
import subprocess
import sys
import time

from ament_index_python.packages import get_package_prefix
import rclpy
from rclpy.signals import SignalHandlerOptions
import yaml

from sat_world_sim.bringup import stop_group

REPO = Path(__file__).resolve().parents[1]
PARAMS = REPO / 'config' / 'paper.yaml'
SCALE_VARIABLE = 'SAT_TEST_TIMEOUT_SCALE'
SPIN_S = 0.05
# What a process gets to exit cleanly on SIGINT before it is killed (started()).
STOP_GRACE_S = 10.0
# What the bring-up gets to stop its processes (one after the other) on SIGINT.
BRINGUP_STOP_S = 60.0
# Runs whose subject is not an agent's failure: an agent is marked inactive only if it is silent
# this long, so a slow step on a loaded machine cannot change the run (run_swarm()).
PATIENT_AGENT_TIMEOUT_S = 60.0


def timeout_scale() -> float:
    """SAT_TEST_TIMEOUT_SCALE as a number > 0 (1 when unset)."""
    text = os.environ.get(SCALE_VARIABLE, '1')
    try:
        scale = float(text)
    except ValueError:
        scale = float('nan')
    if not scale > 0:
        raise ValueError(f'{SCALE_VARIABLE} = {text!r}: must be a number > 0 (e.g. 2 on a machine '
                         'twice as slow)')
    return scale


SCALE = timeout_scale()


def scaled(seconds: float) -> float:
    """Return an upper bound of the tests for this machine (SAT_TEST_TIMEOUT_SCALE)."""
    return seconds * SCALE


def _waited(what: str, seconds: float) -> str:
    return f'{what}: not after {seconds:.0f} s ({SCALE_VARIABLE}={SCALE:g})'


def log_tail(process, chars: int = 3000) -> str:
    """Return the end of the log of a process from started(), for a failure message."""
    path = getattr(process, 'log_path', None)
    return path.read_text(encoding='utf-8', errors='replace')[-chars:] if path else ''


def check_alive(processes):
    """Fail if one of the processes ended with an error (exit code 0 is a normal end)."""
    for process in processes:
        code = process.poll()
        assert code in (None, 0), \
            f'{Path(process.args[0]).name} exited with {code}:\n{log_tail(process)}'


def spin_until(node, done, timeout: float, what: str, processes=()):
    """Spin node until done() holds; fail naming what after scaled(timeout) seconds.

    processes must keep running (or end with 0) meanwhile: a crash fails at once with its log.
    """
    limit = scaled(timeout)
    deadline = time.monotonic() + limit
    while not done():
        check_alive(processes)
        assert time.monotonic() < deadline, _waited(what, limit)
        rclpy.spin_once(node, timeout_sec=SPIN_S)


def wait_matched(node, endpoints, timeout: float, what: str, count: int = 1):
    """Spin until every publisher has count subscribers and every subscription count publishers.

    A publisher must have matched a reader before it writes, or DDS drops the sample for it.
    """
    def matched(endpoint):
        if hasattr(endpoint, 'get_subscription_count'):
            return endpoint.get_subscription_count() >= count
        return endpoint.get_publisher_count() >= count
    endpoints = list(endpoints)
    spin_until(node, lambda: all(map(matched, endpoints)), timeout, what)


def wait_exit(process, timeout: float, what: str, others=()) -> int:
    """Wait for process to end and return its exit code; fail naming what after the bound.

    The failure shows the process's log and the ends of the others' (its peers in the run).
    """
    limit = scaled(timeout)
    try:
        return process.wait(timeout=limit)
    except subprocess.TimeoutExpired:
        peers = ''.join(f'\n--- {Path(p.args[0]).name} (pid {p.pid}):\n{log_tail(p, 1500)}'
                        for p in others)
        raise AssertionError(f'{_waited(what, limit)}\n{log_tail(process)}{peers}') from None


def wait_for_text(path: Path, text: str, timeout: float, what: str, processes=()):
    """Wait until a log file holds text (a node's 'ready' line, say)."""
    limit = scaled(timeout)
    deadline = time.monotonic() + limit
    while text not in path.read_text(encoding='utf-8', errors='replace'):
        check_alive(processes)
        assert time.monotonic() < deadline, f'{_waited(what, limit)}\n{path.read_text()[-3000:]}'
        time.sleep(SPIN_S)


@contextmanager
def ros_node(name: str):
    """Yield a node of the test process; rclpy is initialised without its signal handlers.

    rclpy's handlers take Ctrl-C and SIGTERM to shut rclpy down and nothing more: pytest would
    go on, and on being killed leave the processes of started() running.
    """
    rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
    node = rclpy.create_node(name)
    try:
        yield node
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


@contextmanager
def bringup(command):
    """Run the bring-up (`swarm`) with piped output; stop it and all its processes after.

    SIGINT makes the bring-up stop every process of the run (they run in their own sessions, so
    killing the bring-up alone would leave them running).
    """
    process = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                               start_new_session=True)
    try:
        yield process
    finally:
        stop_group(process, grace=scaled(BRINGUP_STOP_S))


def announce(node, subscriptions, publishers=(), observer: bool = False, key=None):
    """Take part in world_sim's start-up handshake (sat_agent.ros.readiness) as a test node.

    A test node that plays agents passes their writers, one that watches the run its
    subscriptions; world_sim counts a node that writes no agent's commands as an observer, and
    one that says observer (an attacker's writers on agents' topics). key: the run's key, which
    a world_sim with a key needs the announcement signed with. The node announces again every
    readiness.RESEND_S while it lives (world_sim ignores announcements after the start).
    """
    from sat_agent.ros.readiness import ReadyAnnouncer
    return ReadyAnnouncer(node, subscriptions, publishers, observer=observer, key=key)


def executable(package: str, name: str) -> str:
    """Return the installed lib/<package>/<name>, as `ros2 run` finds it."""
    return str(Path(get_package_prefix(package)) / 'lib' / package / name)


def write_scenario(path: Path, **document) -> Path:
    """Write a scenario YAML (keys as in config/scenarios/paper.yaml)."""
    path.write_text(yaml.safe_dump(document), encoding='utf-8')
    return path


@contextmanager
def started(command, log_path: Path):
    """Run command in its own session with output to log_path; stop it (and its group) after.

    The process gets log_path as an attribute, for failure messages (log_tail).
    """
    with open(log_path, 'w', encoding='utf-8') as log:
        process = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT,
                                   env=dict(os.environ, PYTHONUNBUFFERED='1'),
                                   start_new_session=True)
        process.log_path = log_path
        try:
            yield process
        finally:
            stop_group(process, grace=scaled(STOP_GRACE_S))


def run_swarm(run_dir: Path, scenario: Path, *extra, timeout: float = 600.0,
              params: Path = PARAMS):
    """Run the bring-up (`swarm`) to completion; return (exit code, metrics or None, output).

    Unless extra sets --agent-timeout, agents get PATIENT_AGENT_TIMEOUT_S (scaled).
    """
    if '--agent-timeout' not in extra:
        extra += ('--agent-timeout', str(scaled(PATIENT_AGENT_TIMEOUT_S)))
    command = [sys.executable, executable('sat_world_sim', 'swarm'), '--scenario', str(scenario),
               '--params', str(params), '--run-dir', str(run_dir),
               '--domain-id', os.environ['ROS_DOMAIN_ID'], '--timeout', str(scaled(timeout)),
               *extra]
    with bringup(command) as swarm:
        # The bring-up stops its processes after its own --timeout; this bound only catches a
        # hung bring-up.
        out, err = swarm.communicate(timeout=scaled(timeout) + scaled(BRINGUP_STOP_S))
    metrics_path = run_dir / 'metrics.json'
    metrics = json.loads(metrics_path.read_text()) if metrics_path.is_file() else None
    return swarm.returncode, metrics, out + err
