"""Filled-in instances of every sat_msgs type and a plain-value view for comparing them.

Every field gets a distinct, non-default value (float32 fields get values float32 represents
exactly) so a field lost or swapped on the way shows up as a difference.
"""

import array
from dataclasses import fields, is_dataclass
import importlib
from pathlib import Path
import random
import re

import numpy as np

MSG_DIR = Path(__file__).resolve().parents[1] / 'src' / 'sat_msgs' / 'msg'
SEQUENCE = re.compile(r'^sequence<(.+?)(?:, \d+)?>$')
ARRAY = re.compile(r'^(.+)\[(\d+)\]$')
INTEGER_BITS = {'uint8': 8, 'uint16': 16, 'uint32': 32, 'uint64': 63, 'int8': 7, 'int16': 15,
                'int32': 31, 'int64': 63, 'octet': 8, 'char': 7}


def sat_msg_names():
    """Names of the sat_msgs message types (from the package's .msg files)."""
    return sorted(path.stem for path in MSG_DIR.glob('*.msg'))


def message_class(type_name: str):
    """Import 'pkg/Name' (or 'pkg/msg/Name') and return the rclpy class."""
    parts = type_name.split('/')
    module = importlib.import_module(f'{parts[0]}.msg')
    return getattr(module, parts[-1])


def _scalar(type_name: str, rng: random.Random):
    if type_name in ('double', 'float64'):
        return rng.uniform(-1e3, 1e3)
    if type_name in ('float', 'float32'):
        return rng.randrange(-4096, 4096) / 8.0
    if type_name == 'boolean':
        return True     # the non-default value
    if type_name == 'string':
        return f's{rng.randrange(10 ** 6)}'
    if type_name in INTEGER_BITS:
        return rng.randrange(1, 2 ** INTEGER_BITS[type_name])
    return None


def sample_value(type_name: str, rng: random.Random):
    """Return a non-default value of an rclpy field type string."""
    scalar = _scalar(type_name, rng)
    if scalar is not None:
        return scalar
    match = SEQUENCE.match(type_name)
    if match:
        return [sample_value(match.group(1), rng) for _ in range(rng.randrange(2, 5))]
    match = ARRAY.match(type_name)
    if match:
        return [sample_value(match.group(1), rng) for _ in range(int(match.group(2)))]
    return sample_message(message_class(type_name), rng)


def sample_message(cls, rng: random.Random):
    """Return an instance of cls with every field set."""
    msg = cls()
    for name, type_name in cls.get_fields_and_field_types().items():
        setattr(msg, name, sample_value(type_name, rng))
    return msg


def samples(seed: int = 7) -> dict:
    """One filled message per sat_msgs type, keyed by type name."""
    rng = random.Random(seed)
    return {name: sample_message(message_class(f'sat_msgs/{name}'), rng)
            for name in sat_msg_names()}


def plain(value):
    """Recursive plain-Python view of an rclpy or rosbags message (dicts, lists, scalars)."""
    if hasattr(value, 'get_fields_and_field_types'):
        return {name: plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if is_dataclass(value):
        # rosbags keeps constants as dataclass fields; ROS 2 requires them UPPER_CASE and
        # field names lower case, so the case tells them apart.
        return {f.name: plain(getattr(value, f.name)) for f in fields(value)
                if f.name != '__msgtype__' and not f.name.isupper()}
    if isinstance(value, (list, tuple, array.array, np.ndarray)):
        return [plain(item) for item in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
