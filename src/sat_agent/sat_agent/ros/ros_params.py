"""Every ROS 2 parameter the nodes declare: SatParams fields and the node-level ones.

SatParams: every field is declared with its default under its dotted name.
``--params-file config/paper.yaml`` (a ``/**: ros__parameters:`` file) or
``-p sensor.p_detect:=0.9`` then set them like any ROS parameter. Typing is dynamic (``10`` for
a float is fine); SatParams validates the values, and a bad one stops the node at start-up with
a message naming the key, the value and what is allowed.

Node-level parameters (AGENT_PARAMS, WORLD_PARAMS): one NodeParam each, with its default,
description and allowed values, checked the same way.
"""

from dataclasses import dataclass, fields
import math
from types import SimpleNamespace
from typing import Any, Sequence, Tuple

from rcl_interfaces.msg import ParameterDescriptor

from sat_agent.config import SatParams


def declare_sat_params(node) -> SatParams:
    """Declare every SatParams field on node and return the validated values."""
    defaults = SatParams()
    values = {}
    for group in fields(defaults):
        group_defaults = getattr(defaults, group.name)
        for item in fields(group_defaults):
            name = f'{group.name}.{item.name}'
            default = getattr(group_defaults, item.name)
            descriptor = ParameterDescriptor(description=f'SatParams {name} (see config.py)',
                                             dynamic_typing=True)
            values[name] = node.declare_parameter(name, default, descriptor).value
    return SatParams.from_mapping(values)


def declare_required_int(node, name: str, low: int, description: str) -> int:
    """Declare an integer parameter that must be given (>= low); raise ValueError otherwise."""
    value = node.declare_parameter(name, -1, ParameterDescriptor(description=description)).value
    if not isinstance(value, int) or value < low:
        raise ValueError(f"parameter '{name}' = {value!r}: required, an integer >= {low}")
    return value


@dataclass(frozen=True)
class NodeParam:
    """A node-level parameter (not a SatParams field): name, default, description and its check.

    kind is 'int', 'float' or 'str'; numbers must lie in [low, high] (above low when low_open);
    strings must be one of choices when given. Read once at start-up, so read-only.
    """

    name: str
    default: Any
    description: str
    kind: str = 'float'
    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False
    choices: Tuple[str, ...] = ()

    def allowed(self) -> str:
        """Say what values are allowed, for error messages and descriptors."""
        if self.kind == 'str':
            return f'one of {list(self.choices)}' if self.choices else 'a string'
        left = '(' if self.low_open else '['
        what = 'an integer' if self.kind == 'int' else 'a number'
        return f'{what} in {left}{self.low}, {self.high}]'

    def check(self, value) -> Any:
        """Return value converted to kind; raise ValueError naming the parameter otherwise."""
        problem = ValueError(f"parameter '{self.name}' = {value!r}: must be {self.allowed()}")
        if self.kind == 'str':
            if not isinstance(value, str) or (self.choices and value not in self.choices):
                raise problem
            return value
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise problem
        if self.kind == 'int' and not float(value).is_integer():
            raise problem
        number = int(value) if self.kind == 'int' else float(value)
        too_low = number <= self.low if self.low_open else number < self.low
        if not math.isfinite(number) or too_low or number > self.high:
            raise problem
        return number

    def descriptor(self) -> ParameterDescriptor:
        """Return the descriptor `ros2 param describe` shows."""
        return ParameterDescriptor(description=self.description,
                                   additional_constraints=f'{self.allowed()}; read at start-up',
                                   read_only=True, dynamic_typing=self.kind != 'str')


# Node-level parameters of the agent and of world_sim, in one place.
VIEW_RATE = NodeParam(
    'view_rate', 1.0, 'standard views (OccupancyGrid, MarkerArray, PoseArray, Path, '
    'PoseStamped) per second of sim time; 0 = none. 1 with dt = 1 s is every step', low=0.0)
AGENT_PARAMS = (
    NodeParam('agent_id', -1, 'this agent id (required)', kind='int', low=1),
    NodeParam('seed', 0, "the run's seed: the filter draws from (seed, agent_id)", kind='int',
              low=0),
    NodeParam('report_wait_timeout', 2.0, 'lock-step: seconds to wait for the radio messages '
              'a scan announces before stepping without them', low=0.0, low_open=True),
    NodeParam('world_timeout', 60.0, 'seconds without a scan from world_sim before the agent '
              'exits (world_sim input only)', low=0.0, low_open=True),
    NodeParam('input_source', 'world_sim', "where scans come from: 'world_sim' "
              "(MeasurementSet on measurements) or 'robot' (robot/pose PoseStamped and "
              'robot/detections PointCloud2)', kind='str', choices=('world_sim', 'robot')),
    VIEW_RATE,
)
WORLD_PARAMS = (
    NodeParam('scenario', '', 'scenario file (default: the installed paper scenario)',
              kind='str'),
    NodeParam('seed', -1, "the run's seed (-1: the scenario's)", kind='int', low=-1),
    NodeParam('steps', 0, "steps to run (0: the scenario's)", kind='int', low=0),
    NodeParam('clock', 'lock_step', 'lock_step (as fast as the agents answer) or real_time '
              '(a step every period seconds)', kind='str', choices=('lock_step', 'real_time')),
    NodeParam('period', 1.0, 'real_time: wall seconds per step', low=0.0, low_open=True),
    NodeParam('agent_timeout', 5.0, 'lock-step: seconds before a silent agent is marked '
              'inactive', low=0.0, low_open=True),
    NodeParam('startup_timeout', 60.0, 'seconds to wait for every agent and observer before '
              'starting with those found', low=0.0, low_open=True),
    NodeParam('observers', 0, 'observer nodes (metrics, recorder, logger) to wait for',
              kind='int', low=0),
    NodeParam('radio.loss', 0.0, 'probability that the radio drops a message', high=1.0,
              low=0.0),
    NodeParam('radio.delay_steps', 0, 'radio latency in steps', kind='int', low=0),
    VIEW_RATE,
)


def declare_node_params(node, params: Sequence[NodeParam]) -> SimpleNamespace:
    """Declare node-level parameters and return their checked values by name (dots become _)."""
    values = {}
    for param in params:
        value = node.declare_parameter(param.name, param.default, param.descriptor()).value
        values[param.name.replace('.', '_')] = param.check(value)
    return SimpleNamespace(**values)
