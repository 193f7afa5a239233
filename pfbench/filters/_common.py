"""Steps shared by the particle-filter kernels: a step's weights (by ``weights``), the MH move,
diagnostics."""
from __future__ import annotations

import math

import numpy as np
from numba import types
from .._lazy import kernel

from ..rng import STATE, fill_normal, uniform
from ..models.scalar import LikFn, ModelFn, add_process_noise
from .weights import ess as ess_of, normalise, normalise_lanes

_F = types.float64[::1]
_I = types.int64[::1]


@kernel(types.void(STATE, types.float64, types.float64, _F, _F, _F, _I, _F, _F), cache=True)
def start(s, prior_mean, prior_var, x, xhat, ess, resampled, div_l1, distinct):
    """Draw the particles x (N,) from the Gaussian prior and fill the traces' entry for t = 0."""
    fill_normal(s, x)
    sd0 = math.sqrt(prior_var)
    for i in range(x.size):
        x[i] = prior_mean + sd0 * x[i]
    xhat[0] = prior_mean
    ess[0] = x.size
    resampled[0] = 0
    div_l1[0] = np.nan
    distinct[0] = np.nan


@kernel(types.float64(types.float64, types.float64), cache=True, inline="always")
def floored(l, log_floor):
    """log(exp(l) + exp(log_floor)): a log-likelihood with an additive floor on the likelihood.

    The reference implementation of the Gamma-noise benchmark adds 1e-99 to R^(-1/2)
    exp(-d^2 / 2R) "to deal with ill-conditioning"; log_floor = -inf leaves l unchanged.
    """
    if log_floor == -np.inf:
        return l
    hi = max(l, log_floor)
    return hi + math.log1p(math.exp(-abs(l - log_floor)))


@kernel(types.UniTuple(types.float64, 3)(types.float64, types.float64, types.float64,
                                       types.float64, types.int64, _F, _I, _F, _F),
        cache=True, inline="always")
def _record_step(S, S2, sx, under, t, ess, resampled, div_l1, distinct):
    """Step t's ESS from the sums, its resampling entries as 'not resampled'; returns (S, the
    weighted mean, underflow)."""
    ess[t] = ess_of(S, S2)
    resampled[t] = 0
    div_l1[t] = np.nan
    distinct[t] = np.nan
    return S, sx / S, under


@kernel(types.UniTuple(types.float64, 3)(_F, _F, _F, types.float64, types.int64, _F, _I, _F, _F),
      cache=True)
def weigh(lw, w, x, m, t, ess, resampled, div_l1, distinct):
    """One step's weights (``weights.normalise``), ESS and weighted mean; the step's resampling
    entries start as 'not resampled'. Returns (S, the weighted mean, underflow)."""
    S, S2, sx, under = normalise(lw, w, x, m)
    return _record_step(S, S2, sx, under, t, ess, resampled, div_l1, distinct)


@kernel(types.UniTuple(types.float64, 3)(_F, _F, _F, types.float64, types.int64, _F, _I, _F, _F),
        cache=True)
def weigh_lanes(lw, w, x, m, t, ess, resampled, div_l1, distinct):
    """``weigh`` by ``weights.normalise_lanes``."""
    S, S2, sx, under = normalise_lanes(lw, w, x, m)
    return _record_step(S, S2, sx, under, t, ess, resampled, div_l1, distinct)


@kernel(types.UniTuple(types.float64, 2)(_F), cache=True)
def diversity(x):
    """(mean pairwise |x_i - x_j| over pairs i < j, fraction of distinct values) of particles x."""
    N = x.size
    if N < 2:
        return 0.0, 1.0
    z = np.sort(x)
    acc = 0.0
    distinct = 1
    for i in range(N):
        acc += (2.0 * i - N + 1.0) * z[i]
        if i > 0 and z[i] != z[i - 1]:
            distinct += 1
    return 2.0 * acc / (N * (N - 1.0)), distinct / N


@kernel(types.float64(_F), cache=True)
def mean_abs_pairwise(x):
    """Mean over pairs i < j of |x_i - x_j| (O(N log N) through the sorted values)."""
    return diversity(x)[0]


