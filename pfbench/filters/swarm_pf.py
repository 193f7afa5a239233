"""Swarm-optimised particle filters on a scalar model: FA-PF, IFA-PF (ifa2021), BA-PF, PSO-PF,
AFSA-PF.

Per step: predict the particles through the transition, run ``iterations`` swarm moves on them
(fitness: the likelihood of the current measurement), weight the moved particles by the
likelihood, estimate, resample. The likelihood is the model's own (``ScalarModel.loglik``) where it
has one, else the Gaussian of y_t - h(x_t): the weights, the swarms' fitness and IFA's brightness
all read it. As in the papers, the weights are not corrected for having moved
the particles (the moved set is treated as a draw from the prior): a documented property of these
filters, which the equal-compute PF rows of the tables put in perspective.

Two readings of what the papers leave open change that step (keys ``move_correction`` and
``move_order``):

- ``prior_ratio``: the moved particle x' of predicted particle x (parent x_{t-1}) is weighted by
  p(y_t | x') p(x' | x_{t-1}) / p(x | x_{t-1}), the importance weight of x' had it been drawn from
  the predictive at x's place: the move's Jacobian is left out (a firefly move of one particle
  depends on all the others, so it has none to speak of). p(x | x_{t-1}) is the transition
  density at x - f(x_{t-1}) (``models.scalar.process_logpdf``).
- ``resample_then_move``: predict, weigh by the likelihood, resample (when the trigger says so),
  then move the resampled set from its likelihood (the moves' fitness; a mutant of the stepwise
  EWA is evaluated again) and weigh the moved particles again, by p(y_t | x') (times the prior
  ratio with ``prior_ratio``, x_{t-1} the resampled particle's parent); where the step did not
  resample, the step's likelihood counts once, at the moved place. The estimate is the weighted
  mean of the moved, re-weighted set, which the next step predicts from with those weights.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..resampling import (SCHEME_CODES, SCHEMES, STEPWISE_EWA, ess_threshold, ewa_mutant, resample,
                          stepwise_ewa_plan)
from ..rng import STATE
from ..schema import Key
from ..codes import (BRIGHTNESS, BRIGHTNESS_DISTANCE, BRIGHTNESS_GAUSSIAN, BRIGHTNESS_LIKELIHOOD,
                     CORRECTION_PRIOR_RATIO, EWA_COPIES, MOVE_CORRECTIONS, MOVE_ORDERS,
                     ORDER_RESAMPLE_THEN_MOVE)
from ..models.scalar import NOISE_GAUSSIAN, LikFn, ModelFn, add_process_noise, process_logpdf
from ._common import (DIAG_DISTINCT, bound_above, drop_unasked, record_spread, resampled_step,
                      spread_trace, start, weigh_lanes)
from ..diag import flags
from .keys import ewa_keys, pf_keys
from .swarm import (AFSA_JOINT_SHIFT, ALGORITHMS, DONE, FIT_BEHAVIOURS, FIT_BRIGHTNESS,
                    FIT_CANDIDATES, FIT_CENTRES, FIT_X, SWARM_PARAMS, SWARM_WORK, evaluations,
                    keys, new_swarm_work, swarm_move, swarm_params)
from .types import FilterType
from .weights import divide, normalise_lanes, shifted_exp, shifted_exp_less

_F = types.float64[::1]
_I = types.int64[::1]

EWA = STEPWISE_EWA

@kernel(types.void(ModelFn, LikFn, types.int64, _F, types.float64, types.float64, types.float64,
                   _F, _F, _F), cache=True)
def _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, X, hx, ll):
    """ll = log p(y_t | X) up to a constant, for every point of X: the model's own ``lik`` with
    ``use_lik`` (+inf bounded: ``_common.bound_above``), else the Gaussian -(y_t - h(x))^2 / 2R
    (half_inv_R = 1 / 2R); hx is scratch."""
    if use_lik:
        lik(X, tt, theta, yt, ll)
        bound_above(ll)
        return
    h(X, tt, theta, hx)
    for i in range(X.size):
        d = yt - hx[i]
        ll[i] = -half_inv_R * d * d


class SwarmOptions(NamedTuple):
    """A swarm PF's settings, as the jitted steps read them.

    N : particles; algo : the swarm algorithm (swarm.ALGORITHMS); iters : its iterations a step
    scheme : a resampling code, or EWA (stepwise EWA with ewa_beta, mutation ewa_mu, the bias
    correction inside the recursion when ewa_printed, a kept particle's copies ewa_copies, a code of
    codes.EWA_COPIES); threshold : resample when ESS < threshold
    estimate_after : 1 to estimate after resampling; diag : the diagnostics' flags
        (``_common.resampled_step``)
    correction : codes.MOVE_CORRECTIONS, the moved particles' weights; order : codes.MOVE_ORDERS,
        the move before or after the resampling (see the module)
    """

    N: int
    algo: int
    iters: int
    scheme: int
    threshold: float
    estimate_after: int
    ewa_beta: float
    ewa_mu: float
    ewa_printed: int
    diag: int
    ewa_copies: int
    correction: int
    order: int


SWARM_OPTIONS = typeof(SwarmOptions(1, 0, 1, 0, 1.0, 0, 0.8, 0.01, 0, 1, 0, 0, 0))


@kernel(types.void(ModelFn, _F, types.float64, types.float64, _F, _F, types.float64,
                   types.float64, types.int64, SWARM_WORK, _F), cache=True)
def predicted_distance_brightness(f, theta, tt, xprev_hat, noise, xn, M, kind, use_lik, wk, pt):
    """IFA's brightness of the particles xn: d_i, the distance of (h(x_i), x_i) to (y_t,
    f(xhat_{t-1}) + noise mean), each coordinate in units of its noise standard deviation
    (-2 ll = (y - h)^2 / R); kind (codes.BRIGHTNESS) gaussian: exp(-d^2/2), scaled by exp(-M)
    (ratios and order unchanged), inverse: 1 / (1 + d), distance: -d (the distance itself,
    smaller brighter: ``swarm.ifa_move``), likelihood: exp(ll - M), the measurement's alone (no
    distance). pt (2,) scratch. With the model's own likelihood (``use_lik``) the measurement's
    part of d^2 is -2 (ll - M), M the particles' largest log-likelihood (its distance from the
    likeliest particle: a likelihood has no absolute scale)."""
    if kind == BRIGHTNESS_LIKELIHOOD:
        shifted_exp(wk.ll, M, wk.fit)
        return
    Qv = noise[1] if noise[0] == NOISE_GAUSSIAN else noise[1] / (noise[2] * noise[2])
    qmean = 0.0 if noise[0] == NOISE_GAUSSIAN else noise[1] / noise[2]
    pt[0] = xprev_hat
    f(pt[:1], tt, theta, pt[1:])
    xbar = pt[1] + qmean
    if kind == BRIGHTNESS_GAUSSIAN:
        for i in range(xn.size):
            e = xn[i] - xbar
            wk.fit[i] = 0.5 * e * e / Qv
        shifted_exp_less(wk.ll, M, wk.fit, wk.fit)
    elif kind == BRIGHTNESS_DISTANCE:
        M0 = M if use_lik else 0.0
        for i in range(xn.size):
            e = xn[i] - xbar
            wk.fit[i] = -math.sqrt(-2.0 * (wk.ll[i] - M0) + e * e / Qv)
    else:
        if use_lik:
            for i in range(xn.size):
                e = xn[i] - xbar
                wk.fit[i] = 1.0 / (1.0 + math.sqrt(-2.0 * (wk.ll[i] - M) + e * e / Qv))
        else:
            for i in range(xn.size):
                e = xn[i] - xbar
                wk.fit[i] = 1.0 / (1.0 + math.sqrt(-2.0 * wk.ll[i] + e * e / Qv))


@kernel(types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, types.float64, types.float64, _F,
                    types.float64, _F, SWARM_PARAMS, types.int64, SWARM_WORK, _F, _F), cache=True)
def swarm_fitness(f, h, lik, use_lik, theta, tt, yt, noise, xprev_hat, xn, p, request, wk, hx,
                  pt):
    """What ``swarm.swarm_move`` asks (``request``), over the particles xn: the log-likelihood of
    y_t at the points it names (h at up to 3 N points into hx, or the model's own ``lik`` with
    ``use_lik``), or IFA's brightness (its kind p.brightness); returns the likelihood
    evaluations."""
    N = xn.size
    half_inv_R = 0.5 / noise[3]
    if request == FIT_X:
        _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, xn, hx[:N], wk.ll)
    elif request == FIT_CANDIDATES:
        _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, wk.C[:N], hx[:N], wk.llC[:N])
    elif request == FIT_CENTRES:
        _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, wk.Xc, hx[:N], wk.llc)
    elif request == FIT_BEHAVIOURS:
        _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, wk.C, hx, wk.llC)
    elif request == FIT_BRIGHTNESS:
        predicted_distance_brightness(f, theta, tt, xprev_hat, noise, xn, wk.ll.max(),
                                      p.brightness, use_lik, wk, pt)
    return evaluations(request, N)


@kernel(types.void(_F, _F, _F, types.float64, _F, _I, types.int8[::1], SWARM_OPTIONS, STATE),
      cache=True)
def resample_swarm(x, xn, w, S, lw, idx, mutant, o, s):
    """The resampled set of xn (weights w, sum S) into x: the stepwise EWA's plan with its
    mutations, or a standard scheme; the log-weights lw reset."""
    N = x.size
    if o.scheme == EWA:
        divide(w, S, w)
        stepwise_ewa_plan(w, o.ewa_beta, o.ewa_printed, o.ewa_copies, idx, mutant)
        for i in range(N):
            v = xn[idx[i]]
            x[i] = ewa_mutant(v, o.ewa_mu, s) if mutant[i] else v
    else:
        resample(o.scheme, w, S, s, idx)
        for i in range(N):
            x[i] = xn[idx[i]]
    for i in range(N):
        lw[i] = 0.0


@kernel(types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, types.float64, types.float64, _F,
                    types.float64, _F, SWARM_OPTIONS, SWARM_PARAMS, SWARM_WORK, _F, _F, STATE),
        cache=True)
def swarm_refine(f, h, lik, use_lik, theta, tt, yt, noise, xprev_hat, xn, o, p, wk, hx, pt, s):
    """The swarm's o.iters iterations (``swarm.swarm_move``, its fitness ``swarm_fitness``) on
    the predicted particles xn, from their log-likelihood of y_t (into wk.ll, kept up to date);
    returns the likelihood evaluations of the step."""
    N = xn.size
    _loglik(h, lik, use_lik, theta, tt, yt, 0.5 / noise[3], xn, hx[:N], wk.ll)
    return N + swarm_iterations(f, h, lik, use_lik, theta, tt, yt, noise, xprev_hat, xn, o, p, wk,
                                hx, pt, s)


@kernel(types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, types.float64, types.float64, _F,
                    types.float64, _F, SWARM_OPTIONS, SWARM_PARAMS, SWARM_WORK, _F, _F, STATE),
        cache=True)
def swarm_iterations(f, h, lik, use_lik, theta, tt, yt, noise, xprev_hat, xn, o, p, wk, hx, pt,
                     s):
    """``swarm_refine`` from the particles' log-likelihoods already in wk.ll; returns the
    likelihood evaluations of the iterations."""
    nev = 0
    for it in range(o.iters):
        phase = 0
        while True:
            request = swarm_move(o.algo, AFSA_JOINT_SHIFT, phase, xn, 1, p, noise[3], it, wk, s)
            if request == DONE:
                break
            nev += swarm_fitness(f, h, lik, use_lik, theta, tt, yt, noise, xprev_hat, xn, p,
                                 request, wk, hx, pt)
            phase += 1
    return nev


@kernel(types.void(_F, _F, _F, _F, _F), cache=True)
def add_prior_ratio(noise, fx, xpre, xn, ll):
    """ll += log p(xn | x_{t-1}) - log p(xpre | x_{t-1}), the transition density at xn - fx and at
    xpre - fx (fx = f(x_{t-1}), each particle's parent's), the prior-ratio correction of a moved
    particle xn whose place before the move was xpre."""
    for i in range(ll.size):
        ll[i] += process_logpdf(noise, xn[i] - fx[i]) - process_logpdf(noise, xpre[i] - fx[i])


@kernel(types.float64(_F, _F), cache=True)
def add_loglik(lw, ll):
    """lw += ll (the log-weights times the likelihood); returns their maximum (NaN skipped)."""
    mx = -np.inf
    for i in range(lw.size):
        l = lw[i] + ll[i]
        lw[i] = l
        mx = max(mx, l)
    return mx


@kernel(types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, _F, _F, SWARM_OPTIONS, SWARM_PARAMS,
                    STATE, _F, _F, _F, _I, _F, _F, _F, _F, _F, _F, _F, _I, types.int8[::1],
                    types.int8[::1], SWARM_WORK, _F, _F), cache=True)
def resample_then_move(f, h, lik, use_lik, theta, noise, y, o, p, s, x, xhat, ess, resampled,
                       div_l1, distinct, pvar, evals, xn, lw, w, idx, mutant, mark, wk, hx, pt):
    """``swarm_pf_kernel``'s steps in the order predict, weigh, resample, move, weigh again (the
    module's ``resample_then_move``; x the particles drawn from the prior, the rest its traces
    and scratch); returns the underflow count."""
    T, N = y.size - 1, o.N
    correct = o.correction == CORRECTION_PRIOR_RATIO
    fx = np.empty(N)            # f(x_{t-1}) of each particle's parent
    fxr = np.empty(N)           # the same, of the resampled set
    xpre = np.empty(N)
    llr = np.empty(N)
    lw0 = np.empty(N)           # the log-weights before the step's likelihood
    half_inv_R = 0.5 / noise[3]
    events = 0
    for t in range(1, T + 1):
        tt, yt = float(t), y[t]
        f(x, tt, theta, xn)
        fx[:] = xn
        add_process_noise(s, noise, xn)
        _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, xn, hx[:N], wk.ll)
        nev = N
        lw0[:] = lw
        mx = add_loglik(lw, wk.ll)
        S, est, under = weigh_lanes(lw, w, xn, mx, t, ess, resampled, div_l1, distinct)
        events += int(under)
        if ess[t] < o.threshold:
            resample_swarm(x, xn, w, S, lw, idx, mutant, o, s)
            resampled_step(x, xn, idx, mark, t, est, 0, o.diag, resampled, div_l1, distinct,
                           pvar)
            for i in range(N):
                fxr[i] = fx[idx[i]]
                if o.scheme == EWA and mutant[i]:
                    _loglik(h, lik, use_lik, theta, tt, yt, half_inv_R, x[i:i + 1],
                            hx[i:i + 1], llr[i:i + 1])
                    nev += 1
                else:
                    llr[i] = wk.ll[idx[i]]
            wk.ll[:] = llr
        else:
            x[:] = xn
            fxr[:] = fx
            lw[:] = lw0
        xpre[:] = x
        nev += swarm_iterations(f, h, lik, use_lik, theta, tt, yt, noise, xhat[t - 1], x, o, p,
                                wk, hx, pt, s)
        llr[:] = wk.ll
        if correct:
            add_prior_ratio(noise, fxr, xpre, x, llr)
        mx = add_loglik(lw, llr)
        S, S2, sx, under = normalise_lanes(lw, w, x, mx)
        events += int(under)
        xhat[t] = sx / S
        record_spread(o.diag, t, w, x, S, xhat[t], pvar)
        evals[t] = nev
    return events


SWARM_SIG = types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, _F, _F, types.float64,
                        types.float64, SWARM_OPTIONS, SWARM_PARAMS, STATE, _F, _F, _I, _F, _F, _F,
                        _F)


@kernel(SWARM_SIG, cache=True)
def swarm_pf_kernel(f, h, lik, use_lik, theta, noise, y, prior_mean, prior_var, o, p, s, xhat, ess,
                    resampled, div_l1, distinct, pvar, evals):
    """Run a swarm-optimised PF over y (T+1,) (settings o, see ``SwarmOptions``; the swarm's
    parameters p, a ``swarm.SwarmParams``; the likelihood: the model's ``lik`` with ``use_lik``,
    else the Gaussian of y - h(x)); fill the (T+1,) traces and evals, the likelihood
    evaluations of each step (pvar, the variance of the cloud xhat is the mean of, where o.diag
    asks: ``_common.record_spread``, ``resampled_step``); return the underflow count. Each step: predict, refine (the
    swarm), weigh, estimate, resample."""
    T, N = y.size - 1, o.N
    x = np.empty(N)
    start(s, prior_mean, prior_var, x, xhat, ess, resampled, div_l1, distinct)
    xn = np.empty(N)            # the predicted (and refined) particles
    lw = np.zeros(N)
    w = np.empty(N)
    idx = np.empty(N, dtype=np.int64)
    mutant = np.empty(N, dtype=np.int8)
    mark = np.empty(N if o.diag & DIAG_DISTINCT else 0, dtype=np.int8)
    wk = new_swarm_work(N, 1)
    hx = np.empty(3 * N)        # h at the points the swarm's fitness evaluates
    pt = np.empty(2)
    correct = o.correction == CORRECTION_PRIOR_RATIO
    fx = np.empty(N if correct else 0)      # f(x_{t-1}) of each particle's parent
    xpre = np.empty(N if correct else 0)    # its place before the move
    lr = np.empty(N if correct else 0)      # its log-weight increment
    events = 0
    evals[0] = 0.0
    if o.order == ORDER_RESAMPLE_THEN_MOVE:
        return resample_then_move(f, h, lik, use_lik, theta, noise, y, o, p, s, x, xhat, ess,
                                  resampled, div_l1, distinct, pvar, evals, xn, lw, w, idx,
                                  mutant, mark, wk, hx, pt)
    for t in range(1, T + 1):
        tt, yt = float(t), y[t]
        f(x, tt, theta, xn)
        if correct:
            fx[:] = xn
        add_process_noise(s, noise, xn)
        if correct:
            xpre[:] = xn
        evals[t] = swarm_refine(f, h, lik, use_lik, theta, tt, yt, noise, xhat[t - 1], xn, o, p,
                                wk, hx, pt, s)
        if correct:
            lr[:] = wk.ll
            add_prior_ratio(noise, fx, xpre, xn, lr)
            mx = add_loglik(lw, lr)
        else:
            mx = add_loglik(lw, wk.ll)
        S, est, under = weigh_lanes(lw, w, xn, mx, t, ess, resampled, div_l1, distinct)
        events += int(under)
        record_spread(o.diag, t, w, xn, S, est, pvar)
        if ess[t] < o.threshold:
            resample_swarm(x, xn, w, S, lw, idx, mutant, o, s)
            est = resampled_step(x, xn, idx, mark, t, est, o.estimate_after, o.diag, resampled,
                                 div_l1, distinct, pvar)
        else:
            x[:] = xn
        xhat[t] = est
    return events


def make_run(kind: str):
    """The ``run`` of swarm filter ``kind`` (a key of ALGORITHMS)."""
    def run(model, y, params, particles, state, diag=True):
        diag = int(flags(diag))
        T1 = y.size
        out = {"xhat": np.empty(T1), "ess": np.empty(T1),
               "resampled": np.empty(T1, dtype=np.int64), "div_l1": np.empty(T1),
               "distinct": np.empty(T1), "pvar": spread_trace(T1, model.prior_var)}
        evals = np.empty(T1)
        threshold = ess_threshold(params, particles)
        scheme = EWA if params["resampling"] == "stepwise_ewa" else SCHEME_CODES[params["resampling"]]
        o = SwarmOptions(
            N=int(particles), algo=ALGORITHMS[kind], iters=int(params["iterations"]),
            scheme=int(scheme), threshold=float(threshold),
            estimate_after=int(params["estimate"] == "after_resampling"),
            ewa_beta=float(params["ewa_beta"]), ewa_mu=float(params["ewa_mu"]),
            ewa_printed=int(params["ewa_correction"] == "as_printed"), diag=diag,
            ewa_copies=EWA_COPIES[params["ewa_copies"]],
            correction=MOVE_CORRECTIONS[params["move_correction"]],
            order=MOVE_ORDERS[params["move_order"]])
        out["underflow_steps"] = swarm_pf_kernel(
            model.transition, model.observe, *model.likelihood(), model.theta, model.noise, y,
            model.prior_mean, model.prior_var, o, swarm_params(kind, params), state, out["xhat"],
            out["ess"], out["resampled"], out["div_l1"], out["distinct"], out["pvar"], evals)
        out["lik_evals_per_step"] = float(np.mean(evals[1:]))
        return drop_unasked(out, diag)
    return run


def check_order(params):
    """The rule across keys: resample_then_move reports the moved set's weighted mean, so it takes
    no estimate after resampling."""
    if params["move_order"] == "resample_then_move" and params["estimate"] == "after_resampling":
        return ("estimate", "move_order: resample_then_move estimates by the moved set's weighted "
                "mean; estimate: after_resampling applies to move_then_resample only")
    return None


def swarm_pf_keys(algo: str, resampling: str = "systematic", **own) -> dict:
    """The keys of the swarm PF of algorithm ``algo`` (its swarm's keys, then ``own``)."""
    pf = pf_keys()
    return {
        "iterations": Key("int", 1, "swarm iterations per step (each evaluates the likelihood of "
                          "every moved particle)", min=0),
        **keys(algo),
        **own,
        "move_correction": Key(
            "choice", "none", "the moved particles' weights: 'none' the likelihood p(y | x') only "
            "(the papers' text, pfbench's reading); 'prior_ratio' times p(x' | x_{t-1}) / "
            "p(x | x_{t-1}), x the particle's place before the move (the importance correction "
            "of a deterministic move, its Jacobian left out)", choices=tuple(MOVE_CORRECTIONS)),
        "move_order": Key(
            "choice", "move_then_resample", "'move_then_resample': predict, move, weigh, "
            "estimate, resample (pfbench's reading: the papers move the predicted particles); "
            "'resample_then_move': predict, weigh, resample, move the resampled set and weigh "
            "it again by the likelihood; the estimate is the moved set's weighted mean",
            choices=tuple(MOVE_ORDERS)),
        "resampling": Key("choice", resampling, "resampling scheme; 'stepwise_ewa' is ifa2021's "
                          "stepwise EWA resampling", choices=tuple(SCHEMES) + ("stepwise_ewa",)),
        "resample": pf["resample"],
        "neff_ratio": pf["neff_ratio"],
        "estimate": pf["estimate"],
        **ewa_keys(),
    }


FA_PF = FilterType(
    "fa", "firefly-algorithm PF (FA-PF): fireflies toward brighter (likelier) particles; O(N^2) "
    "per iteration", swarm_pf_keys("fa"), make_run("fa"), check=check_order, cost="N^2",
    needs=("likelihood",))
IFA_PF = FilterType(
    "ifa", "improved firefly PF (IFA-PF, ifa2021): distance brightness, adaptive step, stepwise "
    "EWA resampling; O(N^2) per iteration",
    swarm_pf_keys("ifa", "stepwise_ewa", brightness=Key(
        "choice", "gaussian", "IFA's brightness from the distance d (measurement and predicted "
        "state, each in units of its noise standard deviation): 'gaussian' exp(-d^2 / 2) "
        "(pfbench's reading) or 'inverse' 1 / (1 + d); 'distance' d itself, smaller brighter "
        "(ifa2021's text: I = the Euclidean distance; the step's ratio I_i / I_j is then "
        "d_i / d_j >= 1); 'likelihood' the likelihood of the measurement alone, max-shifted "
        "(FA-PF's fitness)", choices=tuple(BRIGHTNESS))),
    make_run("ifa"), check=check_order, cost="N^2", needs=("likelihood",))
BA_PF = FilterType(
    "ba", "bat-algorithm PF (BA-PF): frequency-tuned velocities, loudness and pulse rate",
    swarm_pf_keys("ba"), make_run("ba"), check=check_order, needs=("likelihood",))
PSO_PF = FilterType(
    "pso", "particle-swarm PF (PSO-PF): moves toward personal and global best likelihood",
    swarm_pf_keys("pso"), make_run("pso"), check=check_order, needs=("likelihood",))
AFSA_PF = FilterType(
    "afsa", "artificial-fish-swarm PF (AFSA-PF): prey, swarm and follow behaviours; O(N^2) per "
    "iteration", swarm_pf_keys("afsa"), make_run("afsa"), check=check_order, cost="N^2",
    needs=("likelihood",))
