"""The metrics node: turns the live graph into ``metrics.json`` and plots when the run ends.

Subscribes to ``/world/step``, ``/world/truth``, ``/world/radio`` and every agent's ``status``
and ``radio/out/search_density``; builds one StepRecord per step with records.step_record (the
same code the offline bag replay uses) and, on the world's ``finished`` step, writes
``<run_dir>/metrics.json`` and ``<run_dir>/plots/*.png`` and exits.
"""

from pathlib import Path
import time

import numpy as np
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from sat_agent.node_runner import run_nodes, RunFinished
from sat_agent.ros_params import declare_sat_params
from sat_msgs.msg import AgentStatus, GroundTruth, RadioTraffic, SearchDensity, WorldStep

from sat_world_sim.metrics import compute_metrics, write_metrics
from sat_world_sim.plots import write_plots
from sat_world_sim.records import density_values, step_record

WORLD_QOS = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
AGENT_QOS = QoSProfile(depth=50, reliability=ReliabilityPolicy.RELIABLE)
# After the world says "finished", wait at most this long for the last statuses.
FINAL_WAIT_S = 5.0


class MetricsNode(Node):
    """Collects one run and writes its metrics (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('metrics', **kwargs)
        self.params = declare_sat_params(self)
        run_dir = self.declare_parameter('run_dir', '').value
        if not run_dir:
            raise ValueError("parameter 'run_dir' is required: the directory to write into")
        self.run_dir = Path(run_dir)
        self.agent_ids = list(self.declare_parameter('agent_ids', [1, 2]).value)
        self.truths, self.traffic, self.statuses, self.densities = {}, {}, {}, {}
        self.final = None
        self._final_at = None
        self.create_subscription(WorldStep, '/world/step', self.on_step, WORLD_QOS)
        self.create_subscription(GroundTruth, '/world/truth',
                                 lambda m: self.truths.__setitem__(m.step, m), WORLD_QOS)
        self.create_subscription(RadioTraffic, '/world/radio',
                                 lambda m: self.traffic.__setitem__(m.step, m), WORLD_QOS)
        for i in self.agent_ids:
            self.create_subscription(
                AgentStatus, f'/agent_{i}/status',
                lambda m, i=i: self.statuses.__setitem__((i, m.step), m), AGENT_QOS)
            self.create_subscription(
                SearchDensity, f'/agent_{i}/radio/out/search_density',
                lambda m, i=i: self.densities.__setitem__(i, m), AGENT_QOS)
        self.create_timer(0.1, self._tick)

    def on_step(self, msg: WorldStep):
        if msg.finished:
            self.final = msg
            self._final_at = time.monotonic()

    def _complete(self) -> bool:
        last = self.final.step
        truth = self.truths.get(last)
        if truth is None or last not in self.traffic:
            return False
        active = [a.id for a in truth.agents if a.active]
        return all((i, last) in self.statuses for i in active)

    def _tick(self):
        if self.final is None:
            return
        if not self._complete() and time.monotonic() - self._final_at < FINAL_WAIT_S:
            return
        self.write()
        raise RunFinished(0)

    def write(self):
        records = []
        for step in sorted(self.truths):
            statuses = {i: self.statuses[(i, step)] for i in self.agent_ids
                        if (i, step) in self.statuses}
            records.append(step_record(self.truths[step], statuses, self.traffic.get(step),
                                       self.traffic.get(step - 1)))
        metrics = compute_metrics(records, self.final.scenario, self.final.seed,
                                  late_commands=self.final.late_commands)
        self.run_dir.mkdir(parents=True, exist_ok=True)
        write_metrics(metrics, self.run_dir / 'metrics.json')
        densities = [density_values(m) for m in self.densities.values()]
        fused = np.maximum.reduce(densities) if densities else None
        write_plots(metrics, records, self.run_dir / 'plots',
                    area=(self.params.area.width, self.params.area.height), final_density=fused)
        self.get_logger().info(f'wrote {self.run_dir / "metrics.json"} ({len(records)} steps)')


def main(args=None):
    return run_nodes('metrics', MetricsNode, args)
