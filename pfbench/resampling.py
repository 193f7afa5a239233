"""Resampling schemes: multinomial, systematic, stratified, residual.

Each scheme maps non-negative weights ``w`` (N,), not necessarily normalised, to N ancestor indices.
All of them merge sorted positions in [0, S) against the running sum of ``w`` (S = sum of w). Indices
never pass the last particle of positive weight, so round-off in S (weights that sum to 1 - 1e-12, a
last position that rounds up to S) can neither index past the end nor pick a zero-weight particle.

Any magnitude: weights whose total lies outside [2^-900, 2^960 / N] (a sum that overflows, say
twelve weights of 3.1e307, or weights so small that S / N is subnormal) are first scaled by a
power of two that brings the largest to [0.5, 1) (exact, so the ancestors are those of the same
weights at an ordinary scale) and summed again; inside that range nothing is scaled, so ordinary
weights take the path they always took, bit for bit. In that scaled path an infinite weight
counts as 1 and every finite one as 0, a NaN or negative one as 0, and weights without a positive
entry as uniform: a kernel never fails and never indexes out of [0, N). The Python entry
``ancestors`` refuses negative, NaN and infinite weights, and weights that sum to zero.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from ._lazy import kernel

from .codes import (EWA_COPIES_CEIL, EWA_COPIES_FLOOR_PLUS_ONE, SCHEME_CODES, SCHEME_MULTINOMIAL,
                    SCHEME_STRATIFIED, SCHEME_SYSTEMATIC,
                    STEPWISE_EWA)  # noqa: F401 (STEPWISE_EWA: re-exported)
from .rng import STATE, normal, uniform

SCHEMES = {
    "multinomial": "independent draws from the weights (sorted uniforms, O(N))",
    "systematic": "one uniform offset, N evenly spaced positions (lowest variance, the usual default)",
    "stratified": "one uniform per stratum [i/N, (i+1)/N)",
    "residual": "floor(N w) deterministic copies, the rest multinomial on the residual weights",
}
assert tuple(SCHEME_CODES) == tuple(SCHEMES)     # pfbench.codes numbers them, in this order


def ess_threshold(params, particles: int) -> float:
    """The ESS below which a filter resamples, from its keys 'resample' and 'neff_ratio':
    infinite for 'always' (every step), else neff_ratio * particles."""
    return np.inf if params["resample"] == "always" else params["neff_ratio"] * particles


@kernel(types.float64(types.float64, types.float64, STATE), cache=True, inline="always")
def ewa_mutant(v, mu, s):
    """The stepwise EWA's mutation of a copied value v: v + v mu z, z a standard normal draw
    (ifa2021)."""
    return v + v * mu * normal(s)

_IDX = types.int64[::1]
_W = types.float64[::1]

_S_LO = 2.0 ** -900     # a total below it: S / N and the positions could reach the subnormals
_S_HI = 2.0 ** 960      # S N above it: N w_i, the positions or the sum could overflow


@kernel(types.boolean(types.float64, types.int64), cache=True, inline="always")
def _extreme(S, N):
    """Whether the total S of N weights lies outside the range the schemes handle as they are
    (NaN and infinite totals included)."""
    return not (S >= _S_LO and S * N <= _S_HI)


@kernel(types.Tuple((_W, types.float64))(_W), cache=True)
def scaled_weights(w):
    """(v, T): the weights w scaled by the power of two that brings the largest to [0.5, 1)
    (exact for every weight that stays normal; a weight 2^-1022 below the largest adds nothing),
    and their sum T, added in order. Infinite weights become 1 and every finite one 0; NaN and
    negative weights 0; without a positive weight, all 1 (uniform)."""
    N = w.size
    m = 0.0
    for i in range(N):
        if w[i] > m:
            m = w[i]
    v = np.empty(N)
    if m == 0.0:
        v[:] = 1.0
        return v, float(N)
    if m == np.inf:
        for i in range(N):
            v[i] = 1.0 if w[i] == np.inf else 0.0
    else:
        e = math.frexp(m)[1]
        for i in range(N):
            v[i] = math.ldexp(w[i], -e) if w[i] > 0.0 else 0.0
    T = 0.0
    for i in range(N):
        T += v[i]
    return v, T


@kernel(types.int64(_W), cache=True)
def _last_positive(w):
    j = w.size - 1
    while j > 0 and not (w[j] > 0.0):
        j -= 1
    return j


@kernel(types.void(_W, types.float64, _W, _IDX, types.int64), cache=True)
def _merge(w, S, pos, idx, start):
    """idx[start + i] = first j with cumsum(w)[j] > pos[i]; pos sorted ascending in [0, S)."""
    jmax = _last_positive(w)
    j = 0
    cum = w[0]
    for i in range(pos.size):
        p = pos[i]
        while p >= cum and j < jmax:
            j += 1
            cum += w[j]
        idx[start + i] = j


@kernel(types.int64(types.int64, types.float64, types.float64, types.float64, types.int64),
        cache=True, inline="always")
def _settle(k, cum, u, step, N):
    """#{i < N : (u + i) step < cum}, walked to from any start k: the positions rise with i, so
    the walk down stops at it from above and the walk up from below (NaN: k)."""
    while k > 0 and (u + (k - 1)) * step >= cum:
        k -= 1
    while k < N and (u + k) * step < cum:
        k += 1
    return k


@kernel(types.void(_IDX), cache=True, inline="always")
def _running_counts(idx):
    """idx[i] = idx[0] + ... + idx[i], in place: the ancestors from their histogram."""
    acc = 0
    for k in range(idx.size):
        acc += idx[k]
        idx[k] = acc


@kernel(types.void(_W, types.float64, STATE, _IDX), cache=True, by_address=True,
        error_model="numpy")
def systematic(w, S, s, idx):
    """Systematic resampling: positions p_i = (u + i) S / N with one u ~ U[0, 1).

    The ancestors of the merge (``_merge``) without its branch on every position: first, for each
    particle j before the last positive one, how many positions lie below the running sum cum_j,
    c_j = #{i : p_i < cum_j} (from the quotient cum_j / step, then settled by the very products
    the merge compares, so the result is the merge's bit for bit); then idx[i] = #{j : c_j <= i},
    a histogram of the c_j and its running sum. Per particle this is a few predictable
    comparisons instead of a branch the processor mispredicts about once a particle."""
    N = idx.size
    if _extreme(S, N):
        w, S = scaled_weights(w)
    step = S / N
    u = uniform(s)
    jmax = _last_positive(w)
    for k in range(N):
        idx[k] = 0
    inv = 1.0 / step
    cum = 0.0
    for j in range(jmax):
        cum += w[j]
        q = math.ceil(cum * inv - u)
        k = int(q) if 0.0 <= q <= N else (N if q > N else 0)     # NaN (0 * inf): from 0
        k = _settle(k, cum, u, step, N)
        if k < N:
            idx[k] += 1
    _running_counts(idx)


@kernel(types.void(_W, _W, types.float64, STATE, _IDX, _IDX), cache=True, error_model="numpy")
def systematic_from_sums(w, cum, S, s, idx, c):
    """``systematic`` with the running sums of the weights given: cum[j] = w[0] + ... + w[j],
    added in that order (as a caller's pass over the weights can compute them with other work
    at no cost). c (N,) is scratch. The same ancestors and generator state, bit for bit.

    Each c_j comes from its quotient with one step down and one up, in a pass the compiler
    vectorises; a c_j that needs more (only in extreme cases: a step that rounds to zero, say)
    sends the pass through ``_settle``, systematic's walk, which settles it from any start.
    A total out of range (see the module) scales the weights and sums them again, as systematic
    does, and ignores cum."""
    N = idx.size
    if _extreme(S, N):
        w, S = scaled_weights(w)
        cum = np.empty(w.size)
        acc = 0.0
        for j in range(w.size):
            acc += w[j]
            cum[j] = acc
    step = S / N
    u = uniform(s)
    jmax = _last_positive(w)
    inv = 1.0 / step
    fN = float(N)
    bad = False
    for j in range(jmax):
        cj = cum[j]
        q = math.ceil(cj * inv - u)
        q = q if q >= 0.0 else 0.0          # NaN (0 * inf): from 0, as systematic
        q = q if q <= fN else fN
        q -= 1.0 if q > 0.0 and (u + (q - 1.0)) * step >= cj else 0.0
        q += 1.0 if q < fN and (u + q) * step < cj else 0.0
        bad |= (q > 0.0 and (u + (q - 1.0)) * step >= cj) or (q < fN and (u + q) * step < cj)
        c[j] = int(q)
    if bad:
        for j in range(jmax):
            c[j] = _settle(c[j], cum[j], u, step, N)
    for k in range(N):
        idx[k] = 0
    for j in range(jmax):
        if c[j] < N:
            idx[c[j]] += 1
    _running_counts(idx)


@kernel(types.void(_W, types.float64, STATE, _IDX), cache=True, by_address=True)
def stratified(w, S, s, idx):
    """Stratified resampling: positions (u_i + i) S / N with independent u_i ~ U[0, 1)."""
    N = idx.size
    if _extreme(S, N):
        w, S = scaled_weights(w)
    step = S / N
    jmax = _last_positive(w)
    j = 0
    cum = w[0]
    for i in range(N):
        p = (uniform(s) + i) * step
        while p >= cum and j < jmax:
            j += 1
            cum += w[j]
        idx[i] = j


@kernel(types.void(_W, types.float64, STATE, _IDX, types.int64, types.int64), cache=True)
def _multinomial_into(w, S, s, idx, start, M):
    """Write M multinomial draws from w into idx[start:start+M] (sorted uniforms by spacings)."""
    if M <= 0:
        return
    pos = np.empty(M)
    acc = 0.0
    for i in range(M):
        acc += -math.log(1.0 - uniform(s))
        pos[i] = acc
    total = acc - math.log(1.0 - uniform(s))
    scale = S / total
    for i in range(M):
        pos[i] *= scale
    _merge(w, S, pos, idx, start)


@kernel(types.void(_W, types.float64, STATE, _IDX), cache=True, by_address=True)
def multinomial(w, S, s, idx):
    """Multinomial resampling: N independent draws from the normalised weights."""
    if _extreme(S, idx.size):
        w, S = scaled_weights(w)
    _multinomial_into(w, S, s, idx, 0, idx.size)


@kernel(types.void(_W, types.float64, STATE, _IDX), cache=True, by_address=True)
def residual(w, S, s, idx):
    """Residual resampling: floor(N W_i) copies of i, the remainder multinomial on the residuals."""
    N = idx.size
    if _extreme(S, N):
        w, S = scaled_weights(w)
    r = np.empty(N)
    k = 0
    for i in range(N):
        nw = N * w[i] / S
        c = int(math.floor(nw + 1e-9))  # 1e-9: uniform weights give exactly one copy each
        rem = nw - c
        r[i] = rem if rem > 0.0 else 0.0
        for _ in range(c):
            if k < N:
                idx[k] = i
                k += 1
    if k < N:
        R = 0.0
        for i in range(N):
            R += r[i]
        if R > 0.0:
            _multinomial_into(r, R, s, idx, k, N - k)
        else:  # all mass was deterministic; round-off left slots: fill from the weights
            _multinomial_into(w, S, s, idx, k, N - k)


@kernel(types.void(types.int64, _W, types.float64, STATE, _IDX), cache=True, by_address=True)
def resample(scheme, w, S, s, idx):
    """Dispatch on ``scheme`` (a value of ``SCHEME_CODES``); ``S`` must equal ``w.sum()``."""
    if scheme == SCHEME_MULTINOMIAL:
        multinomial(w, S, s, idx)
    elif scheme == SCHEME_SYSTEMATIC:
        systematic(w, S, s, idx)
    elif scheme == SCHEME_STRATIFIED:
        stratified(w, S, s, idx)
    else:
        residual(w, S, s, idx)


def ancestors(weights, scheme: str, state: np.ndarray) -> np.ndarray:
    """Python entry point: ancestor indices (N,) for ``weights`` (N,) under ``scheme`` (a name
    of ``SCHEMES``), drawing from the generator ``state`` (a uint64 array of 4, advanced in place).

    The weights need not be normalised and may have any finite magnitude, from subnormal to a
    sum past the largest double: the ancestors are those of the same weights scaled to an
    ordinary range (see the module). Raises ValueError, naming what is wrong, for weights that
    are not a non-empty 1-D array of finite non-negative numbers with a positive sum (negative,
    NaN or infinite entries, all zeros), for an unknown scheme and for a state that is not a
    uint64 array of 4."""
    if scheme not in SCHEME_CODES:
        raise ValueError(f"unknown resampling scheme {scheme!r}: expected one of "
                         f"{', '.join(SCHEMES)}")
    if (not isinstance(state, np.ndarray) or state.dtype != np.uint64 or state.shape != (4,)
            or not state.flags.c_contiguous or not state.flags.writeable):
        raise ValueError("state must be a writeable uint64 array of 4 (a generator state, as "
                         "pfbench.rng.state_from_seed makes it)")
    try:
        w = np.ascontiguousarray(weights, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"weights must be an array of numbers: {exc}") from None
    if w.ndim != 1 or w.size == 0:
        raise ValueError(f"weights must be a non-empty 1-D array, got shape {w.shape}")
    bad = np.flatnonzero(~(w >= 0.0) | ~np.isfinite(w))
    if bad.size:
        raise ValueError(f"weights must be finite and non-negative: weights[{bad[0]}] = "
                         f"{float(w[bad[0]])!r}")
    if not (w > 0.0).any():
        raise ValueError("weights must have a positive sum (every weight is zero)")
    idx = np.empty(w.size, dtype=np.int64)
    with np.errstate(over="ignore"):
        S = float(np.sum(w))    # inf when the sum overflows: the kernels rescale then
    resample(SCHEME_CODES[scheme], w, S, state, idx)
    return idx


@kernel(types.int64(types.float64, types.int64), cache=True, inline="always")
def ewa_copies(n, copies):
    """The copies of a kept particle whose weight is n times the stepwise EWA's delta (n >= 1),
    itself included, under the reading ``copies`` (codes.EWA_COPIES): ceil(n) (EWA_COPIES_CEIL),
    floor(n) + 1, or ceil(n) + 1 (the kept particle and ceil(n) copies). A relative guard of
    1e-12 counts an n within round-off of a whole number as that number."""
    if copies == EWA_COPIES_CEIL:
        return int(math.ceil(n - 1e-12))
    if copies == EWA_COPIES_FLOOR_PLUS_ONE:
        return int(math.floor(n + 1e-12)) + 1
    return int(math.ceil(n - 1e-12)) + 1


@kernel(types.int64(_W, types.float64, types.int64, types.int64, _IDX, types.int8[::1]), cache=True)
def stepwise_ewa_plan(W, beta, printed, copies, src, mutant):
    """Stepwise EWA resampling (ifa2021 section 1.2), the deterministic part.

    W : (N,) normalised weights. Fills src (N,) with the particle each new particle comes from and
    mutant (N,) with 1 where it is a mutant of that particle (x' = x + x mu z, applied by the
    caller); returns the number of kept particles.
    1. sort the weights in descending order;
    2. bias-corrected exponentially weighted average along them: v_i = beta v_{i-1} +
       (1 - beta) W_i, delta_i = v_i / (1 - beta^i), i = 1..N (the standard form); with
       ``printed`` = 1 the corrected value feeds the recursion, v_i = delta_i, as ifa2021 prints it;
    3. delta = mean(delta_i); keep the particles with W_i >= delta (at least the heaviest);
    4. copy each kept particle ``ewa_copies(W_i / delta, copies)`` times (EWA_COPIES_CEIL:
       ceil(W_i / delta), the text's "n = w / delta; copied n times, rounded up"), heaviest first,
       at most N in all;
    5. fill the rest with mutants of the kept particles in descending weight order, cycling.
    Both comparisons with delta carry a relative round-off guard of 1e-12 (the average of equal
    weights must equal them: uniform weights keep every particle once). Unnormalised weights of
    any magnitude plan as the same weights at an ordinary scale (their largest out of
    [2^-900, 2^960 / N]: scaled by a power of two, as the schemes do).
    """
    N = W.size
    m = 0.0
    for i in range(N):
        m = max(m, W[i])
    if _extreme(m, N) and m > 0.0:  # any scale: the weights scaled to [0.5, 1) (see the module)
        W = scaled_weights(W)[0]
    order = np.argsort(-W, kind="mergesort")   # stable: ties keep index order
    v = 0.0
    bk = 1.0
    acc = 0.0
    for i in range(N):
        v = beta * v + (1.0 - beta) * W[order[i]]
        bk *= beta
        d = v / (1.0 - bk)
        if printed:
            v = d
        acc += d
    delta = acc / N
    lim = delta * (1.0 - 1e-12)
    kept = 1
    while kept < N and W[order[kept]] >= lim:
        kept += 1
    k = 0
    for i in range(kept):
        c = ewa_copies(W[order[i]] / delta, copies) if delta > 0 else N
        for _ in range(c):
            if k >= N:
                break
            src[k] = order[i]
            mutant[k] = 0
            k += 1
    j = 0
    while k < N:
        src[k] = order[j % kept]
        mutant[k] = 1
        k += 1
        j += 1
    return kept
