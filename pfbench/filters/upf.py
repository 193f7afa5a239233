"""Unscented particle filter (UPF) and SSPF (sspf2008) on a scalar model.

UPF (van der Merwe et al. 2000): each particle i carries a mean x_i and variance P_i; per step an
augmented UKF (L = 3: state, process and measurement noise) run from (x_i, P_i) with the proposal's
Gaussian noise gives N(m_i, Pn_i), the particle is drawn from it, and the weight is multiplied by
p(y | x) p(x | x_prev) / q(x | x_prev, y), with the true (e.g. Gamma) transition density.
All particles' 7 sigma points go through f and h in one call each.

SSPF (sspf2008) adds: resampling triggered when the weight change
K = sum_i W_k^i (W_k^i - W_{k-1}^i)^2 exceeds sigma (normalised weights; W_{k-1} are the weights
after the last step, uniform after a resampling), and after each resampling one independence
Metropolis-Hastings move per particle with the particle's own UKF proposal.

A step whose log-weights are all -inf or NaN (a measurement the model cannot have produced, such as
1e200: each UKF's proposal follows it there) ignores its measurement: the particles are drawn again
from the model's transition p(x | x_prev), each UKF's variance is its prediction (the update
skipped), the weights stay those of the previous step and there is no MH move. The step counts in
``underflow_steps``; every other step is untouched.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..schema import Key
from ..resampling import SCHEME_CODES, SCHEMES, ess_threshold, resample
from ..rng import STATE, normal, uniform
from ..codes import NOISE_GAUSSIAN
from ..models.scalar import ModelFn, add_process_noise, process_logpdf
from ._common import (DIAG_DISTINCT, drop_unasked, floored, record_spread, resampled_step,
                      spread_trace, start, weigh)
from ..diag import flags
from .ekf import noise_moments
from .pf import log_floor
from .keys import floor_key, gaussian_noise_keys, pf_keys, sigma_check, sigma_keys
from .types import FilterType
from .ukf import ut_weights
from .weights import divide

_F = types.float64[::1]
_I = types.int64[::1]
LOG_2PI = math.log(2.0 * math.pi)

TRIGGER_ESS = 0
TRIGGER_WEIGHT_CHANGE = 1

@kernel(types.float64(types.float64, types.float64, types.float64), cache=True, inline="always")
def _log_normal(x, m, v):
    d = x - m
    return -0.5 * d * d / v - 0.5 * (LOG_2PI + math.log(v))


@kernel(types.float64(_F, types.float64), cache=True)
def increment_logprior(noise, w):
    """log of the reference implementation's transition "prior" at the increment w = x_t - x_{t-1}:
    w^(a-1) exp(-b w) for Gamma noise, evaluated for every real w as MATLAB does for the benchmark's
    even power a - 1 = 2 (so a decrease of the state is not impossible there); the Gaussian
    density for Gaussian noise. A transcription of that code, not a density of the model."""
    if noise[0] == NOISE_GAUSSIAN:
        return process_logpdf(noise, w)
    if w == 0.0:
        return -np.inf
    return (noise[1] - 1.0) * math.log(abs(w)) - noise[2] * w


class UpfOptions(NamedTuple):
    """The UPF's settings, as the jitted steps read them.

    N : particles; q_mean, Qp, Rp : the Gaussian noise of the proposal's UKF (process mean and
    variance, measurement variance); the weights use the model's true noise
    alpha, beta, kappa : the sigma points' (L = 3: the state and the two noises)
    scheme : the resampling code; trigger : TRIGGER_ESS (resample when ESS < threshold) or
    TRIGGER_WEIGHT_CHANGE (K > threshold); estimate_after : 1 to estimate after resampling
    mh_steps : independence MH moves per particle after each resampling
    log_floor : log of an additive floor on the likelihood (-inf: none; see ``floored``)
    increment : 1 = the transition density at x_t - x_{t-1} instead of x_t - f(x_{t-1}) (what
    the benchmark's reference implementation does); 0 = the model's density
    diag : the diagnostics' flags (``_common.resampled_step``)
    """

    N: int
    q_mean: float
    Qp: float
    Rp: float
    alpha: float
    beta: float
    kappa: float
    scheme: int
    trigger: int
    threshold: float
    estimate_after: int
    mh_steps: int
    log_floor: float
    increment: int
    diag: int


UPF_OPTIONS = typeof(UpfOptions(1, 0.0, 1.0, 1.0, 1.0, 0.0, 2.0, 0, 0, 1.0, 0, 0, 0.0, 0, 1))


class Sigma(NamedTuple):
    """The augmented UKF's sigma points (n = 7): weights Wm, Wc; the process noise's wn and the
    measurement noise's vn at each point; sq, the points' spread; and per particle (n N) the
    points chi, through the transition fx and through the sensor hz."""

    Wm: np.ndarray
    Wc: np.ndarray
    wn: np.ndarray
    vn: np.ndarray
    sq: np.ndarray
    chi: np.ndarray
    fx: np.ndarray
    hz: np.ndarray


SIGMA = types.NamedUniTuple(_F, 8, Sigma)


@kernel(SIGMA(UPF_OPTIONS), cache=True)
def sigma_points(o):
    n = 7
    Wm = np.empty(n)
    Wc = np.empty(n)
    sq = ut_weights(3, o.alpha, o.beta, o.kappa, Wm, Wc)
    wn = np.full(n, o.q_mean)
    wn[2] += sq * math.sqrt(o.Qp)
    wn[5] -= sq * math.sqrt(o.Qp)
    vn = np.zeros(n)
    vn[3] = sq * math.sqrt(o.Rp)
    vn[6] = -vn[3]
    return Sigma(Wm, Wc, wn, vn, np.full(1, sq), np.empty(n * o.N), np.empty(n * o.N),
                 np.empty(n * o.N))


@kernel(types.void(ModelFn, ModelFn, _F, types.float64, types.float64, _F, _F, SIGMA, UPF_OPTIONS,
                 _F, _F, _F), cache=True)
def proposals(f, h, theta, tt, yt, x, P, sg, o, fprev, pm, pv):
    """Each particle's proposal: an augmented UKF step from (x, P) with the measurement yt, all
    sigma points through f and h in one call each; its mean pm and variance pv, and fprev the
    prior density's anchor (f(x_prev), the centre sigma point before noise, or x_prev itself in
    the reference implementation's form)."""
    n, N, sq = 7, x.size, sg.sq[0]
    chi, fx, hz, Wm, Wc = sg.chi, sg.fx, sg.hz, sg.Wm, sg.Wc
    for i in range(N):
        d = sq * math.sqrt(P[i])
        b = i * n
        for j in range(n):
            chi[b + j] = x[i]
        chi[b + 1] += d
        chi[b + 4] -= d
    f(chi, tt, theta, fx)
    for i in range(N):
        b = i * n
        fprev[i] = x[i] if o.increment else fx[b]
        mp = 0.0
        for j in range(n):
            fx[b + j] += sg.wn[j]
            mp += Wm[j] * fx[b + j]
        pm[i] = mp
    h(fx, tt, theta, hz)
    for i in range(N):
        b = i * n
        mp = pm[i]
        zm = 0.0
        for j in range(n):
            hz[b + j] += sg.vn[j]
            zm += Wm[j] * hz[b + j]
        Pp = 0.0
        S = 0.0
        C = 0.0
        for j in range(n):
            dx = fx[b + j] - mp
            dz = hz[b + j] - zm
            Pp += Wc[j] * dx * dx
            S += Wc[j] * dz * dz
            C += Wc[j] * dx * dz
        K = C / S
        pm[i] = mp + K * (yt - zm)
        v = Pp - K * K * S
        pv[i] = v if v > 1e-300 else 1e-300


@kernel(types.float64(ModelFn, _F, types.float64, _F, _F, SIGMA, STATE, _F, _F, _F, _F),
        cache=True)
def prior_step(f, theta, tt, noise, x, sg, s, Wprev, xn, pv, lw):
    """A step that ignores its measurement (every log-weight -inf or NaN): xn drawn from the
    model's transition p(x | x_prev) at the previous particles x; pv each UKF's predicted variance
    (its update skipped; from the sigma points through f in sg.fx); lw the log of the previous
    step's normalised weights Wprev. Returns the largest log-weight."""
    f(x, tt, theta, xn)
    add_process_noise(s, noise, xn)
    n, Wm, Wc, fx = 7, sg.Wm, sg.Wc, sg.fx
    mx = -np.inf
    for i in range(xn.size):
        b = i * n
        mp = 0.0
        for j in range(n):
            mp += Wm[j] * fx[b + j]
        v = 0.0
        for j in range(n):
            d = fx[b + j] - mp
            v += Wc[j] * d * d
        pv[i] = v if v > 1e-300 else 1e-300
        lw[i] = math.log(Wprev[i]) if Wprev[i] > 0.0 else -np.inf
        mx = max(mx, lw[i])
    return mx


@kernel(types.float64(_F, types.float64, UPF_OPTIONS), cache=True)
def log_prior(noise, w, o):
    """The transition density's log at w: the model's, or the reference implementation's."""
    return increment_logprior(noise, w) if o.increment else process_logpdf(noise, w)


@kernel(types.float64(_F, types.float64, _F, _F, _F, _F, _F, _F, UPF_OPTIONS), cache=True)
def weigh_draws(noise, yt, xn, hx, fprev, pm, pv, lw, o):
    """Multiply each weight (log, lw) by p(y | x) p(x | x_prev) / q(x) at the drawn xn (h(xn) in
    hx); returns the largest log-weight."""
    R = noise[3]
    c0 = -0.5 * math.log(R)  # the likelihood's scale R^(-1/2), which a floor compares with
    mx = -np.inf
    for i in range(xn.size):
        d = yt - hx[i]
        l = lw[i] + (floored(c0 - 0.5 * d * d / R, o.log_floor)
                     + log_prior(noise, xn[i] - fprev[i], o) - _log_normal(xn[i], pm[i], pv[i]))
        lw[i] = l
        mx = max(mx, l)
    return mx


@kernel(types.void(ModelFn, _F, types.float64, types.float64, _F, _F, _F, _F, _F, _F, _F, _F,
                 UPF_OPTIONS, STATE), cache=True)
def independence_mh_moves(h, theta, tt, yt, noise, x, P, am, fa, ha, prop, hprop, o, s):
    """o.mh_steps independence MH moves per particle x with its ancestor's proposal N(am, P)
    (fa: the ancestor's f(x_prev), ha: h(x)); prop, hprop (N,): scratch."""
    N = x.size
    R = noise[3]
    c0 = -0.5 * math.log(R)
    for _ in range(o.mh_steps):
        for i in range(N):
            prop[i] = am[i] + math.sqrt(P[i]) * normal(s)
        h(prop, tt, theta, hprop)
        for i in range(N):
            d0 = yt - ha[i]
            d1 = yt - hprop[i]
            dp = log_prior(noise, prop[i] - fa[i], o) - log_prior(noise, x[i] - fa[i], o)
            log_a = (floored(c0 - 0.5 * d1 * d1 / R, o.log_floor)
                     - floored(c0 - 0.5 * d0 * d0 / R, o.log_floor) + dp
                     - _log_normal(prop[i], am[i], P[i]) + _log_normal(x[i], am[i], P[i]))
            if log_a >= 0.0 or math.log(uniform(s)) < log_a:
                x[i] = prop[i]
                ha[i] = hprop[i]


UPF_SIG = types.int64(ModelFn, ModelFn, _F, _F, _F, types.float64, types.float64, UPF_OPTIONS,
                      STATE, _F, _F, _I, _F, _F, _F)


@kernel(UPF_SIG, cache=True)
def upf_kernel(f, h, theta, noise, y, prior_mean, prior_var, o, s, xhat, ess, resampled, div_l1,
               distinct, pvar):
    """Run the UPF/SSPF over y (T+1,) (settings o, see ``UpfOptions``); fill the (T+1,) traces
    (pvar, the variance of the cloud xhat is the mean of, where o.diag asks:
    ``_common.record_spread``, ``resampled_step``);
    return the underflow count: the steps whose log-weights were all -inf or NaN, which ignore
    their measurement (``prior_step``; no MH move)."""
    T, N = y.size - 1, o.N
    sg = sigma_points(o)
    x = np.empty(N)
    start(s, prior_mean, prior_var, x, xhat, ess, resampled, div_l1, distinct)
    P = np.full(N, prior_var)
    fprev = np.empty(N)     # f(x_prev) of each particle
    pm = np.empty(N)        # proposal mean and variance of each particle
    pv = np.empty(N)
    xn = np.empty(N)
    hx = np.empty(N)
    lw = np.zeros(N)
    w = np.empty(N)
    Wprev = np.full(N, 1.0 / N)
    idx = np.empty(N, dtype=np.int64)
    am = np.empty(N)        # after resampling: the ancestor's proposal mean, f(x_prev), h(x)
    fa = np.empty(N)
    ha = np.empty(N)
    prop = np.empty(N)
    hprop = np.empty(N)
    mark = np.empty(N if o.diag & DIAG_DISTINCT else 0, dtype=np.int8)
    events = 0
    for t in range(1, T + 1):
        tt, yt = float(t), y[t]
        proposals(f, h, theta, tt, yt, x, P, sg, o, fprev, pm, pv)
        for i in range(N):
            xn[i] = pm[i] + math.sqrt(pv[i]) * normal(s)
        h(xn, tt, theta, hx)
        mx = weigh_draws(noise, yt, xn, hx, fprev, pm, pv, lw, o)
        skip = not math.isfinite(mx)        # the measurement is ignored
        if skip:
            mx = prior_step(f, theta, tt, noise, x, sg, s, Wprev, xn, pv, lw)
            events += 1
        Ssum, est, _ = weigh(lw, w, xn, mx, t, ess, resampled, div_l1, distinct)
        record_spread(o.diag, t, w, xn, Ssum, est, pvar)
        if o.trigger == TRIGGER_ESS:
            go = ess[t] < o.threshold
        else:
            Kc = 0.0
            for i in range(N):
                Wi = w[i] / Ssum
                Kc += Wi * (Wi - Wprev[i]) ** 2
            go = Kc > o.threshold
        if not go:
            for i in range(N):
                x[i] = xn[i]
                P[i] = pv[i]
            divide(w, Ssum, Wprev)
            xhat[t] = est
            continue
        resample(o.scheme, w, Ssum, s, idx)
        for i in range(N):            # each particle takes its ancestor's state and proposal
            j = idx[i]
            x[i] = xn[j]
            P[i] = pv[j]
            am[i] = pm[j]
            fa[i] = fprev[j]
            ha[i] = hx[j]
            lw[i] = 0.0
            Wprev[i] = 1.0 / N
        if not skip:
            independence_mh_moves(h, theta, tt, yt, noise, x, P, am, fa, ha, prop, hprop, o, s)
        xhat[t] = resampled_step(x, xn, idx, mark, t, est, o.estimate_after, o.diag, resampled,
                                 div_l1, distinct, pvar)
    return events


def run(model, y, params, particles, state, diag=True):
    """Run the UPF (or SSPF, by its parameters); return a dict of traces (the diagnostics
    ``diag`` asks for: pfbench.diagnostics.flags)."""
    diag = int(flags(diag))
    T1 = y.size
    out = {"xhat": np.empty(T1), "ess": np.empty(T1), "resampled": np.empty(T1, dtype=np.int64),
           "div_l1": np.empty(T1), "distinct": np.empty(T1),
           "pvar": spread_trace(T1, model.prior_var)}
    q_mean, Qp, Rp = noise_moments(model, params)
    if params["resample"] == "weight_change":
        trigger, threshold = TRIGGER_WEIGHT_CHANGE, params["sigma"] / particles ** 2
    else:               # 'neff' or 'always'
        trigger, threshold = TRIGGER_ESS, ess_threshold(params, particles)
    mh = int(params["mh_steps"])
    o = UpfOptions(
        N=int(particles), q_mean=float(q_mean), Qp=float(Qp), Rp=float(Rp),
        alpha=float(params["alpha"]), beta=float(params["beta"]), kappa=float(params["kappa"]),
        scheme=SCHEME_CODES[params["resampling"]], trigger=int(trigger),
        threshold=float(threshold), estimate_after=int(params["estimate"] == "after_resampling"),
        mh_steps=mh, log_floor=float(log_floor(params)),
        increment=int(params["prior_argument"] == "increment"), diag=diag)
    out["underflow_steps"] = upf_kernel(
        model.transition, model.observe, model.theta, model.noise, y, model.prior_mean,
        model.prior_var, o, state, out["xhat"], out["ess"], out["resampled"], out["div_l1"],
        out["distinct"], out["pvar"])
    # 7 sigma points through h per particle, plus the particle itself; an MH sweep adds one more
    out["lik_evals_per_step"] = particles * (8.0 + mh * float(np.mean(out["resampled"][1:])))
    return drop_unasked(out, diag)


def upf_keys(resample: str, mh_steps: int) -> dict:
    """The keys of the UPF family with the defaults of a variant (sspf: weight_change, 1)."""
    pf = pf_keys()
    return {
        "resampling": Key("choice", "residual", "resampling scheme", choices=tuple(SCHEMES)),
        "resample": Key("choice", resample, "'always'; 'neff': when ESS < neff_ratio * N; "
                        "'weight_change': when K = sum W_k (W_k - W_{k-1})^2 > sigma / N^2 "
                        "(sspf2008)", choices=("always", "neff", "weight_change")),
        "neff_ratio": pf["neff_ratio"],
        "sigma": Key("float", 1.0, "threshold of the weight-change trigger in units of 1 / N^2 "
                     "(sspf2008 gives no value; 1 / N^2 is the K of weights split evenly over half "
                     "the particles, an ESS of N / 2)", min=0.0, min_exclusive=True),
        "mh_steps": Key("int", mh_steps, "independence Metropolis-Hastings moves per particle "
                        "after each resampling, with the particle's UKF proposal", min=0),
        "estimate": pf["estimate"],
        "likelihood_floor": floor_key(),
        "prior_argument": Key("choice", "transition", "where the weight's transition density is "
                              "evaluated: 'transition' (w = x_t - f(x_{t-1}), the model) or "
                              "'increment' (x_t - x_{t-1}, as the Gamma benchmark's reference "
                              "implementation does)", choices=("transition", "increment")),
        **sigma_keys(),
        **gaussian_noise_keys("the proposal's UKF"),
    }


UPF = FilterType("upf", "unscented particle filter (a UKF per particle as the proposal)",
                 upf_keys("always", 0), run, check=sigma_check, needs=("gaussian_measurement",))
SSPF = FilterType("sspf", "SSPF (sspf2008): UPF + weight-change-triggered residual resampling + "
                  "MH move", upf_keys("weight_change", 1), run, check=sigma_check,
                  needs=("gaussian_measurement",))
