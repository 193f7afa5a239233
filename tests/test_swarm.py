"""Swarm moves on a fixed unimodal fitness; stepwise EWA resampling against a numpy reference."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfbench.filters import swarm
from pfbench.resampling import stepwise_ewa_plan
from pfbench.rng import state_from_seed

from .conftest import ewa_reference

OPT = np.array([1.0, -2.0])


def fitness(X, D):
    """exp(-|x - OPT|^2 / 2): unimodal, maximal (1) at OPT."""
    P = X.reshape(-1, D)
    return np.exp(-0.5 * np.sum((P - OPT[:D]) ** 2, axis=1))


def _state(k=0):
    return state_from_seed(np.random.SeedSequence(k))


def _cloud(N, D, seed=0, spread=2.0):
    rng = np.random.default_rng(seed)
    return (OPT[:D] + spread * rng.standard_normal((N, D))).ravel().copy()


def _run_move(kind, X, D, s, iters=3):
    """Apply ``iters`` iterations of a move, evaluating the fitness as a filter kernel would."""
    N = X.size // D
    fit = fitness(X, D)
    if kind == "fa":
        for _ in range(iters):
            swarm.fa_move(X, fit, D, 1.0, 0.5, 0.05, np.ones(D), s, 0, 0)
            fit = fitness(X, D)
    elif kind == "ifa":
        for _ in range(iters):
            swarm.ifa_move(X, fit, D, 1.0, 0.5, 0.05, np.ones(D), s, 0, 0)
            fit = fitness(X, D)
    elif kind == "pso":
        V, P, Pfit = np.zeros_like(X), X.copy(), fit.copy()
        for _ in range(iters):
            swarm.pso_propose(X, V, P, Pfit, D, swarm.argmax(Pfit), 0.5, 1.0, 1.0, s)
            fit = fitness(X, D)
            swarm.pso_accept(X, fit, P, Pfit, D)
    elif kind == "ba":
        V, A, r, C = np.zeros_like(X), np.ones(N), np.full(N, 0.5), np.empty_like(X)
        for it in range(iters):
            swarm.ba_propose(X, V, A, r, C, D, swarm.argmax(fit), 0.0, 1.0, np.ones(D), 0, s)
            swarm.ba_accept(X, fit, C, fitness(C, D), A, r, D, 0.9, 0.9, 0.5, it + 1, 0, s)
    else:
        Xc, nf, C = np.empty_like(X), np.empty(N), np.empty(3 * X.size)
        for _ in range(iters):
            swarm.afsa_centres(X, fit, D, 1.5, Xc, nf)
            swarm.afsa_propose(X, fit, Xc, fitness(Xc, D), nf, D, 1.5, 0.3, 0.618, 5, 0, X, fit, s, C)
            swarm.afsa_select(X, fit, C, fitness(C, D), D, 1)
    return fitness(X, D)


@pytest.mark.parametrize("kind", ["fa", "ifa", "pso", "ba", "afsa"])
@pytest.mark.parametrize("D", [1, 2])
def test_moves_raise_the_mean_fitness_of_a_cloud(kind, D):
    gains = []
    for k in range(20):
        X = _cloud(60, D, seed=k)
        before = fitness(X, D).mean()
        after = _run_move(kind, X, D, _state(k))
        gains.append(after.mean() - before)
    gains = np.array(gains)
    # every cloud improves on average; demand a mean gain of 5 standard errors above zero
    assert gains.mean() > 5 * gains.std(ddof=1) / math.sqrt(gains.size)


@pytest.mark.parametrize("kind,step", [("fa", 0.05 / 2), ("ifa", 1.0 / 2), ("afsa", 0.3)])
def test_a_particle_at_the_optimum_moves_at_most_its_step(kind, step):
    # The brightest particle has nobody brighter: the fireflies leave it alone except for nothing
    # at all; AFSA's greedy selection never moves it by more than its step.
    D = 2
    for k in range(10):
        X = _cloud(40, D, seed=k)
        X[:D] = OPT
        s = _state(k)
        _run_move(kind, X, D, s, iters=1)
        assert np.linalg.norm(X[:D] - OPT) <= step * math.sqrt(D) + 1e-12


def test_greedy_afsa_never_lowers_a_fish():
    D = 2
    for k in range(10):
        X = _cloud(50, D, seed=k)
        fit = fitness(X, D)
        before = fit.copy()
        N = fit.size
        Xc, nf, C = np.empty_like(X), np.empty(N), np.empty(3 * X.size)
        s = _state(k)
        swarm.afsa_centres(X, fit, D, 1.5, Xc, nf)
        swarm.afsa_propose(X, fit, Xc, fitness(Xc, D), nf, D, 1.5, 0.3, 0.618, 5, 0, X, fit, s, C)
        swarm.afsa_select(X, fit, C, fitness(C, D), D, 1)
        assert np.all(fit >= before)
        assert np.allclose(fit, fitness(X, D))


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 80), st.integers(0, 2 ** 31), st.floats(0.05, 0.95), st.booleans())
def test_stepwise_ewa_matches_the_numpy_reference(N, seed, beta, printed):
    rng = np.random.default_rng(seed)
    W = rng.gamma(rng.uniform(0.1, 3), size=N)
    W /= W.sum()
    src = np.empty(N, dtype=np.int64)
    mutant = np.empty(N, dtype=np.int8)
    stepwise_ewa_plan(W, beta, int(printed), 0, src, mutant)
    ref_src, ref_mutant = ewa_reference(W, beta, printed)
    assert np.array_equal(src, ref_src)
    assert np.array_equal(mutant, ref_mutant)
    assert src.size == N and src.min() >= 0 and src.max() < N
    heaviest = int(np.argmax(W))
    assert src[0] == heaviest and mutant[0] == 0     # the heaviest particle is kept first


def test_stepwise_ewa_on_one_hot_and_uniform_weights():
    src, mutant = np.empty(10, dtype=np.int64), np.empty(10, dtype=np.int8)
    W = np.zeros(10)
    W[4] = 1.0
    stepwise_ewa_plan(W, 0.8, 0, 0, src, mutant)
    assert np.all(src == 4)
    W = np.full(10, 0.1)
    stepwise_ewa_plan(W, 0.8, 0, 0, src, mutant)
    assert sorted(src) == list(range(10)) and not mutant.any()


@pytest.mark.parametrize("kind", ["fa", "ifa", "ba", "pso", "afsa"])
def test_swarm_pf_without_iterations_is_the_bootstrap_pf_bit_for_bit(kind):
    from pfbench.config import Params
    from pfbench.filters import FILTERS
    from pfbench.scenarios import ungm
    from pfbench.models.scalar import simulate

    model = ungm.build({k: v.default for k, v in ungm.SCHEMA.items()})
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(1)))

    def run(name, **over):
        ft = FILTERS[name]
        p = {k: v.default for k, v in ft.schema.items()}
        p.update(over)
        return ft.run(model, y, Params(p), 64, state_from_seed(np.random.SeedSequence(2)))

    base = run("pf", resampling="systematic")
    sw = run(kind, iterations=0, resampling="systematic")
    assert np.array_equal(base["xhat"], sw["xhat"])
    assert sw["lik_evals_per_step"] == 64
    moved = run(kind, iterations=2, resampling="systematic")
    assert not np.array_equal(base["xhat"], moved["xhat"])
    assert moved["lik_evals_per_step"] > 64


def test_shipped_equal_evaluation_pf_matches_ifa_evaluations():
    from pfbench.config import load
    from pfbench.runner import run_trial

    from .conftest import ROOT
    exp = load(ROOT / "configs/ifa_pf_ungm.yaml", sets=["scenario.steps=5"])
    rows = {r["filter"]: r for r in run_trial(exp, 0)}
    for n, n_eq in ((50, 100), (100, 200), (150, 300)):
        assert rows[f"ifa@{n}"]["lik_evals_per_step"] == n_eq
        assert rows[f"pf_equal@{n_eq}"]["lik_evals_per_step"] == n_eq


def _firefly_reference(X, bright, D, beta0, gamma, alpha, R, adaptive, law, toward, scale, s):
    """The firefly move as its docstring states it, one pair at a time in plain Python, drawing
    from the same generator: each i toward each brighter j (or the first brightest), in the order
    (i, j, coordinate), x_i += beta0 exp(-gamma r_ij^2) (x_j - x_i) + a scale e."""
    from pfbench.codes import (RANDOM_GAUSSIAN, RANDOM_UNIFORM_HALF, RANDOM_UNIFORM_SQRT3,
                               TOWARD_BRIGHTER_ALL_AT_ONCE, TOWARD_BRIGHTEST)
    from pfbench.rng import normal, uniform

    def term():
        if law == RANDOM_UNIFORM_HALF:
            return uniform(s) - 0.5
        if law == RANDOM_UNIFORM_SQRT3:
            return math.sqrt(3.0) * (2.0 * uniform(s) - 1.0)
        if law == RANDOM_GAUSSIAN:
            return normal(s)
        return 0.0
    N = bright.size
    src = X.copy() if toward == TOWARD_BRIGHTER_ALL_AT_ONCE else X
    first = 0                                  # the first of the brightest (a NaN is not)
    for j in range(1, N):
        if bright[j] > bright[first]:
            first = j
    targets = [first] if toward == TOWARD_BRIGHTEST else range(N)
    for i in range(N):
        for j in targets:
            if not bright[j] > bright[i]:
                continue
            r2 = 0.0
            for d in range(D):
                e = src[i * D + d] - src[j * D + d]
                r2 += e * e
            b = beta0 * math.exp(-gamma * r2)
            a = math.exp(-R * bright[i] / bright[j]) if adaptive else alpha
            for d in range(D):
                X[i * D + d] += b * (src[j * D + d] - src[i * D + d]) + a * scale[d] * term()


@pytest.mark.parametrize("D", [1, 3])
@pytest.mark.parametrize("law", [0, 1, 2, 3])
@pytest.mark.parametrize("toward", [0, 1, 2])
@pytest.mark.parametrize("adaptive", [False, True])
def test_firefly_moves_match_the_pairwise_reference_bit_for_bit(D, law, toward, adaptive):
    """fa_move and ifa_move (which list each particle's brighter ones before moving it, and keep
    a scalar state in registers) give the reference's positions and generator state exactly, ties
    in brightness and a NaN one included."""
    N = 40
    rng = np.random.default_rng(D * 100 + law * 10 + toward)
    X0 = rng.normal(size=N * D)
    bright = rng.random(N)
    if adaptive:
        bright = -bright                       # IFA's brightness as a distance: -d
    bright[3] = bright[7]                      # a tie: neither is brighter than the other
    bright[11] = np.nan                        # never brighter, nor dimmer
    scale = np.linspace(0.5, 1.5, D)
    X, s = X0.copy(), _state(5)
    if adaptive:
        swarm.ifa_move(X, bright, D, 1.0, 0.7, 1.3, scale, s, law, toward)
    else:
        swarm.fa_move(X, bright, D, 1.0, 0.7, 0.2, scale, s, law, toward)
    Xr, sr = X0.copy(), _state(5)
    _firefly_reference(Xr, bright, D, 1.0, 0.7, 0.0 if adaptive else 0.2, 1.3 if adaptive else 0.0,
                       adaptive, law, toward, scale, sr)
    assert not np.array_equal(X, X0)
    assert np.array_equal(X.view(np.uint64), Xr.view(np.uint64))
    assert np.array_equal(s, sr)
