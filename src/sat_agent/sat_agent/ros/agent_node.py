"""The agent node: a thin rclpy adapter over sat_agent.agent_core.Agent.

Run one per agent in its own namespace::

    ros2 run sat_agent agent --ros-args -r __ns:=/agent_3 -p agent_id:=3 \
        --params-file config/paper.yaml

Topics (relative, so under the namespace), with the QoS of sat_agent.ros.qos:

- ``measurements`` (sub, MeasurementSet, STEP, signed by the world) with
  ``input_source:=world_sim`` (default), or
  ``robot/pose`` (PoseStamped) and ``robot/detections`` (PointCloud2) with
  ``input_source:=robot`` (sub, ROBOT: sat_agent.ros.robot_input says what they hold);
- ``/world/step`` (sub, WorldStep, WORLD, signed by the world): with world_sim input, the
  agent exits (code 0) when the world says the run is ``finished``, once its last messages are
  acknowledged;
- ``radio/in/{search_density,estimate,mode}`` (sub, RADIO, raw bytes sealed by world_sim's
  relay for this agent, parsed by sat_agent.ros.radio_parsing, once per process in composed
  mode);
- ``cmd`` (pub, ControlCommand, STEP) and ``robot/goal`` (pub, PoseStamped, STEP): the
  position the chosen action leads to, for world_sim or for a real drone's position
  controller; ``radio/out/*`` (pub, RADIO);
- ``status`` (pub, AgentStatus, STEP), for the logger, the metrics and the recorder;
- ``view/*`` (pub, WORLD): the standard views (sat_agent.ros.views) every 1 / ``view_rate``
  seconds of sim time (the plan when it changed).

Every header carries the step's sim time and a frame (sat_agent.stamps).

Parameters: SatParams and node_params.AgentNodeParams (sat_agent.ros.ros_params declares them);
with ``live_parameters:=true`` those in LIVE may be changed with ``ros2 param set`` while the
agent runs; the rest, and by default all, are read-only.

Until its first scan the agent announces on ``/world/ready`` how many readers its writers have
matched (sat_agent.ros.readiness): world_sim starts once none of the run's first messages can
be lost. With robot input it announces the robot inputs instead of the world's, so a robot (or a
test) can tell when the agent's ``robot/goal`` writer matched its reader.

Authentication (sat_agent.message_auth, sat_agent.ros.signed_io): with ``auth_key_file`` set,
cmd, status and radio/out are signed as agent ``agent_id``; scans, /world/step and radio/in
are taken raw and refused (counted) before deserialization when larger than their limit
(message_limits, also without a key), unsigned, badly signed, replayed, not sealed for this
agent by the relay, from a sender off ``agent_ids`` (the roster; unset: the relay's check),
or outside the step window: the world's within MAX_REPORT_LAG behind to MAX_STEP_JUMP ahead
of the step the agent learned from signed world messages, its peers' within MAX_REPORT_LAG
behind to one ahead. A new or respawned agent learns the step only from a signed world
message, so a forged scan of step 2^32-1 cannot move it.

Lock-step: a scan says how many radio messages were forwarded to this agent for its step
(``radio_deliveries``); the agent steps when it has them all, or after ``report_wait_timeout``
seconds with what it has (a lost message must not stall it). If world_sim dies, the agent
holds (it sends no command, so it does not move), resumes when scans come again, and exits
cleanly (code 0) after ``world_timeout`` seconds without a scan. A robot's scans are stepped
at once with the reports in the inbox, as in the real-time clock; one stamped more than
MAX_CLOCK_LEAD steps ahead of the agent's own clock is refused (the robot topics are unsigned).
Every message is validated on arrival (sat_agent.ros.msg_conversions and robot_input: finite
numbers, lengths, the grid geometry, known modes and frames, sane counts, stale or future steps,
the sender), a signed scan before it is taken (``_check_scan``); an invalid one is dropped
with a rate-limited warning and counted per reason, and the counters go to ``/diagnostics``
every second.
"""

import argparse
import sys
import time
from typing import Optional

from geometry_msgs.msg import PoseStamped
import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.utilities import remove_ros_args
from sensor_msgs.msg import PointCloud2

from sat_agent.actions import candidate_poses
from sat_agent.agent_core import Agent, REPORT_KINDS
from sat_agent.beyond_paper.overdue_nodes import node_views_defect
from sat_agent.config import SatParams
from sat_agent.message_auth import Signer, StepWindow, WORLD_SENDER
from sat_agent.node_params import AgentNodeParams
from sat_agent.ros import views
from sat_agent.ros.input_guard import InputGuard, LOG_THROTTLE_S
from sat_agent.ros.message_limits import MessageLimits, STATUS_PARTICLES
from sat_agent.ros.msg_conversions import (estimate_to_msg, header, InvalidMessage, MAX_TARGETS,
                                           measurements_from_msg, message_class, point,
                                           RADIO_TYPES, report_from_parts, report_to_msgs)
