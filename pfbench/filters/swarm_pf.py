"""Swarm-optimised particle filters on a scalar model: FA-PF, IFA-PF (ifa2021), BA-PF, PSO-PF,
AFSA-PF.

Per step: predict the particles through the transition, run ``iterations`` swarm moves on them
(fitness: the likelihood of the current measurement), weight the moved particles by the
likelihood, estimate, resample. As in the papers, the weights are not corrected for having moved
the particles (the moved set is treated as a draw from the prior): a documented property of these
filters, which the equal-compute PF rows of the tables put in perspective.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, types

from ..resampling import SCHEME_CODES, SCHEMES, resample, stepwise_ewa_plan
from ..rng import STATE, normal
from ..schema import Key
from ..models.scalar import NOISE_GAUSSIAN, ModelFn, add_process_noise
from ._common import resampled_step, start, weigh
from .keys import ewa_keys, pf_keys
from .swarm import (ALGORITHMS, BA, FA, IFA, PSO, afsa_centres, afsa_propose, afsa_select, argmax,
                    ba_accept, ba_propose, fa_move, ifa_move, keys, pack, pso_accept, pso_propose)
from .types import FilterType

_F = types.float64[::1]
_I = types.int64[::1]

EWA = len(SCHEME_CODES)          # the stepwise EWA scheme's code, after the standard ones

SWARM_SIG = types.int64(ModelFn, ModelFn, _F, _F, _F, types.float64, types.float64, types.int64,
                        types.int64, _F, types.int64, types.int64, types.float64, types.int64,
                        types.float64, types.float64, types.int64, types.int64, STATE, _F, _F, _I,
                        _F, _F, _F)


@njit(types.void(ModelFn, _F, types.float64, types.float64, types.float64, _F, _F, _F),
      cache=True)
def _loglik(h, theta, tt, yt, half_inv_R, X, hx, ll):
    """ll = log p(y_t | X) up to a constant, for every point of X; hx is scratch."""
    h(X, tt, theta, hx)
    for i in range(X.size):
        d = yt - hx[i]
        ll[i] = -half_inv_R * d * d


@njit(types.void(_F, types.float64, _F), cache=True)
def _shifted_exp(ll, M, out):
    for i in range(ll.size):
        out[i] = math.exp(ll[i] - M)


@njit(SWARM_SIG, cache=True)
def swarm_pf_kernel(f, h, theta, noise, y, prior_mean, prior_var, N, algo, p, iters, scheme,
                    threshold, estimate_after, ewa_beta, ewa_mu, ewa_printed, diag, s,
                    xhat, ess, resampled, div_l1, distinct, evals):
    """Run a swarm-optimised PF over y (T+1,); fill the (T+1,) traces; return the underflow count.

    algo : a value of ALGORITHMS; p : its parameters
        fa [beta0, gamma, alpha]; ifa [beta0, gamma, brightness (0: exp(-d^2/2), 1: 1/(1+d))];
        ba [fmin, fmax, A0, r0, alpha, gamma];
        pso [w, c1, c2]; afsa [visual, step, delta, tries, greedy]
    scheme : a resampling scheme code, or EWA (stepwise EWA with ewa_beta, mutation ewa_mu, the
        bias correction inside the recursion when ewa_printed)
    evals : (T+1,) filled with the likelihood evaluations of each step
    """
    T = y.size - 1
    R = noise[3]
    half_inv_R = 0.5 / R
    Qv = noise[1] if noise[0] == NOISE_GAUSSIAN else noise[1] / (noise[2] * noise[2])
    qmean = 0.0 if noise[0] == NOISE_GAUSSIAN else noise[1] / noise[2]
    x = np.empty(N)
    start(s, prior_mean, prior_var, x, xhat, ess, resampled, div_l1, distinct)
    xn = np.empty(N)
    hx = np.empty(3 * N)
    ll = np.empty(N)
    fit = np.empty(N)
    lw = np.zeros(N)
    w = np.empty(N)
    idx = np.empty(N, dtype=np.int64)
    mutant = np.empty(N, dtype=np.int8)
    V = np.empty(N)
    P = np.empty(N)
    Pfit = np.empty(N)
    A = np.empty(N)
    r = np.empty(N)
    C = np.empty(3 * N)
    llC = np.empty(3 * N)
    Xc = np.empty(N)
    llc = np.empty(N)
    fitc = np.empty(N)
    nf = np.empty(N)
    one = np.empty(1)
    onef = np.empty(1)
    unit = np.ones(1)
    events = 0
    evals[0] = 0.0
    for t in range(1, T + 1):
        tt = float(t)
        yt = y[t]
        f(x, tt, theta, xn)
        add_process_noise(s, noise, xn)
        _loglik(h, theta, tt, yt, half_inv_R, xn, hx[:N], ll)
        nev = N
        for it in range(iters):
            M = ll.max()
            if algo == FA:                                  # FA: brightness = likelihood
                _shifted_exp(ll, M, fit)
                fa_move(xn, fit, 1, p[0], p[1], p[2], unit, s)
            elif algo == IFA:                               # IFA: distance brightness
                # d_i: distance of (h(x_i), x_i) to (y_t, f(xhat_{t-1}) + noise mean), each
                # coordinate in units of its noise standard deviation; -2 ll = (y - h)^2 / R
                one[0] = xhat[t - 1]
                f(one, tt, theta, onef)
                xbar = onef[0] + qmean
                for i in range(N):
                    e = xn[i] - xbar
                    if p[2] == 0.0:   # exp(-d^2/2), scaled by exp(-M): ratios and order unchanged
                        fit[i] = math.exp(ll[i] - M - 0.5 * e * e / Qv)
                    else:
                        fit[i] = 1.0 / (1.0 + math.sqrt(-2.0 * ll[i] + e * e / Qv))
                ifa_move(xn, fit, 1, p[0], p[1], R, unit, s)
            elif algo == BA:
                if it == 0:
                    V[:] = 0.0
                    A[:] = p[2]
                    r[:] = p[3]
                g = argmax(ll)
                ba_propose(xn, V, A, r, C[:N], 1, g, p[0], p[1], unit, s)
                _loglik(h, theta, tt, yt, half_inv_R, C[:N], hx[:N], llC[:N])
                nev += N
                ba_accept(xn, ll, C[:N], llC[:N], A, r, 1, p[4], p[5], p[3], it + 1, s)
                continue
            elif algo == PSO:
                if it == 0:
                    V[:] = 0.0
                    P[:] = xn
                    Pfit[:] = ll
                g = argmax(Pfit)
                pso_propose(xn, V, P, Pfit, 1, g, p[0], p[1], p[2], s)
                _loglik(h, theta, tt, yt, half_inv_R, xn, hx[:N], ll)
                nev += N
                pso_accept(xn, ll, P, Pfit, 1)
                continue
            else:                                           # AFSA
                afsa_centres(xn, fit, 1, p[0], Xc, nf)
                _loglik(h, theta, tt, yt, half_inv_R, Xc, hx[:N], llc)
                # one shift for the fish and their centres, so that no fitness overflows (a
                # centre can be far likelier than every fish when the noise is small)
                M = max(M, llc.max())
                _shifted_exp(ll, M, fit)
                _shifted_exp(llc, M, fitc)
                afsa_propose(xn, fit, Xc, fitc, nf, 1, p[0], p[1], p[2], int(p[3]), s, C)
                _loglik(h, theta, tt, yt, half_inv_R, C, hx, llC)
                nev += 4 * N
                # the choice only compares fitnesses, so it takes the log-likelihoods: exact
                # where exp(ll - M) would underflow to a tie at 0 (or overflow)
                afsa_select(xn, ll, C, llC, 1, int(p[4]))
                continue
            _loglik(h, theta, tt, yt, half_inv_R, xn, hx[:N], ll)   # FA and IFA moved: re-weigh
            nev += N
        evals[t] = nev
        mx = -np.inf
        for i in range(N):
            l = lw[i] + ll[i]
            lw[i] = l
            mx = max(mx, l)
        S, est, under = weigh(lw, w, xn, mx, t, ess, resampled, div_l1, distinct)
        events += int(under)
        if ess[t] < threshold:
            if scheme == EWA:
                for i in range(N):
                    w[i] /= S
                stepwise_ewa_plan(w, ewa_beta, ewa_printed, idx, mutant)
                for i in range(N):
                    v = xn[idx[i]]
                    x[i] = v + v * ewa_mu * normal(s) if mutant[i] else v
            else:
                resample(scheme, w, S, s, idx)
                for i in range(N):
                    x[i] = xn[idx[i]]
            for i in range(N):
                lw[i] = 0.0
            est = resampled_step(x, t, est, estimate_after, diag, resampled, div_l1, distinct)
        else:
            x[:] = xn
        xhat[t] = est
    return events


def make_run(kind: str):
    """The ``run`` of swarm filter ``kind`` (a key of ALGORITHMS)."""
    def run(model, y, params, particles, state, diag=True):
        T1 = y.size
        out = {"xhat": np.empty(T1), "ess": np.empty(T1),
               "resampled": np.empty(T1, dtype=np.int64), "div_l1": np.empty(T1),
               "distinct": np.empty(T1)}
        evals = np.empty(T1)
        threshold = (np.inf if params["resample"] == "always"
                     else params["neff_ratio"] * particles)
        scheme = EWA if params["resampling"] == "stepwise_ewa" else SCHEME_CODES[params["resampling"]]
        out["underflow_steps"] = swarm_pf_kernel(
            model.transition, model.observe, model.theta, model.noise, y, model.prior_mean,
            model.prior_var, particles, ALGORITHMS[kind], pack(kind, params),
            params["iterations"], scheme, threshold,
            int(params["estimate"] == "after_resampling"), params["ewa_beta"], params["ewa_mu"],
            int(params["ewa_correction"] == "as_printed"), int(diag), state, out["xhat"], out["ess"], out["resampled"], out["div_l1"],
            out["distinct"], evals)
        out["lik_evals_per_step"] = float(np.mean(evals[1:]))
        return out
    return run


def swarm_pf_keys(algo: str, resampling: str = "systematic", **own) -> dict:
    """The keys of the swarm PF of algorithm ``algo`` (its swarm's keys, then ``own``)."""
    pf = pf_keys()
    return {
        "iterations": Key("int", 1, "swarm iterations per step (each evaluates the likelihood of "
                          "every moved particle)", min=0),
        **keys(algo),
        **own,
        "resampling": Key("choice", resampling, "resampling scheme; 'stepwise_ewa' is ifa2021's "
                          "stepwise EWA resampling", choices=tuple(SCHEMES) + ("stepwise_ewa",)),
        "resample": pf["resample"],
        "neff_ratio": pf["neff_ratio"],
        "estimate": pf["estimate"],
        **ewa_keys(),
    }


FA_PF = FilterType(
    "fa", "firefly-algorithm PF (FA-PF): fireflies toward brighter (likelier) particles; O(N^2) "
    "per iteration", swarm_pf_keys("fa"), make_run("fa"), cost="N^2")
IFA_PF = FilterType(
    "ifa", "improved firefly PF (IFA-PF, ifa2021): distance brightness, adaptive step, stepwise "
    "EWA resampling; O(N^2) per iteration",
    swarm_pf_keys("ifa", "stepwise_ewa", brightness=Key(
        "choice", "gaussian", "how the distance d (measurement and predicted state, each in units "
        "of its noise standard deviation) becomes a brightness: 'gaussian' exp(-d^2 / 2) or "
        "'inverse' 1 / (1 + d); ifa2021 leaves it open", choices=("gaussian", "inverse"))),
    make_run("ifa"), cost="N^2")
BA_PF = FilterType(
    "ba", "bat-algorithm PF (BA-PF): frequency-tuned velocities, loudness and pulse rate",
    swarm_pf_keys("ba"), make_run("ba"))
PSO_PF = FilterType(
    "pso", "particle-swarm PF (PSO-PF): moves toward personal and global best likelihood",
    swarm_pf_keys("pso"), make_run("pso"))
AFSA_PF = FilterType(
    "afsa", "artificial-fish-swarm PF (AFSA-PF): prey, swarm and follow behaviours; O(N^2) per "
    "iteration", swarm_pf_keys("afsa"), make_run("afsa"), cost="N^2")
