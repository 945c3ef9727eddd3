"""Declares a node's parameter schemas: descriptors, start-up checks and live changes.

The schemas (sat_agent.config.SatParams, sat_agent.node_params) say everything about a
parameter once; here each becomes a ROS parameter under its dotted name with a descriptor
(description, range, allowed values, read-only) that ``ros2 param describe`` shows.
``--params-file config/paper.yaml`` or ``-p sensor.p_detect:=0.9`` set them at start-up; typing
is dynamic (``10`` for a float is fine) and a bad value stops the node with a message naming
the parameter, the value and what is allowed.

While the node runs, ``ros2 param set`` of a read-only parameter is refused by rclpy; of a live
one (those the node lists, each ``live`` in its schema) it is checked against the schema by the
on-set callback, refused with the schema's message as the reason, or applied by the node's
callback after it is stored. A node's live parameters are live only if it was started with
``live_parameters:=true`` (node_params.LIVE_SWITCH): parameter services take anyone's call on
the ROS domain, so by default every parameter is read-only, rclpy's ``use_sim_time`` and those
a node declares outside the schemas included (the on-set callback refuses them).
"""

from typing import Callable, Optional, Sequence

from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                SetParametersResult)

from sat_agent.node_params import LIVE_SWITCH
from sat_agent.parameter_schema import build, leaves, ParameterError, Spec, with_overrides

INT64 = 2 ** 63 - 1


def descriptor(spec: Spec, live: bool) -> ParameterDescriptor:
    """Return the descriptor of one parameter: ranges as ROS can say them, the rest in words.

    ROS ranges are closed, so an open end is checked by the schema (the constraints say it).
    """
    when = 'live: ros2 param set applies it' if live else 'read-only: read at start-up'
    result = ParameterDescriptor(description=spec.description, read_only=not live,
                                 additional_constraints=f'{spec.allowed()}; {when}',
                                 dynamic_typing=True)
    if isinstance(spec.low, str):      # the bound is another parameter's value
        return result
    if spec.kind == 'float':
        result.floating_point_range = [FloatingPointRange(
            from_value=float(spec.low), to_value=float(spec.high), step=0.0)]
    elif spec.kind == 'int':
        result.integer_range = [IntegerRange(
            from_value=int(max(spec.low, -INT64)), to_value=int(min(spec.high, INT64)), step=0)]
    return result


class NodeParameters:
    """A node's parameters, declared from its schemas; ``values`` holds one instance per schema.

    live: the dotted names this node applies while it runs (each must be live in its schema),
    read-only unless a schema's LIVE_SWITCH is true; on_change(*values) is called after a live
    change is stored. Each live change is logged with ``moment()``, where the node is in its
    run (e.g. "at step 12"), so a run's log says from which step on a change holds. The
    schemas' names must not overlap. Raises ParameterError if a start-up value is not allowed.
    """

    def __init__(self, node, schemas: Sequence[type], live: Sequence[str] = (),
                 on_change: Optional[Callable] = None,
                 moment: Callable[[], str] = lambda: 'before its run'):
        self._node = node
        self._owner = {}      # dotted name -> index of its schema
        self._on_change = on_change
        self._moment = moment
        self.values = []
        for index, schema in enumerate(schemas):
            given = {}
            for name, spec, default in leaves(schema):
                if name in live and not spec.live:
                    raise ValueError(f"parameter '{name}' is not live in its schema")
                # Declared without range or read-only first: the schema's check below gives
                # the message; the full descriptor follows once the value is known good.
                plain = ParameterDescriptor(description=spec.description, dynamic_typing=True)
                value = default if spec.kind != 'ints' else list(default)
                given[name] = node.declare_parameter(name, value, plain).value
                self._owner[name] = index
            self.values.append(build(schema, given))
        self._switched_on = any(getattr(values, LIVE_SWITCH, False) for values in self.values)
        self._live = frozenset(live if self._switched_on else ())
        for schema in schemas:
            for name, spec, _ in leaves(schema):
                node.set_descriptor(name, descriptor(spec, name in self._live))
        node.add_on_set_parameters_callback(self._check)
        node.add_post_set_parameters_callback(self._apply)

    def _changed(self, parameters) -> list:
        changes = [{} for _ in self.values]
        for parameter in parameters:
            if parameter.name in self._owner:
                changes[self._owner[parameter.name]][parameter.name] = parameter.value
        return [with_overrides(values, change) if change else values
                for values, change in zip(self.values, changes)]

    def _check(self, parameters) -> SetParametersResult:
        """Refuse a change of anything but the live parameters, or a value the schema refuses.

        Also the parameters outside the schemas (rclpy's ``use_sim_time``, which would stop the
        node's clock, and those a node declares itself, like the roster ``agent_ids``). Names
        the node does not have yet are being declared, and pass.
        """
        for parameter in parameters:
            if self._node.has_parameter(parameter.name) and parameter.name not in self._live:
                why = '' if self._switched_on else f' (started without {LIVE_SWITCH}:=true)'
                return SetParametersResult(
                    successful=False,
                    reason=f"parameter '{parameter.name}' is read-only while the node runs{why}")
        try:
            self._changed(parameters)
        except ParameterError as error:
            return SetParametersResult(successful=False, reason=str(error))
        return SetParametersResult(successful=True)

    def _apply(self, parameters) -> None:
        self.values = self._changed(parameters)
        changed = ', '.join(f'{p.name} = {p.value!r}' for p in parameters if p.name in self._owner)
        if changed:
            self._node.get_logger().info(f'live change {self._moment()}: {changed}')
        if self._on_change is not None:
            self._on_change(*self.values)
