"""The readings of ifa2021's firefly PFs that the text leaves open: each choice's arithmetic on a
small case worked by hand (or by numpy beside the kernel), and each choice end to end."""
import math

import numpy as np
import pytest
from scipy import stats

from pfbench import codes
from pfbench.filters import swarm
from pfbench.rng import state_from_seed


def _state(k=0):
    return state_from_seed(np.random.SeedSequence(k))


def _reference(X, bright, D, beta0, gamma, toward, alpha=None, R=None):
    """Firefly moves without a random term, written out in numpy: each i toward the brighter j
    of ``toward``, in place or from the positions at the start; the step a (alpha, or
    exp(-R I_i / I_j)) multiplies a zero term, so only the attraction moves."""
    X = X.reshape(-1, D).copy()
    start = X.copy()
    N = len(bright)
    for i in range(N):
        js = [int(np.argmax(bright))] if toward == "brightest" else range(N)
        for j in js:
            if bright[j] > bright[i]:
                src = start if toward == "brighter_all_at_once" else X
                r2 = float(np.sum((src[i] - src[j]) ** 2))
                X[i] = X[i] + beta0 * math.exp(-gamma * r2) * (src[j] - src[i])
    return X.ravel()


def _move(kind, X, bright, D, law, toward, beta0=1.0, gamma=0.5, step=0.3, s=None):
    X = X.copy()
    mover = swarm.fa_move if kind == "fa" else swarm.ifa_move
    mover(X, bright, D, beta0, gamma, step, np.ones(D), s if s is not None else _state(),
          codes.RANDOM_TERMS[law], codes.MOVE_TOWARD[toward])
    return X


@pytest.mark.parametrize("kind", ["fa", "ifa"])
@pytest.mark.parametrize("toward", list(codes.MOVE_TOWARD))
@pytest.mark.parametrize("D", [1, 2])
def test_attraction_of_each_reading_matches_numpy(kind, toward, D):
    """Without the random term, each move is the attraction as written out in numpy: in place
    (later fireflies see moved ones), all at once (from a frozen copy), toward the brightest."""
    rng = np.random.default_rng(3)
    N = 9
    X = rng.normal(0.0, 1.0, N * D)
    bright = rng.uniform(0.1, 1.0, N)
    got = _move(kind, X, bright, D, "none", toward)
    want = _reference(X, bright, D, 1.0, 0.5, toward)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_the_three_move_readings_differ():
    """In place and all at once differ once a firefly moved before another is attracted to it;
    toward the brightest, every firefly but the brightest lands on the line to the brightest."""
    X = np.array([0.0, 1.0, 3.0])
    bright = np.array([0.2, 0.5, 0.9])
    inplace = _move("fa", X, bright, 1, "none", "brighter_in_place", gamma=0.1)
    jacobi = _move("fa", X, bright, 1, "none", "brighter_all_at_once", gamma=0.1)
    best = _move("fa", X, bright, 1, "none", "brightest", gamma=0.1)
    # by hand: firefly 1 moves toward 2 by exp(-0.1 * 4) * 2 in both
    moved1 = 1.0 + math.exp(-0.4) * 2.0
    assert inplace[1] == pytest.approx(moved1) and jacobi[1] == pytest.approx(moved1)
    # firefly 0: toward 1, then toward 2; in place its distance to 2 is from where the first
    # move left it, all at once from its start
    x0 = 0.0 + math.exp(-0.1) * 1.0
    x0_inplace = x0 + math.exp(-0.1 * (3.0 - x0) ** 2) * (3.0 - x0)
    x0_jacobi = x0 + math.exp(-0.1 * 9.0) * 3.0
    assert inplace[0] == pytest.approx(x0_inplace) and jacobi[0] == pytest.approx(x0_jacobi)
    assert best[0] == pytest.approx(math.exp(-0.9) * 3.0) and best[2] == 3.0
    assert inplace[2] == jacobi[2] == 3.0


