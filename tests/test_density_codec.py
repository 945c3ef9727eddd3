"""The radio's search-density encoding: lossless, small, and safe on untrusted bytes."""

from pathlib import Path
import zlib

from hypothesis import given, strategies as st
import numpy as np
import pytest

from sat_agent.config import load_params_file
from sat_agent.density_codec import (
    decode_density, DensityDecodeError, encode_density, ENCODINGS, max_encoded_bytes, PATCHES,
    SMOOTH, SMOOTH_TAG)
from sat_world_sim.inprocess_swarm import InProcessSwarm
from sat_world_sim.scenario import load_scenario

CONFIG = Path(__file__).resolve().parent.parent / 'config'
SHAPE = (100, 100)


@pytest.mark.parametrize('encoding', ENCODINGS)
@given(values=st.lists(st.floats(0.0, 1.0, width=32), min_size=12, max_size=12))
def test_round_trip_is_bit_exact(encoding, values):
    values = np.array(values, dtype=np.float32).reshape(3, 4)
    decoded = decode_density(encode_density(values, encoding), (3, 4))
    assert decoded.dtype == np.float32
    assert not decoded.flags.writeable   # agents in one process share it (radio_parsing.py)
    np.testing.assert_array_equal(decoded, values)


@given(st.lists(st.integers(0, 2 ** 32 - 1), min_size=35, max_size=35))
def test_the_smooth_layout_keeps_every_bit_pattern(bits):
    """Ulps below 1, row steps and zig-zag wrap modulo 2^32: NaNs and negatives survive too."""
    bits = np.array(bits, dtype=np.uint32).reshape(5, 7)
    decoded = decode_density(encode_density(bits.view(np.float32), SMOOTH), (5, 7))
    np.testing.assert_array_equal(decoded.view(np.uint32), bits)


def test_the_patches_layout_is_the_zlib_of_the_float32_bytes():
    """What radio densities were before the smooth layout: bags recorded then still decode."""
    values = np.linspace(0.0, 1.0, 20).reshape(4, 5)
    encoded = encode_density(values, PATCHES)
    assert encoded == zlib.compress(values.astype('<f4').tobytes(), 6)
    assert encoded[:1] != SMOOTH_TAG and encode_density(values, SMOOTH)[:1] == SMOOTH_TAG


def _density_after(profile: str, steps: int) -> np.ndarray:
    swarm = InProcessSwarm(load_scenario(CONFIG / 'scenarios' / 'paper.yaml'),
                           load_params_file(CONFIG / f'{profile}.yaml'))
    for _ in range(steps):
        swarm.step()
    return swarm.agents[1].filter.search.values


def test_a_real_density_shrinks_at_least_twentyfold():
    values = _density_after('paper', 120)
    encoded = encode_density(values)
    assert len(encoded) * 20 <= values.size * 4
    np.testing.assert_array_equal(decode_density(encoded, SHAPE), values.astype(np.float32))


def test_a_regrowing_density_travels_smooth_and_smaller():
    """The persistent profile's values differ by ulps from cell to cell (density_codec.py)."""
    values = _density_after('persistent', 120)
    assert len(np.unique(values.astype(np.float32))) > 100   # not the paper's few patches
    smooth = encode_density(values, SMOOTH)
    assert len(smooth) * 2 <= len(encode_density(values, PATCHES))
    np.testing.assert_array_equal(decode_density(smooth, SHAPE), values.astype(np.float32))


def test_the_bound_holds_for_incompressible_values():
    noise = np.random.default_rng(0).random(SHAPE, dtype=np.float32)
    for encoding in ENCODINGS:
        assert len(encode_density(noise, encoding)) <= max_encoded_bytes(noise.size)


def test_an_unknown_encoding_or_a_smooth_vector_is_refused():
    with pytest.raises(ValueError, match='allowed are'):
        encode_density(np.zeros(SHAPE), 'jpeg')
    with pytest.raises(ValueError, match='rows x columns'):
        encode_density(np.zeros(12), SMOOTH)


@pytest.mark.parametrize('data, reason', [
    (b'\x00 not zlib at all', 'bad_encoding'),
    (encode_density(np.zeros(SHAPE))[:-6], 'wrong_length'),           # truncated stream
    (encode_density(np.zeros(SHAPE[0] * SHAPE[1] - 1)), 'wrong_length'),
    (encode_density(np.zeros(SHAPE)) + b'tail', 'wrong_length'),
    (zlib.compress(bytes(1000 * SHAPE[0] * SHAPE[1] * 4)), 'wrong_length'),   # 40 MB bomb
    (b'', 'wrong_length'),
    (SMOOTH_TAG, 'wrong_length'),
    (SMOOTH_TAG + b'\x78\x9c not zlib', 'bad_encoding'),
    (encode_density(np.zeros(SHAPE), SMOOTH)[:-6], 'wrong_length'),
    (encode_density(np.zeros((SHAPE[0] - 1, SHAPE[1])), SMOOTH), 'wrong_length'),
    (encode_density(np.zeros(SHAPE), SMOOTH) + b'tail', 'wrong_length'),
    (SMOOTH_TAG + zlib.compress(bytes(1000 * SHAPE[0] * SHAPE[1] * 4)), 'wrong_length'),
])
def test_bad_bytes_are_refused_with_a_reason(data, reason):
    with pytest.raises(DensityDecodeError) as refused:
        decode_density(data, SHAPE)
    assert refused.value.reason == reason


def test_a_smooth_density_needs_rows_and_columns():
    with pytest.raises(DensityDecodeError) as refused:
        decode_density(encode_density(np.zeros((1, 12)), SMOOTH), (12,))
    assert refused.value.reason == 'bad_encoding'
