"""The readings of the stepwise EWA's copies, the bat algorithm's acceptance and local walk, and
AFSA's prey target and convergence (keys ewa_copies, ba_accept, ba_walk, prey_target, converge):
each on a small hand-checked case, then end to end in the swarm PFs and FastSLAM."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from pfbench.codes import (BA_ACCEPT_BETTER_THAN_BEST, BA_ACCEPT_FITTER_AND_LOUD,
                           BA_WALK_GAUSSIAN, BA_WALK_UNIFORM, EWA_COPIES, EWA_COPIES_CEIL,
                           EWA_COPIES_CEIL_PLUS_ONE, EWA_COPIES_FLOOR_PLUS_ONE)
from pfbench.config import Params
from pfbench.filters import FILTERS
from pfbench.filters import swarm as sw
from pfbench.resampling import ewa_copies, stepwise_ewa_plan
from pfbench.rng import state_from_seed

from .conftest import ewa_reference


def _state(k=0):
    return state_from_seed(np.random.SeedSequence(k))


def _plan(W, copies, beta=0.8, printed=0):
    N = W.size
    src, mutant = np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int8)
    kept = stepwise_ewa_plan(np.asarray(W, dtype=np.float64), beta, printed, copies, src, mutant)
    return kept, src.tolist(), mutant.tolist()


# --- the stepwise EWA's copies ------------------------------------------------------------------

@pytest.mark.parametrize("n, ceil, floor1, ceil1", [
    (1.0, 1, 2, 2), (1.5, 2, 2, 3), (2.0, 2, 3, 3), (2.0 - 1e-14, 2, 3, 3), (2.0 + 1e-14, 2, 3, 3),
    (3.25, 4, 4, 5)])
def test_ewa_copies_of_a_kept_particle(n, ceil, floor1, ceil1):
    """ceil(n); floor(n) + 1; ceil(n) + 1, a whole n within round-off counted as whole."""
    assert ewa_copies(n, EWA_COPIES_CEIL) == ceil
    assert ewa_copies(n, EWA_COPIES_FLOOR_PLUS_ONE) == floor1
    assert ewa_copies(n, EWA_COPIES_CEIL_PLUS_ONE) == ceil1


def test_ewa_copies_n_plus_one_on_uniform_and_one_hot_weights():
    # uniform: every bias-corrected average is 1/4 = delta, every particle kept with n = 1
    W = np.full(4, 0.25)
    assert _plan(W, EWA_COPIES_CEIL) == (4, [0, 1, 2, 3], [0, 0, 0, 0])
    assert _plan(W, EWA_COPIES_FLOOR_PLUS_ONE) == (4, [0, 0, 1, 1], [0, 0, 0, 0])
    assert _plan(W, EWA_COPIES_CEIL_PLUS_ONE) == (4, [0, 0, 1, 1], [0, 0, 0, 0])
    # one-hot on particle 2: delta = mean(0.2/0.2, 0.16/0.36, 0.128/0.488, 0.1024/0.5904)
    # = 0.4700, n = 2.128: ceil 3 copies then a mutant; floor + 1 the same; ceil + 1 four copies
    W = np.array([0.0, 0.0, 1.0, 0.0])
    delta = np.mean([0.2 / 0.2, 0.16 / 0.36, 0.128 / 0.488, 0.1024 / 0.5904])
    assert 2.0 < 1.0 / delta < 3.0
    assert _plan(W, EWA_COPIES_CEIL) == (1, [2, 2, 2, 2], [0, 0, 0, 1])
    assert _plan(W, EWA_COPIES_FLOOR_PLUS_ONE) == (1, [2, 2, 2, 2], [0, 0, 0, 1])
    assert _plan(W, EWA_COPIES_CEIL_PLUS_ONE) == (1, [2, 2, 2, 2], [0, 0, 0, 0])


@settings(max_examples=100, deadline=None)
@given(st.integers(1, 60), st.integers(0, 2 ** 31), st.sampled_from(sorted(EWA_COPIES)))
def test_ewa_copies_match_the_numpy_reference(N, seed, copies):
    rng = np.random.default_rng(seed)
    W = rng.gamma(rng.uniform(0.1, 3), size=N)
    W /= W.sum()
    _, src, mutant = _plan(W, EWA_COPIES[copies])
    ref_src, ref_mutant = ewa_reference(W, 0.8, copies=copies)
    assert (src, mutant) == ([int(i) for i in ref_src], [int(m) for m in ref_mutant])


# --- the bat algorithm --------------------------------------------------------------------------

def _accept(rule, A):
    X = np.array([0.0, 1.0, 2.0])
    fit = np.array([1.0, 5.0, 3.0])
    C = np.array([10.0, 11.0, 12.0])
    fitc = np.array([2.0, 4.0, 6.0])
    Av, r = np.full(3, A), np.zeros(3)
    best = sw.ba_accept(X, fit, C, fitc, Av, r, 1, 0.5, 0.9, 0.5, 1, rule, _state())
    return X.tolist(), fit.tolist(), Av.tolist(), best


def test_ba_accepts_fitter_than_itself_or_only_beyond_the_best():
    # candidates: 2 > 1 (bat 0), 4 < 5 (bat 1), 6 > 3 (bat 2); the best bat's fitness is 5
    X, fit, A, best = _accept(BA_ACCEPT_FITTER_AND_LOUD, 1.0)     # u < 1 always
    assert X == [10.0, 1.0, 12.0] and fit == [2.0, 5.0, 6.0] and A == [0.5, 1.0, 0.5]
    assert best == 2
    X, fit, A, best = _accept(BA_ACCEPT_BETTER_THAN_BEST, 1.0)
    assert X == [0.0, 1.0, 12.0] and fit == [1.0, 5.0, 6.0] and A == [1.0, 1.0, 0.5]
    assert best == 2
    for rule in (BA_ACCEPT_FITTER_AND_LOUD, BA_ACCEPT_BETTER_THAN_BEST):
        assert _accept(rule, 0.0)[0] == [0.0, 1.0, 2.0]       # silent bats take nothing


@pytest.mark.parametrize("D", [1, 3])
def test_ba_uniform_walk_stays_within_the_mean_loudness(D):
    """With pulse rate 0 every bat walks around the best: x_best + e mean(A) scale, |e| <= 1
    under 'uniform', unbounded under the Gaussian."""
    N = 2000
    X = np.random.default_rng(1).normal(size=N * D)
    A = np.random.default_rng(2).uniform(0.2, 0.6, N)
    scale = np.linspace(0.5, 2.0, D)
    g = 7
    out = {}
    for walk in (BA_WALK_UNIFORM, BA_WALK_GAUSSIAN):
        C = np.empty(N * D)
        sw.ba_propose(X.copy(), np.zeros(N * D), A, np.zeros(N), C, D, g, 0.0, 1.0, scale, walk,
                      _state(3))
        out[walk] = (C.reshape(N, D) - X[g * D:(g + 1) * D]) / (A.mean() * scale)
    e = out[BA_WALK_UNIFORM]
    assert np.all(np.abs(e) <= 1.0 + 1e-12)      # 1e-12: mean(A) summed in another order
    assert e.min() < -0.99 and e.max() > 0.99
    # U(-1, 1): variance 1/3; 2000 D draws, 5 standard errors (var of e^2: 4/45)
    assert abs(np.mean(e * e) - 1 / 3) < 5 * math.sqrt(4 / 45 / e.size)
    assert np.mean(np.abs(out[BA_WALK_GAUSSIAN]) > 1.0) > 0.25    # N(0, 1): 32% beyond 1


# --- AFSA ---------------------------------------------------------------------------------------

@pytest.mark.parametrize("D", [1, 2, 3])
def test_random_point_targets_lie_within_the_visual_range(D):
    N, visual = 4000, 0.7
    X = np.random.default_rng(D).normal(size=N * D)
    found = np.zeros(N)
    found[::5] = 1.0
    Xq = np.empty(N * D)
    sw.afsa_prey_points(X, D, visual, found, Xq, _state(D))
    d = np.linalg.norm((Xq - X).reshape(N, D), axis=1)
    assert np.all(d <= visual * (1 + 1e-12))
    assert np.all(d[::5] == 0.0)                      # a fish that found its target draws none
    looking = np.ones(N, dtype=bool)
    looking[::5] = False
    # uniform in the ball: P(d < visual / 2) = 2^-D, within 5 standard errors
    frac = np.mean(d[looking] < visual / 2)
    p = 0.5 ** D
    assert abs(frac - p) < 5 * math.sqrt(p * (1 - p) / looking.sum())


def test_prey_check_keeps_the_first_fitter_point():
    ll = np.array([0.0, -1.0, -2.0])
    llq = np.array([1.0, -3.0, -2.0])      # fitter, worse, equal (not fitter)
    Xq = np.array([10.0, 11.0, 12.0])
    Xp = np.full(3, np.nan)
    found = np.zeros(3)
    assert sw.afsa_prey_check(ll, llq, Xq, Xp, found, 1) == 2
    assert found.tolist() == [1.0, 0.0, 0.0] and Xp[0] == 10.0
    # a later try does not replace a target found before
    assert sw.afsa_prey_check(ll, np.array([5.0, 0.0, -1.0]), Xq + 1, Xp, found, 1) == 0
    assert Xp.tolist() == [10.0, 12.0, 13.0]


def _loglik(pts, D):
    q = pts.reshape(-1, D) - 1.0
    return -0.5 * (q * q).sum(axis=1)


def _drive(X, D, p, iters, afsa=sw.AFSA_JOINT_SHIFT, seed=1):
    """Run ``iters`` AFSA iterations through ``swarm.swarm_move`` with the fitness above; return
    the evaluations of each iteration and whether it moved a fish to a fitter place."""
    N = X.size // D
    wk = sw.new_swarm_work(N, D)
    s = _state(seed)
    wk.ll[:] = _loglik(X, D)
    evals, improved = [], []
    for it in range(iters):
        before = wk.ll.copy()
        phase, n = 0, 0
        request = sw.swarm_move(sw.AFSA, afsa, phase, X, D, p, 1.0, it, wk, s)
        while request != sw.DONE:
            if request == sw.FIT_CENTRES:
                wk.llc[:] = _loglik(wk.Xc, D)
            elif request == sw.FIT_BEHAVIOURS:
                wk.llC[:] = _loglik(wk.C, D)
            else:
                raise AssertionError(f"AFSA asked for {request}")
            n += sw.evaluations(request, N)
            phase += 1
            request = sw.swarm_move(sw.AFSA, afsa, phase, X, D, p, 1.0, it, wk, s)
        evals.append(n)
        improved.append(bool(np.any(wk.ll > before)))
        assert np.allclose(wk.ll, _loglik(X, D))
    return evals, improved


def _params(**over):
    keys = {k: key.default for k, key in sw.keys("afsa").items()}
    keys.update(over)
    return sw.swarm_params("afsa", keys)


@pytest.mark.parametrize("afsa", [sw.AFSA_JOINT_SHIFT, sw.AFSA_FISH_SHIFT])
def test_converge_stops_when_no_fish_improves(afsa):
    """Fish all at the optimum: no behaviour finds a fitter place, the first iteration improves
    nothing and the next ones are over at once (no draws, no evaluations)."""
    N, D = 12, 2
    X = np.ones(N * D)
    evals, improved = _drive(X.copy(), D, _params(converge=True), 5, afsa)
    assert improved[0] is False
    assert evals == [4 * N, 0, 0, 0, 0]
    evals, _ = _drive(X.copy(), D, _params(converge=False), 5, afsa)
    assert evals == [4 * N] * 5


@pytest.mark.parametrize("prey", ["fish", "random_point"])
def test_converge_runs_until_an_iteration_improves_nothing_or_the_cap(prey):
    """A cloud far from the optimum: under converge each iteration is the plain one (same draws,
    same positions) until the first that improves no fish, after which nothing runs; the cap is
    'iterations'."""
    N, D, cap = 16, 2, 6
    for seed in range(4):
        X0 = np.random.default_rng(seed).normal(4.0, 2.0, N * D)
        Xa, Xb = X0.copy(), X0.copy()
        ev_a, imp_a = _drive(Xa, D, _params(converge=True, prey_target=prey, visual=0.3), cap,
                             seed=seed)
        ev_b, imp_b = _drive(Xb, D, _params(converge=False, prey_target=prey, visual=0.3), cap,
                             seed=seed)
        ran = next((k + 1 for k, imp in enumerate(imp_b) if not imp), cap)
        assert [e > 0 for e in ev_a] == [k < ran for k in range(cap)]
        assert ev_a[:ran] == ev_b[:ran]
        if ran == cap:
            assert all(imp_b)
        # the converged run stopped where the plain run stood after `ran` iterations
        Xc = X0.copy()
        _drive(Xc, D, _params(converge=False, prey_target=prey, visual=0.3), ran, seed=seed)
        assert np.array_equal(Xa, Xc)


@pytest.mark.parametrize("afsa", [sw.AFSA_JOINT_SHIFT, sw.AFSA_FISH_SHIFT])
def test_random_point_prey_tries_and_counts_its_evaluations(afsa):
    """Each try asks for N evaluations of its points; the tries stop at p.tries or once every
    fish found a fitter point, then the iteration is the usual 4 N."""
    N, D = 20, 2
    X = np.random.default_rng(5).normal(4.0, 2.0, N * D)
    for tries in (1, 3, 8):
        evals, _ = _drive(X.copy(), D, _params(prey_target="random_point", tries=tries), 2, afsa)
        assert all(4 * N + N <= e <= 4 * N + tries * N and e % N == 0 for e in evals)
    # fish all at the optimum never find a fitter point: every try runs
    evals, _ = _drive(np.ones(N * D), D, _params(prey_target="random_point", tries=3), 1, afsa)
    assert evals == [4 * N + 3 * N]


# --- end to end -----------------------------------------------------------------------------------

def _ungm_run(kind, N=40, **over):
    from pfbench.models.scalar import simulate
    from pfbench.scenarios import ungm
    model = ungm.build({k: v.default for k, v in ungm.SCHEMA.items()})
    _, y = simulate(model, _state(1))
    ft = FILTERS[kind]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    return ft.run(model, y, Params(p), N, _state(2))


@pytest.mark.parametrize("kind, over, differs", [
    ("ba", {"ba_accept": "better_than_best"}, True),
    ("ba", {"ba_walk": "uniform"}, True),
    ("ifa", {"ewa_copies": "ceil_plus_one"}, True),
    ("ifa", {"ewa_copies": "floor_plus_one"}, False),   # differs only where W / delta is whole
    ("afsa", {"prey_target": "random_point"}, True),
    ("afsa", {"converge": True, "iterations": 5}, True),
])
def test_each_reading_runs_in_the_swarm_pfs(kind, over, differs):
    base = _ungm_run(kind)
    out = _ungm_run(kind, **over)
    assert np.isfinite(out["xhat"]).all()
    if differs:
        assert not np.array_equal(base["xhat"], out["xhat"])
    if "prey_target" in over:
        assert out["lik_evals_per_step"] > base["lik_evals_per_step"]


@pytest.mark.parametrize("over", [
    {"refine": "ba", "ba_accept": "better_than_best"},
    {"refine": "ba", "ba_walk": "uniform"},
    {"refine": "afsa", "prey_target": "random_point", "tries": 2},
    {"refine": "afsa", "converge": True, "iterations": 4},
    {"resampling": "stepwise_ewa", "ewa_copies": "ceil_plus_one"},
])
def test_each_reading_runs_in_fastslam(over):
    from pfbench.scenarios import waypoint_course as wc

    from .conftest import ROOT
    p = {k: v.default for k, v in wc.SCHEMA.items()}
    p.update(steps=800)
    model = wc.build(wc.resolve(p, ROOT / "configs"))
    _, data = wc.simulate(model, _state(9))
    ft = FILTERS["fastslam"]

    def run(**o):
        q = {k: v.default for k, v in ft.schema.items()}
        q.update(o)
        return ft.run(model, data, Params(q), 20, _state(4))

    base = {k: v for k, v in over.items() if k in ("refine", "resampling")}
    a, b = run(**base), run(**over)
    assert np.isfinite(b["pose"]).all()
    assert not np.array_equal(a["pose"], b["pose"])
