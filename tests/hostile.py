"""A hostile participant for the attack tests, and a short signed swarm to attack.

``Hostile`` is an rclpy node of the test process on the swarm's ROS domain: it publishes raw
bytes on any topic (garbage, forged messages, replays of genuine ones it captured) and, as an
insider, can sign with the run's key. ``Diagnostics`` reads what the nodes count on
/diagnostics. ``signed_swarm`` starts world_sim, the metrics node, optionally the recorder
and the logger, and two agents, all with one key file and run id RUN_ID; the test node is one
more observer the world waits for, so every attack can be timed on the steps it sees.
"""

from contextlib import contextmanager, ExitStack
import json
from pathlib import Path
from typing import Dict, List, Optional

from diagnostic_msgs.msg import DiagnosticArray
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from ros_harness import announce, executable, PARAMS, spin_until, started, write_scenario
import yaml

from sat_agent.message_auth import create_key_file, load_key, run_key, Signer

DEPTH = 300
# The attacked runs' id: their key is run_key(the key file's, RUN_ID).
RUN_ID = 'attacked-run'
RELIABLE = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=DEPTH, reliability=ReliabilityPolicy.RELIABLE,
                     durability=DurabilityPolicy.TRANSIENT_LOCAL)


def forge(msg, topic: str, step: int, sender: int, key: Optional[bytes],
          relayed: bool = False) -> bytes:
    """Serialize msg and sign it for topic as sender (key None: unsigned, a zero tail)."""
    return Signer(key, sender).sign(topic, serialize_message(msg), step, relayed)


class Hostile:
    """Publishes raw bytes anywhere, captures genuine messages raw for replays."""

    def __init__(self, node):
        self.node = node
        self._publishers = {}
        self.captured: Dict[str, List[bytes]] = {}

    def send(self, topic: str, msg_type, data: bytes, qos=RELIABLE):
        """Publish data (serialized bytes, valid or not) on topic as msg_type."""
        self.publisher(topic, msg_type, qos).publish(data)

    def publisher(self, topic: str, msg_type, qos=RELIABLE):
        """Return the test's writer of topic with qos (created on first call)."""
        key = (topic, msg_type, qos.durability)
        if key not in self._publishers:
            self._publishers[key] = self.node.create_publisher(msg_type, topic, qos)
        return self._publishers[key]

    def capture(self, topic: str, msg_type, qos=RELIABLE, callback=None, keep=None):
        """Keep the raw messages of topic (those keep(data) accepts) in captured[topic].

        callback(data) runs on each. The test's node also receives its own forgeries: keep
        filters them out where a capture is replayed.
        """
        self.captured[topic] = []

        def on_data(data):
            if keep is None or keep(data):
                self.captured[topic].append(bytes(data))
            if callback is not None:
                callback(data)
        return self.node.create_subscription(msg_type, topic, on_data, qos, raw=True)


class Diagnostics:
    """The last counters each node published on /diagnostics, by node name."""

    def __init__(self, node):
        self.values: Dict[str, Dict[str, str]] = {}
        node.create_subscription(DiagnosticArray, '/diagnostics', self._on, 100)

    def _on(self, msg):
        for status in msg.status:
            self.values[status.name.split(':')[0]] = {v.key: v.value for v in status.values}

    def final(self, *nodes: str) -> bool:
        """Whether each node has published its last counters (InputGuard.publish_final)."""
        return all(self.values.get(node, {}).get('final') == '1' for node in nodes)

    def dropped(self, node: str, reason: str) -> int:
        """Messages node (e.g. '/world_sim', '/agent_1/agent') dropped for reason so far."""
        return int(self.values.get(node, {}).get(f'dropped.{reason}', 0))

    def dropped_all(self, node: str) -> Dict[str, int]:
        return {k[len('dropped.'):]: int(v) for k, v in self.values.get(node, {}).items()
                if k.startswith('dropped.')}