def test_all_at_once_sees_the_start_positions_when_a_brighter_one_moved_first():
    """The mid-bright firefly (index 0) moves before the dimmest (index 1) is attracted to it:
    in place the dimmest sees it moved, all at once where it started."""
    X = np.array([1.0, 0.0, 3.0])       # index 0 mid-bright, 1 dimmest, 2 brightest
    bright = np.array([0.5, 0.2, 0.9])
    inplace = _move("fa", X, bright, 1, "none", "brighter_in_place", gamma=0.1)
    jacobi = _move("fa", X, bright, 1, "none", "brighter_all_at_once", gamma=0.1)
    moved0 = 1.0 + math.exp(-0.4) * 2.0
    x1 = 0.0 + math.exp(-0.1 * moved0 ** 2) * moved0          # toward 0 as moved
    x1 = x1 + math.exp(-0.1 * (3.0 - x1) ** 2) * (3.0 - x1)
    assert inplace[1] == pytest.approx(x1)
    j1 = math.exp(-0.1) * 1.0 + math.exp(-0.9) * 3.0           # both from the start positions
    assert jacobi[1] == pytest.approx(j1)


def _one_draw_each(law, n=100_000, seed=5):
    """n draws of the random term: fireflies 1..n each take one step toward the brightest
    (firefly 0) with no attraction and a unit step, so each moves by exactly one draw."""
    X = np.zeros(n + 1)
    bright = np.zeros(n + 1)
    bright[0] = 1.0
    return _move("fa", X, bright, 1, law, "brightest", beta0=0.0, step=1.0, s=_state(seed))[1:]


@pytest.mark.parametrize("law, lo, hi, var, dist", [
    ("uniform_half", -0.5, 0.5, 1.0 / 12.0, stats.uniform(-0.5, 1.0)),
    ("uniform_sqrt3", -math.sqrt(3.0), math.sqrt(3.0), 1.0,
     stats.uniform(-math.sqrt(3.0), 2.0 * math.sqrt(3.0))),
    ("gaussian", -np.inf, np.inf, 1.0, stats.norm()),
])
def test_random_terms_have_their_law(law, lo, hi, var, dist):
    """Mean 0 and the stated variance within 6 standard errors of 100 000 draws (var of the
    sample variance (mu4 - sigma^4) / n); the bounds; a KS test at level 1e-3 (fixed seed)."""
    e = _one_draw_each(law)
    n = e.size
    mu4 = dist.moment(4)
    assert abs(e.mean()) < 6.0 * math.sqrt(var / n)
    assert abs(e.var() - var) < 6.0 * math.sqrt((mu4 - var * var) / n)
    assert e.min() >= lo and e.max() <= hi
    assert stats.kstest(e, dist.cdf).pvalue > 1e-3


def test_no_random_term_draws_nothing():
    """'none': the fireflies only attract, and the generator is where it was."""
    s = _state(7)
    before = s.copy()
    X = np.array([0.0, 2.0])
    out = _move("ifa", X, np.array([0.1, 0.9]), 1, "none", "brighter_in_place", s=s)
    assert out[0] == pytest.approx(math.exp(-0.5 * 4.0) * 2.0) and out[1] == 2.0
    assert np.array_equal(s, before)


def test_distance_brightness_moves_toward_the_nearer_with_the_step_of_the_distance_ratio():
    """A distance brightness comes as I = -d: firefly 0 (d = 2) moves toward 1 (d = 1), with
    the step exp(-R d_0 / d_1) = exp(-2 R); the brighter one does not move."""
    R = 0.7
    X = np.array([0.0, 5.0])
    e = _move("fa", X, np.array([-2.0, -1.0]), 1, "gaussian", "brighter_in_place", beta0=0.0,
              step=1.0, s=_state(11))[0]                        # the draw itself
    got = _move("ifa", X, np.array([-2.0, -1.0]), 1, "gaussian", "brighter_in_place", beta0=0.0,
                step=R, s=_state(11))
    assert got[0] == pytest.approx(math.exp(-2.0 * R) * e, rel=1e-12) and got[1] == 5.0
    # a firefly at distance 0 attracts with no random step (exp(-inf) = 0)
    got = _move("ifa", X, np.array([-2.0, -0.0]), 1, "gaussian", "brighter_in_place",
                beta0=0.0, step=R, s=_state(11))
    assert got[0] == 0.0


