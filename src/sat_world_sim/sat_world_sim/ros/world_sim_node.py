"""The world_sim node: ground truth, sensors and the radio of a run, as a thin adapter.

The maths is in world_model.World (truth, scans, moves, coverage) and radio.Radio (range gate,
loss, delay, counters); this node moves messages:

- publishes ``/clock`` (rosgraph_msgs/Clock: t_k = k dt when step k starts, in both clocks),
  ``/world/step`` (WorldStep), ``/world/truth`` (GroundTruth), ``/world/radio``
  (RadioTraffic), ``/world/truth_markers`` (MarkerArray, every 1 / ``view_rate`` s of sim
  time: sat_agent.ros.views) and each agent's ``/agent_<i>/measurements`` (MeasurementSet);
  every header carries t_k and its frame (sat_agent.stamps);
- takes ``/agent_<i>/cmd`` (ControlCommand) and ``/agent_<i>/radio/out/<kind>``, forwarding the
  latter to ``/agent_<j>/radio/in/<kind>`` for the agents j in range (the only path between
  agents). Reports are taken raw and, once validated, the received bytes are forwarded as they
  are: a report reaches ~30 agents with 64 spread over the area, and publishing a message
  object (serialised again for each receiver) took about half of this node's CPU with 48.

Parameters: SatParams and sat_agent.node_params.WorldNodeParams; those in LIVE (the radio
range C_R and loss, ``agent_timeout``, ``view_rate``) may be changed with ``ros2 param set``
while it runs if it was started with ``live_parameters:=true``; the rest, and by default all,
are read-only.

Clocks (parameter ``clock``):

- ``lock_step``: step k+1 starts as soon as every active agent has sent its command and its
  three reports for step k. Deterministic for a seed, as fast as the CPUs allow.
- ``real_time``: a step every ``period`` seconds on a fixed schedule; agents that are late
  hold position. Agents step on their scan without waiting for their inbox, so with no radio
  delay each report is forwarded as soon as it arrives (read by the receiver's next step, as
  in lock-step) instead of in one burst with the next step's scans.

An agent that stays silent for ``agent_timeout`` seconds (lock-step) is marked inactive: it holds
position and is not waited for until it answers a scan sent since (sat_world_sim.attendance).
Commands that are not one of the actions of Eqn. controlVectors or leave the area are refused
with a log line; the agent holds. Every command and report is validated (the sender's
namespace, the step, the content: the radio never forwards garbage); what is dropped is counted
per reason on ``/diagnostics``.
Authentication (sat_agent.message_auth, sat_agent.ros.signed_io): with ``auth_key_file`` set,
the world signs /world/step, /world/truth, /world/radio and every scan as sender 0, and takes
each agent's cmd and radio/out raw, refusing (and counting) before deserialization and before
the duplicate check what is too large (message_limits, also without a key), unsigned, badly
signed, signed by anyone but that agent, replayed, ahead of the current step or more than
REJOIN_STEPS behind it (an inactive agent's late answer rejoins it): a forged command cannot
take an agent's place. The radio relays only for the roster, and seals each delivery for its
receiver (Signer.seal: one short HMAC per delivery); only that seal makes a report acceptable
on a radio/in topic.
Step 1 starts once the start-up handshake of sat_agent.ros.readiness says no first message can
be lost (or after ``startup_timeout`` seconds, with a warning naming what is missing). When the
run is over the node publishes a final WorldStep with ``finished`` (the agents exit on it) and
exits once its readers acknowledged the last messages. Its timers run on the steady clock
(node_runner.steady_timer): it is the source of ``/clock``, so under ``use_sim_time`` its own
ROS clock only moves when it steps.
"""

from collections import Counter
from pathlib import Path
import time

from ament_index_python.packages import get_package_share_directory
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Vector3
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from sat_agent.agent_core import wire_bytes
from sat_agent.config import SatParams
from sat_agent.message_auth import Signer, StepWindow, WORLD_SENDER
from sat_agent.motion_model import POSITION
from sat_agent.node_params import WorldNodeParams
from sat_agent.ros import readiness, views
from sat_agent.ros.input_guard import InputGuard, LOG_THROTTLE_S
from sat_agent.ros.message_limits import MessageLimits
from sat_agent.ros.msg_conversions import (header, InvalidMessage, measurements_to_msg, point,
                                           RADIO_TYPES)
