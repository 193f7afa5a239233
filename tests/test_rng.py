import math

import numpy as np

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
