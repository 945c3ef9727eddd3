"""Scenario files: who starts where, which targets exist when, and the seed of a run.

A scenario is a YAML mapping (see ``config/scenarios/paper.yaml`` and ``random.yaml``)::

    name: paper            # free text, copied into metrics.json
    seed: 1                # seed of the ground truth, the sensors and the agents
    steps: 200             # steps k = 1 .. steps
    truth_process_noise: 1.0e-4   # scale of the paper's Q for the true targets
    agents:                # one entry per agent, ids unique and >= 1
      - {id: 1, start: [10.0, 60.0]}
    targets:               # scripted targets (optional); via: optional [k, x, y] waypoints
      - {id: 1, born: 104, died: 179, start: [50.0, 69.0], end: [80.0, 31.0],
         via: [[144, 44.0, 34.0]]}
    random_births:         # random targets (optional; a missing key takes the value shown)
      rate: 0.02           # expected births per step, uniform over the area
      survival: 0.99       # per-step survival probability of a random target
      speed_std: 0.5       # m/s, std of each velocity component of a newborn

A scripted target exists on the steps ``born <= k <= died`` (the paper tracks target 1 up to
k = 179, its death step) and starts with the constant velocity that takes it from ``start`` at
``born`` to its first waypoint (``via``, steps strictly between born and died, ascending), or to
``end`` at ``died`` without one. At a waypoint's step its velocity is set again, from where it
is to the next waypoint or ``end``; the truth process noise makes it arrive only *near* each.
Every key is checked; unknown keys and bad values raise ScenarioError naming the key, the value
and what is allowed. The scalar keys and ``random_births`` are parameter schemas
(sat_agent.parameter_schema: ScenarioSettings, RandomBirths), the lists' numbers are checked by
the same Spec.
"""

from dataclasses import dataclass
from typing import Any, Mapping, Optional, Tuple

import numpy as np

from sat_agent.config import read_yaml
from sat_agent.parameter_schema import build, param, ParameterError, Spec


class ScenarioError(ValueError):
    """A scenario file or mapping with an unknown key or a value outside what is allowed."""


@dataclass(frozen=True)
class AgentStart:
    """One agent of the scenario and its start position s_1."""

    agent_id: int
    start: Tuple[float, float]


@dataclass(frozen=True)
class ScriptedTarget:
    """A target with fixed birth and death steps and positions."""

    target_id: int
    born: int
    died: int
    start: Tuple[float, float]
    end: Tuple[float, float]
    via: Tuple[Tuple[int, float, float], ...] = ()   # (step, x, y), born < step < died

    def initial_state(self) -> np.ndarray:
        """State [x, vx, y, vy] at the birth step, velocity from start to the next point."""
        vx, vy = self.velocity_at(self.born, self.start)
        return np.array([self.start[0], vx, self.start[1], vy])

    def velocity_at(self, step: int, position) -> Optional[np.ndarray]:
        """Velocity from position to the next waypoint (or end) at its step; None off-schedule.

        Defined at the birth step and at each waypoint's step, where the target turns.
        """
        schedule = [(self.born, None)] + [(k, (x, y)) for k, x, y in self.via] \
            + [(max(self.died, self.born + 1), self.end)]
        for (turn, _), (arrival, point) in zip(schedule, schedule[1:]):
            if turn == step:
                return (np.asarray(point, dtype=float)
                        - np.asarray(position, dtype=float)) / (arrival - turn)
        return None


@dataclass(frozen=True)
class RandomBirths:
    """Random targets: Poisson births anywhere in the area, geometric lifetimes."""

    rate: float = param(0.02, 'expected births per step, uniform over the area', low=0,
                        high=100)
    survival: float = param(0.99, 'per-step survival probability of a random target', low=0,
                            high=1)
    speed_std: float = param(0.5, 'std of each velocity component of a newborn (m/s)', low=0,
                             high=100)


