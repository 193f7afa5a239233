"""One owner per concept: the ziggurat's step, the ESS threshold rule, the stepwise EWA's code
and mutation each live in one function that the kernels call (no copy kept equal by hand), and
the kernels' step functions have names of their own."""
from __future__ import annotations

import ast
import functools
import re
from pathlib import Path

import numpy as np
import pytest

from .conftest import parsed

ROOT = Path(__file__).resolve().parent.parent / "pfbench"


def _sources() -> dict[str, str]:
    return {p.relative_to(ROOT.parent).as_posix(): p.read_text(encoding="utf-8")
            for p in sorted(ROOT.rglob("*.py"))}


@functools.cache
def _code(text: str) -> str:
    """A module's code without its comments and docstrings (``ast.unparse``'s spelling: single
    quotes, one space around operators); once per text in a test process."""
    tree = ast.parse(text)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            node.body = [b for b in body if not (isinstance(b, ast.Expr)
                                                 and isinstance(b.value, ast.Constant)
                                                 and isinstance(b.value.value, str))] or [
                ast.Pass()]
    return ast.unparse(tree)


def _where(pattern: str) -> list[str]:
    """The files of pfbench/ whose code (comments and docstrings aside) matches ``pattern``."""
    return [name for name, text in _sources().items() if re.search(pattern, _code(text))]


@pytest.mark.parametrize("pattern, owner", [
    # the ziggurat: its acceptance test reads the thresholds _ZKI (rng.in_layer_rectangle), and
    # the tail and wedge test on a local state is rng.normal_off_rectangle
    (r"_ZKI\[", "pfbench/rng.py"),
    (r"_normal_slow\(", "pfbench/rng.py"),
    # the ESS from the weights' sums, S^2 / S2: weights.ess
    (r"(\w+) \* \1 / (S2\b|\(\(q0)|1\.0 / S2\b", "pfbench/filters/weights.py"),
    # the ESS threshold a filter resamples below: resampling.ess_threshold
    (r"\['neff_ratio'\] \*", "pfbench/resampling.py"),
    # the stepwise EWA's scheme code after the standard ones: codes.STEPWISE_EWA
    (r"\bSTEPWISE_EWA = ", "pfbench/codes.py"),
    # the stepwise EWA's mutation v + v mu z: resampling.ewa_mutant
    (r"ewa_mu\s*\*\s*normal\(|\*\s*mu\s*\*\s*normal\(", "pfbench/resampling.py"),
])
def test_each_concept_is_written_once(pattern, owner):
    assert _where(pattern) == [owner]


def test_the_kernels_steps_do_not_share_names():
    """A name says what it does: no two modules define ``weigh``, ``compare`` or ``Finding``,
    none ``summarise`` beside metrics' ``summarize``, no kernel is a vague '_core'."""
    defined: dict[str, list[str]] = {}
    for name, text in _sources().items():
        for node in ast.walk(parsed(text)):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.col_offset == 0:
                defined.setdefault(node.name, []).append(name)
    for twice in ("weigh", "compare", "Finding"):
        assert len(defined.get(twice, [])) <= 1, (twice, defined[twice])
    assert "summarise" not in defined
    assert not [n for n in defined if n.endswith("_core")]
    assert not any(re.search(r"\b\w+_core\s*=\s*variant\(", t) for t in _sources().values())


def test_the_filters_steps_have_names_of_their_own():
    """No two filter modules define a function or class of one name (each filter's ``run``, the
    entry its FilterType names, aside): IFA's brightness of a scalar state and of a pose cloud,
    the UPF's and the field SSPF's MH moves are different steps."""
    defined: dict[str, list[str]] = {}
    for name, text in _sources().items():
        if name.startswith("pfbench/filters/"):
            for node in parsed(text).body:
                if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
                    defined.setdefault(node.name, []).append(name)
    assert {k: v for k, v in defined.items() if len(v) > 1 and k != "run"} == {}


def test_the_ziggurat_step_on_a_local_state_is_normals_draw():
    """rng's ziggurat step on a local state (next_local, _layer, in_layer_rectangle, else
    normal_off_rectangle), the one the kernels' loops write, draws what rng.normal draws and
    leaves the state where normal leaves it (tail and wedge draws included: 20,000 draws pass
    through them about 240 times)."""
    import numba

    from pfbench.rng import (_layer, in_layer_rectangle, load_local, next_local, normal,
                             normal_off_rectangle, state_from_seed, store_local)

    @numba.njit
    def local_draws(s, n):
        out = np.empty(n)
        q = load_local(s)
        for i in range(n):
            r, q = next_local(q)
            layer, rabs, x = _layer(r)
            if not in_layer_rectangle(layer, rabs):
                x, q = normal_off_rectangle(s, q, layer, rabs, x)
            out[i] = x
        store_local(s, q)
        return out

    @numba.njit
    def plain_draws(s, n):
        out = np.empty(n)
        for i in range(n):
            out[i] = normal(s)
        return out

    a = state_from_seed(np.random.SeedSequence(7))
    b = a.copy()
    assert np.array_equal(local_draws(a, 20_000), plain_draws(b, 20_000))
    assert np.array_equal(a, b)


