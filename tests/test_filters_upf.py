"""EKF, PF+MH, UPF and SSPF against exact answers; the MH move; the Gamma benchmark's pieces."""
import math

import numpy as np
import pytest

from pfbench.filters import FILTERS
from pfbench.filters._common import mh_move
from pfbench.rng import standard_gamma, state_from_seed
from pfbench.scenarios import linear_gaussian, upf_gamma
from pfbench.models.scalar import process_logpdf, simulate

from .conftest import default_params

_params = default_params


def _linear(**over):
    return linear_gaussian.build(_params(linear_gaussian.SCHEMA, **over))


def _run(kind, model, y, N=None, seed=0, **over):
    ftype = FILTERS[kind]
    return ftype.run(model, y, _params(ftype.schema, **over), N,
                     state_from_seed(np.random.SeedSequence(seed)))


@pytest.mark.parametrize("a,c,Q,R", [(0.9, 1.0, 1.0, 1.0), (1.05, 0.3, 0.1, 4.0),
                                     (-0.5, 2.0, 10.0, 0.01)])
def test_ekf_equals_kalman_on_linear_gaussian(a, c, Q, R):
    model = _linear(a=a, c=c, process_noise_var=Q, measurement_noise_var=R, steps=80, prior_var=2.0)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(11)))
    kf = _run("kf", model, y)
    ek = _run("ekf", model, y)
    assert np.max(np.abs(ek["xhat"] - kf["xhat"])) <= 1e-10 * max(1.0, np.abs(kf["xhat"]).max())
    assert np.max(np.abs(ek["pvar"] - kf["pvar"])) <= 1e-10 * max(1.0, kf["pvar"].max())


@pytest.mark.parametrize("kind,extra", [("upf", {}), ("sspf", {}), ("pfmh", {}),
                                        ("upf", {"resample": "neff"})])
def test_particle_filters_are_unbiased_against_kalman(kind, extra):
    model = _linear(a=0.9, c=1.0, process_noise_var=1.0, measurement_noise_var=0.5, steps=20)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(3)))
    m = _run("kf", model, y)["xhat"]
    errs = np.array([_run(kind, model, y, 300, r, **extra)["xhat"] - m for r in range(200)])[:, 1:]
    se = errs.std(axis=0, ddof=1) / math.sqrt(errs.shape[0])
    # the bias of these filters is O(1/N): far below 5 standard errors of 200 runs at N = 300
    assert np.all(np.abs(errs.mean(axis=0)) < 5 * se + 1e-12)
    assert np.sqrt(np.mean(errs ** 2)) < 0.15


def test_upf_with_the_optimal_proposal_beats_the_bootstrap_pf_on_informative_measurements():
    # With R << Q the transition prior is a poor proposal; the UKF proposal is the optimal one on a
    # linear-Gaussian model, so the UPF's error to the Kalman mean is far smaller at equal N.
    model = _linear(a=0.9, c=1.0, process_noise_var=4.0, measurement_noise_var=0.01, steps=30)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(8)))
    m = _run("kf", model, y)["xhat"][1:]
    e_pf = np.mean([np.mean((_run("pf", model, y, 100, r)["xhat"][1:] - m) ** 2)
                    for r in range(30)])
    e_upf = np.mean([np.mean((_run("upf", model, y, 100, r)["xhat"][1:] - m) ** 2)
                     for r in range(30)])
    assert e_upf < e_pf / 10