@contextmanager
def signed_swarm(tmp_path: Path, scenario: Path, steps: int, key_file: Optional[Path],
                 observers=('metrics',), extra=()):
    """Start world_sim, the observers and agents 1 and 2 of scenario, with key_file (None: off).

    Yields a dict name -> Popen; world_sim waits for the observers and for the test itself
    (ros_harness.announce with the test's subscriptions). extra: ROS arguments for every
    process. Everything is stopped at the end.
    """
    run_dir = tmp_path / 'run'
    key = ('-p', f'auth_key_file:={key_file}', '-p', f'auth_run_id:={RUN_ID}') if key_file else ()
    params = ('--ros-args', '--params-file', str(PARAMS), *key, *extra)
    # world_sim and the agents draw from the scenario's seed, as in the bring-up.
    seed = ('-p', f"seed:={yaml.safe_load(scenario.read_text())['seed']}")
    ids = ('-p', 'agent_ids:=[1,2]')
    commands = {
        'world_sim': [executable('sat_world_sim', 'world_sim'), *params,
                      '-p', f'scenario:={scenario}', '-p', f'steps:={steps}',
                      '-p', f'observers:={len(observers) + 1}', *seed],
        **{name: [executable('sat_world_sim', name), *params, '-p', f'run_dir:={run_dir}', *ids]
           for name in observers},
        **{f'agent_{i}': [executable('sat_agent', 'agent'), *params, '-r', f'__ns:=/agent_{i}',
                          '-p', f'agent_id:={i}', *ids, *seed] for i in (1, 2)}}
    with ExitStack() as stack:
        yield {name: stack.enter_context(started(command, tmp_path / f'{name}.log'))
               for name, command in commands.items()}


def run_attacked(node, hostile, tmp_path: Path, scenario: Path, steps: int, key_file: Path,
                 targets, watch, diagnostics: 'Diagnostics', final_from,
                 observers=('metrics',)) -> Dict[str, int]:
    """Run signed_swarm to its end under attack; return each process's exit code.

    targets: (topic, type, qos) of every attack's writer, matched before the run starts;
    watch(processes): the test's subscriptions (its captures, which time the attacks);
    final_from: the nodes whose last counters (InputGuard.publish_final) the test reads.
    """
    with signed_swarm(tmp_path, scenario, steps, key_file, observers=observers,
                      extra=('-p', 'diagnostics_period:=0.1')) as processes:
        watched = watch(processes)
        # The attack writers take part in world_sim's handshake, so step 1 waits until each has
        # matched every announced reader of its topic. Waiting for a first match only let a
        # writer pass on the test's own capture of the topic: the metrics node then never got
        # an attack on the agents' topics (flake_hunt, full-suite run). An observer, though it
        # writes an agent's commands (a hijack), or world_sim would wait for the observer it is
        # not and start only at its start-up timeout.
        announce(node, watched, [hostile.publisher(*target) for target in targets],
                 observer=True, key=run_key(load_key(key_file), RUN_ID))
        spin_until(node, lambda: all(p.poll() is not None for p in processes.values()), 240,
                   'the attacked run ended', processes.values())
        spin_until(node, lambda: diagnostics.final(*final_from), 30,
                   f'the final counters of {", ".join(final_from)} on /diagnostics')
        return {name: p.poll() for name, p in processes.items()}


def new_key(tmp_path: Path) -> Path:
    """Return a fresh key file (0600) for one test's swarm."""
    return create_key_file(tmp_path / 'swarm.key')


def attack_setup(tmp_path_factory, name: str, seed: int, steps: int):
    """Return (tmp_path, scenario, key_file, the run's key) of one attacked run (near_scenario)."""
    tmp_path = tmp_path_factory.mktemp(name)
    key_file = new_key(tmp_path)
    return (tmp_path, near_scenario(tmp_path, seed, steps), key_file,
            run_key(load_key(key_file), RUN_ID))


def near_scenario(tmp_path: Path, seed: int, steps: int) -> Path:
    """Write a scenario of two agents in radio range and one target between them."""
    return write_scenario(
        tmp_path / 'near.yaml', name='near', seed=seed, steps=steps, truth_process_noise=1e-4,
        agents=[{'id': 1, 'start': [44.0, 50.0]}, {'id': 2, 'start': [56.0, 50.0]}],
        targets=[{'id': 1, 'born': 1, 'died': steps, 'start': [50.0, 46.0],
                  'end': [57.0, 46.0]}])


def read_metrics(tmp_path: Path) -> Optional[dict]:
    path = tmp_path / 'run' / 'metrics.json'
    return json.loads(path.read_text()) if path.is_file() else None


def decode(data: bytes, msg_type):
    return deserialize_message(data, msg_type)