def _ungm(steps=20, seed=1):
    from pfbench.models.scalar import simulate
    from pfbench.scenarios import ungm

    model = ungm.build({**{k: v.default for k, v in ungm.SCHEMA.items()}, "steps": steps})
    x, y = simulate(model, _state(seed))
    return model, x, y


@pytest.mark.parametrize("kind", ["likelihood", "distance"])
def test_brightness_readings_from_a_hand_computed_distance(kind):
    """IFA's brightness on UNGM (Q = R = 1): the likelihood reading is exp(ll - max ll), the
    distance reading -sqrt((y - h(x))^2 / R + (x - f(xhat))^2 / Q)."""
    from pfbench.filters.swarm_pf import predicted_distance_brightness

    model, _, y = _ungm()
    xn = np.array([-3.0, -0.5, 0.2, 1.7, 4.0])
    tt, yt, xprev = 3.0, float(y[3]), 0.8
    hx = np.empty_like(xn)
    model.observe(xn, tt, model.theta, hx)
    fbar = np.empty(1)
    model.transition(np.array([xprev]), tt, model.theta, fbar)
    R, Q = model.noise[3], model.noise[1]
    ll = -0.5 * (yt - hx) ** 2 / R
    wk = swarm.new_swarm_work(xn.size, 1)
    wk.ll[:] = ll
    predicted_distance_brightness(model.transition, model.theta, tt, xprev, model.noise, xn,
                                  ll.max(), codes.BRIGHTNESS[kind], 0, wk, np.empty(2))
    if kind == "likelihood":
        want = np.exp(ll - ll.max())
    else:
        want = -np.sqrt((yt - hx) ** 2 / R + (xn - fbar[0]) ** 2 / Q)
    np.testing.assert_allclose(wk.fit, want, rtol=1e-12)


@pytest.mark.parametrize("noise", [np.array([0.0, 2.0, 0.0, 1.0]),     # Gaussian, Q = 2
                                   np.array([1.0, 3.0, 2.0, 1.0])])    # Gamma(3, rate 2)
def test_prior_ratio_is_the_closed_form(noise):
    """ll + log p(x' | x_{t-1}) - log p(x | x_{t-1}): on a Gaussian transition
    -(x' - f)^2 / 2Q + (x - f)^2 / 2Q, on a Gamma one the ratio of scipy's densities."""
    from pfbench.filters.swarm_pf import add_prior_ratio

    fx = np.array([0.0, 1.0, -2.0, 0.5])
    xpre = fx + np.array([0.3, 1.2, 0.7, 2.5])
    xn = fx + np.array([0.1, 2.0, 0.7, 0.4])
    ll0 = np.array([-0.5, -1.0, -2.0, -0.1])
    ll = ll0.copy()
    add_prior_ratio(noise, fx, xpre, xn, ll)
    if noise[0] == codes.NOISE_GAUSSIAN:
        Q = noise[1]
        want = ll0 - (xn - fx) ** 2 / (2 * Q) + (xpre - fx) ** 2 / (2 * Q)
    else:
        g = stats.gamma(noise[1], scale=1.0 / noise[2])
        want = ll0 + g.logpdf(xn - fx) - g.logpdf(xpre - fx)
    np.testing.assert_allclose(ll, want, rtol=1e-12)


def _run(name, model, y, seed=2, N=48, **over):
    from pfbench.config import Params
    from pfbench.filters import FILTERS

    ft = FILTERS[name]
    p = {k: v.default for k, v in ft.schema.items()}
    p.update(over)
    assert ft.check(p) is None
    return ft.run(model, y, Params(p), N, _state(seed))


def test_prior_ratio_without_a_move_is_the_plain_weight():
    """With no swarm iteration the prior ratio is exactly 1: bit for bit the uncorrected filter."""
    model, _, y = _ungm()
    a = _run("ifa", model, y, iterations=0)
    b = _run("ifa", model, y, iterations=0, move_correction="prior_ratio")
    assert np.array_equal(a["xhat"], b["xhat"])


