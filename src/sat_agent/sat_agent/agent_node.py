"""The agent node: a thin rclpy adapter over sat_agent.agent_core.Agent.

Run one per agent in its own namespace::

    ros2 run sat_agent agent --ros-args -r __ns:=/agent_3 -p agent_id:=3 \
        --params-file config/paper.yaml

Topics (relative, so under the namespace), with the QoS of sat_agent.qos:

- ``measurements`` (sub, MeasurementSet, STEP);
- ``radio/in/{search_density,estimate,mode}`` (sub, RADIO, raw bytes parsed by
  sat_agent.radio_parsing, once per process in composed mode);
- ``cmd`` (pub, ControlCommand, STEP), ``radio/out/*`` (pub, RADIO);
- ``status`` (pub, AgentStatus, STEP), for the logger, the metrics and the recorder.

Until its first scan the agent announces on ``/world/ready`` how many readers its writers have
matched (sat_agent.readiness): world_sim starts once none of the run's first messages can be lost.

Lock-step: a scan says how many radio messages were forwarded to this agent for its step
(``radio_deliveries``); the agent steps when it has them all, or after ``report_wait_timeout``
seconds with what it has (a lost message must not stall it). If world_sim dies, the agent
holds (it sends no command, so it does not move), resumes when scans come again, and exits
cleanly (code 0) after ``world_timeout`` seconds without a scan. Every message is validated on
arrival (sat_agent.msg_conversions: finite numbers, lengths, the grid geometry, known modes,
sane counts, stale or future steps, the sender); an invalid one is dropped with a rate-limited
warning and counted per reason, and the counters go to ``/diagnostics`` every second.
"""

import argparse
import sys
import time
from typing import Optional

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args

from sat_agent.actions import candidate_poses
from sat_agent.agent_core import Agent, REPORT_KINDS
from sat_agent.input_guard import InputGuard, LOG_THROTTLE_S
from sat_agent.msg_conversions import (estimate_to_msg, InvalidMessage, measurements_from_msg,
                                       point, RADIO_TYPES, report_from_parts, report_to_msgs)
from sat_agent.node_runner import finish_run, run_nodes
from sat_agent.qos import RADIO, STEP
from sat_agent.radio_parsing import RadioParser
from sat_agent.readiness import ReadyAnnouncer
from sat_agent.ros_params import declare_required_int, declare_sat_params
from sat_agent.search_density import Lattice
from sat_msgs.msg import AgentStatus, ControlCommand, MeasurementSet

# Particles shown to the logger per step: enough to see the cloud, small on the wire.
STATUS_PARTICLES = 300
# A scan further ahead than this is garbage, not a world that ran on without us.
MAX_STEP_JUMP = 1000
# Reports older than this many steps are stale; younger late ones (radio latency) still add
# their search density (Agent.step).
MAX_REPORT_LAG = 4
# Composed mode: parsed radio messages kept per agent of the process, two steps' worth of its
# three messages (radio_parsing.py).
PARSED_PER_AGENT = 2 * len(REPORT_KINDS)