def test_mh_move_leaves_the_posterior_invariant():
    # One step of x_t = a x + w, y_t = x_t + v. Draw (x_{t-1}, x_t) exactly from their joint
    # posterior given y_t; the move targets p(x_t | x_{t-1}, y_t), so x_t keeps the Kalman
    # posterior N(m_t, P_t) as its marginal.
    a, Q, R, m0, P0, yt = 0.9, 1.0, 0.5, 0.3, 2.0, 1.7
    model = _linear(a=a, c=1.0, process_noise_var=Q, measurement_noise_var=R)
    Pp = a * a * P0 + Q
    K = Pp / (Pp + R)
    mt, Pt = a * m0 + K * (yt - a * m0), (1 - K) * Pp
    # x_{t-1} | x_t is Gaussian: the backward (RTS) conditional
    J = P0 * a / Pp
    rng = np.random.default_rng(0)
    N = 200_000
    xt = rng.normal(mt, math.sqrt(Pt), N)
    xprev = rng.normal(m0 + J * (xt - a * m0), math.sqrt(P0 - J * a * P0), N)
    x = xt.copy()
    hx = x.copy()
    prop, hprop = np.empty(N), np.empty(N)
    s = state_from_seed(np.random.SeedSequence(1))
    accepted = 0
    for _ in range(3):
        accepted += mh_move(model.transition, model.observe, model.theta, model.noise, xprev, x,
                            hx, yt, 1.0, -np.inf, s, prop, hprop)
    assert 0.2 * 3 * N < accepted < 3 * N           # it does move particles
    assert np.mean(x != xt) > 0.5
    se_m = math.sqrt(Pt / N)
    assert abs(x.mean() - mt) < 5 * se_m
    assert abs(x.var() - Pt) < 5 * Pt * math.sqrt(2 / N)


def test_standard_gamma_moments():
    s = state_from_seed(np.random.SeedSequence(4))
    for shape in (0.5, 1.0, 3.0, 10.0):
        n = 200_000
        g = np.array([standard_gamma(s, shape) for _ in range(n)])
        assert np.all(g > 0)
        assert abs(g.mean() - shape) < 5 * math.sqrt(shape / n)
        assert abs(g.var() - shape) < 5 * shape * math.sqrt((2 + 6 / shape) / n)


@pytest.mark.parametrize("noise", [[0, 0.7, 0, 1], [1, 3.0, 2.0, 1], [1, 0.8, 1.5, 1]])
def test_process_density_integrates_to_one_with_the_right_mean(noise):
    noise = np.array(noise, dtype=float)
    w = np.linspace(-15, 15, 600_001)
    p = np.exp([process_logpdf(noise, v) for v in w])
    dw = w[1] - w[0]
    assert abs(p.sum() * dw - 1) < 2e-3
    mean = 0.0 if noise[0] == 0 else noise[1] / noise[2]
    assert abs((w * p).sum() * dw - mean) < 2e-3


def test_upf_gamma_simulation_follows_the_model():
    model = upf_gamma.build(_params(upf_gamma.SCHEMA))
    x, y = simulate(model, state_from_seed(np.random.SeedSequence(2)))
    assert x.size == 60 and x[0] == 1.0
    t = np.arange(1, 60)
    fx = 1 + np.sin(0.04 * np.pi * (t + 1)) + 0.5 * x[:-1]
    w = x[1:] - fx
    assert np.all(w > 0)                                  # Gamma noise is positive
    assert abs(w.mean() - 1.5) < 5 * math.sqrt(0.75 / 59)
    h = np.where(t + 1 <= 30, x[1:] ** 2 / 5, x[1:] / 2 - 2)
    assert np.max(np.abs(y[1:] - h)) < 6 * math.sqrt(1e-5)


def test_floored_loglik_is_log_of_likelihood_plus_floor():
    from pfbench.filters._common import floored
    for l in (-1000.0, -300.0, -228.0, -5.0, 0.0, 3.0):
        for floor in (1e-99, 1e-10, 0.5):
            want = np.logaddexp(l, math.log(floor))
            assert math.isclose(floored(l, math.log(floor)), want, rel_tol=1e-12, abs_tol=1e-12)
        assert floored(l, -np.inf) == l


