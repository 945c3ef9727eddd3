"""The run's bag writer: rosbags' rosbag2 Writer with the recorder's format, O(1) per message.

A run's bag is one rosbag2 bag (version 9) in one MCAP file with zstd chunk compression (not
rosbag2's file or message modes), so that any MCAP reader and `ros2 bag play` open it without
a decompression step.

rosbags 0.11.9's ``Writer.write`` refuses a connection the bag does not hold by testing
``connection in self.connections``, a list: one scan of every connection for every message.
A run has 15 topics per agent (965 at 64 agents), where that scan made a write 2.7-3 times
slower (``scripts/bench_bag.py``, session 71: 8.3-10.5 against 3.0-3.5 us; the recorder spends
~160-190 us of CPU per message in a 64-agent real-time run, most of it taking the message
through rclpy and the middleware), and it grows with the swarm. ``RunBagWriter`` keeps the
same test (equality with a connection the bag holds), answered from a dict keyed by the
connection's id.
"""

from pathlib import Path

from rosbags.interfaces import Connection
from rosbags.rosbag2 import CompressionFormat, CompressionMode, StoragePlugin, Writer

VERSION = 9
STORAGE = StoragePlugin.MCAP
COMPRESSION = (CompressionMode.STORAGE, CompressionFormat.ZSTD)


class _Connections(list):
    """The writer's connections in order, with ``in`` answered by id instead of a scan."""

    def __init__(self):
        super().__init__()
        self._by_id = {}

    def append(self, connection: Connection):
        super().append(connection)
        self._by_id[connection.id] = connection

    def __contains__(self, connection) -> bool:
        held = self._by_id.get(getattr(connection, 'id', None))
        return held is not None and held == connection


class RunBagWriter(Writer):
    """A rosbag2 (version 9) MCAP bag with zstd chunks, open for writing (module docstring)."""

    def __init__(self, path: Path):
        super().__init__(path, version=VERSION, storage_plugin=STORAGE)
        self.connections = _Connections()
        self.set_compression(*COMPRESSION)