# The diagnostics flags a kernel's ``diag`` holds (pfbench.diagnostics.Diag).
DIAG_DISTINCT = 1       # the fraction of distinct particles after each resampling
DIAG_DIVERSITY = 2      # their mean pairwise |x_i - x_j| (a sort at each resampling)
DIAG_MAP_TRACE = 4      # SLAM: the map error after each observation
DIAG_SPREAD = 8         # the posterior variance of the cloud the estimate is the mean of (NEES)


@kernel(types.float64(_F, _F, types.float64, types.float64), cache=True, error_model="numpy")
def weighted_var(w, x, S, m):
    """sum_i w_i (x_i - m)^2 / S: the variance about m (their weighted mean) of particles x (N,)
    of weights w (N,) summing to S, the posterior variance the weighted mean m estimates with.
    Four partial sums (a loop the compiler vectorises); a particle of weight 0 counts for
    nothing even at +-inf or NaN (as in the weighted mean, ``weights._finite_sum``)."""
    N = x.size
    a0 = a1 = a2 = a3 = 0.0
    top = N - N % 4
    for i in range(0, top, 4):
        d0, d1, d2, d3 = x[i] - m, x[i + 1] - m, x[i + 2] - m, x[i + 3] - m
        a0 += w[i] * d0 * d0
        a1 += w[i + 1] * d1 * d1
        a2 += w[i + 2] * d2 * d2
        a3 += w[i + 3] * d3 * d3
    for i in range(top, N):
        d = x[i] - m
        a0 += w[i] * d * d
    v = (a0 + a1) + (a2 + a3)
    if not math.isfinite(v):
        v = 0.0
        for i in range(N):
            if w[i] > 0.0:
                d = x[i] - m
                v += w[i] * d * d
    return v / S


@kernel(types.float64(_F, types.float64), cache=True, error_model="numpy")
def plain_var(x, m):
    """sum_i (x_i - m)^2 / N: the variance about m (their plain mean) of equally weighted
    particles x (N,), a resampled set's."""
    N = x.size
    a0 = a1 = a2 = a3 = 0.0
    top = N - N % 4
    for i in range(0, top, 4):
        d0, d1, d2, d3 = x[i] - m, x[i + 1] - m, x[i + 2] - m, x[i + 3] - m
        a0 += d0 * d0
        a1 += d1 * d1
        a2 += d2 * d2
        a3 += d3 * d3
    for i in range(top, N):
        d = x[i] - m
        a0 += d * d
    return ((a0 + a1) + (a2 + a3)) / N


@kernel(types.int64(_F, _F, _I, types.int8[::1]), cache=True)
def distinct_count(x, xn, idx, mark):
    """The distinct particles of a resampled set, counted from its ancestors: x (N,) the set,
    particle i drawn from xn[idx[i]] (xn: the particles before resampling, unchanged) and then
    perhaps moved (an MH move, a mutation). A particle whose value is no longer its ancestor's
    counts once (a NaN too, as a NaN equals nothing), and each ancestor of the others once.
    O(N), no sort: two passes the compiler vectorises when the ancestors come in order
    (systematic, stratified and multinomial resampling give them so) and no particle moved (a
    plain PF), a third without a branch when some moved; ancestors out of order (residual
    resampling) are counted by marks instead (mark (xn.size,) scratch).

    This is the number of distinct values of x whenever the particles xn are pairwise distinct
    and a moved particle's value is new: what continuous noise drawn for every particle gives,
    with probability one (every pfbench scalar filter draws its process noise, of a variance > 0,
    for every particle). It counts more than the distinct values only when two ancestors hold
    one value (noise below the rounding of the particles' magnitude, two that ran off to the
    same infinity)."""
    N = x.size
    if N == 0:
        return 0
    # the usual case, in two passes the compiler vectorises: ancestors in order and no particle
    # moved, so the count is that of the changes of ancestor
    changes = 0
    down = 0
    for i in range(1, N):
        changes += idx[i] != idx[i - 1]
        down += idx[i] < idx[i - 1]
    moved = 0
    for i in range(N):
        moved += x[i] != xn[idx[i]]
    if moved == 0 and down == 0:
        return 1 + changes
    c = 0
    last = -1           # the ancestor of the last particle that kept its value
    if down == 0:
        for i in range(N):
            j = idx[i]
            m = x[i] != xn[j]
            c += m | (j != last)
            last = last if m else j
        return c
    for j in range(mark.size):
        mark[j] = 0
    c = 0
    for i in range(N):
        j = idx[i]
        if x[i] != xn[j]:
            c += 1
        elif mark[j] == 0:
            mark[j] = 1
            c += 1
    return c


