"""Per-contact random streams: xoshiro256** (Blackman and Vigna 2018) over uint64[4] states.

Each contact owns one stream (a row of a ``(n_contacts, 4)`` uint64 array), so the draws
a contact sees do not depend on which thread runs it: same seed, same trajectory, with
any thread count. Streams are seeded from :class:`numpy.random.SeedSequence`.
"""

from __future__ import annotations

import numpy as np

from nanoblock.kernels._jit import kernel

_TO_UNIT = 1.0 / 9007199254740992.0  # 2^-53


@kernel(inline=True)
def _rotl(value: np.uint64, shift: int) -> np.uint64:
    return (value << np.uint64(shift)) | (value >> np.uint64(64 - shift))


@kernel(inline=True)
def next_uint64(state: np.ndarray) -> np.uint64:
    """Advance one xoshiro256** stream (``state``: uint64[4], modified) and return 64 bits."""
    s0, s1, s2, s3 = state[0], state[1], state[2], state[3]
    result = _rotl(s1 * np.uint64(5), 7) * np.uint64(9)
    shifted = s1 << np.uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= shifted
    s3 = _rotl(s3, 45)
    state[0], state[1], state[2], state[3] = s0, s1, s2, s3
    return result


@kernel(inline=True)
def uniform(state: np.ndarray) -> float:
    """A uniform draw in [0, 1) with 53 random bits."""
    return float(next_uint64(state) >> np.uint64(11)) * _TO_UNIT


@kernel(inline=True)
def standard_exponential(state: np.ndarray) -> float:
    """An Exp(1) draw by inversion, -ln(1 - U), finite for every U in [0, 1)."""
    return -np.log(1.0 - uniform(state))


def seed_streams(seed: int, n_streams: int) -> np.ndarray:
    """Independent xoshiro256** states for ``n_streams`` contacts, shape (n_streams, 4)."""
    state = np.random.SeedSequence(seed).generate_state(4 * n_streams, dtype=np.uint64)
    state = state.reshape(n_streams, 4)
    zero_rows = ~state.any(axis=1)
    state[zero_rows, 0] = np.uint64(0x9E3779B97F4A7C15)  # an all-zero state never moves
    return state
