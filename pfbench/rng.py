"""Random numbers inside numba kernels: xoshiro256+ bits, ziggurat normals.

Every kernel takes its generator state ``s`` (uint64[4]) as an argument and advances it in place, so
a kernel is a pure function of its inputs and the state is seeded from a ``numpy.random.SeedSequence``
(:func:`state_from_seed`). An explicit state array, rather than a numpy ``Generator``, keeps kernels in
numba's disk cache, works inside ``prange`` loops, and matched the C reference's speed here.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types, uint64
from ._lazy import kernel

_U53 = 1.0 / 9007199254740992.0  # 2**-53

STATE = types.uint64[::1]


def _ziggurat_tables():
    """Tables of the 256-layer ziggurat for the standard normal (Marsaglia & Tsang 2000, with the
    52-bit mantissas numpy uses): ki (acceptance thresholds), wi (widths), fi (densities)."""
    n, m1 = 256, 2.0 ** 52
    dn = tn = 3.6541528853610088      # r, the start of the tail
    vn = 0.00492867323399             # area of each layer
    ki = np.zeros(n, dtype=np.uint64)
    wi = np.zeros(n)
    fi = np.zeros(n)
    q = vn / math.exp(-0.5 * dn * dn)
    ki[0] = int(dn / q * m1)
    wi[0], wi[n - 1] = q / m1, dn / m1
    fi[0], fi[n - 1] = 1.0, math.exp(-0.5 * dn * dn)
    for i in range(n - 2, 0, -1):
        dn = math.sqrt(-2.0 * math.log(vn / dn + math.exp(-0.5 * dn * dn)))
        ki[i + 1] = int(dn / tn * m1)
        tn = dn
        fi[i] = math.exp(-0.5 * dn * dn)
        wi[i] = dn / m1
    return ki, wi, fi


_ZKI, _ZWI, _ZFI = _ziggurat_tables()
# the widths with the sign folded in: entry 2 i + b is wi[i], negated when b = 1, so that the top
# nine bits of a draw (its layer, then its sign bit) index the signed width in one load;
# -(m wi) and m (-wi) are the same double
_ZWS = np.empty(2 * _ZWI.size)
_ZWS[0::2], _ZWS[1::2] = _ZWI, -_ZWI
_ZR = 3.6541528853610088
_ZINV_R = 1.0 / _ZR
_MANT52 = uint64(0x000FFFFFFFFFFFFF)


def state_from_seed(seed_seq: np.random.SeedSequence) -> np.ndarray:
    """Return a fresh uint64[4] xoshiro256+ state drawn from ``seed_seq`` (never all zero)."""
    s = seed_seq.generate_state(4, np.uint64)
    if not s.any():
        s[0] = 1
    return s


@kernel(types.uint64(STATE), cache=True, by_address=True, inline="always")
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


@kernel(types.float64(types.uint64), cache=True, by_address=True, inline="always")
def unit(r):
    """U[0, 1) from 64 random bits r (their top 53)."""
    return float(r >> uint64(11)) * _U53


@kernel(types.float64(STATE), cache=True, by_address=True, inline="always")
def uniform(s):
    """One draw from U[0, 1) with 53 random bits."""
    return unit(next_u64(s))


@kernel(types.float64(STATE, types.uint64, types.uint64, types.float64), cache=True, inline="always")
def _normal_slow(s, idx, rabs, x):
    """The rest of :func:`normal` once a draw fell outside its layer's rectangle: the tail
    (layer 0) or the wedge test; NaN when the draw is rejected (the caller draws again)."""
    if idx == 0:
        while True:
            xx = -_ZINV_R * math.log1p(-uniform(s))
            yy = -math.log1p(-uniform(s))
            if yy + yy > xx * xx:
                return -(_ZR + xx) if math.copysign(1.0, x) < 0.0 else _ZR + xx
    if (_ZFI[idx - 1] - _ZFI[idx]) * uniform(s) + _ZFI[idx] < math.exp(-0.5 * x * x):
        return x
    return math.nan


@kernel(types.Tuple((types.uint64, types.uint64, types.float64))(types.uint64), cache=True,
      inline="always")
def _layer(r):
    """The ziggurat's reading of 64 random bits: (layer, 52-bit magnitude, signed candidate).

    The layer is bits 56-63 and the sign bit 55, the magnitude bits 3-54: xoshiro256+'s lowest
    bits are its weakest (their authors say so), and the lowest three are not used at all. The
    sign comes with the width (``_ZWS``): no branch or select for it."""
    rabs = (r >> uint64(3)) & _MANT52
    return r >> uint64(56), rabs, rabs * _ZWS[r >> uint64(55)]


@kernel(types.float64(STATE), cache=True, by_address=True)
def normal(s):
    """One standard normal draw (ziggurat: one 64-bit draw per value 98.8% of the time)."""
    while True:
        idx, rabs, x = _layer(next_u64(s))
        if in_layer_rectangle(idx, rabs):
            return x
        x = _normal_slow(s, idx, rabs, x)
        if x == x:
            return x


_LOCAL = types.UniTuple(types.uint64, 4)


@kernel(types.Tuple((types.uint64, _LOCAL))(_LOCAL), cache=True, inline="always")
def next_local(q):
    """next_u64 on a state held in local variables, q = (s0, s1, s2, s3): (64 random bits, the
    next state). The compiler keeps a local state in registers, where it must reload an array's
    after every store that might alias it. :func:`normal_off_rectangle` says how the ziggurat
    draws on a local state, bit for bit :func:`normal`'s.
    """
    s0, s1, s2, s3 = q
    r = s0 + s3
    t = s1 << uint64(17)
    s2 ^= s0
    s3 ^= s1
    s1 ^= s2
    s0 ^= s3
    s2 ^= t
    s3 = (s3 << uint64(45)) | (s3 >> uint64(19))
    return r, (s0, s1, s2, s3)


@kernel(_LOCAL(STATE), cache=True, inline="always")
def load_local(s):
    """The state array's contents as a local state (see ``next_local``)."""
    return s[0], s[1], s[2], s[3]


