"""Radio messages as serialized bytes: deserialize and validate each distinct message once.

world_sim forwards a sender's report to every agent in range. It subscribes to the radio/out
topics raw, parses them here and republishes the very bytes it received (no re-serialisation
per receiver), and the agents subscribe to their radio/in topics raw. In composed mode many
agents share one process, which then receives the same bytes once per receiver: ~30 copies of
every message with 64 agents spread over the area. A RadioParser shared by those agents
deserializes and validates each distinct message once (for a density that includes the zlib
decode); the other copies cost a dict lookup. The parsed contents are read-only (a decoded
density is a view of immutable bytes), so agents can share them.
"""

from typing import Tuple

from rclpy.serialization import deserialize_message

from sat_agent.ros.msg_conversions import InvalidMessage, RADIO_TYPES, report_part_from_msg
from sat_agent.search_density import Lattice


class RadioParser:
    """(kind, bytes) -> (message or None, validated content or the InvalidMessage to drop it for).

    ``max_entries`` bounds the cache of parsed messages (0: no cache, one agent per process).
    The cache is emptied when full: entries matter only while the receivers of one step take
    their copies, so a few steps' worth of messages is enough.
    """

    def __init__(self, max_entries: int = 0):
        self.max_entries = int(max_entries)
        self._parsed = {}

    def parse(self, kind: str, data: bytes, lattice: Lattice) -> Tuple[object, object]:
        """Parse one radio message (see the class docstring); never raises InvalidMessage."""
        key = (kind, lattice, bytes(data))
        parsed = self._parsed.get(key)
        if parsed is None:
            parsed = self._parse(kind, key[2], lattice)
            if self.max_entries:
                if len(self._parsed) >= self.max_entries:
                    self._parsed.clear()
                self._parsed[key] = parsed
        return parsed

    @staticmethod
    def _parse(kind: str, data: bytes, lattice: Lattice) -> Tuple[object, object]:
        try:
            msg = deserialize_message(data, RADIO_TYPES[kind])
        except Exception as error:     # rclpy raises different types for different CDR defects
            return None, InvalidMessage('undecodable', f'not a {kind} message ({error})')
        try:
            return msg, report_part_from_msg(kind, msg, lattice)
        except InvalidMessage as error:
            return msg, error