from sat_agent.ros.node_runner import (all_acked, FINAL_ACK_TIMEOUT_S, finish_run, run_nodes,
                                       steady_timer)
from sat_agent.ros.qos import RADIO, STEP, WORLD
from sat_agent.ros.radio_parsing import RadioParser
from sat_agent.ros.ros_params import NodeParameters
from sat_agent.ros.signed_io import auth_key, SignedPublisher, VerifiedInput
from sat_agent.search_density import Lattice
from sat_agent.stamps import step_time, views_due
from sat_agent.topic_names import CLOCK, radio_topic, TRUTH_MARKERS
from sat_msgs.msg import (AgentTruth, ControlCommand, GroundTruth, MeasurementSet, RadioTraffic,
                          TargetTruth, WorldStep)

from sat_world_sim.attendance import Attendance, deadline_after_stall, REJOIN_STEPS
from sat_world_sim.radio import Radio
from sat_world_sim.scenario import load_scenario
from sat_world_sim.world_model import World

CLOCKS = {'lock_step': WorldStep.CLOCK_LOCK_STEP, 'real_time': WorldStep.CLOCK_REAL_TIME}
# The world knows the step: agents' messages of this step, or older ones from an inactive agent
# that rejoins with them (attendance.py); they are then dropped as stale.
WINDOW = StepWindow(behind=REJOIN_STEPS, ahead=0, world_ahead=0)
# Applied while world_sim runs (``ros2 param set``); the others are read-only here.
LIVE = ('cooperation.comm_range', 'radio.loss', 'agent_timeout', 'view_rate')


def default_scenario() -> str:
    """Return the path of the installed paper scenario."""
    return str(Path(get_package_share_directory('sat_world_sim')) / 'config' / 'scenarios'
               / 'paper.yaml')


