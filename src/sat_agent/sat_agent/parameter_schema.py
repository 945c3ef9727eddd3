"""The parameter schema: each parameter is written once, as a dataclass field made by ``param``.

A schema is a frozen dataclass whose fields are parameters (``param``: default, description,
allowed range or choices, live or read-only) or groups (nested schemas, dotted names such as
``sensor.p_detect``). From it come, with no second list anywhere:

- the defaults (the dataclass itself);
- the checks of YAML profiles, ``-p`` overrides and code (``build``, ``validate``,
  ``with_overrides``): unknown names and bad values raise ParameterError naming the parameter,
  the value and what is allowed;
- the ROS parameter declarations and descriptors (sat_agent.ros.ros_params reads ``leaves``);
- which parameters may change mid-run (``Spec.live``); a node applies those it uses.

The schemas are sat_agent.config.SatParams (the SAT problem and the agent) and the node-level
ones of sat_agent.node_params. ROS-free.
"""

from dataclasses import asdict, dataclass, field, fields
import math
from typing import Any, Iterator, Mapping, Tuple, Union

INF = math.inf


class ParameterError(ValueError):
    """A parameter (from YAML, ROS or code) that is unknown or outside its allowed range."""


def _bound(number) -> str:
    return f'{number:g}' if isinstance(number, (int, float)) else str(number)


@dataclass(frozen=True)
class Spec:
    """What one parameter means and allows.

    kind is 'bool', 'int', 'float', 'str' or 'ints' (a list of integers). Numbers lie in
    [low, high] (open ends with low_open / high_open); low may name a sibling parameter whose
    value is the bound. Strings must be one of choices when given, and non-empty when required.
    live: the value may change while a node runs (a node applies the live parameters it uses;
    the others are read-only there).
    """

    description: str
    kind: str
    low: Union[float, str] = -INF
    high: float = INF
    low_open: bool = False
    high_open: bool = False
    choices: Tuple[str, ...] = ()
    required: bool = False
    live: bool = False

    def _brackets(self) -> Tuple[str, str]:
        return ('(' if self.low_open or self.low == -INF else '[',
                ')' if self.high_open or self.high == INF else ']')

    def allowed(self) -> str:
        """Return what values are allowed, in words (error messages and ROS descriptors)."""
        if self.kind == 'bool':
            return 'true or false'
        if self.kind == 'str':
            if self.choices:
                return f'one of {list(self.choices)}'
            return 'a non-empty string' if self.required else 'a string'
        if self.kind == 'ints':
            return 'a list of integers'
        left, right = self._brackets()
        what = 'an integer' if self.kind == 'int' else 'a number'
        return f'{what} in {left}{_bound(self.low)}, {_bound(self.high)}{right}'

    def convert(self, key: str, value: Any) -> Any:
        """Return value as this kind; raise ParameterError naming key otherwise (no range)."""
        def refuse(what):
            return ParameterError(f"parameter '{key}' = {value!r}: {what}")

        if self.kind == 'bool':
            if not isinstance(value, bool):
                raise refuse('must be true or false')
            return value
        if self.kind == 'str':
            if not isinstance(value, str):
                raise refuse('must be a string')
            return value
        if self.kind == 'ints':
            if not isinstance(value, (list, tuple)) or not all(
                    isinstance(v, int) and not isinstance(v, bool) for v in value):
                raise refuse('must be a list of integers')
            return tuple(int(v) for v in value)
        what = 'must be an integer' if self.kind == 'int' else 'must be a number'
        if isinstance(value, bool):
            raise refuse(what)
        try:
            number = float(value)
        except (TypeError, ValueError):
            raise refuse(what) from None
        if not math.isfinite(number):
            raise refuse('must be finite')
        if self.kind == 'int':
            if not number.is_integer():
                raise refuse(what)
            return int(number)
        return number

    def check(self, key: str, value: Any, low: float) -> None:
        """Raise ParameterError unless the (converted) value is allowed; low resolves self.low."""
        if self.kind == 'str':
            if self.choices and value not in self.choices:
                raise ParameterError(
                    f"parameter '{key}' = {value!r}: allowed values are {list(self.choices)}")
            if self.required and not value:
                raise ParameterError(f"parameter '{key}' is required: {self.description}")
            return
        if self.kind not in ('int', 'float'):
            return
        too_low = value <= low if self.low_open else value < low
        too_high = value >= self.high if self.high_open else value > self.high
        if too_low or too_high:
            left, right = self._brackets()
            shown = _bound(low) if self.low == low else f'{self.low} = {_bound(low)}'
            raise ParameterError(f"parameter '{key}' = {value!r}: allowed range is "
                                 f'{left}{shown}, {_bound(self.high)}{right}')


def param(default, description: str, **allowed):
    """Make a schema field: its default, what it means and what it allows (Spec's keywords).

    The kind follows the default (bool, int, float, str, or a tuple of ints).
    """
    if isinstance(default, bool):
        kind = 'bool'
    elif isinstance(default, int):
        kind = 'int'
    elif isinstance(default, float):
        kind = 'float'
    elif isinstance(default, str):
        kind = 'str'
    elif isinstance(default, tuple):
        kind = 'ints'
    else:
        raise TypeError(f'no parameter kind for default {default!r}')
    return field(default=default, metadata={'spec': Spec(description, kind, **allowed)})


