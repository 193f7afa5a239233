import math

import numpy as np
import pytest

from pfbench.rng import fill_normal, fill_uniform, state_from_seed


def test_same_seed_same_stream_and_state_advances():
    a = state_from_seed(np.random.SeedSequence(0))
    b = state_from_seed(np.random.SeedSequence(0))
    x, y, z = np.empty(101), np.empty(101), np.empty(101)
    fill_normal(a, x)
    fill_normal(b, y)
    fill_normal(a, z)
    assert np.array_equal(x, y)
    assert not np.array_equal(x, z)


def test_uniform_range_and_mean():
    u = np.empty(200_000)
    fill_uniform(state_from_seed(np.random.SeedSequence(1)), u)
    assert u.min() >= 0.0 and u.max() < 1.0
    # mean 1/2, sd of the mean sqrt(1/12/n): allow 5 standard errors
    assert abs(u.mean() - 0.5) < 5 * math.sqrt(1 / 12 / u.size)


def test_normal_moments_and_cdf():
    n = 400_000
    z = np.empty(n)
    fill_normal(state_from_seed(np.random.SeedSequence(2)), z)
    se = 1 / math.sqrt(n)
    assert abs(z.mean()) < 5 * se
    assert abs(z.var() - 1.0) < 5 * math.sqrt(2) * se
    assert abs(np.mean(z ** 3)) < 5 * math.sqrt(15) * se
    # Kolmogorov-Smirnov distance to the normal CDF; the 0.001 critical value is 1.95 / sqrt(n)
    zs = np.sort(z)
    cdf = 0.5 * (1 + np.vectorize(math.erf)(zs / math.sqrt(2)))
    i = np.arange(1, n + 1)
    d = max(np.max(i / n - cdf), np.max(cdf - (i - 1) / n))
    assert d < 1.95 / math.sqrt(n)
    # tails: P(|z| > 3) = 0.0026998
    p = np.mean(np.abs(z) > 3)
    assert abs(p - 0.0026998) < 5 * math.sqrt(0.0027 / n)


def test_normal_tail_beyond_the_ziggurat_base():
    # |z| > 3.6541528853610088 is drawn by the ziggurat's tail method; check its mass and shape.
    n = 2_000_000
    z = np.empty(n)
    fill_normal(state_from_seed(np.random.SeedSequence(3)), z)
    r = 3.6541528853610088
    tail = np.abs(z[np.abs(z) > r])
    p = math.erfc(r / math.sqrt(2))
    assert abs(tail.size / n - p) < 5 * math.sqrt(p / n)
    # conditional mean of |z| beyond r: phi(r) / (1 - Phi(r)) for one side
    phi = math.exp(-r * r / 2) / math.sqrt(2 * math.pi)
    cond = phi / (p / 2)
    assert abs(tail.mean() - cond) < 5 * tail.std() / math.sqrt(tail.size)
    assert np.mean(z[np.abs(z) > r] > 0) == pytest.approx(0.5, abs=5 * 0.5 / math.sqrt(tail.size))


def test_ziggurat_tables_are_consistent():
    from pfbench import rng
    ki, wi, fi = rng._ZKI, rng._ZWI, rng._ZFI
    assert fi[0] == 1.0 and np.all(np.diff(fi) < 0)        # densities fall layer by layer
    assert np.all(np.diff(wi[1:]) > 0)                      # widths grow toward the base
    assert hex(int(ki[0]))[:10] == hex(0x000EF33D8025EF6A)[:10]  # numpy's table, same layers


def test_fill_normal_draws_what_normal_draws_bit_for_bit():
    """fill_normal keeps the state in registers; its draws, slow paths (the tail, the wedges,
    rejections) included, and the state it leaves must be those of as many normal() calls."""
    from pfbench.rng import normal
    a = state_from_seed(np.random.SeedSequence(11))
    b = a.copy()
    z = np.empty(300_000)
    fill_normal(a, z)
    ref = np.array([normal(b) for _ in range(z.size)])
    assert np.array_equal(z, ref) and np.array_equal(a, b)
    assert np.abs(z).max() > 3.6541528853610088      # the tail was drawn from


def test_the_ziggurat_reads_its_layer_and_sign_from_the_high_bits():
    # xoshiro256+'s lowest bits are its weakest: the layer is bits 56-63, the sign bit 55, and
    # the lowest three bits are not read at all
    from pfbench.rng import _ZWI, _layer
    for k in (0, 1, 77, 255):
        idx, rabs, x = _layer(np.uint64(k) << np.uint64(56))
        assert idx == k and rabs == 0
    for low in range(8):
        assert _layer(np.uint64(low))[:2] == (0, 0)
    idx, rabs, x = _layer((np.uint64(5) << np.uint64(56)) | (np.uint64(1) << np.uint64(55))
                          | (np.uint64(1) << np.uint64(3)))
    assert idx == 5 and rabs == 1 and x == -_ZWI[5]


def test_the_draws_of_each_ziggurat_layer_are_uniform():
    # 2^21 raw draws: every one of the 256 layers is chosen equally often (chi-square, 255
    # degrees of freedom, 0.001 critical value 330.5), and within each layer the sign is a fair
    # coin and the magnitude uniform (mean 1/2 within 5 standard errors)
    from pfbench.rng import _layer, next_u64
    from numba import njit

    @njit(cache=False)
    def draws(s, n):
        idx = np.empty(n, dtype=np.int64)
        mag = np.empty(n)
        neg = np.empty(n, dtype=np.int8)
        for i in range(n):
            k, rabs, x = _layer(next_u64(s))
            idx[i] = k
            mag[i] = rabs / 4503599627370496.0          # 2^52
            neg[i] = 1 if x < 0 or (x == 0 and math.copysign(1.0, x) < 0) else 0
        return idx, mag, neg

    n = 1 << 21
    idx, mag, neg = draws(state_from_seed(np.random.SeedSequence(7)), n)
    counts = np.bincount(idx, minlength=256)
    expected = n / 256
    assert counts.size == 256
    assert ((counts - expected) ** 2 / expected).sum() < 330.5
    per = n / 256
    for k in range(256):
        sel = idx == k
        assert abs(neg[sel].mean() - 0.5) < 5 * math.sqrt(0.25 / per)
        assert abs(mag[sel].mean() - 0.5) < 5 * math.sqrt(1 / 12 / per)


def test_the_signed_width_table_gives_the_sign_the_select_gave():
    # the candidate is rabs * wi[layer], negated when bit 55 is set; the table of signed widths
    # must give that double bit for bit, signed zeros included (rabs = 0)
    from pfbench.rng import _MANT52, _ZWI, _layer
    rng = np.random.default_rng(3)
    raw = rng.integers(0, 2**63, size=4000, dtype=np.uint64) * np.uint64(2) \
        + rng.integers(0, 2, size=4000, dtype=np.uint64)
    raw[:512] = np.arange(512, dtype=np.uint64) << np.uint64(55)    # every layer and sign, rabs 0
    for r in raw:
        idx, rabs, x = _layer(r)
        assert rabs == (int(r) >> 3) & int(_MANT52)
        ref = float(rabs) * _ZWI[idx]
        ref = -ref if (int(r) >> 55) & 1 else ref
        assert np.float64(x).view(np.int64) == np.float64(ref).view(np.int64)
