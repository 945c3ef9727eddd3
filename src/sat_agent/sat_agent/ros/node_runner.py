"""The one way every sat-swarm node process starts, ticks, spins and stops (ros2/demos idiom).

The executor is rclpy's EventsExecutor where the installed rclpy has it (Jazzy >= 7.1.4): it
hands each arriving message to its callback directly, whereas the SingleThreadedExecutor
rebuilds its wait set in Python before every callback, a cost that grows with the number of
topics a process serves. world_sim and the recorder serve a few topics per agent and take one
callback per radio message, so with 16 agents the waits cost more CPU than the work. Older
rclpy falls back to the SingleThreadedExecutor.
"""

import faulthandler
import signal
import sys

import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.signals import SignalHandlerOptions

try:
    from rclpy.experimental import EventsExecutor as FastExecutor
except ImportError:
    FastExecutor = SingleThreadedExecutor

# How long one spin waits for work before the loop looks at rclpy.ok() and finish requests.
SPIN_TIMEOUT_S = 0.1
# Signals that end a process cleanly (Ctrl-C, the bring-up's stop, `kill`).
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# At the end of a run, a node exits once its readers acknowledged its last messages, or after this.
FINAL_ACK_TIMEOUT_S = 10.0
# Teardown (the guards' final counters, each waiting at most
# input_guard.FINAL_DIAGNOSTICS_ACK_S; the nodes' own closing: the recorder's bag, the logger's
# flush to its file and viewer; destroying the nodes; shutting rclpy down) takes seconds. One
# still running after this long is stuck in the middleware: the process then dumps every
# thread's stack to stderr and exits with status 1 instead of hanging its launcher. The same
# bound holds for the interpreter's exit after run_nodes returns (a thread that never ends, an
# atexit handler such as a library's flush).
TEARDOWN_LIMIT_S = 120.0


def steady_timer(node, period: float, callback):
    """Create a timer on the steady (monotonic) clock, whatever ``use_sim_time`` says.

    Every timer of these nodes is a watchdog or a poller (start-up handshakes, step deadlines,
    timeouts, diagnostics). Under ``use_sim_time`` a node's own clock advances only when
    world_sim publishes ``/clock``, at the start of a step, and world_sim waits for these very
    timers before it starts one: on the ROS clock they would never fire. Message stamps come
    from the step (sat_agent.stamps); what reads the node's clock (the diagnostics' stamps)
    follows ``/clock``.
    """
    # Positional: callback group, then clock (rclpy's Node.create_timer signature).
    return node.create_timer(period, callback, None, Clock(clock_type=ClockType.STEADY_TIME))


def all_acked(publishers) -> bool:
    """Whether every reader acknowledged everything these reliable writers sent (no waiting).

    A reliable writer destroyed with unacknowledged samples loses them: a node polls this
    before finish_run at the end of a run, so an observer does not miss the last step.
    """
    return all(p.wait_for_all_acked(Duration(seconds=0)) for p in publishers)


def finish_run(node, code: int = 0):
    """Ask run_nodes to stop spinning once the current callback returns, then exit with code.

    A flag, not an exception: the EventsExecutor logs every exception that leaves a callback as
    FATAL, and a node that is done is not an error.
    """
    node.sat_exit_code = int(code)


def _exit_code(nodes):
    return next((n.sat_exit_code for n in nodes if getattr(n, 'sat_exit_code', None) is not None),
                None)


def run_nodes(name: str, factory, args=None) -> int:
    """Create the node(s) factory() returns, spin them in one executor, return the exit code.

    Ctrl-C, SIGTERM and external shutdown end cleanly with 0; a ValueError or OSError while
    building the nodes (bad parameters, a missing or malformed scenario or YAML file) is printed
    as one line naming the problem and gives 2; finish_run from a callback ends the spin with
    its code. Any other error is a bug and propagates with its traceback. A stop that no node
    asked for is logged with its cause (the signal, the shutdown, the exception), and a teardown
    stuck for TEARDOWN_LIMIT_S dumps every thread's stack and exits with 1.

    run_nodes is a process's main loop (every node's main returns it to sys.exit): it returns
    with the same bound armed for the interpreter's exit, which joins the threads left running
    and runs the atexit handlers. CI once saw a logger write its run.rrd and never exit; if
    that was the exit, the dump now says which thread held it.

    The stop signals only set a flag that the loop reads between callbacks. rclpy's own handlers
    raise KeyboardInterrupt wherever the main thread is, and inside a callback the
    EventsExecutor reports that as a FATAL exception before the process ends.
    """
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop_requests = []
    previous = {number: signal.signal(number, lambda number, _: stop_requests.append(number))
                for number in STOP_SIGNALS}
    nodes = []
    code = None
    try:
        try:
            made = factory()
        except (ValueError, OSError) as error:
            print(f'{name}: {error}', file=sys.stderr, flush=True)
            return 2
        nodes = list(made) if isinstance(made, (list, tuple)) else [made]
        executor = FastExecutor()
        for node in nodes:
            executor.add_node(node)
        # spin_once in a loop rather than spin(): EventsExecutor.spin() of rclpy 7.1.5 never
        # runs a callback, and the loop is where finish requests are seen.
        while code is None and not stop_requests and rclpy.ok():
            executor.spin_once(timeout_sec=SPIN_TIMEOUT_S)
            code = _exit_code(nodes)
        if code is None:
            _log_stop(nodes, stop_requests)
    except (KeyboardInterrupt, ExternalShutdownException) as stop:
        _log_stop(nodes, stop_requests, stop)
    finally:
        try:
            _teardown(nodes)
        finally:
            for number, handler in previous.items():
                signal.signal(number, handler)
            # Not cancelled: the process ends before it fires unless its exit hangs.
            faulthandler.dump_traceback_later(TEARDOWN_LIMIT_S, exit=True)
    return code or 0


def _teardown(nodes):
    """Publish the guards' final counters, destroy the nodes, shut rclpy down: bounded.

    The bound is armed for this teardown only: an error raised on the way disarms it, so a
    process ending on that error is not killed later by a stale dump.
    """
    # exit=True: faulthandler ends the process with status 1 after the dump.
    faulthandler.dump_traceback_later(TEARDOWN_LIMIT_S, exit=True)
    try:
        for node in nodes:
            if rclpy.ok():
                for guard in getattr(node, 'sat_guards', ()):
                    guard.publish_final()
            node.destroy_node()
        rclpy.try_shutdown()
    finally:
        faulthandler.cancel_dump_traceback_later()


def _log_stop(nodes, stop_requests, stop=None):
    """Say why a process stops when no node asked to finish: a signal, a shutdown, an error."""
    if stop_requests:
        reason = f'stopping on {signal.Signals(stop_requests[0]).name}'
    elif stop is not None:
        reason = f'stopping on {type(stop).__name__}'
    else:
        reason = 'stopping: the ROS context was shut down'
    if nodes:
        nodes[0].get_logger().info(reason)
    else:
        print(reason, file=sys.stderr, flush=True)