from sat_agent.ros.node_runner import (all_acked, FINAL_ACK_TIMEOUT_S, finish_run, run_nodes,
                                       steady_timer)
from sat_agent.ros.qos import RADIO, ROBOT, STEP, WORLD
from sat_agent.ros.radio_parsing import RadioParser
from sat_agent.ros.readiness import ReadyAnnouncer
from sat_agent.ros.robot_input import detections_from_msg, pose_from_msg, RobotPose
from sat_agent.ros.ros_params import NodeParameters
from sat_agent.ros.signed_io import auth_key, SignedPublisher, VerifiedInput
from sat_agent.search_density import Lattice
from sat_agent.search_map import SearchMap
from sat_agent.stamps import step_at, views_due
from sat_agent.topic_names import (AGENT_VIEWS, radio_topic, ROBOT_DETECTIONS, ROBOT_GOAL,
                                   ROBOT_POSE, VIEW_PREFIX)
from sat_msgs.msg import AgentStatus, ControlCommand, MeasurementSet, WorldStep

# A scan further ahead than this is garbage, not a world that ran on without us.
MAX_STEP_JUMP = 1000
# A robot's scan may be stamped this many steps ahead of the agent's clock (_check_robot_clock).
MAX_CLOCK_LEAD = 2
# Reports older than this many steps are stale; younger late ones (radio latency) still add
# their search density (Agent.step).
MAX_REPORT_LAG = 4
# Applied while the agent runs (``ros2 param set``); the others are read-only here.
LIVE = ('search.investigate_steps', 'view_rate', 'report_wait_timeout', 'world_timeout')
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
        # Steps run whole between callbacks: a change holds from the step after the last one.
        self.parameters = NodeParameters(self, (SatParams, AgentNodeParams), LIVE, self._retune,
                                         lambda: f'after step {self.last_step}')
        self.params, self.node_params = self.parameters.values
        self.agent_id = self.node_params.agent_id
        self.dt = self.params.motion.dt
        self._last_scan_at = None
        self._finished_at = None      # when /world/step said the run is finished
        self.core = None
        self.lattice = Lattice.for_area(self.params.area, self.params.search.lattice_spacing)
        self.search_nodes = SearchMap.for_area(self.params.area,
                                               self.params.search.node_spacing).size
        self.last_step = 0
        self.guard = InputGuard(self, f'agent_{self.agent_id}',
                                self.node_params.diagnostics_period)
        key = auth_key(self, self.node_params)
        # The roster (the bring-up passes it); unset: any sender the relay sealed for us.
        roster = self.declare_parameter('agent_ids', Parameter.Type.INTEGER_ARRAY).value
        self.inputs = VerifiedInput(self, self.guard, key, roster,
                                    StepWindow(behind=MAX_REPORT_LAG, ahead=1,
                                               world_ahead=MAX_STEP_JUMP))
        self.limits = MessageLimits.compute(self.params, len(roster or ()))
        signer = Signer(key, self.agent_id)
        self._pending = None          # (step, (pose, measurements), deliveries, arrival time)
        self._radio = {}              # (sender, step) -> {kind: validated content}
        self._received_since_step = 0
        self._robot_pose = RobotPose(None, 0.0)
        self._last_view_step = None
        self._last_plan = None

        self.cmd_pub = SignedPublisher(self, ControlCommand, 'cmd', STEP, signer)
        self.goal_pub = self.create_publisher(PoseStamped, ROBOT_GOAL[0], STEP)
        self.status_pub = SignedPublisher(self, AgentStatus, 'status', STEP, signer)
        self.radio_pubs = {kind: SignedPublisher(self, cls, f'radio/out/{kind}', RADIO, signer,
                                                 relayed=True)
                           for kind, cls in RADIO_TYPES.items()}
        self.view_pubs = {name: self.create_publisher(message_class(msgtype),
                                                      VIEW_PREFIX + name, WORLD)
                          for name, msgtype in AGENT_VIEWS.items()}
        radio_in = [self._radio_subscription(kind, cls) for kind, cls in RADIO_TYPES.items()]
        # What an observer (the recorder) or a robot must not miss a message of.
        self.answer_pubs = [self.cmd_pub, self.goal_pub, self.status_pub,
                            *self.radio_pubs.values()]
        if self.node_params.input_source == 'robot':
            # A robot reads its goal from the agent's writer: the announcement says when that
            # writer matched it (the radio, from a bridge, may come later or never).
            inputs = [self.create_subscription(PoseStamped, ROBOT_POSE[0], self.on_robot_pose,
                                               ROBOT),
                      self.create_subscription(PointCloud2, ROBOT_DETECTIONS[0],
                                               self.on_detections, ROBOT)]
        else:
            inputs = [self.inputs.subscribe(MeasurementSet, 'measurements',
                                            self.on_measurements, STEP, self.limits.scan,
                                            sender=WORLD_SENDER, names_sender=False,
                                            content=self._check_scan),
                      self.inputs.subscribe(WorldStep, '/world/step', self.on_world_step,
                                            WORLD, self.limits.step, sender=WORLD_SENDER),
                      *radio_in]
        # world_sim starts step 1 once these writers have matched every reader of the run.
        self.ready = ReadyAnnouncer(self, inputs, self.answer_pubs, key=key)
        steady_timer(self, 0.05, self._check_wait_timeout)
        self.get_logger().info(f'agent {self.agent_id} ready')

    def _retune(self, params: SatParams, node_params: AgentNodeParams):
        """Take a live change (LIVE): the node reads its own at each use, the core at each step."""
        self.params, self.node_params = params, node_params
        if self.core is not None:
            self.core.retune(params)

    # -- input ------------------------------------------------------------------------------

    def _radio_subscription(self, kind: str, cls):
        """Subscribe raw to radio/in/<kind>: seals are checked against its full name."""
        channel = self.resolve_topic_name(f'radio/in/{kind}')
        return self.create_subscription(cls, channel,
                                        lambda data: self.on_radio(kind, channel, data),
                                        RADIO, raw=True)

    def _check_scan(self, msg: MeasurementSet):
        """Raise InvalidMessage for a scan this agent cannot take (VerifiedInput's content hook).

        Run before the scan is taken, so a signed scan refused here (another agent's, of an old
        step, NaNs) does not advance the world's replay counter past the genuine one it races.
        """
        if msg.agent_id != self.agent_id:
            raise InvalidMessage('wrong_agent_id', f'scan for agent {msg.agent_id}')
        self._check_step(msg.step)
        measurements_from_msg(msg)

    def on_measurements(self, msg: MeasurementSet):
        self._take_scan('measurements', msg.step, measurements_from_msg(msg),
                        msg.radio_deliveries)

    def on_robot_pose(self, msg: PoseStamped):
        try:
            self._robot_pose = pose_from_msg(msg)
        except InvalidMessage as error:
            self.guard.drop(error.reason, f'robot/pose: {error.detail}')
            return
        self.guard.accept(ROBOT_POSE[0])

    def on_detections(self, msg: PointCloud2):
        step = step_at(msg.header.stamp.sec, msg.header.stamp.nanosec, self.dt)
        try:
            self._check_step(step)
            self._check_robot_clock(step)
            if self._robot_pose.xy is None:
                raise InvalidMessage('no_pose', 'before any robot/pose')
            z = detections_from_msg(msg, self._robot_pose, self.agent_id)
        except InvalidMessage as error:
            self.guard.drop(error.reason, f'detections of step {step}: {error.detail}')
            return
        self._take_scan(ROBOT_DETECTIONS[0], step, (self._robot_pose.xy, z), 0)

    def on_world_step(self, msg: WorldStep):
        if msg.finished and self._finished_at is None:
            # The exit waits for the observers' acks of the last answers (_check_wait_timeout).
            self.get_logger().info(f'the run finished after step {msg.step}: exiting')
            self._finished_at = time.monotonic()

    def _check_step(self, step: int):
        """Raise InvalidMessage unless a scan of this step is news: not stale, not far ahead."""
        if step <= self.last_step:
            raise InvalidMessage('stale_step', f'scan of step {step} after step {self.last_step}')
        if self.last_step and step > self.last_step + MAX_STEP_JUMP:
            raise InvalidMessage('future_step', f'scan of step {step} at step {self.last_step}')

    def _check_robot_clock(self, step: int):
        """Raise InvalidMessage for a robot scan stamped ahead of this node's clock.

        The robot's stamps are unsigned: without this bound a forged first scan stamped far
        ahead would make every genuine later one stale. The drone's and the agent's clocks
        agree to within dt / 2 (README, "A real drone"); MAX_CLOCK_LEAD steps also cover a
        /clock that reaches this node after the scan of its step. A clock at 0 (sim time before
        any /clock) bounds nothing; under sim time the bound is only as good as /clock, which is
        unsigned too.
        """
        now = self.get_clock().now().nanoseconds
        clock_step = step_at(0, now, self.dt)
        if now and step > clock_step + MAX_CLOCK_LEAD:
            raise InvalidMessage('future_step', f"stamped ahead of this node's clock (step "
                                 f'{clock_step})')

    def _take_scan(self, kind: str, step: int, scan, deliveries: int):
        self.guard.accept(kind)
        self.ready.stop()
        self._last_scan_at = time.monotonic()
        if self._pending is not None:
            # The world moved on without our command (we were too slow): step the newest scan.
            self.guard.drop('superseded_scan', f'scan of step {self._pending[0]} never stepped')
        self._pending = (step, scan, deliveries, time.monotonic())
        self._try_step()

    def on_radio(self, kind: str, channel: str, data: bytes):
        received = self.inputs.receive_report(
            self.radio_parser, kind, channel, data, self.lattice, self.limits.radio(kind),
            origin=lambda sender: radio_topic(sender, 'out', kind))
        if received is None:
            return
        msg, part = received
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
        if self._finished_at is not None:
            if all_acked(self.answer_pubs) \
                    or time.monotonic() - self._finished_at > FINAL_ACK_TIMEOUT_S:
                finish_run(self, 0)
            return
        world_timeout = self.node_params.world_timeout
        if self._last_scan_at is not None and self.node_params.input_source == 'world_sim' \
                and time.monotonic() - self._last_scan_at > world_timeout:
            self.get_logger().warning(f'no scan for {world_timeout} s: world_sim is gone, '
                                      'exiting')
            finish_run(self, 0)
            return
        wait = self.node_params.report_wait_timeout
        if self._pending and time.monotonic() - self._pending[3] > wait:
            self.get_logger().warning(
                f'step {self._pending[0]}: radio messages missing after {wait} s, stepping '
                'without them',
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
            report = report_from_parts(sender, sent, parts)
            defect = node_views_defect(report.node_views, self.search_nodes, sent)
            if defect:
                self.guard.drop(defect, f'agent {sender} step {sent}: '
                                f'{len(report.node_views)} node views for '
                                f'{self.search_nodes} nodes, or one after the step')
                continue
            reports.append(report)
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
            self.core = Agent(self.agent_id, self.params, pose, seed=self.node_params.seed)
        output = self.core.step(step, pose, measurements, self._inbox(step))
        self.last_step = step
        lattice = self.core.filter.search.lattice
        for kind, out in zip(REPORT_KINDS, report_to_msgs(output.report, lattice, self.dt)):
            self.radio_pubs[kind].publish(out, step)
        stamp = header(step, self.dt)
        self.status_pub.publish(self._status(stamp, step, pose, output,
                                             time.perf_counter() - started), step)
        target = candidate_poses(pose, self.params.actions)[output.action]
        self.cmd_pub.publish(ControlCommand(header=stamp, agent_id=self.agent_id, step=step,
                                            action_index=output.action,
                                            target_position=point(target)), step)
        self.goal_pub.publish(views.pose_stamped(target, stamp))
        if views_due(step, self._last_view_step, self.dt, self.node_params.view_rate):
            self._last_view_step = step
            self._publish_views(stamp, pose, output)

    def _publish_views(self, stamp, pose, output):
        """Publish the standard views of this step (sat_agent.ros.views)."""
        lattice = self.core.filter.search.lattice
        pubs = self.view_pubs
        pubs['search_density'].publish(views.occupancy_grid(output.report.search_values,
                                                            lattice, stamp))
        pubs['estimates'].publish(views.estimate_markers(self.agent_id, output.estimate, stamp))
        pubs['estimate_poses'].publish(views.estimate_poses(output.estimate, stamp))
        if self._last_plan is None or not np.array_equal(output.plan, self._last_plan):
            self._last_plan = output.plan
            pubs['plan'].publish(views.plan_path(output.plan, stamp))
        pubs['pose'].publish(views.pose_stamped(pose, stamp, self._robot_pose.yaw))

    def _status(self, stamp, step: int, pose, output, compute_time: float) -> AgentStatus:
        targets = self.core.filter.targets
        keep = np.linspace(0, len(targets.weights) - 1,
                           min(STATUS_PARTICLES, len(targets.weights))).astype(int)
        return AgentStatus(
            header=stamp, agent_id=self.agent_id, step=step, mode=int(output.mode),
            position=point(pose), plan=[point(p) for p in output.plan],
            group=sorted(self.core.planner.group),
            estimate=estimate_to_msg(self.agent_id, step, pose, output.estimate, self.dt),
            coasted=[point(p) for p in output.coasted[:MAX_TARGETS]],
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