@kernel(types.float64(_F, _F, _I, types.int8[::1], types.int64, types.float64, types.int64,
                      types.int64, _I, _F, _F, _F), cache=True)
def resampled_step(x, xn, idx, mark, t, est, estimate_after, diag, resampled, div_l1, distinct,
                   pvar):
    """Record that step t resampled xn (N,) into x (N,) through the ancestors idx (then perhaps
    moved): with ``diag`` & DIAG_DISTINCT its fraction of distinct particles (``distinct_count``;
    mark (N,) its scratch, empty without it), with & DIAG_DIVERSITY its mean pairwise
    |x_i - x_j| (a sort); returns the estimate, the plain mean of x when ``estimate_after``,
    else ``est`` unchanged. With ``estimate_after`` and & DIAG_SPREAD, pvar[t] becomes the
    variance of x about that mean (``plain_var``: the cloud the estimate is the mean of); else
    pvar[t] keeps what the step put there (the weighted variance before resampling)."""
    resampled[t] = 1
    if diag & DIAG_DIVERSITY:
        div_l1[t] = mean_abs_pairwise(x)
    if diag & DIAG_DISTINCT:
        distinct[t] = distinct_count(x, xn, idx, mark) / x.size
    if not estimate_after:
        return est
    est = x.sum() / x.size
    if diag & DIAG_SPREAD:
        pvar[t] = plain_var(x, est)
    return est


@kernel(types.void(types.int64, types.int64, _F, _F, types.float64, types.float64, _F),
        cache=True, inline="always")
def record_spread(diag, t, w, x, S, est, pvar):
    """With ``diag`` & DIAG_SPREAD, pvar[t] = the weighted variance of the particles x (N,) of
    weights w (N,, sum S) about their weighted mean ``est`` (``weighted_var``); nothing
    otherwise."""
    if diag & DIAG_SPREAD:
        pvar[t] = weighted_var(w, x, S, est)


def spread_trace(T1: int, prior_var: float):
    """The (T+1,) output 'pvar' of a scalar PF, its entry for t = 0 the prior's variance (the
    kernel fills the others where DIAG_SPREAD asks)."""
    pvar = np.empty(T1)
    pvar[0] = prior_var
    return pvar


def drop_unasked(out: dict, diag: int) -> dict:
    """``out`` without the diagnostic outputs ``diag`` does not ask for ('div_l1', 'distinct',
    'pvar'): a metric without its output is NaN."""
    if not diag & DIAG_DIVERSITY:
        out.pop("div_l1", None)
    if not diag & DIAG_DISTINCT:
        out.pop("distinct", None)
    if not diag & DIAG_SPREAD:
        out.pop("pvar", None)
    return out




@kernel(types.int64(ModelFn, ModelFn, _F, _F, _F, _F, _F, types.float64, types.float64,
                  types.float64, STATE, _F, _F), cache=True)