@dataclass(frozen=True)
class ScenarioSettings:
    """The scalar keys of a scenario file (seed and steps are required)."""

    name: str = param('unnamed', 'free text, copied into metrics.json')
    seed: int = param(0, 'seed of the ground truth, the sensors and the agents', low=0,
                      high=2 ** 63 - 1)
    steps: int = param(1, 'steps k = 1 .. steps', low=1, high=10 ** 7)
    truth_process_noise: float = param(0.0, "scale of the paper's Q for the true targets",
                                       low=0, high=100)


@dataclass(frozen=True)
class Scenario:
    """A validated scenario (see the module docstring for the file format)."""

    name: str
    seed: int
    steps: int
    truth_process_noise: float
    agents: Tuple[AgentStart, ...]
    targets: Tuple[ScriptedTarget, ...] = ()
    random_births: Optional[RandomBirths] = None

    @property
    def agent_ids(self) -> Tuple[int, ...]:
        """Agent ids in ascending order."""
        return tuple(sorted(a.agent_id for a in self.agents))

    def with_seed(self, seed: int) -> 'Scenario':
        """Return a copy with another seed (validated)."""
        checked = _schema(ScenarioSettings, {'seed': seed}).seed
        return Scenario(self.name, checked, self.steps, self.truth_process_noise,
                        self.agents, self.targets, self.random_births)


_TOP_KEYS = ('name', 'seed', 'steps', 'truth_process_noise', 'agents', 'targets',
             'random_births')
_SETTINGS_KEYS = ('name', 'seed', 'steps', 'truth_process_noise')
_AGENT_KEYS = ('id', 'start')
_TARGET_KEYS = ('id', 'born', 'died', 'start', 'end')
_TARGET_OPTIONAL_KEYS = ('via',)


def scenario_from_mapping(document: Any, area_width: float = 100.0,
                          area_height: float = 100.0) -> Scenario:
    """Validate a parsed scenario document; positions must lie in [0, width] x [0, height]."""
    if not isinstance(document, Mapping):
        raise ScenarioError(f'scenario = {document!r}: must be a mapping with keys {_TOP_KEYS}')
    _known_keys('scenario', document, _TOP_KEYS)
    for key in ('seed', 'steps', 'agents'):
        if key not in document:
            raise ScenarioError(f"scenario key '{key}' is missing: it is required")
    settings = _schema(ScenarioSettings, {k: document[k] for k in _SETTINGS_KEYS
                                          if k in document})
    area = (float(area_width), float(area_height))
    agents = _agents(document['agents'], area)
    targets = _targets(document.get('targets') or [], settings.steps, area)
    births = document.get('random_births')
    return Scenario(
        name=settings.name, seed=settings.seed, steps=settings.steps,
        truth_process_noise=settings.truth_process_noise, agents=agents, targets=targets,
        random_births=None if births is None else _schema(RandomBirths, births,
                                                          'random_births'))


def load_scenario(path, area_width: float = 100.0, area_height: float = 100.0) -> Scenario:
    """Read and validate a scenario YAML file."""
    document = read_yaml(path, ScenarioError)
    try:
        return scenario_from_mapping(document, area_width, area_height)
    except ScenarioError as error:
        raise ScenarioError(f'{path}: {error}') from None


def _known_keys(where: str, mapping: Mapping, allowed) -> None:
    unknown = sorted(str(k) for k in mapping if k not in allowed)
    if unknown:
        raise ScenarioError(f'{where}: unknown key(s) {unknown}: allowed keys are {list(allowed)}')


def _schema(schema, values: Any, key: str = ''):
    """Build a schema from a scenario mapping; its errors become ScenarioErrors."""
    if not isinstance(values, Mapping):
        raise ScenarioError(f"scenario key '{key}' = {values!r}: must be a mapping")
    try:
        return build(schema, values, f'{key}.' if key else '')
    except ParameterError as error:
        raise ScenarioError(f'scenario {error}') from None


def _value(key: str, value: Any, kind: str, low: float, high: float):
    spec = Spec(key, kind, low=low, high=high)
    try:
        checked = spec.convert(key, value)
        spec.check(key, checked, low)
    except ParameterError as error:
        raise ScenarioError(f'scenario {error}') from None
    return checked