class WorldSimNode(Node):
    """Runs one scenario (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('world_sim', **kwargs)
        # A change landing during step k gates the links and reports of step k on.
        self.parameters = NodeParameters(self, (SatParams, WorldNodeParams), LIVE,
                                         self._retune, lambda: f'at step {self.world.step}')
        self.params, self.settings = self.parameters.values
        node = self.settings
        scenario = load_scenario(node.scenario or default_scenario(), self.params.area.width,
                                 self.params.area.height)
        if node.seed >= 0:
            scenario = scenario.with_seed(node.seed)
        self.total_steps = node.steps if node.steps > 0 else scenario.steps
        self.clock = clock = node.clock
        self.period = node.period
        self.startup_timeout = node.startup_timeout
        self.observers = node.observers
        self.dt = self.params.motion.dt
        self.radio = Radio(self.params.cooperation.comm_range, node.radio.loss,
                           node.radio.delay_steps, seed=scenario.seed)

        self.world = World(scenario, self.params)
        self.ids = self.world.agent_ids
        self.attendance = Attendance(self.ids)
        self.guard = InputGuard(self, 'world_sim', node.diagnostics_period)
        key = auth_key(self, node)
        self.inputs = VerifiedInput(self, self.guard, key, self.ids, WINDOW)
        self.limits = MessageLimits.compute(self.params, len(self.ids))
        self.signer = Signer(key, WORLD_SENDER)
        self.lattice = Lattice.for_area(self.params.area, self.params.search.lattice_spacing)
        # Each report arrives once, so nothing to cache (radio_parsing.py).
        self.radio_parser = RadioParser()
        self.late_commands = 0
        self._cmds = {}
        self._reports = {i: set() for i in self.ids}
        self._deadline = None
        self._last_tick = None
        self._started = False
        # Each node's last start-up announcement, by node name.
        self._announcements = readiness.Announcements(
            len(self.ids) + self.observers + readiness.EXTRA_ANNOUNCERS)
        self._finished_at = None
        self._last_view_step = None

        self.clock_pub = self.create_publisher(Clock, CLOCK[0], STEP)
        self.markers_pub = self.create_publisher(MarkerArray, TRUTH_MARKERS[0], WORLD)
        self.step_pub = SignedPublisher(self, WorldStep, '/world/step', WORLD, self.signer)
        self.truth_pub = SignedPublisher(self, GroundTruth, '/world/truth', WORLD, self.signer)
        self.traffic_pub = SignedPublisher(self, RadioTraffic, '/world/radio', WORLD,
                                           self.signer)
        self.scan_pubs, self.inbox_pubs = {}, {}
        for i in self.ids:
            ns = f'/agent_{i}'
            self.scan_pubs[i] = SignedPublisher(self, MeasurementSet, f'{ns}/measurements',
                                                STEP, self.signer)
            self.inputs.subscribe(ControlCommand, f'{ns}/cmd',
                                  lambda msg, i=i: self.on_cmd(i, msg), STEP,
                                  self.limits.command, sender=i)
            for kind, cls in RADIO_TYPES.items():
                self.inbox_pubs[(i, kind)] = self.create_publisher(
                    cls, radio_topic(i, 'in', kind), RADIO)
                # Raw: the bytes received are the bytes forwarded, serialised once by the sender.
                self.create_subscription(
                    cls, radio_topic(i, 'out', kind),
                    lambda data, i=i, kind=kind: self.on_report(i, kind, data), RADIO, raw=True)
        self.create_subscription(String, readiness.TOPIC, self.on_announcement, readiness.QOS)
        self._launched = time.monotonic()
        steady_timer(self, 0.02, self._tick)
        self.get_logger().info(
            f'{scenario.name}: {len(self.ids)} agents, {self.total_steps} steps, {clock} clock')

    def _retune(self, params: SatParams, settings: WorldNodeParams):
        """Take a live change (LIVE): the radio and the world gate the next message with it."""
        self.params, self.settings = params, settings
        self.world.params = params
        self.radio.comm_range = params.cooperation.comm_range
        self.radio.loss = settings.radio.loss

    # -- start-up ---------------------------------------------------------------------------

    def on_announcement(self, msg: String):
        """Keep each node's last start-up announcement (sat_agent.ros.readiness).

        Every one is checked (a malformed, unsigned or badly signed one is counted); they are
        kept only until the run starts, and for at most the agents, the observers and
        readiness.EXTRA_ANNOUNCERS nodes; with a key, each node's only while its counter grows.
        """
        try:
            text, counter = readiness.unseal(msg.data, self.inputs.verifier.key)
            announced = readiness.parse(text)
        except readiness.AnnouncementError as error:
            self.guard.drop(error.reason, f'{readiness.TOPIC}: {error}')
            return
        if self._started:
            return
        refused = self._announcements.take(announced, counter)
        if refused is not None:
            self.guard.drop(refused[0], f'{readiness.TOPIC}: {refused[1]}')

    def _unmet(self):
        """Return what keeps step 1 from starting (sat_agent.ros.readiness).

        Every agent and ``observers`` other nodes (metrics, a logger, a recorder, a test's
        watcher) must have announced, and every writer must have matched their readers.
        """
        return readiness.unmet(
            self._announcements, (s.topic_name for s in self.subscriptions),
            {p.topic_name: p.get_subscription_count() for p in self._run_publishers()},
            self.ids, self.observers)

    def _run_publishers(self):
        return [self.clock_pub, self.step_pub, self.truth_pub, self.traffic_pub,
                *self.scan_pubs.values(), *self.inbox_pubs.values()]

    # -- the loop ---------------------------------------------------------------------------

    def _tick(self):
        now = time.monotonic()
        if self._finished_at is not None:
            # A reliable writer destroyed with unacknowledged samples loses them: the observers
            # would miss the final step.
            if self._final_messages_acked() or now - self._finished_at > FINAL_ACK_TIMEOUT_S:
                finish_run(self, 0)
            return
        if not self._started:
            self._start_when_ready(now)
            return
        if self.clock == 'real_time':
            if now >= self._deadline:
                late = sorted(self.attendance.active - set(self._cmds))
                if late:
                    self.late_commands += len(late)
                    self.get_logger().warning(
                        f'step {self.world.step}: no command in time from agents {late} '
                        f'({self.late_commands} late so far): they hold position',
                        throttle_duration_sec=LOG_THROTTLE_S)
                self._finish_step()
            return
        previous, self._last_tick = self._last_tick, now
        deadline = deadline_after_stall(self._deadline, previous or now, now)
        if deadline > self._deadline:
            self.get_logger().warning(
                f'step {self.world.step}: world_sim did not tick for {now - previous:.1f} s '
                '(suspended, starved of CPU or busy): the silent agents get '
                f'{deadline - self._deadline:.1f} s more', throttle_duration_sec=LOG_THROTTLE_S)
            self._deadline = deadline
        if now >= self._deadline:
            silent = sorted(i for i in self.attendance.active if not self._answered(i))
            self.get_logger().warning(
                f'step {self.world.step}: agents {silent} silent for '
                f'{self.settings.agent_timeout} s: '
                'marked inactive, they hold position')
            self.attendance.let_go(silent, self.world.step)
            self._finish_step()

    def _start_when_ready(self, now: float):
        unmet = self._unmet()
        if unmet and now - self._launched <= self.startup_timeout:
            return
        if unmet:
            self.get_logger().warning(f'start-up timeout ({self.startup_timeout} s): starting '
                                      f"without: {'; '.join(unmet)}")
        self._started = True
        self._begin_step()

    def _final_messages_acked(self) -> bool:
        """Whether /clock, the world's topics, the active agents' scans and inboxes are acked."""
        publishers = [self.clock_pub, self.step_pub, self.truth_pub, self.traffic_pub]
        active = self.attendance.active
        publishers += [self.scan_pubs[i] for i in active]
        publishers += [p for (i, _), p in self.inbox_pubs.items() if i in active]
        return all_acked(publishers)

    def _answered(self, agent_id: int) -> bool:
        return agent_id in self._cmds and len(self._reports[agent_id]) == len(RADIO_TYPES)

    def _begin_step(self):
        k = self.world.step
        self.inputs.verifier.step = k
        sec, nanosec = step_time(k, self.dt)
        self.clock_pub.publish(Clock(clock=Time(sec=sec, nanosec=nanosec)))
        delivered = self._forward(self.radio.due(k))
        poses = self.world.poses()
        truth = self.world.truth()
        self.step_pub.publish(self._step_msg(k, finished=False), k)
        self.truth_pub.publish(self._truth_msg(k, poses, truth), k)
        if views_due(k, self._last_view_step, self.dt, self.settings.view_rate):
            self._last_view_step = k
            self.markers_pub.publish(views.truth_markers(
                truth.ids, truth.states[:, POSITION], poses,
                (self.params.area.width, self.params.area.height),
                self.params.sensor.square_side, header(k, self.dt)))
        lock_step = self.clock == 'lock_step'
        for i, scan in self.world.scan_all().items():
            self.scan_pubs[i].publish(measurements_to_msg(
                i, k, poses[i], scan.measurements, self.dt,
                delivered[i] if lock_step else 0), k)
        self._cmds = {}
        self._reports = {i: set() for i in self.ids}
        now = time.monotonic()
        if lock_step:
            self._deadline = now + self.settings.agent_timeout
        else:
            # A fixed schedule, step k ending at start + k T: timing from now would stretch
            # every period by the time publishing took. A world that fell a whole period
            # behind restarts the schedule instead of rushing steps to catch up.
            scheduled = (self._deadline or now) + self.period
            self._deadline = scheduled if scheduled > now else now + self.period

    def _maybe_finish(self):
        active = self.attendance.active
        if self.clock == 'lock_step' and active and all(map(self._answered, active)):
            self._finish_step()

    def _finish_step(self):
        k = self.world.step
        # Everything sent at step k is counted by now; links are those of s_k.
        self.traffic_pub.publish(self._traffic_msg(k, self.world.poses()), k)
        moves = self.world.apply_actions(self._cmds)
        for agent_id, move in moves.items():
            if not move.accepted and agent_id in self._cmds:
                self.guard.drop('refused_action', f'step {k}: agent {agent_id}: {move.reason}')
        if k >= self.total_steps:
            self.step_pub.publish(self._step_msg(k, finished=True), k)
            self.get_logger().info(f'run finished after step {k}')
            self._finished_at = time.monotonic()
            return
        self.world.advance()
        self._begin_step()

    # -- input ------------------------------------------------------------------------------

    def _current(self, agent_id: int, msg, what: str) -> bool:
        """Whether msg is this agent's and of the current step; a silent agent speaking rejoins."""
        if msg.agent_id != agent_id:
            self.guard.drop('wrong_agent_id',
                            f'{what} on /agent_{agent_id} claims agent_id {msg.agent_id}')
            return False
        if not self._started or self._finished_at is not None:
            self.guard.drop('stale_step', f'{what} of step {msg.step} at {self.world.step}')
            return False
        if msg.step > self.world.step:
            self.guard.drop('future_step', f'{what} of step {msg.step} at {self.world.step}')
            return False
        if self.attendance.heard(agent_id, msg.step):
            self.get_logger().info(f'agent {agent_id} speaks again (step {msg.step} at '
                                   f'{self.world.step}): active')
        if msg.step < self.world.step:
            self.guard.drop('stale_step', f'{what} of step {msg.step} at {self.world.step}')
            return False
        return True

    def on_cmd(self, agent_id: int, msg: ControlCommand):
        if not self._current(agent_id, msg, 'cmd'):
            return
        if agent_id in self._cmds:
            self.guard.drop('duplicate', f'second cmd of agent {agent_id} for step {msg.step}')
            return
        self.guard.accept('cmd')
        self._cmds[agent_id] = int(msg.action_index)
        self._maybe_finish()

    def on_report(self, agent_id: int, kind: str, data: bytes):
        """Validate an agent's report message and hand it to the radio (never forward garbage)."""
        channel = radio_topic(agent_id, 'out', kind)
        received = self.inputs.receive_report(self.radio_parser, kind, channel, data,
                                              self.lattice, self.limits.radio(kind),
                                              sender=agent_id, relayed=True)
        if received is None:
            return
        msg, part = received
        if not self._current(agent_id, msg, f'radio/out/{kind}'):
            return
        if kind in self._reports[agent_id]:
            self.guard.drop('duplicate', f'second {kind} of agent {agent_id} at {msg.step}')
            return
        if isinstance(part, InvalidMessage):
            self.guard.drop(part.reason, f'{kind} of agent {agent_id}: {part.detail}')
            return
        self.guard.accept(f'radio/out/{kind}')
        self._reports[agent_id].add(kind)
        if kind == 'search_density':
            nbytes = wire_bytes(kind, len(msg.values_zlib), len(msg.node_views))
        else:
            nbytes = wire_bytes(kind, len(part.targets) if kind == 'estimate' else 0)
        self.radio.send(msg.step, agent_id, kind, data, nbytes, self.world.poses())
        if self.clock == 'real_time' and self.radio.delay_steps == 0:
            # Real-time agents do not wait for their inbox, so nothing is gained by holding
            # the step's reports back for one burst at the next step's start, together with
            # the scans: 16 agents in range already make ~700 messages.
            self._forward(self.radio.due(msg.step + 1))
        self._maybe_finish()

    def _forward(self, deliveries) -> Counter:
        """Seal deliveries (serialised messages) for their receivers, publish them; count them."""
        delivered = Counter()
        k = self.world.step
        for delivery in deliveries:
            inbox = self.inbox_pubs[(delivery.receiver, delivery.kind)]
            inbox.publish(self.signer.seal(inbox.topic_name, delivery.payload, k))
            delivered[delivery.receiver] += 1
        return delivered

    # -- messages ---------------------------------------------------------------------------

    def _step_msg(self, k: int, finished: bool) -> WorldStep:
        scenario = self.world.scenario
        return WorldStep(header=header(k, self.dt), step=k, total_steps=self.total_steps,
                         clock=CLOCKS[self.clock],
                         finished=finished, scenario=scenario.name, seed=scenario.seed,
                         late_commands=self.late_commands)

    def _truth_msg(self, k: int, poses, truth) -> GroundTruth:
        targets = [TargetTruth(id=int(i), alive=True, position=point(s[[0, 2]]),
                               velocity=Vector3(x=float(s[1]), y=float(s[3]), z=0.0))
                   for i, s in zip(truth.ids, truth.states)]
        agents = [AgentTruth(id=i, position=point(poses[i]),
                             active=i in self.attendance.active) for i in self.ids]
        return GroundTruth(header=header(k, self.dt), step=k, targets=targets, agents=agents,
                           searched_fraction=self.world.searched_fraction())

    def _traffic_msg(self, k: int, poses) -> RadioTraffic:
        links = sorted(self.radio.links(poses))
        pairs = sorted(self.radio.messages)
        senders = sorted(self.radio.dropped)
        return RadioTraffic(header=header(k, self.dt), step=k, link_a=[a for a, _ in links],
                            link_b=[b for _, b in links],
                            sender=[s for s, _ in pairs], receiver=[r for _, r in pairs],
                            messages=[self.radio.messages[p] for p in pairs],
                            bytes=[self.radio.bytes[p] for p in pairs],
                            drop_sender=senders, dropped=[self.radio.dropped[s] for s in senders])


def main(args=None):
    return run_nodes('world_sim', WorldSimNode, args)
