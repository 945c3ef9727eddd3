"""The metrics node: turns the live graph into ``metrics.json`` and plots when the run ends.

Subscribes to ``/world/step``, ``/world/truth``, ``/world/radio`` and every agent's ``status``
and ``radio/out/search_density``, hands every message to records.RunCollector (the same code the
offline replay of a bag uses) and, once the world's ``finished`` step and the last step's data
are in, writes ``<run_dir>/metrics.json`` and ``<run_dir>/plots/*.png`` and exits. Its memory
stays flat over long runs: the collector keeps the messages of the last records.SETTLE_STEPS
steps, a compact record of each earlier step and each agent's last search density.
"""

from pathlib import Path
import time

from rclpy.node import Node

from sat_agent.config import SatParams
from sat_agent.node_params import ObserverParams

from sat_agent.ros.node_runner import finish_run, run_nodes, steady_timer
from sat_agent.ros.ros_params import NodeParameters

from sat_world_sim.records import RunCollector
from sat_world_sim.ros.observer import watch_run

# After the world says "finished", wait at most this long for the last statuses.
FINAL_WAIT_S = 5.0


class MetricsNode(Node):
    """Collects one run and writes its metrics (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('metrics', **kwargs)
        self.params, run = NodeParameters(self, (SatParams, ObserverParams)).values
        self.run_dir = Path(run.run_dir)
        self.collector = RunCollector(run.agent_ids)
        self._finished_at = None
        self.ready = watch_run(self, run.agent_ids, self.collector.add)
        steady_timer(self, 0.1, self._tick)

    def _tick(self):
        if self.collector.final is None:
            return
        if self._finished_at is None:
            self._finished_at = time.monotonic()
        if not self.collector.complete() and \
                time.monotonic() - self._finished_at < FINAL_WAIT_S:
            return
        area = (self.params.area.width, self.params.area.height)
        metrics = self.collector.write(self.run_dir, area)
        self.get_logger().info(
            f"wrote {self.run_dir / 'metrics.json'} ({len(metrics['steps'])} steps)")
        finish_run(self, 0)


def main(args=None):
    return run_nodes('metrics', MetricsNode, args)
