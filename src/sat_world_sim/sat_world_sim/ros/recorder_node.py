"""The recorder node: every topic of the graph into a rosbag2 bag (MCAP), written with rosbags.

``<run_dir>/bag/`` gets ``metadata.yaml`` and an MCAP file holding each topic's messages as the
CDR bytes that crossed DDS (subscriptions are raw, nothing is re-serialised), with the message
definitions of sat_msgs and the publishers' QoS profiles, so ``ros2 bag play`` on a full Jazzy
install (with sat_msgs built) plays it back. Timestamps are the receive times (ns since epoch).
The MCAP chunks are zstd-compressed (rosbag2's MCAP storage reads them natively; metadata.yaml
says no bag-level compression): ~25 times smaller, mostly the search densities (a 4-agent
soak: ~0.4 GB per 1,000 steps uncompressed, 14 MB compressed).
The node closes the bag and exits after the world's final step once the run's last messages are
in (or after FINAL_WAIT_S), or on Ctrl-C. DDS does not order messages across topics, so the
final WorldStep can come before the last step's other messages: the run's last messages are in
when each agent active at the final step has sent its scan's answers (cmd, robot/goal, status,
radio/out) of that step (by their headers' sim time), and world_sim has exited, which it does
only once every reader acknowledged its messages (so they are all in this node's queues).
Only verified bytes are recorded (observer.signature_of says how each topic is signed): a
signed topic's message is size-checked and verified, never deserialized (but /world/step, for
``finished``), and a refused one is counted on /diagnostics instead of written. The bag keeps
the signatures: a live replay of it is accepted by nodes with the run's key or with
authentication off. Standard-typed topics (clock, views, markers, robot/goal) are not signed,
so anyone on the domain can publish there; they are bounded instead (unsigned_input), never
deserialized either (but a recorded robot/goal's stamp at the end): a message larger than the
largest a genuine publisher can send (message_limits.standard_limits, computed at start-up) is
refused as ``too_large``, one beyond its topic's budget (BURST messages, then PER_STEP more
per world step, where a genuine publisher sends one) as ``rate_limited``, both counted on
/diagnostics. The step is the one the verifier learned from the world's signed messages. A
publisher on the domain can still write into the bag, but at most PER_STEP messages per
topic and step of at most the genuine size (after a first BURST): with 4 agents up to ~8 MB a
step, mostly the estimates' markers (0.8 MB a message); a long run's bag can still grow by
gigabytes, but no longer as fast as a publisher can send.
"""

from pathlib import Path
import time

from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)

from sat_agent.config import SatParams
from sat_agent.node_params import ObserverParams
from sat_agent.ros.message_limits import standard_limits
from sat_agent.ros.msg_conversions import message_class
from sat_agent.ros.node_runner import finish_run, run_nodes, steady_timer
from sat_agent.ros.readiness import ReadyAnnouncer
from sat_agent.ros.ros_params import NodeParameters
from sat_agent.topic_names import ROBOT_GOAL
from sat_msgs.msg import GroundTruth, WorldStep

from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.bag_writer import RunBagWriter
from sat_world_sim.ros.observer import observer_input, signature_of
from sat_world_sim.ros.replay_support import topic_qos
from sat_world_sim.topics import graph_topics, Topic
from sat_world_sim.unsigned_input import UnsignedInput

# After the world's final step, wait at most this long for the run's last messages.
FINAL_WAIT_S = 10.0
# An active agent's answers to a scan: the messages of the final step the bag must hold.
ANSWERS = ('cmd', ROBOT_GOAL[0], 'status', 'radio/out/search_density', 'radio/out/estimate',
           'radio/out/mode')


def bag_qos(profile) -> Qos:
    """Describe an rclpy QoS profile as rosbag2 records it in metadata.yaml."""
    zero = QosTime(sec=0, nsec=0)
    return Qos(history=QosHistory.KEEP_LAST, depth=int(profile.depth),
               reliability=QosReliability(int(profile.reliability)),
               durability=QosDurability(int(profile.durability)),
               deadline=zero, lifespan=zero, liveliness=QosLiveliness.AUTOMATIC,
               liveliness_lease_duration=zero, avoid_ros_namespace_conventions=False)


