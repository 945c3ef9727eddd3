"""Node-level parameters (not SatParams fields), one schema per node, ROS-free.

Every node also declares the SatParams groups (sat_agent.config); these are its own settings,
given with ``-p name:=value`` (the bring-up and the launch file pass them). Each field is
written once with ``param`` (sat_agent.parameter_schema); ``live`` ones may be changed with
``ros2 param set`` while the node runs if it was started with ``live_parameters:=true``, the
others are read-only.
"""

from dataclasses import dataclass
from typing import Any, Mapping, Tuple

from sat_agent.parameter_schema import check_given, group, leaves, param, ParameterError

LONG_S = 86400.0    # upper bound of the waits in seconds: a day
# The node parameter that lets a node's live parameters change while it runs (ros_params).
LIVE_SWITCH = 'live_parameters'


@dataclass(frozen=True)
class InputParams:
    """What every node that takes the run's messages shares: the key and the drop counters."""

    diagnostics_period: float = param(
        1.0, 'seconds between the dropped-input counters on /diagnostics', low=0, high=LONG_S,
        low_open=True)
    # A path, never the key: parameters can be read by anyone on the domain.
    auth_key_file: str = param(
        '', "the run's swarm key file (sat_agent/message_auth.py: >= 32 random bytes, mode "
        "0600, owned by the node's user or root) to sign and verify messages with; '' = "
        'authentication off (warned)')
    # Not secret: a run's id only makes its MACs its own (message_auth.run_key).
    auth_run_id: str = param(
        '', "the run's id, bound into every signature so that a recording of another run under "
        'the same key is refused; every node of a run must have the same one (the bring-up '
        "and the launch make one per run); '' = none (warned with a key)")


@dataclass(frozen=True)
class SteppingParams(InputParams):
    """What the agent and world_sim share: the standard views, the key, the drop counters."""

    # Off by default: ROS 2 parameter services take anyone's call on the domain, unsigned.
    live_parameters: bool = param(
        False, "accept 'ros2 param set' of this node's live parameters while it runs; false = "
        'every parameter is read-only (anyone on the ROS domain can call parameter services)')
    # 1 with dt = 1 s is every step; read at every step, so a change applies at once.
    view_rate: float = param(
        1.0, 'standard views (OccupancyGrid, MarkerArray, PoseArray, Path, PoseStamped) per '
        'second of sim time; 0 = none', low=0, high=1000, live=True)


@dataclass(frozen=True)
class AgentNodeParams(SteppingParams):
    """The agent node's own parameters (sat_agent.ros.agent_node)."""

    agent_id: int = param(-1, 'this agent id (required, >= 1)', low=1, high=10 ** 6)
    seed: int = param(0, "the run's seed: the filter draws from (seed, agent_id)", low=0,
                      high=2 ** 63 - 1)
    report_wait_timeout: float = param(
        2.0, 'lock-step: seconds to wait for the radio messages a scan announces before '
        'stepping without them', low=0, high=LONG_S, low_open=True, live=True)
    world_timeout: float = param(
        60.0, 'seconds without a scan from world_sim before the agent exits (world_sim input '
        'only)', low=0, high=LONG_S, low_open=True, live=True)
    input_source: str = param(
        'world_sim', "where scans come from: 'world_sim' (MeasurementSet on measurements) or "
        "'robot' (robot/pose PoseStamped and robot/detections PointCloud2)",
        choices=('world_sim', 'robot'))


@dataclass(frozen=True)
class RadioNodeParams:
    """The simulated radio's loss and latency (sat_world_sim.radio; its range is C_R)."""

    loss: float = param(0.0, 'probability that the radio drops a message', low=0, high=1,
                        high_open=True, live=True)
    delay_steps: int = param(0, 'radio latency in steps', low=0, high=1000)


@dataclass(frozen=True)
class WorldNodeParams(SteppingParams):
    """world_sim's own parameters (sat_world_sim.ros.world_sim_node)."""

    scenario: str = param('', 'scenario file (default: the installed paper scenario)')
    seed: int = param(-1, "the run's seed (-1: the scenario's)", low=-1, high=2 ** 63 - 1)
    steps: int = param(0, "steps to run (0: the scenario's)", low=0, high=10 ** 7)
    clock: str = param('lock_step', 'lock_step (as fast as the agents answer) or real_time (a '
                       'step every period seconds)', choices=('lock_step', 'real_time'))
    period: float = param(1.0, 'real_time: wall seconds per step', low=0, high=LONG_S,
                          low_open=True)
    agent_timeout: float = param(
        5.0, 'lock-step: seconds before a silent agent is marked inactive', low=0, high=LONG_S,
        low_open=True, live=True)
    startup_timeout: float = param(
        60.0, 'seconds to wait for every agent and observer before starting with those found',
        low=0, high=LONG_S, low_open=True)
    observers: int = param(0, 'observer nodes (metrics, recorder, logger) to wait for', low=0,
                           high=100)
    radio: RadioNodeParams = group(RadioNodeParams)


@dataclass(frozen=True)
class ObserverParams(InputParams):
    """The metrics and recorder nodes' parameters (sat_world_sim.ros.observer)."""

    run_dir: str = param('', 'the directory the run is written to (required)', required=True)
    agent_ids: Tuple[int, ...] = param((1, 2), 'the ids of the agents to watch')


@dataclass(frozen=True)
class LoggerParams(ObserverParams):
    """The logger node's parameters (sat_world_sim.ros.logger_node)."""

    sink: str = param('file', 'where the Rerun recording goes besides <run_dir>/run.rrd: '
                      "'file' (only there), 'viewer' (native viewer) or 'web' (web viewer)",
                      choices=('file', 'viewer', 'web'))
    viewer_port: int = param(9876, 'port of the Rerun viewer (gRPC)', low=1, high=65535)
    web_port: int = param(9090, 'HTTP port of the web viewer', low=1, high=65535)


NODE_SCHEMAS = (AgentNodeParams, WorldNodeParams, ObserverParams, LoggerParams)


def check_node_settings(section: Mapping[str, Any], where: str = '') -> None:
    """Check the node-level keys of a ``/**: ros__parameters:`` section.

    A key that is a parameter of some node is checked against it (a profile's ``view_rate: -1``
    fails at load, not when the node starts); keys that no schema knows are left to the nodes
    (ROS ignores parameters a node does not declare, e.g. ``use_sim_time``).
    """
    for schema in NODE_SCHEMAS:
        tops = {name.split('.')[0] for name, _, _ in leaves(schema)}
        mine = {key: value for key, value in section.items() if key.split('.')[0] in tops}
        try:
            check_given(schema, mine)
        except ParameterError as error:
            raise ParameterError(f'{where}{error}') from None