@pytest.mark.parametrize("params, particles, expected", [
    ({"resample": "always", "neff_ratio": 0.5}, 100, np.inf),
    ({"resample": "neff", "neff_ratio": 0.5}, 100, 50.0),
    ({"resample": "neff", "neff_ratio": 1.0}, 7, 7.0),
    ({"resample": "neff", "neff_ratio": 0.0}, 1000, 0.0),
])
def test_ess_threshold(params, particles, expected):
    from pfbench.resampling import ess_threshold
    assert ess_threshold(params, particles) == expected


def test_ewa_mutant_is_v_plus_v_mu_z():
    import numba

    from pfbench.resampling import ewa_mutant
    from pfbench.rng import normal, state_from_seed

    @numba.njit
    def both(s, t, v, mu):
        return ewa_mutant(v, mu, s), v + v * mu * normal(t)

    s = state_from_seed(np.random.SeedSequence(3))
    t = s.copy()
    for v in (0.0, 1.5, -3.25, 1e300):
        a, b = both(s, t, v, 0.01)
        assert a == b or (np.isnan(a) and np.isnan(b))


# --- weights: one owner per arithmetic (pfbench/filters/weights.py) ------------------------------

WEIGHTS = "pfbench/filters/weights.py"
_EXP = {"exp"}


def _is_exp(node) -> bool:
    f = node.func if isinstance(node, ast.Call) else None
    return (isinstance(f, ast.Attribute) and f.attr in _EXP) or (isinstance(f, ast.Name)
                                                                 and f.id in _EXP)


