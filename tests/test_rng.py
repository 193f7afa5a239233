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