CHOICES = ([("ifa", "brightness", v) for v in ("inverse", "likelihood", "distance")]
           + [(k, "random_term", v) for k in ("fa", "ifa")
              for v in ("uniform_sqrt3", "gaussian", "none")]
           + [(k, "move_toward", v) for k in ("fa", "ifa")
              for v in ("brighter_all_at_once", "brightest")]
           + [(k, "move_correction", "prior_ratio") for k in ("fa", "ifa", "ba", "pso", "afsa")]
           + [(k, "move_order", "resample_then_move")
              for k in ("fa", "ifa", "ba", "pso", "afsa")])


@pytest.mark.parametrize("name, key, value", CHOICES)
def test_each_reading_runs_end_to_end(name, key, value):
    """Each reading runs a swarm PF on UNGM to a finite estimate, differs from the default, and
    costs the default's likelihood evaluations (resample_then_move with systematic resampling:
    the moved set's evaluations replace the predicted set's, none extra)."""
    model, x, y = _ungm(steps=30)
    base = _run(name, model, y, resampling="systematic")
    got = _run(name, model, y, resampling="systematic", **{key: value})
    assert np.all(np.isfinite(got["xhat"]))
    assert not np.array_equal(base["xhat"], got["xhat"])
    assert got["lik_evals_per_step"] == base["lik_evals_per_step"]
    assert np.sqrt(np.mean((got["xhat"][1:] - x[1:]) ** 2)) < 20.0


def test_resample_then_move_with_the_stepwise_ewa_runs_and_counts_its_mutants():
    """With the stepwise EWA a mutant's likelihood is evaluated again: at least the default's
    evaluations."""
    model, _, y = _ungm(steps=30)
    base = _run("ifa", model, y)
    got = _run("ifa", model, y, move_order="resample_then_move")
    assert np.all(np.isfinite(got["xhat"]))
    assert got["lik_evals_per_step"] >= base["lik_evals_per_step"]


def test_resample_then_move_refuses_an_estimate_after_resampling(tmp_path):
    """The moved set's weighted mean is its estimate: 'after_resampling' is refused, exit 2."""
    from typer.testing import CliRunner

    from pfbench.cli import app

    from .conftest import ROOT
    r = CliRunner().invoke(app, ["validate", str(ROOT / "configs/ifa_pf_ungm.yaml"), "--set",
                                 "filters.ifa.move_order=resample_then_move", "--set",
                                 "filters.ifa.estimate=after_resampling"])
    assert r.exit_code == 2 and "resample_then_move" in r.output


def test_the_move_readings_reach_fastslam_with_its_defaults_unchanged():
    """FastSLAM takes FA's firefly keys for FA and IFA: their defaults are pfbench's codes 0, a
    choice lands in the swarm parameters, and a FastSLAM run moves differently with it."""
    from pfbench.config import load
    from pfbench.filters.fastslam import FASTSLAM
    from pfbench.runner import run_trial

    from .conftest import ROOT
    p = {k: v.default for k, v in FASTSLAM.schema.items()}
    for algo in ("fa", "ifa"):
        sp = swarm.swarm_params(algo, p)
        assert sp.random_term == 0.0 and sp.move_toward == 0.0
        sp = swarm.swarm_params(algo, {**p, "random_term": "none", "move_toward": "brightest"})
        assert sp.random_term == codes.RANDOM_NONE and sp.move_toward == codes.TOWARD_BRIGHTEST
    sets = ["scenario.steps=400", "filters.fa.particles=20", "filters.ifa.particles=20"]

    def rmse(extra):
        exp = load(ROOT / "configs/ifa_fastslam.yaml", sets=sets + extra)
        return {r["filter"]: r["rmse"] for r in run_trial(exp, 0)}

    base = rmse([])
    moved = rmse(["filters.fa.move_toward=brightest", "filters.ifa.random_term=none"])
    assert base["fastslam@100"] == moved["fastslam@100"]
    assert base["fa@20"] != moved["fa@20"] and base["ifa@20"] != moved["ifa@20"]
