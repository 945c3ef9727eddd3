"""The radio's search-density encoding: lossless, small, and safe on untrusted bytes."""

from pathlib import Path
import zlib

from hypothesis import given, strategies as st
import numpy as np
import pytest

from sat_agent.config import load_params_file
from sat_agent.density_codec import decode_density, DensityDecodeError, encode_density
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.scenario import load_scenario

CONFIG = Path(__file__).resolve().parent.parent / 'config'
SHAPE = (100, 100)


@given(st.lists(st.floats(0.0, 1.0, width=32), min_size=12, max_size=12))
def test_round_trip_is_bit_exact(values):
    values = np.array(values, dtype=np.float32).reshape(3, 4)
    decoded = decode_density(encode_density(values), (3, 4))
    assert decoded.dtype == np.float32
    np.testing.assert_array_equal(decoded, values)


def test_a_real_density_shrinks_at_least_twentyfold():
    swarm = InProcessSwarm(load_scenario(CONFIG / 'scenarios' / 'paper.yaml'),
                           load_params_file(CONFIG / 'paper.yaml'))
    for _ in range(120):
        swarm.step()
    values = swarm.agents[1].filter.search.values
    encoded = encode_density(values)
    assert len(encoded) * 20 <= values.size * 4
    np.testing.assert_array_equal(decode_density(encoded, SHAPE), values.astype(np.float32))


@pytest.mark.parametrize('data, reason', [
    (b'\x00 not zlib at all', 'bad_encoding'),
    (encode_density(np.zeros(SHAPE))[:-6], 'wrong_length'),           # truncated stream
    (encode_density(np.zeros(SHAPE[0] * SHAPE[1] - 1)), 'wrong_length'),
    (encode_density(np.zeros(SHAPE)) + b'tail', 'wrong_length'),
    (zlib.compress(bytes(1000 * SHAPE[0] * SHAPE[1] * 4)), 'wrong_length'),   # 40 MB bomb
])
def test_bad_bytes_are_refused_with_a_reason(data, reason):
    with pytest.raises(DensityDecodeError) as refused:
        decode_density(data, SHAPE)
    assert refused.value.reason == reason