def _is_max(node) -> bool:
    """A max: ``max(..)``, ``np.max(..)``, ``a.max()``, ``np.nanmax(..)``."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    name = f.attr if isinstance(f, ast.Attribute) else getattr(f, "id", "")
    return name in ("max", "amax", "nanmax")


def _shifted(expr, assigned: dict, varying: set) -> bool:
    """Whether ``expr`` holds a subtraction of a shift (a max, or a name the innermost loop does
    not assign: the same for every term) from something, directly or through a local name assigned
    such a difference."""
    for node in ast.walk(expr):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Sub) and (
                _is_max(node.right) or (isinstance(node.right, ast.Name)
                                        and node.right.id not in varying)):
            return True
        if isinstance(node, ast.Name) and node.id in assigned and \
                _shifted(assigned[node.id], {}, varying):
            return True
    return False


def inline_normalisers(source: str) -> list[str]:
    """The functions of ``source`` that write a max-shifted exponential themselves: in a loop,
    exp of a difference with a shift the loop leaves unchanged (the per-particle weights or
    fitness), or anywhere exp of a difference with a max (numpy's ``np.exp(lw - lw.max())``)."""
    found = []
    for fn in ast.walk(ast.parse(source)):
        if not isinstance(fn, ast.FunctionDef):
            continue
        assigned = {t.id: n.value for n in ast.walk(fn) if isinstance(n, ast.Assign)
                    for t in n.targets if isinstance(t, ast.Name)}
        loops = [n for n in ast.walk(fn) if isinstance(n, (ast.For, ast.While, ast.ListComp,
                                                           ast.GeneratorExp, ast.SetComp))]
        for call in (n for n in ast.walk(fn) if _is_exp(n) and n.args):
            arg = call.args[0]
            around = [lp for lp in loops if any(c is call for c in ast.walk(lp))]
            inner = min(around, key=lambda lp: sum(1 for _ in ast.walk(lp)), default=None)
            varying = {n.id for n in ast.walk(inner) if isinstance(n, ast.Name)
                       and isinstance(n.ctx, ast.Store)} if inner else set()
            by_max = any(isinstance(n, ast.BinOp) and isinstance(n.op, ast.Sub)
                         and _is_max(n.right) for n in ast.walk(arg))
            if by_max or (around and _shifted(arg, assigned, varying)):
                found.append(fn.name)
                break
    return found


def test_no_filter_writes_its_own_normaliser():
    """The max-shifted exponentials (weights from log-weights, a swarm's fitness) are written in
    weights.py alone: every filter calls it."""
    found = {name: inline_normalisers(text) for name, text in _sources().items()
             if name.startswith("pfbench/filters/") and name != WEIGHTS}
    assert {k: v for k, v in found.items() if v} == {}
    assert inline_normalisers(_sources()[WEIGHTS])      # the scan sees the owner's own


@pytest.mark.parametrize("body", [
    "for i in range(n):\n        w[i] = math.exp(lw[i] - mx)",
    "for i in range(n):\n        l = lw[i] - m\n        w[i] = vm.exp(l)",
    "w = np.exp(lw - lw.max())",
    "w = np.exp(lw - np.max(lw))",
    "for i in range(n):\n        fit[i] = math.exp(ll[i] - M0 - 0.5 * d2)",
    "w = [math.exp(l - m) for l in lw]",
    ("for k in range(3):\n        M = ll.max()\n        for i in range(n):\n"
     "            fit[i] = math.exp(ll[i] - M)"),
    "while i < n:\n        w[i] = exp(lw[i] - shift)\n        i += 1",
])
def test_the_scan_catches_an_inline_normaliser(body):
    assert inline_normalisers(f"def weigh_again(lw, w, n, m):\n    {body}\n") == ["weigh_again"]


@pytest.mark.parametrize("body", [
    "for i in range(n):\n        b = math.exp(-gamma * d2[i])",       # a firefly's attraction
    ("for i in range(n):\n        lt, lq = f(i), g(i)\n        la = (lt - lq) - (c[i] - d[i])\n"
     "        ok = u < math.exp(la)"),                                      # an MH acceptance
    "return hi + math.log1p(math.exp(-abs(l - log_floor)))",          # a floor, no loop
])
def test_the_scan_leaves_other_exponentials(body):
    assert inline_normalisers(f"def other(lw, w, n, m):\n    {body}\n") == []


def test_each_weights_variant_is_defined_once():
    defined: dict[str, list[str]] = {}
    for name, text in _sources().items():
        for node in parsed(text).body:
            if isinstance(node, ast.FunctionDef):
                defined.setdefault(node.name, []).append(name)
    for fn in ("normalise", "normalise_lanes", "exp_pass", "exp_sum", "lane_sum", "normalised",
               "shifted_exp", "shifted_exp_less", "divide", "reset_unless_finite"):
        assert defined.get(fn) == [WEIGHTS], (fn, defined.get(fn))


def test_the_weights_variants_keep_their_contracts():
    """Each variant computes what its docstring says: the C library's exponential exactly where
    it says so, vecmath's within 2 ulp, sums to rounding, the underflow resets."""
    import math

    from pfbench.filters import weights as W

    rng = np.random.default_rng(5)
    lw = np.concatenate([rng.normal(0.0, 30.0, 37), [-np.inf, np.nan, -800.0]])
    x = rng.normal(size=lw.size)
    m = float(np.nanmax(lw))
    exact = np.array([0.0 if math.isnan(v) else math.exp(v - m) for v in lw])

    a, wa = lw.copy(), np.empty(lw.size)
    S, S2, sx, under = W.normalise(a, wa, x, m)
    assert np.array_equal(wa, exact) and under == 0.0
    assert S == math.fsum(exact) or abs(S - math.fsum(exact)) <= 1e-15 * S
    assert abs(sx - math.fsum(exact * x)) <= 1e-12 and abs(S2 - math.fsum(exact ** 2)) <= 1e-12
    b, wb = lw.copy(), np.empty(lw.size)
    Sl, _, sxl, underl = W.normalise_lanes(b, wb, x, m)
    big = exact > 1e-300
    assert np.allclose(wb[big], exact[big], rtol=5e-16, atol=0) and wb[-1] == 0.0
    assert abs(Sl - S) <= 1e-14 * S and abs(sxl - sx) <= 1e-12 and underl == 0.0

    dead, w = np.full(5, -np.inf), np.empty(5)
    assert W.normalise(dead, w, np.zeros(5), -np.inf) == (5.0, 5.0, 0.0, 1.0)
    assert np.array_equal(w, np.ones(5))

    out = np.empty(lw.size)
    W.exp_pass(lw, m, lw.size - 1, out)
    assert np.allclose(out[:-1][big[:-1]], exact[:-1][big[:-1]], rtol=5e-16, atol=0)
    assert W.exp_sum(lw, m, 7, out) == W.lane_sum(out, 7)
    assert abs(W.lane_sum(out, 7) - math.fsum(out[:7])) <= 1e-15 * math.fsum(out[:7])

    fin = lw[np.isfinite(lw)]
    Wn = np.empty(fin.size)
    assert W.normalised(fin.copy(), Wn, float(fin.max())) == 0.0
    assert abs(Wn.sum() - 1.0) <= 1e-14 and Wn.argmax() == fin.argmax()
    bad = np.array([0.0, np.inf, 1.0])
    assert W.normalised(bad, np.empty(3), np.inf) == 1.0 and np.array_equal(bad, np.zeros(3))

    sh, less = np.empty(fin.size), np.full(fin.size, 0.25)
    W.shifted_exp(fin, 1.5, sh)
    assert np.array_equal(sh, [math.exp(v - 1.5) for v in fin])
    W.shifted_exp_less(fin, 1.5, less, less)
    assert np.array_equal(less, [math.exp(v - 1.5 - 0.25) for v in fin])
    d = np.empty(3)
    W.divide(np.array([1.0, 2.0, 5.0]), 8.0, d)
    assert np.array_equal(d, [0.125, 0.25, 0.625])


# --- swarms: one dispatcher (swarm.swarm_move), one scratch record (swarm.SwarmWork) --------------

_MOVES = r"\b(fa_move|ifa_move|ba_propose|ba_accept|pso_propose|pso_accept|afsa_centres|" \
         r"afsa_propose|afsa_select)\("


def test_the_swarm_moves_are_dispatched_in_one_place():
    """Only swarm.py runs the swarm moves (its ``swarm_move`` dispatches them); the filters
    evaluate what it asks for."""
    assert _where(_MOVES) == ["pfbench/filters/swarm.py"]


def test_one_swarm_scratch_record():
    """The swarm's scratch (velocities, bests, loudness, candidates) is one record type."""
    holders = []
    for name, text in _sources().items():
        for node in ast.walk(parsed(text)):
            if isinstance(node, ast.ClassDef):
                fields = {b.target.id for b in node.body if isinstance(b, ast.AnnAssign)
                          and isinstance(b.target, ast.Name)}
                if fields & {"Pfit", "Pb"} or {"V", "A"} <= fields:
                    holders.append(f"{name}:{node.name}")
    assert holders == ["pfbench/filters/swarm.py:SwarmWork"]


@pytest.mark.parametrize("algo, afsa", [(0, 0), (1, 0), (2, 0), (3, 0), (4, 0), (4, 1)])
def test_swarm_move_asks_for_what_it_needs(algo, afsa):
    """Driven with a fitness of our own (a Gaussian log-likelihood in D = 2), every algorithm's
    iterations end with the log-likelihoods of where the particles are, after the evaluations its
    cost says (AFSA 4 N, the others N); both AFSA arithmetics."""
    from pfbench.filters import swarm as sw
    from pfbench.rng import state_from_seed

    N, D = 24, 2
    rng = np.random.default_rng(algo + 10 * afsa)
    X = rng.normal(0.0, 2.0, N * D)
    wk = sw.new_swarm_work(N, D)

    def loglik(pts):
        q = pts.reshape(-1, D)
        return -0.5 * (q * q).sum(axis=1)

    name = {v: k for k, v in sw.ALGORITHMS.items()}[algo]
    p = sw.swarm_params(name, {k: key.default for k, key in sw.keys(name).items()})
    s = state_from_seed(np.random.SeedSequence(1))
    wk.ll[:] = loglik(X)
    for it in range(3):
        phase, evals, seen = 0, 0, []
        request = sw.swarm_move(algo, afsa, phase, X, D, p, 1.0, it, wk, s)
        while request != sw.DONE:
            seen.append(request)
            if request == sw.FIT_X:
                wk.ll[:] = loglik(X)
            elif request == sw.FIT_CANDIDATES:
                wk.llC[:N] = loglik(wk.C[:N * D])
            elif request == sw.FIT_CENTRES:
                wk.llc[:] = loglik(wk.Xc)
            elif request == sw.FIT_BEHAVIOURS:
                wk.llC[:] = loglik(wk.C)
            else:
                assert request == sw.FIT_BRIGHTNESS
                wk.fit[:] = np.exp(wk.ll - wk.ll.max())
            evals += sw.evaluations(request, N)
            phase += 1
            assert phase < 5
            request = sw.swarm_move(algo, afsa, phase, X, D, p, 1.0, it, wk, s)
        assert evals == (4 * N if algo == sw.AFSA else N), seen
        assert np.allclose(wk.ll, loglik(X), rtol=1e-12, atol=1e-12)
        assert np.all(np.isfinite(X))