def test_likelihood_floor_ties_all_particles_when_none_is_near():
    # Every particle is far from y (likelihood below 1e-99 for all): the floor makes all weights
    # equal (ESS = N); without it the nearest particles dominate.
    model = _linear(steps=1, prior_var=1.0, measurement_noise_var=1e-5)
    y = np.array([0.0, 50.0])
    with_floor = _run("pf", model, y, 500, 0, likelihood_floor=1e-99)
    exact = _run("pf", model, y, 500, 0)
    assert with_floor["ess"][1] == pytest.approx(500.0)
    assert exact["ess"][1] < 5


def test_increment_prior_transcribes_the_reference_expression():
    from pfbench.filters.upf import increment_logprior
    gamma = np.array([1.0, 3.0, 2.0, 1.0])
    for w in (-1.3, -0.2, 0.4, 2.5):
        # (x_t - x_{t-1})^(g1 - 1) * exp(-g2 (x_t - x_{t-1})), as MATLAB evaluates it for g1 = 3
        assert math.isclose(increment_logprior(gamma, w), math.log(w ** 2 * math.exp(-2 * w)),
                            rel_tol=1e-12)
    gauss = np.array([0.0, 0.7, 0.0, 1.0])
    assert increment_logprior(gauss, 0.3) == process_logpdf(gauss, 0.3)


def test_gaussian_filters_use_the_configured_noise_mean():
    # x_t = a x + mu + w: the EKF and UKF with process_noise_mean = mu match the textbook
    # recursion with the same mean.
    model = _linear(a=0.8, c=1.0, process_noise_var=0.5, measurement_noise_var=0.3, steps=30)
    _, y = simulate(model, state_from_seed(np.random.SeedSequence(6)))
    mu = 1.25
    m, P, ms = 0.0, 1.0, [0.0]
    for t in range(1, y.size):
        mp, Pp = 0.8 * m + mu, 0.64 * P + 0.5
        K = Pp / (Pp + 0.3)
        m, P = mp + K * (y[t] - mp), (1 - K) * Pp
        ms.append(m)
    for kind in ("ekf", "ukf"):
        out = _run(kind, model, y, process_noise_mean=mu)
        assert np.max(np.abs(out["xhat"] - np.array(ms))) < 1e-10


@pytest.mark.parametrize("kind,extra", [("upf", {}), ("sspf", {}), ("upf", {"resample": "neff"})])
@pytest.mark.parametrize("bad", [1e200, -1e200, math.inf, math.nan])
def test_an_impossible_measurement_is_ignored_and_the_filter_recovers(kind, extra, bad):
    # The UKF proposal follows a measurement of 1e200 there: every log-weight is -inf or NaN at
    # that step, which then ignores its measurement (particles from the transition, weights kept)
    model = _linear(a=0.9, c=1.0, process_noise_var=1.0, measurement_noise_var=0.5, steps=40)
    x, y = simulate(model, state_from_seed(np.random.SeedSequence(5)))
    t0 = 15
    bad_y = y.copy()
    bad_y[t0] = bad
    clean = _run(kind, model, y, 300, 1, **extra)
    out = _run(kind, model, bad_y, 300, 1, **extra)
    assert clean["underflow_steps"] == 0 and out["underflow_steps"] == 1
    assert np.all(np.isfinite(out["xhat"])) and np.all(np.isfinite(out["ess"]))
    assert np.array_equal(out["xhat"][:t0], clean["xhat"][:t0])    # the steps before: untouched
    # the step's estimate is the prediction a * (the previous estimate), within Monte Carlo error
    assert abs(out["xhat"][t0] - 0.9 * out["xhat"][t0 - 1]) < 0.5
    # a few steps later the errors are those of the clean run again
    later = slice(t0 + 5, None)
    e_bad = np.sqrt(np.mean((out["xhat"][later] - x[later]) ** 2))
    e_clean = np.sqrt(np.mean((clean["xhat"][later] - x[later]) ** 2))
    assert e_bad < 1.2 * e_clean + 0.05
