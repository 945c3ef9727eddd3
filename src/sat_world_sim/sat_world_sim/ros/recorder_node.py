"""The recorder node: every topic of the graph into a rosbag2 bag (MCAP), written with rosbags.

``<run_dir>/bag/`` gets ``metadata.yaml`` and an MCAP file holding each topic's messages as the
CDR bytes that crossed DDS (subscriptions are raw, nothing is re-serialised), with the message
definitions of sat_msgs and the publishers' QoS profiles, so ``ros2 bag play`` on a full Jazzy
install (with sat_msgs built) plays it back. Timestamps are the receive times (ns since epoch).
The MCAP chunks are zstd-compressed (rosbag2's MCAP storage reads them natively; metadata.yaml
says no bag-level compression): ~25 times smaller, mostly the search densities (a 4-agent
soak: ~0.4 GB per 1,000 steps uncompressed, 14 MB compressed).
Only verified bytes are recorded (observer.signature_of says how each topic is signed): a
signed topic's message is size-checked and verified, never deserialized (but /world/step, for
``finished``), and a refused one is counted on /diagnostics instead of written. The bag keeps
the signatures: a live replay of it is accepted by nodes with the run's key or with
authentication off. Standard-typed topics (clock, views, markers) are not signed.
The node closes the bag and exits after the world's final step, or on Ctrl-C.
"""

import time

from rclpy.node import Node
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

from sat_agent.ros.msg_conversions import message_class
from sat_agent.ros.node_runner import finish_run, run_nodes, steady_timer
from sat_agent.ros.ros_params import declare_sat_params
from sat_msgs.msg import WorldStep

from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.ros.observer import (declare_run, observer_input, ReadyAnnouncer,
                                        signature_of)
from sat_world_sim.ros.replay_support import topic_qos
from sat_world_sim.topics import graph_topics

# After the world's final step, keep recording this long for the last messages in flight.
FINAL_WAIT_S = 2.0


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
        params = declare_sat_params(self)
        run_dir, agent_ids = declare_run(self, 'the bag goes to <run_dir>/bag')
        self.inputs, limits, key = observer_input(self, params, agent_ids)
        self.path = run_dir / 'bag'
        if self.path.exists():
            raise ValueError(f"parameter 'run_dir' = '{run_dir}': {self.path} exists already")
        self.path.parent.mkdir(parents=True, exist_ok=True)
        store = sat_typestore()
        self.writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        # Chunk compression, not rosbag2's file or message modes: the bag stays one plain MCAP
        # that any MCAP reader and `ros2 bag play` open without a decompression step.
        self.writer.set_compression(CompressionMode.STORAGE, CompressionFormat.ZSTD)
        self.writer.open()
        self.count = 0
        self._finished_at = None
        subscriptions = []
        for topic in graph_topics(agent_ids):
            qos = topic_qos(topic)
            connection = self.writer.add_connection(topic.name, topic.msgtype, typestore=store,
                                                    offered_qos_profiles=[bag_qos(qos)])
            subscriptions.append(self.create_subscription(
                message_class(topic.msgtype), topic.name,
                lambda data, c=connection, name=topic.name,
                signature=signature_of(topic.name, limits): self._take(c, name, signature, data),
                qos, raw=True))
        self.ready = ReadyAnnouncer(self, subscriptions, key)
        steady_timer(self, 0.2, self._tick)

    def _take(self, connection, name: str, signature, data: bytes):
        """Record a message that passes its topic's checks (signature None: not signed)."""
        if name == '/world/step':
            msg = self.inputs.receive(name, data, WorldStep, **signature)
            if msg is None:
                return
            if msg.finished:
                self._finished_at = time.monotonic()
        elif signature is not None:
            checks = {k: v for k, v in signature.items() if k != 'names_sender'}
            if self.inputs.check(name, data, **checks) is False:
                return
        self.writer.write(connection, time.time_ns(), data)
        self.count += 1

    def _tick(self):
        if self._finished_at is not None and time.monotonic() - self._finished_at > FINAL_WAIT_S:
            self.get_logger().info(f'wrote {self.count} messages to {self.path}')
            finish_run(self, 0)

    def destroy_node(self):
        """Close the bag (metadata.yaml is written on close) whatever ended the node."""
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        return super().destroy_node()


def main(args=None):
    return run_nodes('recorder', RecorderNode, args)
