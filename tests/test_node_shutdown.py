"""A node process ends cleanly on Ctrl-C or SIGTERM, whatever callback it is in."""

import signal
import subprocess
import sys

from diagnostic_msgs.msg import DiagnosticArray
import pytest
from ros_harness import executable, PARAMS, ros_node, scaled, spin_until, started, wait_exit


@pytest.mark.ros
@pytest.mark.timeout(120)
@pytest.mark.parametrize('number', [signal.SIGINT, signal.SIGTERM])
def test_an_agent_stopped_by_a_signal_exits_0_without_an_error(tmp_path, number):
    # The agent's 20 Hz timer runs while it waits for a world: a signal lands in or between
    # callbacks. rclpy's own handlers raised KeyboardInterrupt inside a callback, which the
    # EventsExecutor logged as FATAL (seen at the end of a `make run`).
    log = tmp_path / 'agent.log'
    command = [executable('sat_agent', 'agent'), '--ros-args', '--params-file', str(PARAMS),
               '-r', '__ns:=/agent_9', '-p', 'agent_id:=9', '-p', 'diagnostics_period:=0.05']
    spinning = []
    with ros_node('signal_sender') as node, started(command, log) as agent:
        # The agent's diagnostics timer has fired: its executor is spinning its callbacks.
        node.create_subscription(DiagnosticArray, '/diagnostics', lambda m: spinning.extend(
            s.name for s in m.status if s.name.startswith('/agent_9/')), 10)
        spin_until(node, lambda: spinning, 60, "agent 9's first /diagnostics", (agent,))
        agent.send_signal(number)
        assert wait_exit(agent, 10, f'agent 9 exiting on {number.name}') == 0, log.read_text()
    output = log.read_text(encoding='utf-8')
    assert 'FATAL' not in output and 'Traceback' not in output, output


SELF_SIGNALLING_NODE = '''
import os, signal, sys
from rclpy.node import Node
from sat_agent.ros.node_runner import run_nodes

class Node_(Node):
    def __init__(self):
        super().__init__('self_signalling')
        self.create_timer(0.05, self.tick)

    def tick(self):
        os.kill(os.getpid(), signal.{name})   # the signal arrives inside this callback
        print('callback returned', flush=True)

sys.exit(run_nodes('self_signalling', Node_))
'''


@pytest.mark.timeout(60)
@pytest.mark.parametrize('name', ['SIGINT', 'SIGTERM'])
def test_a_signal_inside_a_callback_lets_the_callback_finish_and_the_process_exit_0(name):
    result = subprocess.run([sys.executable, '-c', SELF_SIGNALLING_NODE.format(name=name)],
                            capture_output=True, text=True, timeout=scaled(30))
    output = result.stdout + result.stderr
    assert result.returncode == 0, output
    assert 'callback returned' in output and 'FATAL' not in output, output
    assert f'stopping on {name}' in output, output


HUNG_NODE = '''
import atexit, sys, threading
from rclpy.node import Node
from sat_agent.ros import node_runner

node_runner.TEARDOWN_LIMIT_S = 1.0

def never_ends():
    threading.Event().wait()   # a middleware call or a library's flush that never returns

class Done(Node):
    def __init__(self):
        super().__init__('hung')
        self.create_timer(0.05, lambda: node_runner.finish_run(self, 0))
{hang}
sys.exit(node_runner.run_nodes('hung', Done))
'''


@pytest.mark.timeout(60)
@pytest.mark.parametrize('hang, frame', [
    # Seen once in CI: a logger finished its run.rrd, then never exited (killed after 200 s).
    ('    def destroy_node(self):\n        never_ends()', 'in destroy_node'),
    # After a clean teardown the interpreter joins the threads left running, then runs the
    # atexit handlers: either may hold a process whose nodes are all gone.
    ('threading.Thread(target=never_ends).start()', 'in never_ends'),
    ('atexit.register(never_ends)', 'in never_ends')])
def test_a_teardown_or_an_exit_that_hangs_dumps_the_stacks_and_exits_1(hang, frame):
    result = subprocess.run([sys.executable, '-c', HUNG_NODE.format(hang=hang)],
                            capture_output=True, text=True, timeout=scaled(30))
    assert result.returncode == 1, result.stdout + result.stderr
    assert 'Timeout' in result.stderr and frame in result.stderr, result.stderr
