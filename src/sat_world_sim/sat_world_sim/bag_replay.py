"""Read a recorded run's bag without ROS, and turn it into metrics, plots and a Rerun file.

The offline half of the ``replay`` command (sat_world_sim.ros.replay has the command and the live
re-publishing)::

    replay runs/<name>/bag --offline --out runs/<name>-replay [--params config/paper.yaml]

feeds the bag's messages to records.RunCollector, the code the live metrics node runs, and
writes ``metrics.json`` and ``plots/*.png`` equal to the live run's, and ``run.rrd`` through the
same Rerun view the live logger uses. rosbags reads the bag: no rclpy here.

A bag keeps the definition of each type it recorded, and messages are read with the bag's own
definitions, so a bag recorded by an older version (a SearchDensity before it carried
node_views) reads as it was written; the installed sat_msgs serve only a bag that keeps none.
The live replay re-publishes the recorded bytes, which today's nodes read with the installed
definitions: ``outdated`` names the topics where the two differ.
"""

from pathlib import Path
from typing import Iterator, List, Optional, Sequence, Tuple

from rosbags.highlevel import AnyReader

from sat_agent.config import SatParams

from sat_world_sim import rerun_view
from sat_world_sim.bag_types import sat_typestore
from sat_world_sim.records import route, RunCollector
from sat_world_sim.topics import agent_of


def open_bag(bag: Path) -> AnyReader:
    """Return a reader of the bag whose typestore holds the bag's own definitions."""
    return AnyReader([Path(bag)], default_typestore=sat_typestore())


def outdated(reader: AnyReader, connections) -> List[Tuple[str, str]]:
    """(topic, msgtype) of the connections recorded with a definition other than the installed.

    Compared by RIHS01 type hash, which covers the nested types (an older Auth dates every
    signed type).
    """
    installed = sat_typestore()
    return [(c.topic, c.msgtype) for c in connections
            if reader.typestore.hash_rihs01(c.msgtype) != installed.hash_rihs01(c.msgtype)]


def bag_agent_ids(reader: AnyReader) -> List[int]:
    """Agent ids whose topics the bag holds."""
    owners = (agent_of(c.topic) for c in reader.connections)
    return sorted({owner[0] for owner in owners if owner is not None})


def selected(reader: AnyReader, topics: Optional[Sequence[str]]):
    """Return the bag's connections, only those of the given topics when any are given."""
    if not topics:
        return list(reader.connections)
    known = {c.topic for c in reader.connections}
    unknown = sorted(set(topics) - known)
    if unknown:
        raise ValueError(f'--topics {unknown} are not in the bag: it has {sorted(known)}')
    return [c for c in reader.connections if c.topic in set(topics)]


def raw_messages(reader: AnyReader, connections) -> Iterator[Tuple[object, int, bytes]]:
    """Yield (connection, timestamp ns, CDR bytes) in time order."""
    yield from reader.messages(connections=connections)


def deserialized(bag: Path, agent_ids: Optional[Sequence[int]] = None
                 ) -> Iterator[Tuple[str, object]]:
    """Yield (topic, message) of a bag in time order, read with the bag's own definitions.

    With agent_ids, only the topics metrics and views read (records.route): a bag also holds
    the standard views, which they do not need.
    """
    with open_bag(bag) as reader:
        connections = [c for c in reader.connections
                       if agent_ids is None or route(c.topic, agent_ids) is not None]
        for connection, _, raw in raw_messages(reader, connections):
            yield connection.topic, reader.deserialize(raw, connection.msgtype)


def replay_offline(bag: Path, out: Path, params: SatParams) -> dict:
    """Write metrics.json, plots and run.rrd from a bag, as the live metrics and logger do."""
    with open_bag(bag) as reader:
        agent_ids = bag_agent_ids(reader)
    collector = RunCollector(agent_ids)
    for topic, msg in deserialized(bag, agent_ids):
        collector.add(topic, msg)
    area = (params.area.width, params.area.height)
    metrics = collector.write(out, area)
    rerun_view.write_rrd(deserialized(bag, agent_ids), out / 'run.rrd', agent_ids, area,
                         params.sensor.square_side)
    return metrics
