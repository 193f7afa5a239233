"""Bootstrap particle filter (SIR) on a scalar model; the whole time loop runs in numba.

Per step: propagate through the transition and process noise, weight by the measurement likelihood
in the log domain (max-shift normalisation), estimate, and resample when ESS < threshold. The
likelihood is the model's own (``ScalarModel.loglik``) where it has one, else the Gaussian of
y_t - h(x_t), computed inline.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from .._lazy import kernel

from ..schema import Key
from ..resampling import SCHEME_CODES, ess_threshold, resample
from ..rng import STATE
from ..models.scalar import LikFn, ModelFn, add_process_noise
from ._common import (DIAG_DISTINCT, add_own_loglik, drop_unasked, floored, mh_step,
                      record_spread, resampled_step, spread_trace, start, weigh_lanes)
from ..diag import flags
from .keys import pf_keys
from .types import FilterType

_F = types.float64[::1]
_I = types.int64[::1]

PF_SIG = types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, _F, _F, types.float64,
                     types.float64, types.int64, types.int64, types.float64, types.int64,
                     types.int64, types.float64, types.int64, STATE, _F, _F, _I, _F, _F, _F)


@kernel(PF_SIG, cache=True)
def pf_kernel(f, h, lik, use_lik, theta, noise, y, prior_mean, prior_var, N, scheme, threshold,
              estimate_after, mh_steps, log_floor, diag, s, xhat, ess, resampled, div_l1,
              distinct, pvar):
    """Run a bootstrap PF over y (T+1,) and fill the (T+1,) traces; return the underflow count.

    lik, use_lik : the model's log-likelihood (``LIK_SIG``) and 1 to weigh by it, or 0 to weigh by
        the Gaussian of y - h(x) of variance noise[3] (``ScalarModel.likelihood()``)
    threshold : resample when ESS < threshold (np.inf: every step)
    estimate_after : 1 = estimate is the mean of the particles after resampling (and the MH
        moves), 0 = the weighted mean before resampling
    mh_steps : Metropolis-Hastings moves per particle after each resampling (0: plain PF; PF+MH)
    log_floor : log of an additive floor on the likelihood (-inf: none; see ``floored``)
    diag : flags (pfbench.diagnostics.Diag): DIAG_DISTINCT fills distinct (the fraction of
        distinct particles, from the ancestors: ``distinct_count``), DIAG_DIVERSITY div_l1 (mean
        pairwise |x_i - x_j|, a sort) after each resampling; NaN at steps without resampling and
        where not asked; DIAG_SPREAD pvar[1:], the variance of the cloud xhat is the mean of (the
        weighted particles, or with estimate_after the resampled; untouched where not asked)
    An underflow step (every log-weight -inf or NaN) resets the weights to uniform: the measurement
    of that step is ignored rather than turned into NaN.
    """
    T = y.size - 1
    half_inv_R = 0.5 / noise[3]
    c0 = -0.5 * math.log(noise[3])  # the likelihood's scale R^(-1/2), which a floor compares with
    x = np.empty(N)
    start(s, prior_mean, prior_var, x, xhat, ess, resampled, div_l1, distinct)
    xn = np.empty(N)
    hx = np.empty(N)            # h(x), or with use_lik the log-likelihoods
    w = np.empty(N)
    lw = np.zeros(N)
    idx = np.empty(N, dtype=np.int64)
    mark = np.empty(N if diag & DIAG_DISTINCT else 0, dtype=np.int8)
    m = mh_steps > 0
    xprev = np.empty(N if m else 0)
    hcur = np.empty(N if m else 0)
    prop = np.empty(N if m else 0)
    hprop = np.empty(N if m else 0)
    events = 0
    for t in range(1, T + 1):
        tt = float(t)
        f(x, tt, theta, xn)
        add_process_noise(s, noise, xn)
        yt = y[t]
        mx = -np.inf
        if use_lik:
            mx = add_own_loglik(lik, theta, xn, tt, yt, log_floor, hx, lw)
        elif log_floor == -np.inf:
            h(xn, tt, theta, hx)
            for i in range(N):
                d = yt - hx[i]
                l = lw[i] - half_inv_R * d * d
                lw[i] = l
                mx = max(mx, l)  # a NaN loses every comparison: it never becomes the max
        else:
            h(xn, tt, theta, hx)
            for i in range(N):
                d = yt - hx[i]
                l = lw[i] + floored(c0 - half_inv_R * d * d, log_floor)
                lw[i] = l
                mx = max(mx, l)
        S, est, under = weigh_lanes(lw, w, xn, mx, t, ess, resampled, div_l1, distinct)
        events += int(under)
        record_spread(diag, t, w, xn, S, est, pvar)
        if ess[t] < threshold:
            resample(scheme, w, S, s, idx)
            if m:
                for i in range(N):
                    xprev[i] = x[idx[i]]
                    hcur[i] = hx[idx[i]]
            for i in range(N):
                x[i] = xn[idx[i]]
                lw[i] = 0.0
            for _ in range(mh_steps):
                mh_step(f, h, lik, use_lik, theta, noise, xprev, x, hcur, yt, tt, log_floor, s,
                        prop, hprop)
            est = resampled_step(x, xn, idx, mark, t, est, estimate_after, diag, resampled,
                                 div_l1, distinct, pvar)
        else:
            x, xn = xn, x
        xhat[t] = est
    return events


def log_floor(params) -> float:
    """log of the configured likelihood floor (-inf when there is none)."""
    floor = params.get("likelihood_floor", 0.0)
    return math.log(floor) if floor > 0 else -np.inf


def run(model, y, params, particles, state, diag=True):
    """Run the bootstrap PF; return a dict of traces and counters (see :func:`pf_kernel`).
    ``diag``: the per-step diagnostics (pfbench.diagnostics.flags; True: all), whose outputs
    'distinct', 'div_l1' and 'pvar' it returns only when asked."""
    diag = int(flags(diag))
    T1 = y.size
    out = {"xhat": np.empty(T1), "ess": np.empty(T1), "resampled": np.empty(T1, dtype=np.int64),
           "div_l1": np.empty(T1), "distinct": np.empty(T1),
           "pvar": spread_trace(T1, model.prior_var)}
    threshold = ess_threshold(params, particles)
    mh = int(params.get("mh_steps", 0))
    out["underflow_steps"] = pf_kernel(
        model.transition, model.observe, *model.likelihood(), model.theta, model.noise, y,
        model.prior_mean, model.prior_var, particles, SCHEME_CODES[params["resampling"]], threshold,
        int(params["estimate"] == "after_resampling"), mh, log_floor(params), diag, state,
        out["xhat"], out["ess"], out["resampled"], out["div_l1"], out["distinct"], out["pvar"])
    drop_unasked(out, diag)
    # each MH sweep evaluates the likelihood once more per particle (at the proposal), at the
    # steps that resample
    out["lik_evals_per_step"] = particles * (1.0 + mh * float(np.mean(out["resampled"][1:])))
    return out


PF = FilterType("pf", "bootstrap particle filter (SIR)", pf_keys(), run, needs=("likelihood",))
PFMH = FilterType(
    "pfmh", "bootstrap PF with Metropolis-Hastings moves after resampling (PF+MH)",
    {**pf_keys(), "mh_steps": Key("int", 1, "MH moves per particle after each resampling "
                                  "(proposal: the transition prior)", min=1)}, run,
    needs=("likelihood",))