class RecorderNode(Node):
    """Records a run (module docstring)."""

    def __init__(self, **kwargs):
        super().__init__('recorder', **kwargs)
        params, run = NodeParameters(self, (SatParams, ObserverParams)).values
        run_dir, agent_ids = Path(run.run_dir), run.agent_ids
        self.inputs, limits = observer_input(self, params, run)
        self.path = run_dir / 'bag'
        if self.path.exists():
            raise ValueError(f"parameter 'run_dir' = '{run_dir}': {self.path} exists already")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        store = sat_typestore()
        self.writer = RunBagWriter(self.path)
        self.writer.open()
        self.count = 0
        self._finished_at = None
        self._agent_ids = agent_ids
        self._last = {}          # topic -> (Topic, CDR bytes of its last message)
        topics = graph_topics(agent_ids)
        signatures = {topic.name: signature_of(topic.name, limits) for topic in topics}
        self.unsigned = UnsignedInput([name for name, signature in signatures.items()
                                       if signature is None],
                                      standard_limits(params, agent_ids))
        subscriptions = []
        for topic in topics:
            qos = topic_qos(topic)
            connection = self.writer.add_connection(topic.name, topic.msgtype, typestore=store,
                                                    offered_qos_profiles=[bag_qos(qos)])
            subscriptions.append(self.create_subscription(
                message_class(topic.msgtype), topic.name,
                lambda data, c=connection, t=topic,
                signature=signatures[topic.name]: self._take(c, t, signature, data),
                qos, raw=True))
        self.ready = ReadyAnnouncer(self, subscriptions, key=self.inputs.verifier.key,
                                    started=self.inputs.took_any)
        steady_timer(self, 0.2, self._tick)

    def _take(self, connection, topic: Topic, signature, data: bytes):
        """Record a message that passes its topic's checks (signature None: unsigned, bounded)."""
        if topic.name == '/world/step':
            msg = self.inputs.receive(topic.name, data, WorldStep, **signature)
            if msg is None:
                return
            if msg.finished:
                self._finished_at = time.monotonic()
        elif signature is None:
            refusal = self.unsigned.refusal(topic.name, len(data), self.inputs.verifier.step)
            if refusal is not None:
                self.inputs.guard.drop(*refusal)
                return
        else:
            checks = {k: v for k, v in signature.items() if k != 'names_sender'}
            if self.inputs.check(topic.name, data, **checks) is False:
                return
        self.writer.write(connection, time.time_ns(), data)
        self.count += 1
        self._last[topic.name] = (topic, data)

    def _last_stamp(self, name: str) -> int:
        """Return the header stamp (ns of sim time) of the last message on a topic, -1 before any.

        Every message of step k carries t_k (sat_agent.stamps), the standard-typed ones too.
        """
        if name not in self._last:
            return -1
        topic, data = self._last[name]
        try:
            stamp = deserialize_message(data, message_class(topic.msgtype)).header.stamp
        except Exception:      # an unsigned topic (robot/goal) may carry anything
            return -1
        return stamp.sec * 10**9 + stamp.nanosec

    def _all_in(self) -> bool:
        """Whether the run's last messages are in (module docstring)."""
        if self.count_publishers('/world/step') > 0:
            return False
        final = self._last_stamp('/world/step')
        if self._last_stamp('/world/truth') != final:
            return False
        truth = deserialize_message(self._last['/world/truth'][1], GroundTruth)
        active = [a.id for a in truth.agents if a.active and a.id in self._agent_ids]
        return all(self._last_stamp(f'/agent_{i}/{name}') >= final
                   for i in active for name in ANSWERS)

    def _tick(self):
        if self._finished_at is None:
            return
        waited = time.monotonic() - self._finished_at
        if self._all_in():
            self.get_logger().info(f'wrote {self.count} messages to {self.path}')
        elif waited > FINAL_WAIT_S:
            self.get_logger().warning(f'wrote {self.count} messages to {self.path}; the last '
                                      f'step was still incomplete after {FINAL_WAIT_S} s')
        else:
            return
        finish_run(self, 0)

    def destroy_node(self):
        """Close the bag (metadata.yaml is written on close) whatever ended the node."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        return super().destroy_node()


def main(args=None):
    return run_nodes('recorder', RecorderNode, args)