def _number(key: str, value: Any, low: float, high: float) -> float:
    return _value(key, value, 'float', low, high)


def _integer(key: str, value: Any, low: int, high: int) -> int:
    return _value(key, value, 'int', low, high)


def _point(key: str, value: Any, area) -> Tuple[float, float]:
    if not isinstance(value, (list, tuple)) or len(value) != 2:
        raise ScenarioError(f"scenario key '{key}' = {value!r}: must be a list [x, y]")
    x = _number(f'{key}[0]', value[0], 0.0, area[0])
    y = _number(f'{key}[1]', value[1], 0.0, area[1])
    return (x, y)


def _entries(key: str, value: Any) -> list:
    if not isinstance(value, list):
        raise ScenarioError(f"scenario key '{key}' = {value!r}: must be a list of mappings")
    for index, entry in enumerate(value):
        if not isinstance(entry, Mapping):
            raise ScenarioError(f"scenario key '{key}[{index}]' = {entry!r}: must be a mapping")
    return value


def _required(where: str, entry: Mapping, keys, optional=()) -> None:
    _known_keys(where, entry, tuple(keys) + tuple(optional))
    for key in keys:
        if key not in entry:
            raise ScenarioError(f"scenario key '{where}.{key}' is missing: it is required")


def _agents(value: Any, area) -> Tuple[AgentStart, ...]:
    entries = _entries('agents', value)
    if not entries:
        raise ScenarioError("scenario key 'agents' = []: at least one agent is required")
    agents = []
    for index, entry in enumerate(entries):
        where = f'agents[{index}]'
        _required(where, entry, _AGENT_KEYS)
        # Ids start at 1: messages use agent id 0 for "none" (AgentStatus.yielded_to).
        agents.append(AgentStart(_integer(f'{where}.id', entry['id'], 1, 10 ** 6),
                                 _point(f'{where}.start', entry['start'], area)))
    _unique_ids('agents', [a.agent_id for a in agents])
    return tuple(agents)


def _targets(value: Any, steps: int, area) -> Tuple[ScriptedTarget, ...]:
    targets = []
    for index, entry in enumerate(_entries('targets', value)):
        where = f'targets[{index}]'
        _required(where, entry, _TARGET_KEYS, _TARGET_OPTIONAL_KEYS)
        born = _integer(f'{where}.born', entry['born'], 1, steps)
        died = _integer(f'{where}.died', entry['died'], born, 10 ** 7)
        targets.append(ScriptedTarget(
            target_id=_integer(f'{where}.id', entry['id'], 0, 10 ** 6), born=born, died=died,
            start=_point(f'{where}.start', entry['start'], area),
            end=_point(f'{where}.end', entry['end'], area),
            via=_waypoints(f'{where}.via', entry.get('via', []), born, died, area)))
    _unique_ids('targets', [t.target_id for t in targets])
    return tuple(targets)


def _waypoints(key: str, value: Any, born: int, died: int, area) -> Tuple[tuple, ...]:
    if not isinstance(value, list):
        raise ScenarioError(f"scenario key '{key}' = {value!r}: must be a list of [k, x, y]")
    waypoints = []
    last = born
    for index, entry in enumerate(value):
        where = f'{key}[{index}]'
        if not isinstance(entry, (list, tuple)) or len(entry) != 3:
            raise ScenarioError(f"scenario key '{where}' = {entry!r}: must be a list [k, x, y]")
        step = _integer(f'{where}[0]', entry[0], last + 1, died - 1)
        waypoints.append((step, _number(f'{where}[1]', entry[1], 0.0, area[0]),
                          _number(f'{where}[2]', entry[2], 0.0, area[1])))
        last = step
    return tuple(waypoints)


def _unique_ids(key: str, ids) -> None:
    seen = set()
    for item in ids:
        if item in seen:
            raise ScenarioError(
                f"scenario key '{key}': id {item} appears twice: ids must be unique")
        seen.add(item)
