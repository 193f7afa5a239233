"""Random numbers inside numba kernels: xoshiro256+ with Box-Muller normals.

Every kernel takes its generator state ``s`` (uint64[4]) as an argument and advances it in place, so
a kernel is a pure function of its inputs and the state is seeded from a ``numpy.random.SeedSequence``
(:func:`state_from_seed`). An explicit state array, rather than a numpy ``Generator``, keeps kernels in
numba's disk cache, works inside ``prange`` loops, and matched the C reference's speed here.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types, uint64

TWO_PI = 6.283185307179586
_U53 = 1.0 / 9007199254740992.0  # 2**-53

STATE = types.uint64[::1]


def state_from_seed(seed_seq: np.random.SeedSequence) -> np.ndarray:
    """Return a fresh uint64[4] xoshiro256+ state drawn from ``seed_seq`` (never all zero)."""
    s = seed_seq.generate_state(4, np.uint64)
    if not s.any():
        s[0] = 1
    return s


@njit(types.uint64(STATE), cache=True, inline="always")
def next_u64(s):
    """Advance the xoshiro256+ state ``s`` and return 64 random bits."""
    res = s[0] + s[3]
    t = s[1] << uint64(17)
    s[2] ^= s[0]
    s[3] ^= s[1]
    s[1] ^= s[2]
    s[0] ^= s[3]
    s[2] ^= t
    s[3] = (s[3] << uint64(45)) | (s[3] >> uint64(19))
    return res


@njit(types.float64(STATE), cache=True, inline="always")
def uniform(s):
    """One draw from U[0, 1) with 53 random bits."""
    return float(next_u64(s) >> uint64(11)) * _U53


@njit(types.float64(STATE), cache=True)
def normal(s):
    """One standard normal draw (Box-Muller; the second value of the pair is discarded)."""
    u1 = 1.0 - uniform(s)
    u2 = uniform(s)
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(TWO_PI * u2)


@njit(types.void(STATE, types.float64[::1]), cache=True)
def fill_normal(s, z):
    """Fill ``z`` with independent standard normal draws (Box-Muller pairs)."""
    n = z.size
    i = 0
    while i + 1 < n:
        u1 = 1.0 - uniform(s)
        u2 = uniform(s)
        r = math.sqrt(-2.0 * math.log(u1))
        th = TWO_PI * u2
        z[i] = r * math.cos(th)
        z[i + 1] = r * math.sin(th)
        i += 2
    if i < n:
        z[i] = normal(s)


@njit(types.void(STATE, types.float64[::1]), cache=True)
def fill_uniform(s, u):
    """Fill ``u`` with independent U[0, 1) draws."""
    for i in range(u.size):
        u[i] = uniform(s)
