import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfbench.resampling import SCHEMES, ancestors
from pfbench.rng import state_from_seed

ALL = list(SCHEMES)


def _state(seed=0):
    return state_from_seed(np.random.SeedSequence(seed))


@pytest.mark.parametrize("scheme", ALL)
def test_weights_summing_to_one_minus_eps_stay_in_range(scheme):
    N = 1000
    w = np.full(N, 1.0 / N)
    w *= (1 - 1e-12) / w.sum()
    for seed in range(50):
        idx = ancestors(w, scheme, _state(seed))
        assert idx.shape == (N,)
        assert idx.min() >= 0 and idx.max() <= N - 1
        assert np.bincount(idx, minlength=N).sum() == N


@pytest.mark.parametrize("scheme", ALL)
def test_one_hot_weights_copy_that_particle(scheme):
    for hot in (0, 3, 9):
        w = np.zeros(10)
        w[hot] = 1.0
        assert np.all(ancestors(w, scheme, _state(hot)) == hot)


@pytest.mark.parametrize("scheme", ["systematic", "residual"])
def test_uniform_weights_keep_each_particle_once(scheme):
    for N in (1, 7, 100, 1001):
        idx = ancestors(np.full(N, 1.0 / N), scheme, _state(N))
        assert np.array_equal(np.sort(idx), np.arange(N))


@pytest.mark.parametrize("scheme", ["multinomial", "stratified"])
def test_uniform_weights_random_schemes_are_unbiased(scheme):
    N, reps = 50, 2000
    counts = np.zeros(N)
    for r in range(reps):
        counts += np.bincount(ancestors(np.full(N, 1.0 / N), scheme, _state(r)), minlength=N)
    # each particle expects reps copies; multinomial variance per draw is at most 1
    assert np.all(np.abs(counts - reps) < 5 * math.sqrt(reps))


@pytest.mark.parametrize("scheme", ALL)
def test_expected_copies_equal_N_times_weight(scheme):
    rng = np.random.default_rng(3)
    N, reps = 40, 4000
    w = rng.gamma(0.5, size=N)
    w /= w.sum()
    counts = np.zeros(N)
    for r in range(reps):
        counts += np.bincount(ancestors(w, scheme, _state(1000 + r)), minlength=N)
    mean = counts / reps
    # Unbiasedness: each mean copy count within 5 standard errors of N w. The multinomial variance
    # N w (1 - w) bounds the variance of all four schemes (the others are lower-variance).
    se = np.sqrt(N * w * (1 - w) / reps)
    assert np.all(np.abs(mean - N * w) <= 5 * se)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.one_of(st.just(0.0), st.floats(1e-300, 1e6)), min_size=1, max_size=60)
       .filter(lambda w: sum(w) > 0), st.sampled_from(ALL), st.integers(0, 2 ** 32))
def test_only_positive_weight_particles_are_chosen(w, scheme, seed):
    w = np.array(w)
    idx = ancestors(w, scheme, _state(seed))
    assert idx.size == w.size
    assert idx.min() >= 0 and idx.max() < w.size
    assert np.all(w[idx] > 0)


def test_bad_weights_are_rejected():
    with pytest.raises(ValueError):
        ancestors(np.array([0.0, 0.0]), "systematic", _state())
    with pytest.raises(ValueError):
        ancestors(np.array([1.0, np.nan]), "systematic", _state())
