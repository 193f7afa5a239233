"""Bootstrap particle filter (SIR) on a scalar model; the whole time loop runs in numba.

Per step: propagate through the transition and process noise, weight by the measurement likelihood
in the log domain (max-shift normalisation), estimate, and resample when ESS < threshold.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..resampling import SCHEME_CODES, resample
from ..rng import STATE, fill_normal
from ..scenarios.base import ModelFn, add_process_noise

_F = types.float64[::1]
_I = types.int64[::1]

PF_SIG = types.int64(ModelFn, ModelFn, _F, _F, _F, types.float64, types.float64, types.int64,
                     types.int64, types.float64, types.int64, types.int64, STATE,
                     _F, _F, _I, _F, _F)


@njit(types.float64(_F), cache=True)
def mean_abs_pairwise(x):
    """Mean over pairs i < j of |x_i - x_j| (O(N log N) through the sorted values)."""
    N = x.size
    if N < 2:
        return 0.0
    z = np.sort(x)
    acc = 0.0
    for i in range(N):
        acc += (2.0 * i - N + 1.0) * z[i]
    return 2.0 * acc / (N * (N - 1.0))


@njit(types.float64(_I, _I, types.int64), cache=True)
def distinct_fraction(idx, mark, stamp):
    """Fraction of distinct values in ancestor indices ``idx``; ``mark`` (N,) is scratch."""
    count = 0
    for i in range(idx.size):
        j = idx[i]
        if mark[j] != stamp:
            mark[j] = stamp
            count += 1
    return count / idx.size


@njit(PF_SIG, cache=True)
def pf_kernel(f, h, theta, noise, y, prior_mean, prior_var, N, scheme, threshold, estimate_after,
              diag, s, xhat, ess, resampled, div_l1, distinct):
    """Run a bootstrap PF over y (T+1,) and fill the (T+1,) traces; return the underflow count.

    threshold : resample when ESS < threshold (np.inf: every step)
    estimate_after : 1 = estimate is the mean of the resampled particles, 0 = weighted mean before
    diag : 1 = fill div_l1 (mean pairwise |x_i - x_j|) and distinct (fraction of distinct ancestors)
           after each resampling; NaN at steps without resampling
    An underflow step (every log-weight -inf or NaN) resets the weights to uniform: the measurement of
    that step is ignored rather than turned into NaN.
    """
    T = y.size - 1
    half_inv_R = 0.5 / noise[3]
    x = np.empty(N)
    fill_normal(s, x)
    sd0 = math.sqrt(prior_var)
    for i in range(N):
        x[i] = prior_mean + sd0 * x[i]
    xn = np.empty(N)
    hx = np.empty(N)
    w = np.empty(N)
    lw = np.zeros(N)
    idx = np.empty(N, dtype=np.int64)
    mark = np.full(N, -1, dtype=np.int64)
    events = 0
    xhat[0] = prior_mean
    ess[0] = N
    resampled[0] = 0
    div_l1[0] = np.nan
    distinct[0] = np.nan
    for t in range(1, T + 1):
        tt = float(t)
        f(x, tt, theta, xn)
        add_process_noise(s, noise, xn)
        h(xn, tt, theta, hx)
        yt = y[t]
        m = -np.inf
        for i in range(N):
            d = yt - hx[i]
            l = lw[i] - half_inv_R * d * d
            lw[i] = l
            m = max(m, l)  # NaN log-weights lose every comparison: they never become the max
        if not (m > -np.inf):
            events += 1
            for i in range(N):
                lw[i] = 0.0
            m = 0.0
        S = 0.0
        S2 = 0.0
        sx = 0.0
        for i in range(N):
            e = math.exp(lw[i] - m)
            e = e if e == e else 0.0  # a NaN log-weight is a zero weight
            w[i] = e
            S += e
            S2 += e * e
            sx += e * xn[i]
        if not math.isfinite(sx):  # rare: a zero-weight particle at +-inf or NaN (0 * inf)
            sx = 0.0
            for i in range(N):
                if w[i] > 0.0:
                    sx += w[i] * xn[i]
        ess[t] = S * S / S2
        est = sx / S
        if ess[t] < threshold:
            resample(scheme, w, S, s, idx)
            acc = 0.0
            for i in range(N):
                v = xn[idx[i]]
                x[i] = v
                acc += v
                lw[i] = 0.0
            resampled[t] = 1
            if estimate_after:
                est = acc / N
            if diag:
                div_l1[t] = mean_abs_pairwise(x)
                distinct[t] = distinct_fraction(idx, mark, t)
            else:
                div_l1[t] = np.nan
                distinct[t] = np.nan
        else:
            for i in range(N):
                x[i] = xn[i]
                lw[i] -= m
            resampled[t] = 0
            div_l1[t] = np.nan
            distinct[t] = np.nan
        xhat[t] = est
    return events


def run(model, y, params, particles, state, diag=True):
    """Run the bootstrap PF; return a dict of traces and counters (see :func:`pf_kernel`)."""
    T1 = y.size
    out = {"xhat": np.empty(T1), "ess": np.empty(T1), "resampled": np.empty(T1, dtype=np.int64),
           "div_l1": np.empty(T1), "distinct": np.empty(T1)}
    threshold = np.inf if params["resample"] == "always" else params["neff_ratio"] * particles
    out["underflow_steps"] = pf_kernel(
        model.transition, model.observe, model.theta, model.noise, y, model.prior_mean,
        model.prior_var, particles, SCHEME_CODES[params["resampling"]], threshold,
        int(params["estimate"] == "after_resampling"), int(diag), state,
        out["xhat"], out["ess"], out["resampled"], out["div_l1"], out["distinct"])
    out["lik_evals_per_step"] = float(particles)
    return out