@kernel(types.void(STATE, _LOCAL), cache=True, inline="always")
def store_local(s, q):
    """Write a local state back into the state array."""
    s[0], s[1], s[2], s[3] = q


@kernel(types.boolean(types.uint64, types.uint64), cache=True, inline="always")
def in_layer_rectangle(layer, rabs):
    """The ziggurat's fast test (98.8% of draws): the candidate of magnitude rabs (``_layer``)
    lies inside its layer's rectangle, and is the draw."""
    return rabs < _ZKI[layer]


@kernel(types.Tuple((types.float64, _LOCAL))(STATE, _LOCAL, types.uint64, types.uint64,
                                             types.float64), cache=True, inline="always")
def normal_off_rectangle(s, q, layer, rabs, x):
    """The rest of a draw on a local state q (see ``next_local``) whose candidate x fell outside
    its layer's rectangle: the state goes back to the array s for the tail or wedge test
    (``_normal_slow``), a fresh :func:`normal` when that rejects, and is loaded again. Returns
    (the draw, the local state).

    The ziggurat's step on a local state, :func:`normal`'s bit for bit, is
    ``r, q = next_local(q); layer, rabs, x = _layer(r)``, then this when not
    ``in_layer_rectangle(layer, rabs)``. Its fast path stays in the caller's loop: a helper
    that returns the local state on the fast path keeps it out of registers (2.5 times slower,
    even inlined)."""
    store_local(s, q)
    x = _normal_slow(s, layer, rabs, x)
    if x != x:
        x = normal(s)
    return x, load_local(s)


@kernel(types.void(STATE, types.float64[::1]), cache=True, by_address=True)
def fill_normal(s, z):
    """Fill ``z`` with independent standard normal draws: the draws of as many calls of
    :func:`normal`, bit for bit, about 2.5x faster, with the state in registers (see
    ``normal_off_rectangle``)."""
    q = load_local(s)
    for i in range(z.size):
        r, q = next_local(q)
        layer, rabs, x = _layer(r)
        if not in_layer_rectangle(layer, rabs):
            x, q = normal_off_rectangle(s, q, layer, rabs, x)
        z[i] = x
    store_local(s, q)


@kernel(types.void(STATE, types.float64, types.float64[::1]), cache=True, by_address=True)
def add_normal(s, sd, x):
    """x += sd * z in place, z independent standard normal draws (the draws of as many calls of
    :func:`normal`: all of them first, by ``fill_normal``, then the sum, a pass that vectorises)."""
    z = np.empty(x.size)
    fill_normal(s, z)
    for i in range(x.size):
        x[i] += sd * z[i]


@kernel(types.void(STATE, types.float64[::1]), cache=True, by_address=True)
def fill_uniform(s, u):
    """Fill ``u`` with independent U[0, 1) draws."""
    for i in range(u.size):
        u[i] = uniform(s)


@kernel(types.float64(STATE, types.float64), cache=True, by_address=True)
def standard_gamma(s, shape):
    """One Gamma(shape, rate 1) draw (Marsaglia & Tsang 2000; shape < 1 by the U^(1/shape) boost)."""
    boost = 1.0
    a = shape
    if a < 1.0:
        boost = uniform(s) ** (1.0 / a)
        a += 1.0
    d = a - 1.0 / 3.0
    c = 1.0 / math.sqrt(9.0 * d)
    while True:
        z = normal(s)
        v = 1.0 + c * z
        if v <= 0.0:
            continue
        v = v * v * v
        u = uniform(s)
        if u < 1.0 - 0.0331 * z ** 4 or math.log(u) < 0.5 * z * z + d * (1.0 - v + math.log(v)):
            return boost * d * v
