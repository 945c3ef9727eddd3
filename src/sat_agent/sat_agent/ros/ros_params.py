"""SatParams as ROS 2 parameters: every field is declared with its default under its dotted name.

``--params-file config/paper.yaml`` (a ``/**: ros__parameters:`` file) or
``-p sensor.p_detect:=0.9`` then set them like any ROS parameter. Typing is dynamic (``10`` for
a float is fine); SatParams validates the values, and a bad one stops the node at start-up with
a message naming the key, the value and what is allowed.
"""

from dataclasses import fields

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
