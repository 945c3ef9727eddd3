"""The one way every sat-swarm node process starts, spins and stops (ros2/demos idiom)."""

import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor


class RunFinished(SystemExit):
    """Raised from a callback when a node's work is done; the process exits with ``code``."""


def run_nodes(name: str, factory, args=None) -> int:
    """Create the node(s) factory() returns, spin them in one executor, return the exit code.

    Ctrl-C and external shutdown end cleanly with 0; a ValueError while building (bad
    parameters, scenario, YAML) is printed as one line naming the problem and gives 2;
    RunFinished from a callback ends the spin with its code.
    """
    rclpy.init(args=args)
    nodes = []
    code = 0
    try:
        made = factory()
        nodes = list(made) if isinstance(made, (list, tuple)) else [made]
        executor = SingleThreadedExecutor()
        for node in nodes:
            executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    except RunFinished as done:
        code = done.code or 0
    except ValueError as error:
        print(f'{name}: {error}', file=sys.stderr, flush=True)
        code = 2
    finally:
        for node in nodes:
            node.destroy_node()
        rclpy.try_shutdown()
    return code
