"""The one way every sat-swarm node process starts, spins and stops (ros2/demos idiom)."""

import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor


class RunFinished(SystemExit):
    """Raised from a callback when a node's work is done; the process exits with ``code``."""


def run_nodes(name: str, factory, args=None) -> int:
    """Create the node(s) factory() returns, spin them in one executor, return the exit code.

    Ctrl-C and external shutdown end cleanly with 0; a ValueError or OSError while building the
    nodes (bad parameters, a missing or malformed scenario or YAML file) is printed as one line
    naming the problem and gives 2; RunFinished from a callback ends the spin with its code.
    Any other error is a bug and propagates with its traceback.
    """
    rclpy.init(args=args)
    nodes = []
    code = 0
    try:
        try:
            made = factory()
        except (ValueError, OSError) as error:
            print(f'{name}: {error}', file=sys.stderr, flush=True)
            return 2
        nodes = list(made) if isinstance(made, (list, tuple)) else [made]
        executor = SingleThreadedExecutor()
        for node in nodes:
            executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RunFinished as done:
        code = done.code or 0
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
