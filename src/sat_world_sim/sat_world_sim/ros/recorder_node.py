"""The recorder node: every topic of the graph into a rosbag2 bag (MCAP), written with rosbags.

``<run_dir>/bag/`` gets ``metadata.yaml`` and an MCAP file holding each topic's messages as the
CDR bytes that crossed DDS (subscriptions are raw, nothing is re-serialised), with the message
definitions of sat_msgs and the publishers' QoS profiles, so ``ros2 bag play`` on a full Jazzy
install (with sat_msgs built) plays it back. Timestamps are the receive times (ns since epoch).
The MCAP chunks are zstd-compressed (rosbag2's MCAP storage reads them natively; metadata.yaml
says no bag-level compression): ~25 times smaller, mostly the search densities (a 4-agent
soak: ~0.4 GB per 1,000 steps uncompressed, 14 MB compressed).
The node closes the bag and exits after the world's final step, or on Ctrl-C.
"""

import time

from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rosbags.interfaces import (Qos, QosDurability, QosHistory, QosLiveliness, QosReliability,
                                QosTime)
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

from sat_agent.ros.msg_conversions import message_class
from sat_agent.ros.node_runner import finish_run, run_nodes, steady_timer
from sat_msgs.msg import WorldStep

from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.ros.observer import declare_run, ReadyAnnouncer
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
        run_dir, agent_ids = declare_run(self, 'the bag goes to <run_dir>/bag')
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
                lambda data, c=connection, name=topic.name: self._write(c, name, data),
                qos, raw=True))
        self.ready = ReadyAnnouncer(self, subscriptions)
        steady_timer(self, 0.2, self._tick)

    def _write(self, connection, name: str, data: bytes):
        self.writer.write(connection, time.time_ns(), data)
        self.count += 1
        if name == '/world/step' and deserialize_message(data, WorldStep).finished:
            self._finished_at = time.monotonic()

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
