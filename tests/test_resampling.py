import math

import numpy as np
import pytest
from hypothesis import example, given, settings
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


def _merge_systematic(w, S, u):
    """Systematic resampling as the plain merge of the positions (u + i) S / N against the running
    sum, never past the last positive weight: the definition the kernel must reproduce. A total
    outside [2^-900, 2^960 / N] is first brought to an ordinary scale, as the module's docstring
    says: every weight times the power of two that puts the largest in [0.5, 1), summed again."""
    N = len(w)
    if not (S >= 2.0 ** -900 and S * N <= 2.0 ** 960):
        e = math.frexp(max(w))[1]
        w = [math.ldexp(x, -e) for x in w]
        S = 0.0
        for x in w:
            S += x
    step = S / N
    jmax = max(j for j in range(N) if w[j] > 0.0) if any(x > 0.0 for x in w) else 0
    out, j, cum = [], 0, w[0]
    for i in range(N):
        p = (u + i) * step
        while p >= cum and j < jmax:
            j += 1
            cum += w[j]
        out.append(j)
    return out


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.just(0.0), st.floats(1e-300, 1e3), st.floats(0.0, 1.0)),
                min_size=1, max_size=300),
       st.integers(0, 2**32 - 1), st.booleans())
@example([0.0, 5e-324], 0, False)     # S / N rounds to 0: the step is zero, its inverse inf
@example([0.0, 5e-324, 5e-324], 0, False)   # S / N rounds up to S / 2: only scaled is it S / 3
def test_systematic_is_the_merge_bit_for_bit(w, seed, uniform_w):
    """The counting form of systematic resampling picks the merge's ancestors exactly, ties of a
    position with a running sum, zero weights, tiny and uniform weights included."""
    from pfbench.resampling import systematic
    from pfbench.rng import uniform as draw
    w = np.array([1.0 / len(w)] * len(w) if uniform_w else w)
    if not w.sum() > 0:
        w[len(w) // 2] = 1.0
    S = 0.0
    for x in w:
        S += x
    state = state_from_seed(np.random.SeedSequence(seed))
    u = draw(state.copy())
    idx = np.empty(len(w), dtype=np.int64)
    systematic(w, S, state, idx)
    assert idx.tolist() == _merge_systematic(w.tolist(), S, u)


def _from_sums(w, S, seed):
    """systematic_from_sums on w with its running sums (in order): ancestors and the state."""
    from pfbench.resampling import systematic_from_sums
    cum = np.empty(len(w))
    acc = 0.0
    for j, x in enumerate(w):
        acc += x
        cum[j] = acc
    state = state_from_seed(np.random.SeedSequence(seed))
    idx = np.full(len(w), -7, dtype=np.int64)
    systematic_from_sums(w, cum, S, state, idx, np.full(len(w), 99, dtype=np.int64))
    return idx.tolist(), state.tolist()


@settings(max_examples=300, deadline=None)
@given(st.lists(st.one_of(st.just(0.0), st.floats(1e-300, 1e3), st.floats(0.0, 1.0),
                          st.floats(0.0, 1e-305)), min_size=1, max_size=300),
       st.integers(0, 2**32 - 1), st.sampled_from(["sum", "one", "tiny"]))
@example([0.0, 5e-324], 0, "sum")     # S / N rounds to 0: the step is zero, its inverse inf
@example([1e-310, 3e-310, 0.0, 2e-309], 5, "tiny")   # quotients far off: settled by the loops
def test_systematic_from_sums_is_systematic_bit_for_bit(w, seed, total):
    """Given the running sums, the vectorised counts pick systematic's ancestors exactly and draw
    the same, whatever S: the weights' sum (as MCL passes), 1 (normalised weights), or a sum of
    subnormal weights, whose step's inverse is so inexact that quotients miss by more than one."""
    from pfbench.resampling import systematic
    w = np.array(w)
    if not w.sum() > 0:
        w[len(w) // 2] = 1e-310 if total == "tiny" else 1.0
    if total == "one":
        w = w / w.sum()
    S = 0.0
    for x in w:
        S += x
    S = 1.0 if total == "one" else S
    state = state_from_seed(np.random.SeedSequence(seed))
    idx = np.empty(len(w), dtype=np.int64)
    systematic(w, S, state, idx)
    assert _from_sums(w, S, seed) == (idx.tolist(), state.tolist())


def test_systematic_from_sums_settles_far_quotients():
    """Subnormal weights: the step S / N keeps few bits, its inverse is far off, and the
    quotients miss their counts by more than a step; the result is still systematic's."""
    from pfbench.resampling import systematic
    w = np.array([1e-322, 3e-322, 0.0, 5e-321, 2e-322, 7e-322])
    S = float(np.sum(w))
    N = len(w)
    step, u = S / N, 0.5
    cum = np.cumsum(w)
    q = np.clip(np.ceil(cum * (1.0 / step) - u), 0, N)
    exact = np.array([sum((u + i) * step < c for i in range(N)) for c in cum])
    assert np.max(np.abs(q - exact)) > 1       # the case the loops exist for
    for seed in range(20):
        state = state_from_seed(np.random.SeedSequence(seed))
        idx = np.empty(N, dtype=np.int64)
        systematic(w, S, state, idx)
        assert _from_sums(w, S, seed) == (idx.tolist(), state.tolist())


def test_systematic_with_positions_on_the_running_sums():
    """Weights whose running sums fall exactly on the positions (u = 0 ... ): a position equal to
    cum_j belongs to the next particle, as in the merge."""
    from pfbench.resampling import systematic
    for N in (1, 2, 4, 8, 64):
        w = np.full(N, 0.25)
        state = np.zeros(4, dtype=np.uint64)     # not a valid generator: u = 0 exactly
        idx = np.empty(N, dtype=np.int64)
        systematic(w, float(w.sum()), state, idx)
        assert idx.tolist() == _merge_systematic(w.tolist(), float(w.sum()), 0.0)