class AgentNode(Node):
    """Validates input, steps the core Agent, publishes its command, reports and status.

    radio_parser: shared by the agents of one process in composed mode (radio_parsing.py).
    """

    def __init__(self, radio_parser: Optional[RadioParser] = None, **kwargs):
        super().__init__('agent', **kwargs)
        self.radio_parser = radio_parser or RadioParser()
        self.params = declare_sat_params(self)
        self.agent_id = declare_required_int(self, 'agent_id', 1, 'this agent id (>= 1)')
        self.seed = self.declare_parameter('seed', 0).value
        self.report_wait_timeout = float(self.declare_parameter('report_wait_timeout', 2.0).value)
        self.world_timeout = float(self.declare_parameter('world_timeout', 60.0).value)
        if self.report_wait_timeout <= 0 or self.world_timeout <= 0:
            raise ValueError("parameters 'report_wait_timeout', 'world_timeout': must be > 0")
        self._last_scan_at = None
        self.core = None
        self.lattice = Lattice.for_area(self.params.area, self.params.search.lattice_spacing)
        self.last_step = 0
        self.guard = InputGuard(self, f'agent_{self.agent_id}')
        self._pending = None          # (step, (pose, measurements), deliveries, arrival time)
        self._radio = {}              # (sender, step) -> {kind: validated content}
        self._received_since_step = 0

        self.cmd_pub = self.create_publisher(ControlCommand, 'cmd', STEP)
        self.status_pub = self.create_publisher(AgentStatus, 'status', STEP)
        self.radio_pubs = {kind: self.create_publisher(cls, f'radio/out/{kind}', RADIO)
                           for kind, cls in RADIO_TYPES.items()}
        inputs = [self.create_subscription(MeasurementSet, 'measurements', self.on_measurements,
                                           STEP)]
        for kind, cls in RADIO_TYPES.items():
            inputs.append(self.create_subscription(
                cls, f'radio/in/{kind}', lambda data, kind=kind: self.on_radio(kind, data), RADIO,
                raw=True))
        # world_sim starts step 1 once these writers have matched every reader of the run.
        self.ready = ReadyAnnouncer(self, inputs, [self.cmd_pub, self.status_pub,
                                                   *self.radio_pubs.values()])
        self.create_timer(0.05, self._check_wait_timeout)
        self.get_logger().info(f'agent {self.agent_id} ready')

    # -- input ------------------------------------------------------------------------------

    def on_measurements(self, msg: MeasurementSet):
        if msg.agent_id != self.agent_id:
            self.guard.drop('wrong_agent_id', f'scan for agent {msg.agent_id}')
            return
        if msg.step <= self.last_step:
            self.guard.drop('stale_step', f'scan of step {msg.step} after step {self.last_step}')
            return
        if self.last_step and msg.step > self.last_step + MAX_STEP_JUMP:
            self.guard.drop('future_step', f'scan of step {msg.step} at step {self.last_step}')
            return
        try:
            scan = measurements_from_msg(msg)
        except InvalidMessage as error:
            self.guard.drop(error.reason, f'scan of step {msg.step}: {error.detail}')
            return
        self.guard.accept('measurements')
        self.ready.stop()
        self._last_scan_at = time.monotonic()
        if self._pending is not None:
            # The world moved on without our command (we were too slow): step the newest scan.
            self.guard.drop('superseded_scan', f'scan of step {self._pending[0]} never stepped')
        self._pending = (msg.step, scan, msg.radio_deliveries, time.monotonic())
        self._try_step()

    def on_radio(self, kind: str, data: bytes):
        msg, part = self.radio_parser.parse(kind, data, self.lattice)
        if msg is None:
            self.guard.drop(part.reason, f'{kind}: {part.detail}')
            return
        if msg.agent_id == self.agent_id:
            self.guard.drop('own_report', f'{kind} from this agent came back')
            return
        if msg.step + MAX_REPORT_LAG < self.last_step:
            self.guard.drop('stale_step', f'{kind} of step {msg.step} at step {self.last_step}')
            return
        if msg.step > self.last_step + 1:
            self.guard.drop('future_step', f'{kind} of step {msg.step} at step {self.last_step}')
            return
        if isinstance(part, InvalidMessage):
            self.guard.drop(part.reason, f'{kind} of agent {msg.agent_id}: {part.detail}')
            return
        self.guard.accept(f'radio/in/{kind}')
        self._received_since_step += 1
        self._radio.setdefault((msg.agent_id, msg.step), {})[kind] = part
        self._try_step()

    def _check_wait_timeout(self):
        if self._last_scan_at is not None and \
                time.monotonic() - self._last_scan_at > self.world_timeout:
            self.get_logger().warning(f'no scan for {self.world_timeout} s: world_sim is gone, '
                                      'exiting')
            finish_run(self, 0)
            return
        if self._pending and time.monotonic() - self._pending[3] > self.report_wait_timeout:
            self.get_logger().warning(
                f'step {self._pending[0]}: radio messages missing after '
                f'{self.report_wait_timeout} s, stepping without them',
                throttle_duration_sec=LOG_THROTTLE_S)
            self._step()

    def _try_step(self):
        if self._pending and self._received_since_step >= self._pending[2]:
            self._step()

    def _inbox(self, step: int):
        """Complete reports (all three kinds) sent before step k; partial ones are dropped."""
        reports = []
        for (sender, sent), parts in sorted(self._radio.items()):
            if sent >= step:
                continue
            if len(parts) < len(REPORT_KINDS):
                self.guard.drop('partial_report',
                                f'agent {sender} step {sent}: only {sorted(parts)}')
                continue
            reports.append(report_from_parts(sender, sent, parts))
        self._radio = {key: parts for key, parts in self._radio.items() if key[1] >= step}
        return reports

    # -- one step ---------------------------------------------------------------------------

    def _step(self):
        step, (pose, measurements), _, _ = self._pending
        self._pending = None
        self._received_since_step = 0
        started = time.perf_counter()
        if self.core is None:
            # (Re)started agents build their core at the first scan they get.
            self.core = Agent(self.agent_id, self.params, pose, seed=self.seed)
        output = self.core.step(step, pose, measurements, self._inbox(step))
        self.last_step = step
        for kind, out in zip(REPORT_KINDS,
                             report_to_msgs(output.report, self.core.filter.search.lattice)):
            self.radio_pubs[kind].publish(out)
        self.status_pub.publish(self._status(step, pose, output,
                                             time.perf_counter() - started))
        target = candidate_poses(pose, self.params.actions)[output.action]
        self.cmd_pub.publish(ControlCommand(agent_id=self.agent_id, step=step,
                                            action_index=output.action,
                                            target_position=point(target)))

    def _status(self, step: int, pose, output, compute_time: float) -> AgentStatus:
        targets = self.core.filter.targets
        keep = np.linspace(0, len(targets.weights) - 1,
                           min(STATUS_PARTICLES, len(targets.weights))).astype(int)
        return AgentStatus(
            agent_id=self.agent_id, step=step, mode=int(output.mode), position=point(pose),
            plan=[point(p) for p in output.plan], group=sorted(self.core.planner.group),
            estimate=estimate_to_msg(self.agent_id, step, pose, output.estimate),
            particle_xy=targets.states[keep][:, (0, 2)].astype(np.float32).ravel(),
            particle_weights=targets.weights[keep].astype(np.float32),
            yielded_to=output.left_overlap_with or 0, compute_time=compute_time)


def main(args=None):
    return run_nodes('agent', AgentNode, args)


def main_composed(args=None):
    """Many agents in one process and one executor: ``agents_composed --ids 1 2 ... --ros-args``.

    For large swarms: each agent is the same AgentNode in its own namespace ``/agent_<i>``, so
    the graph is the one of separate processes, without one Python interpreter per agent.
    """
    argv = remove_ros_args(args if args is not None else sys.argv)
    parser = argparse.ArgumentParser(prog='agents_composed', description=main_composed.__doc__)
    parser.add_argument('--ids', type=int, nargs='+', required=True, help='agent ids (>= 1)')
    ids = parser.parse_args(argv[1:]).ids
    shared = RadioParser(max_entries=PARSED_PER_AGENT * len(ids))
    return run_nodes('agents_composed', lambda: [
        AgentNode(radio_parser=shared, namespace=f'/agent_{i}',
                  parameter_overrides=[Parameter('agent_id', Parameter.Type.INTEGER, i)])
        for i in ids], args)