def mh_move(f, h, theta, noise, xprev, x, hx, yt, tt, log_floor, s, prop, hprop):
    """One Metropolis-Hastings move per particle toward p(x_t | x_{t-1}, y_t) (resample-move).

    xprev : (N,) each particle's previous state (its ancestor's x_{t-1})
    x, hx : (N,) current particles and h(x), updated in place where a move is accepted
    The proposal is the transition prior x* ~ p(. | xprev), so the acceptance ratio is the
    likelihood ratio p(y_t | x*) / p(y_t | x) (with the likelihood floor, see ``floored``).
    prop, hprop : (N,) scratch. Returns the number of accepted moves.
    """
    f(xprev, tt, theta, prop)
    add_process_noise(s, noise, prop)
    h(prop, tt, theta, hprop)
    half_inv_R = 0.5 / noise[3]
    c0 = -0.5 * math.log(noise[3])
    accepted = 0
    for i in range(x.size):
        d0 = yt - hx[i]
        d1 = yt - hprop[i]
        log_a = (floored(c0 - half_inv_R * d1 * d1, log_floor)
                 - floored(c0 - half_inv_R * d0 * d0, log_floor))
        if log_a >= 0.0 or math.log(uniform(s)) < log_a:
            x[i] = prop[i]
            hx[i] = hprop[i]
            accepted += 1
    return accepted


@kernel(types.int64(ModelFn, LikFn, _F, _F, _F, _F, _F, types.float64, types.float64,
                    types.float64, STATE, _F, _F), cache=True)
def mh_move_lik(f, lik, theta, noise, xprev, x, llx, yt, tt, log_floor, s, prop, llprop):
    """``mh_move`` through the model's own log-likelihood ``lik`` (``LIK_SIG``): llx (N,) holds
    the log-likelihoods of x (updated where a move is accepted), llprop (N,) scratch. A proposal
    of log-likelihood -inf is never accepted; one from a particle at -inf (or NaN) always is."""
    f(xprev, tt, theta, prop)
    add_process_noise(s, noise, prop)
    lik(prop, tt, theta, yt, llprop)
    accepted = 0
    for i in range(x.size):
        l1 = floored(llprop[i], log_floor)
        l0 = floored(llx[i], log_floor)
        if not (l1 > -np.inf):
            continue
        log_a = l1 - l0 if l0 > -np.inf else np.inf
        if log_a >= 0.0 or math.log(uniform(s)) < log_a:
            x[i] = prop[i]
            llx[i] = llprop[i]
            accepted += 1
    return accepted


# A log-likelihood of +inf (a density without bound at the measurement) counts as the largest
# double: the particles there take the weight, rather than every weight turning into NaN.
LOGLIK_MAX = np.finfo(np.float64).max


@kernel(types.void(_F), cache=True, inline="always")
def bound_above(ll):
    """ll with every +inf replaced by ``LOGLIK_MAX`` (NaN and -inf stay)."""
    for i in range(ll.size):
        if ll[i] == np.inf:
            ll[i] = LOGLIK_MAX


@kernel(types.float64(LikFn, _F, _F, types.float64, types.float64, types.float64, _F, _F),
        cache=True)
def add_own_loglik(lik, theta, x, tt, yt, log_floor, ll, lw):
    """lw += the model's own log-likelihood of y_t at the particles x (``LIK_SIG``; with the
    likelihood floor, see ``floored``; +inf bounded, see ``bound_above``), its values kept in ll
    (N,); returns the largest log-weight (NaN skipped)."""
    lik(x, tt, theta, yt, ll)
    bound_above(ll)
    mx = -np.inf
    for i in range(x.size):
        l = lw[i] + floored(ll[i], log_floor)
        lw[i] = l
        mx = max(mx, l)
    return mx


@kernel(types.int64(ModelFn, ModelFn, LikFn, types.int64, _F, _F, _F, _F, _F, types.float64,
                    types.float64, types.float64, STATE, _F, _F), cache=True)
def mh_step(f, h, lik, use_lik, theta, noise, xprev, x, hx, yt, tt, log_floor, s, prop, hprop):
    """One MH move per particle (``mh_move``), through the model's own likelihood with
    ``use_lik`` (``mh_move_lik``: hx, hprop then hold log-likelihoods)."""
    if use_lik:
        return mh_move_lik(f, lik, theta, noise, xprev, x, hx, yt, tt, log_floor, s, prop, hprop)
    return mh_move(f, h, theta, noise, xprev, x, hx, yt, tt, log_floor, s, prop, hprop)
