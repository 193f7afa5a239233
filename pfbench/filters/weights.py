"""Weights from log-weights: the max-shifted exponentials, their sums, their normalisation.

Every filter turns its log-weights (or a swarm its log-likelihoods) into weights here; no
filter writes the shift, the exponential, the sum or the division itself. The variants differ
in arithmetic, and each filter keeps the one its committed results were computed with:

- the exponential: the C library's ``math.exp`` (correctly rounded in practice, subnormal
  results below -708) or ``vecmath.exp`` (within 2 ulp of it, 0 below -708, NaN and -inf give
  0), which the compiler vectorises;
- the sums: one running sum (its order is part of its result, so it does not vectorise), or
  four partial sums added pairwise at the end (``lane_sum``), which do;
- normalised (divided by their sum, ``divide``) or left as the shifted terms, where a later
  pass divides once (an estimate, a resampling that takes unnormalised weights).

Which filter uses which:

- ``normalise``: C library, one running sum; the UPF and scalar SSPF (``_common.weigh``) and
  FastSLAM's weights after the maps' update;
- ``normalise_lanes``: vecmath, partial sums; the bootstrap PF and the swarm PFs
  (``_common.weigh_lanes``), the filters whose speed is benchmarked per particle;
- ``exp_pass`` and ``exp_sum``: vecmath, partial sums, on the first n entries; MCL
  (``weigh_observations``), whose weights stay unnormalised (its estimate and resampling divide
  once by the running sum they make);
- ``normalised``: C library, one running sum, divided; the field SSPF (``weights_and_change``),
  whose weight-change trigger compares normalised weights across steps;
- ``shifted_exp`` and ``shifted_exp_less``: C library, no sum; the swarms' fitness (FA, AFSA,
  IFA's brightness) in (0, 1], in the scalar swarm PFs and FastSLAM's refinement;
- ``divide``: weights over their sum, where a filter keeps them normalised (the field SSPF,
  FastSLAM, the UPF's previous weights, the swarm PFs' stepwise EWA plan).

The shift is the largest log-weight, found by the caller while it computed the log-weights
(a kernel folds it into its likelihood loop). A set whose log-weights are all -inf or NaN has
no shift: ``normalise`` and ``normalise_lanes`` reset it to uniform (``_underflow``), MCL and
the field SSPF whenever the largest is not finite (``reset_unless_finite``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import types

from .. import vecmath as vm
from .._lazy import kernel

_F = types.float64[::1]
_F4 = types.UniTuple(types.float64, 4)


@kernel(types.UniTuple(types.float64, 2)(_F, types.float64), cache=True, inline="always")
def _underflow(lw, m):
    """(the shift, underflow): (m, 0.0), or, when every log-weight was -inf or NaN (m is not
    above -inf), lw reset to 0 and (0.0, 1.0)."""
    if m > -np.inf:
        return m, 0.0
    for i in range(lw.size):
        lw[i] = 0.0
    return 0.0, 1.0


@kernel(types.float64(_F, _F, types.float64), cache=True, inline="always")
def _finite_sum(w, x, sx):
    """sx, the weighted sum of x, unless it is not finite: then the sum over the particles of
    positive weight only (rare: a zero-weight particle at +-inf or NaN makes 0 * inf)."""
    if math.isfinite(sx):
        return sx
    sx = 0.0
    for i in range(w.size):
        if w[i] > 0.0:
            sx += w[i] * x[i]
    return sx


@kernel(_F4(_F, _F, _F, types.float64), cache=True, by_address=True)
def normalise(lw, w, x, m):
    """Max-shifted weights from log-weights, by the C library's exponential and one running sum.

    lw : (N,) log-weights, shifted in place by m (all -inf/NaN: reset to 0)
    m : max(lw) over the non-NaN entries, as the caller found it while computing lw (kernels fold
        it into their likelihood loop; ``max(m, l)`` skips NaN)
    w : (N,) output, exp(lw); a NaN log-weight gives weight 0
    x : (N,) particles, for the weighted sum
    Returns (S, S2, sx, underflow): sum of w, sum of w^2, sum of w x, and 1.0 when every
    log-weight was -inf or NaN (the weights were reset to uniform), else 0.0.
    """
    N = lw.size
    m, underflow = _underflow(lw, m)
    S = 0.0
    S2 = 0.0
    sx = 0.0
    for i in range(N):
        l = lw[i] - m
        lw[i] = l
        e = math.exp(l)
        e = e if e == e else 0.0
        w[i] = e
        S += e
        S2 += e * e
        sx += e * x[i]
    return S, S2, _finite_sum(w, x, sx), underflow


@kernel(_F4(_F, _F, _F, types.float64), cache=True, error_model="numpy")
def normalise_lanes(lw, w, x, m):
    """``normalise`` written to vectorise: the exponentials by ``vecmath.exp`` (within 2 ulp of
    the C library's; 0 below -708, where the library's are subnormal) and the three sums in four
    partial sums each, added pairwise at the end. Same arguments and results, to rounding."""
    N = lw.size
    m, underflow = _underflow(lw, m)
    for i in range(N):
        l = lw[i] - m
        lw[i] = l
        w[i] = vm.exp(l)            # NaN and -inf give 0
    a0 = a1 = a2 = a3 = 0.0
    b0 = b1 = b2 = b3 = 0.0
    c0 = c1 = c2 = c3 = 0.0
    top = N - N % 4
    for i in range(0, top, 4):
        e0, e1, e2, e3 = w[i], w[i + 1], w[i + 2], w[i + 3]
        a0 += e0
        a1 += e1
        a2 += e2
        a3 += e3
        b0 += e0 * e0
        b1 += e1 * e1
        b2 += e2 * e2
        b3 += e3 * e3
        c0 += e0 * x[i]
        c1 += e1 * x[i + 1]
        c2 += e2 * x[i + 2]
        c3 += e3 * x[i + 3]
    for i in range(top, N):
        a0 += w[i]
        b0 += w[i] * w[i]
        c0 += w[i] * x[i]
    sx = (c0 + c1) + (c2 + c3)
    return (a0 + a1) + (a2 + a3), (b0 + b1) + (b2 + b3), _finite_sum(w, x, sx), underflow


@kernel(types.float64(_F, types.int64), cache=True, error_model="numpy")
def lane_sum(a, n):
    """sum a[i] over i < n in four partial sums (lanes the compiler keeps in one vector), added
    pairwise at the end: a reduction that vectorises (a single running sum does not, as its
    order is part of its result)."""
    s0 = s1 = s2 = s3 = 0.0
    top = n - n % 4
    for i in range(0, top, 4):
        s0 += a[i]
        s1 += a[i + 1]
        s2 += a[i + 2]
        s3 += a[i + 3]
    for i in range(top, n):
        s0 += a[i]
    return (s0 + s1) + (s2 + s3)


@kernel(types.void(_F, types.float64, types.int64, _F), cache=True, error_model="numpy")
def exp_pass(a, shift, n, out):
    """out[i] = exp(a[i] - shift) for i < n (a, out of at least n; out may be a).

    ``vecmath.exp`` (within 2 ulp of the C library's, 0 below -708, NaN and -inf give 0) in a
    loop the compiler vectorises: the weights' exponentials after their maximum's shift."""
    for i in range(n):
        out[i] = vm.exp(a[i] - shift)


@kernel(types.float64(_F, types.float64, types.int64, _F), cache=True, error_model="numpy")
def exp_sum(a, shift, n, out):
    """``exp_pass``, returning their sum (in partial sums, ``lane_sum``)."""
    exp_pass(a, shift, n, out)
    return lane_sum(out, n)


@kernel(types.UniTuple(types.float64, 2)(_F, types.int64, types.float64), cache=True,
        inline="always")
def reset_unless_finite(lw, n, mx):
    """(the shift, underflow) for log-weights lw[:n] of largest value mx: (mx, 0.0) when mx is
    finite, else lw[:n] reset to 0 and (0.0, 1.0) (every weight underflowed, or one is +inf or
    NaN: the set starts again uniform)."""
    if np.isfinite(mx):
        return mx, 0.0
    lw[:n] = 0.0
    return 0.0, 1.0


@kernel(types.void(_F, types.float64, _F), cache=True, by_address=True)
def divide(w, S, out):
    """out[i] = w[i] / S: weights normalised by their sum S (out may be w)."""
    for i in range(w.size):
        out[i] = w[i] / S


@kernel(types.float64(_F, _F, types.float64), cache=True, by_address=True)
def normalised(lw, W, mx):
    """Normalised weights W (N,) from the log-weights lw (N,) of largest value mx, by the C
    library's exponential (a log-weight that is not finite gives 0), one running sum and a
    division (``divide``); a largest value that is not finite resets lw to 0 first
    (``reset_unless_finite``). Returns 1.0 when it did, else 0.0."""
    mx, under = reset_unless_finite(lw, lw.size, mx)
    tot = 0.0
    for i in range(lw.size):
        W[i] = math.exp(lw[i] - mx) if np.isfinite(lw[i]) else 0.0
        tot += W[i]
    divide(W, tot, W)
    return under


@kernel(types.void(_F, types.float64, _F), cache=True)
def shifted_exp(a, shift, out):
    """out[i] = exp(a[i] - shift) by the C library's exponential, unsummed: a swarm's fitness
    from its log-likelihoods a (shift: their largest, so the fitness lies in (0, 1])."""
    for i in range(a.size):
        out[i] = math.exp(a[i] - shift)


@kernel(types.void(_F, types.float64, _F, _F), cache=True)
def shifted_exp_less(a, shift, q, out):
    """out[i] = exp(a[i] - shift - q[i]) (C library): ``shifted_exp`` times the factor
    exp(-q[i]), IFA's brightness (q: half the squared distance to the predicted state); out
    may be q."""
    for i in range(a.size):
        out[i] = math.exp(a[i] - shift - q[i])


@kernel(types.float64(types.float64, types.float64), cache=True, by_address=True, inline="always")
def ess(S, S2):
    """The effective sample size (sum w)^2 / sum w^2 of weights w whose sum is S and sum of
    squares S2 (as ``normalise`` returns them; normalised weights: S = 1, 1 / S2). The one
    place the ESS is computed from the sums (the scalar PFs' traces, FastSLAM's weights, MCL's
    and the field SSPF's)."""
    return S * S / S2


@kernel(types.float64(_F), cache=True, by_address=True)
def log_sum_exp(lw):
    """log(sum exp(lw)) over the entries of lw that are not NaN, max-shifted so that no
    exponential overflows or underflows to nothing: m + log(sum exp(lw - m)), m the largest.
    -inf when there is no entry above -inf (an empty array, every entry -inf or NaN), +inf when
    one is +inf. The log of a set's total weight (the log of a marginal-likelihood factor:
    log_sum_exp(lw) - log(N))."""
    m = -np.inf
    for i in range(lw.size):
        if lw[i] > m:
            m = lw[i]
    if not np.isfinite(m):
        return m
    S = 0.0
    for i in range(lw.size):
        if lw[i] == lw[i]:
            S += math.exp(lw[i] - m)
    return m + math.log(S)
