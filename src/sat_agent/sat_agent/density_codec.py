"""The radio's encoding of a search density: zlib of the float32 values, lossless, two layouts.

Why compress: a density is one float32 per lattice cell (40 kB on the default 100 x 100
lattice), and every agent sends one to each neighbour at every step, so a 16-agent swarm in
radio range of each other moved about 10 MB per step through DDS. Both layouts give the
receiver exactly the float32 values the sender had (the fused density is the same as with the
raw array); they differ in what zlib finds to match, so the sender picks the one its density
model suits (``wire_encoding`` of search_density.ConstantDecay and
beyond_paper/regrowing_density.Regrowth):

- ``PATCHES``: zlib of the float32 little-endian bytes. The paper's values are J^k for a few
  dozen distinct ages k (search_density.py), in large equal patches, which zlib matches whole:
  35 to 400 times smaller in a fraction of a millisecond. A zlib stream starts with a header
  byte whose low nibble is 8 (RFC 1950, deflate); radio densities of runs before session 39
  (2026-12-05) are all in this layout, so their bags decode as before.
- ``SMOOTH``: the tag byte ``SMOOTH_TAG`` (low nibble not 8, so never a zlib header), then zlib
  of the values' bits rearranged. The regrowing density is v = exp(-u) with u ~ 1e-6 per cell
  and step: values within 1e-3 of 1 that change by a few ulps from cell to cell, so few float32
  values repeat and zlib kept the PATCHES layout only ~2.7 times smaller at 3-6 ms a message.
  Each value is taken as its distance in ulps below 1.0 (0x3F800000 minus its bits, modulo
  2^32: exact for every bit pattern), each row as its difference to the row above (modulo
  2^32, zig-zag so that small steps either way are small numbers), and the four byte planes
  are sent one after the other, so the high bytes, nearly all zero, form long runs (the
  byte-shuffle of HDF5 and Blosc). On the random default's densities: about 2.5 times fewer
  bytes than PATCHES at a quarter of its encoding time (scripts/bench_codec.py).

Decoding is the only place untrusted bytes become an array: it never inflates more than the
expected size (a "zip bomb" cannot allocate memory), and it rejects anything that is not
exactly height x width values in a known layout.
"""

import zlib

import numpy as np

# zlib's default level: within 10 % of level 9's size here at half its time.
LEVEL = 6
WIRE_DTYPE = np.dtype('<f4')
PATCHES = 'patches'
SMOOTH = 'smooth'
ENCODINGS = (PATCHES, SMOOTH)
SMOOTH_TAG = b'\x01'
# The bits of float32 1.0: the SMOOTH layout counts ulps down from it.
_ONE_BITS = np.uint32(0x3F800000)
_BITS = np.dtype('<u4')
_SIGNED = np.dtype('<i4')


class DensityDecodeError(ValueError):
    """The bytes are not a density of the expected shape; ``reason`` names a drop counter."""

    def __init__(self, reason: str, detail: str):
        super().__init__(f'{reason}: {detail}')
        self.reason = reason
        self.detail = detail


def max_encoded_bytes(cells: int) -> int:
    """Return the most bytes either layout makes of `cells` values (zlib's compressBound)."""
    n = cells * WIRE_DTYPE.itemsize
    return len(SMOOTH_TAG) + n + (n >> 12) + (n >> 14) + (n >> 25) + 13


def smooth_planes(values: np.ndarray) -> bytes:
    """Return the SMOOTH layout's bytes before zlib (module docstring); values: 2-D floats."""
    values = np.ascontiguousarray(values, dtype=WIRE_DTYPE)
    if values.ndim != 2:
        raise ValueError(f'the {SMOOTH!r} density encoding takes rows x columns, not shape '
                         f'{values.shape}')
    ulps = _ONE_BITS - values.view(_BITS)
    steps = np.diff(ulps, axis=0, prepend=np.zeros((1, ulps.shape[1]), _BITS)).view(_SIGNED)
    zigzag = ((steps << 1) ^ (steps >> 31)).view(_BITS)
    return np.ascontiguousarray(zigzag.reshape(-1).view(np.uint8).reshape(-1, 4).T).tobytes()


def smooth_values(planes: bytes, shape) -> np.ndarray:
    """Invert ``smooth_planes``: the float32 array of this (rows, columns) shape."""
    zigzag = np.frombuffer(planes, np.uint8).reshape(4, -1).T.copy().view(_BITS).reshape(shape)
    steps = (zigzag >> np.uint32(1)) ^ (np.uint32(0) - (zigzag & np.uint32(1)))
    ulps = np.cumsum(steps, axis=0, dtype=_BITS)
    return (_ONE_BITS - ulps).view(WIRE_DTYPE)


def encode_density(values: np.ndarray, encoding: str = PATCHES) -> bytes:
    """Compress row-major float32 values (any float array; it is cast to float32).

    encoding: ``PATCHES`` (any shape) or ``SMOOTH`` (2-D values) (module docstring).
    """
    if encoding == SMOOTH:
        return SMOOTH_TAG + zlib.compress(smooth_planes(values), LEVEL)
    if encoding != PATCHES:
        raise ValueError(f'density encoding {encoding!r}: allowed are {ENCODINGS}')
    return zlib.compress(np.ascontiguousarray(values, dtype=WIRE_DTYPE).tobytes(), LEVEL)


def decode_density(data: bytes, shape) -> np.ndarray:
    """Return the float32 array of this shape that encode_density compressed into data.

    Read-only: agents in one process share a decoded density (ros/radio_parsing.py).
    """
    data = bytes(data)
    smooth = data[:1] == SMOOTH_TAG
    if smooth and len(shape) != 2:
        raise DensityDecodeError('bad_encoding', f'a {SMOOTH!r} density for shape {shape}')
    expected = int(np.prod(shape)) * WIRE_DTYPE.itemsize
    inflater = zlib.decompressobj()
    try:
        raw = inflater.decompress(data[len(SMOOTH_TAG):] if smooth else data, expected)
    except zlib.error as error:
        raise DensityDecodeError('bad_encoding', f'not zlib data ({error})') from None
    if len(raw) != expected or inflater.unconsumed_tail or not inflater.eof \
            or inflater.unused_data:
        raise DensityDecodeError(
            'wrong_length', f'{"more than" if inflater.unconsumed_tail else len(raw)} bytes '
            f'for a {" x ".join(map(str, shape))} grid of float32 ({expected} bytes)')
    if not smooth:
        return np.frombuffer(raw, dtype=WIRE_DTYPE).reshape(shape)
    values = smooth_values(raw, shape)
    values.flags.writeable = False
    return values