def group(schema):
    """Make a schema field holding a nested schema (parameters named '<field>.<name>')."""
    return field(default_factory=schema)


def _is_group(item) -> bool:
    return 'spec' not in item.metadata


def leaves(schema, prefix: str = '') -> Iterator[Tuple[str, Spec, Any]]:
    """Yield (dotted name, Spec, default) for every parameter of a schema class, in order."""
    for item in fields(schema):
        name = f'{prefix}{item.name}'
        if _is_group(item):
            yield from leaves(item.default_factory, f'{name}.')
        else:
            yield name, item.metadata['spec'], item.default


def live_names(schema) -> Tuple[str, ...]:
    """Return the dotted names of the parameters that may change mid-run."""
    return tuple(name for name, spec, _ in leaves(schema) if spec.live)


def validate(values, prefix: str = ''):
    """Check every parameter of a schema instance; raise ParameterError naming the first bad one.

    Returns values.
    """
    for item in fields(values):
        value = getattr(values, item.name)
        if _is_group(item):
            validate(value, f'{prefix}{item.name}.')
            continue
        spec = item.metadata['spec']
        low = getattr(values, spec.low) if isinstance(spec.low, str) else spec.low
        spec.check(f'{prefix}{item.name}', value, low)
    return values


def build(schema, values: Mapping[str, Any], prefix: str = ''):
    """Build and validate a schema instance from nested ({'sensor': {...}}) or dotted keys.

    Missing parameters take their defaults; unknown ones raise ParameterError.
    """
    return validate(_build(schema, values, prefix), prefix)


def check_given(schema, values: Mapping[str, Any]) -> None:
    """Check only the parameters given (nested or dotted); the others may still be unset.

    For a file that sets a few parameters of a node whose required ones come from elsewhere.
    """
    built = flatten(_build(schema, values, ''))
    given = _flat_keys(_nest(values))
    for name, spec, _ in leaves(schema):
        if name in given:
            low = built[spec.low] if isinstance(spec.low, str) else spec.low
            spec.check(name, built[name], low)


def _flat_keys(nested: Mapping, prefix: str = '') -> set:
    """Return the dotted names of the leaves of a nested mapping."""
    names = set()
    for key, value in nested.items():
        if isinstance(value, Mapping):
            names |= _flat_keys(value, f'{prefix}{key}.')
        else:
            names.add(f'{prefix}{key}')
    return names


def _build(schema, values: Mapping[str, Any], prefix: str):
    nested = _nest(values)
    known = {item.name: item for item in fields(schema)}
    unknown = sorted(set(nested) - set(known))
    if unknown:
        if not prefix and all(_is_group(item) for item in known.values()):
            raise ParameterError(f'unknown parameter group(s) {unknown}: allowed groups are '
                                 f'{list(known)}')
        raise ParameterError(f'unknown parameter(s) {[prefix + k for k in unknown]}: '
                             f'allowed are {[prefix + k for k in known]}')
    built = {}
    for name, given in nested.items():
        item = known[name]
        if _is_group(item):
            if not isinstance(given, Mapping):
                raise ParameterError(
                    f"parameter '{prefix}{name}' = {given!r}: must be a mapping of "
                    f'{[f.name for f in fields(item.default_factory)]}')
            built[name] = _build(item.default_factory, given, f'{prefix}{name}.')
        else:
            built[name] = item.metadata['spec'].convert(f'{prefix}{name}', given)
    return schema(**built)


def with_overrides(values, changes: Mapping[str, Any]):
    """Return a validated copy of a schema instance with some dotted or nested values replaced."""
    merged = asdict(values)
    _merge(merged, _nest(changes))
    return build(type(values), merged)


def _merge(into: dict, changes: Mapping) -> None:
    for key, value in changes.items():
        if isinstance(value, Mapping) and isinstance(into.get(key), dict):
            _merge(into[key], value)
        else:
            into[key] = value


def _nest(values: Mapping[str, Any]) -> dict:
    nested: dict = {}
    for key, value in values.items():
        head, _, tail = str(key).partition('.')
        if tail:
            nested.setdefault(head, {})
            if not isinstance(nested[head], dict):
                raise ParameterError(f"parameter '{head}' given both as a value and a group")
            nested[head][tail] = value
        elif isinstance(value, Mapping):
            nested.setdefault(head, {}).update(value)
        else:
            nested[head] = value
    return nested


def flatten(values, prefix: str = '') -> dict:
    """Return {dotted name: value} of every parameter of a schema instance."""
    flat = {}
    for item in fields(values):
        value = getattr(values, item.name)
        if _is_group(item):
            flat.update(flatten(value, f'{prefix}{item.name}.'))
        else:
            flat[f'{prefix}{item.name}'] = value
    return flat


def changed_names(old, new) -> Tuple[str, ...]:
    """Return the dotted names whose values differ between two instances of one schema."""
    before, after = flatten(old), flatten(new)
    return tuple(name for name, value in after.items() if before[name] != value)
