"""FastSLAM 1.0 (Montemerlo et al. 2002) on the waypoint course, with optional swarm refinement of
the predicted poses (FA, IFA, BA, PSO: ifa2021 Table 3). The whole trial runs in numba.

Particles carry a pose (x, y, theta) and, per landmark, an EKF: mean (2) and covariance (3 unique
entries of the symmetric 2x2). Known data association (the sensor reports landmark identities).
Per control step each particle is moved with its own noisy copy of the controls (``predict_noise``;
without it every particle moves alike, the trap of the classic simulator's default). At an
observation: optional swarm moves of the poses (fitness: likelihood of the observations of already
mapped landmarks under the particle's own map), then per particle and observation either a new
landmark (initialised by the inverse measurement model, weight unchanged) or a weight update by the
innovation likelihood and an EKF update (Joseph form, or the symmetrised simple form); then
resampling when ESS < threshold, maps copied with their particles.
Memory: two buffers of N x M x 5 floats (means and covariances), 80 N M bytes.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel, stub, variant

from ..angles import wrap
from .. import vecmath as vm
from ..models.observations import OBSERVATIONS, observations
from ..models.pose import estimate_pose
from ..codes import (DIRECTIONAL, DIRECTIONAL_MAP_BOARD, DIRECTIONAL_MAPS, EWA_COPIES,
                     POSE_BRIGHTNESS, POSE_BRIGHTNESS_COMBINED,
                     POSE_BRIGHTNESS_INVERSE, POSE_BRIGHTNESS_LIKELIHOOD, SCHEME_CODES,
                     SLAM_ODOMETRY, SLAM_STEERED, STEP_UNIT_FIXED, STEP_UNITS,
                     STEPWISE_EWA)
from ..resampling import (SCHEMES, ess_threshold, ewa_mutant, resample,
                          stepwise_ewa_plan)
from ..rng import STATE, normal
from ..schema import Key
from ._common import DIAG_DISTINCT, DIAG_DIVERSITY, DIAG_MAP_TRACE, drop_unasked
from ..diag import flags
from .keys import ewa_keys, pf_keys
from .swarm import (AFSA, AFSA_FISH_SHIFT, ALGORITHMS, DONE, FIT_BEHAVIOURS, FIT_BRIGHTNESS,
                    FIT_CANDIDATES, FIT_CENTRES, FIT_X, NO_SWARM, SWARM_PARAMS, SWARM_WORK,
                    afsa_fish_shift, afsa_joint_shift, evaluations, keys, new_swarm_work,
                    swarm_move, swarm_params)
from .types import FilterType
from .weights import divide, ess as ess_of, normalise, shifted_exp, shifted_exp_less

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]
_B2 = types.int8[:, ::1]

EWA = STEPWISE_EWA


class DirectionalNoise(NamedTuple):
    """The noise of directional resampling's copies (afsa2014): standard deviations m along x
    and y (key directional_noise_m), rad in the heading (directional_noise_deg)."""

    m: float
    rad: float


DIRECTIONAL_NOISE = typeof(DirectionalNoise(1.0, 1.0))
LOG_2PI = math.log(2.0 * math.pi)


@kernel(types.UniTuple(types.float64, 7)(types.float64, types.float64, types.float64,
                                       types.float64, types.float64), cache=True)
def observe_landmark(px, py, pth, lx, ly):
    """Predicted [range, bearing] of landmark (lx, ly) from pose (px, py, pth) and the Jacobian H
    with respect to the landmark: returns (r, b, h11, h12, h21, h22, ok)."""
    dx = lx - px
    dy = ly - py
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    if r < 1e-9:
        return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    return r, wrap(math.atan2(dy, dx) - pth), dx / r, dy / r, -dy / q, dx / q, 1.0


@kernel(types.UniTuple(types.float64, 11)(types.float64, types.float64, types.float64, types.float64,
                                        types.float64, types.float64, types.float64, types.float64,
                                        types.float64, types.float64, types.float64, types.float64),
      cache=True)
def innovation(px, py, pth, lx, ly, a, c, d, zr, zb, Rr, Rb):
    """Innovation of the observation [zr, zb] of landmark (lx, ly) with covariance [[a, c], [c, d]]
    from pose (px, py, pth): returns (v1, v2, S11, S12, S22, det S, h11, h12, h21, h22, ok), with
    v the wrapped innovation, S = H P H^T + R and H the Jacobian with respect to the landmark; ok
    is 0 when the landmark sits on the pose."""
    r, b, h11, h12, h21, h22, ok = observe_landmark(px, py, pth, lx, ly)
    if ok == 0.0:
        return 0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0
    S11, S12, S22 = innovation_cov(h11, h12, h21, h22, a, c, d, Rr, Rb)
    return (zr - r, wrap(zb - b), S11, S12, S22, S11 * S22 - S12 * S12, h11, h12, h21, h22, 1.0)


@kernel(types.UniTuple(types.float64, 3)(types.float64, types.float64, types.float64,
                                       types.float64, types.float64, types.float64,
                                       types.float64, types.float64, types.float64),
        cache=True, inline="always")
def innovation_cov(h11, h12, h21, h22, a, c, d, Rr, Rb):
    """(S11, S12, S22) of S = H P H^T + R, H = [[h11, h12], [h21, h22]], P = [[a, c], [c, d]],
    R = diag(Rr, Rb)."""
    p11 = h11 * a + h12 * c
    p12 = h11 * c + h12 * d
    p21 = h21 * a + h22 * c
    p22 = h21 * c + h22 * d
    return (p11 * h11 + p12 * h12 + Rr, p11 * h21 + p12 * h22, p21 * h21 + p22 * h22 + Rb)


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64,
                    types.float64), cache=True, inline="always")
def _maha(v1, v2, S11, S12, S22, det):
    return (v1 * (S22 * v1 - S12 * v2) + v2 * (S11 * v2 - S12 * v1)) / det


@kernel(types.float64(types.float64, types.float64, types.float64, _F, _F, types.float64,
                    types.float64, types.float64, types.float64, types.int64), cache=True)
def ekf_landmark_update(px, py, pth, mu, sig, zr, zb, Rr, Rb, joseph):
    """Update one landmark's EKF (mean mu (2,), covariance sig (3,) = [s11, s12, s22]) with the
    observation [zr, zb] from pose (px, py, pth); return the log-likelihood of the innovation,
    log N(v; 0, S). joseph: 1 = Joseph form, 0 = (I - KH) P symmetrised."""
    v1, v2, S11, S12, S22, det, h11, h12, h21, h22, ok = innovation(
        px, py, pth, mu[0], mu[1], sig[0], sig[1], sig[2], zr, zb, Rr, Rb)
    if ok == 0.0:
        return 0.0
    return ekf_apply(mu, sig, v1, v2, S11, S12, S22, det, h11, h12, h21, h22, Rr, Rb, joseph)


@kernel(types.float64(_F, _F, types.float64, types.float64, types.float64, types.float64,
                    types.float64, types.float64, types.float64, types.float64, types.float64,
                    types.float64, types.float64, types.float64, types.int64), cache=True)
def ekf_apply(mu, sig, v1, v2, S11, S12, S22, det, h11, h12, h21, h22, Rr, Rb, joseph):
    """The update of ``ekf_landmark_update`` from the innovation ``innovation`` computed (v, S
    without the pose's uncertainty, det S, H)."""
    a, c, d = sig[0], sig[1], sig[2]
    i11, i12, i22 = S22 / det, -S12 / det, S11 / det
    # K = P H^T S^-1 (2 x 2)
    q11 = a * h11 + c * h12
    q12 = a * h21 + c * h22
    q21 = c * h11 + d * h12
    q22 = c * h21 + d * h22
    k11 = q11 * i11 + q12 * i12
    k12 = q11 * i12 + q12 * i22
    k21 = q21 * i11 + q22 * i12
    k22 = q21 * i12 + q22 * i22
    mu[0] += k11 * v1 + k12 * v2
    mu[1] += k21 * v1 + k22 * v2
    # A = I - K H
    a11 = 1.0 - (k11 * h11 + k12 * h21)
    a12 = -(k11 * h12 + k12 * h22)
    a21 = -(k21 * h11 + k22 * h21)
    a22 = 1.0 - (k21 * h12 + k22 * h22)
    if joseph:
        # A P A^T + K R K^T
        t11 = a11 * a + a12 * c
        t12 = a11 * c + a12 * d
        t21 = a21 * a + a22 * c
        t22 = a21 * c + a22 * d
        n11 = t11 * a11 + t12 * a12 + k11 * k11 * Rr + k12 * k12 * Rb
        n12 = t11 * a21 + t12 * a22 + k11 * k21 * Rr + k12 * k22 * Rb
        n22 = t21 * a21 + t22 * a22 + k21 * k21 * Rr + k22 * k22 * Rb
    else:
        n11 = a11 * a + a12 * c
        n12 = 0.5 * ((a11 * c + a12 * d) + (a21 * a + a22 * c))
        n22 = a21 * c + a22 * d
    sig[0], sig[1], sig[2] = n11, n12, n22
    return -0.5 * _maha(v1, v2, S11, S12, S22, det) - 0.5 * (2.0 * LOG_2PI + math.log(det))


@kernel(types.float64(types.float64, types.float64, types.float64, _F, _F, types.float64,
                    types.float64, types.float64, types.float64, _F), cache=True)
def mahalanobis2(px, py, pth, mu, sig, zr, zb, Rr, Rb, pc):
    """Squared Mahalanobis distance of the observation [zr, zb] to the landmark (mu, sig) seen
    from the pose (inf where the landmark sits on the pose), with the pose's own uncertainty pc
    (6,) = [xx, xy, xt, yy, yt, tt] added to the innovation covariance: S + Hx C Hx^T, Hx the
    Jacobian with respect to the pose (all zeros: the plain FastSLAM 1.0 distance)."""
    # Hx = [[a], [b]] = [[-h11, -h12, 0], [-h21, -h22, -1]] adds [[aCa, aCb], [aCb, bCb]] to S:
    # the bounded search without a bound (it computes this exactly where it does not skip)
    return mahalanobis2_within(px, py, pth, mu[0], mu[1], sig[0], sig[1], sig[2], zr, zb, Rr,
                               Rb, pc, 0.0, 0.0, np.inf)[0]


@kernel(types.void(_F, types.float64, types.float64, types.float64, types.float64, types.float64,
                 types.float64, types.float64, types.float64, types.float64, types.float64,
                 types.float64), cache=True)
def propagate_pose_cov(c, fx, fy, g1x, g1y, g1t, q1, g2x, g2y, g2t, q2, qxy):
    """One motion step of a pose covariance c (6,) = [xx, xy, xt, yy, yt, tt], in place:
    c <- F c F^T + q1 g1 g1^T + q2 g2 g2^T + diag(qxy, qxy, 0), with F the identity plus
    (fx, fy, 0) in its heading column (the move's dependence on the heading) and g1, g2 the
    Jacobian columns of two independent noises of variances q1, q2."""
    xx, xy, xt, yy, yt, tt = c[0], c[1], c[2], c[3], c[4], c[5]
    c[0] = xx + 2.0 * fx * xt + fx * fx * tt + q1 * g1x * g1x + q2 * g2x * g2x + qxy
    c[1] = xy + fx * yt + fy * xt + fx * fy * tt + q1 * g1x * g1y + q2 * g2x * g2y
    c[2] = xt + fx * tt + q1 * g1x * g1t + q2 * g2x * g2t
    c[3] = yy + 2.0 * fy * yt + fy * fy * tt + q1 * g1y * g1y + q2 * g2y * g2y + qxy
    c[4] = yt + fy * tt + q1 * g1y * g1t + q2 * g2y * g2t
    c[5] = tt + q1 * g1t * g1t + q2 * g2t * g2t


@kernel(types.UniTuple(types.float64, 10)(types.float64, types.float64, types.float64,
                                        types.float64, types.float64, types.float64,
                                        types.float64, types.float64, types.float64,
                                        types.float64, types.float64, types.float64, _F,
                                        types.float64, types.float64, types.float64),
        cache=True, inline="always")
def mahalanobis2_within(px, py, pth, lx, ly, a, c, d, zr, zb, Rr, Rb, pc, co, so, bound):
    """``mahalanobis2`` where it can be at most ``bound``; inf where it is certainly beyond.
    Returns (d2, and the innovation as ``innovation`` computes it: v1, v2, S11, S12, S22
    without the pose's uncertainty, h11, h12, h21, h22; meaningful where d2 is finite).

    (lx, ly), [[a, c], [c, d]] : the landmark's mean and covariance; co, so : cos and sin of
    pth + zb, the direction in which it was observed (for the bound only: to within 1e-12).
    Two lower bounds of d2 = v^T S^-1 v for a positive definite S (its Schur complements),
    v1^2 / S11 and v2^2 / S22, need no arctangent: v1 is the range innovation, and |v2| (the
    wrapped bearing innovation) is at least |sin v2|, the cross product of the observed and the
    predicted directions. A landmark either bound puts beyond ``bound`` (with margins of 1e-6
    relative and 1e-12 in the cross product for rounding) costs a square root and a few
    products instead of the whole distance; any other gets exactly what ``mahalanobis2``
    computes (the same operations in the same order)."""
    dx = lx - px
    dy = ly - py
    q = dx * dx + dy * dy
    r = math.sqrt(q)
    if r < 1e-9:
        return np.inf, 0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0
    h11, h12, h21, h22 = dx / r, dy / r, -dy / q, dx / q
    S11, S12, S22 = innovation_cov(h11, h12, h21, h22, a, c, d, Rr, Rb)
    cax = -(h11 * pc[0] + h12 * pc[1])
    cay = -(h11 * pc[1] + h12 * pc[3])
    cbx = -(h21 * pc[0] + h22 * pc[1] + pc[2])
    cby = -(h21 * pc[1] + h22 * pc[3] + pc[4])
    cbt = -(h21 * pc[2] + h22 * pc[4] + pc[5])
    T11 = S11 - (h11 * cax + h12 * cay)
    T12 = S12 - (h11 * cbx + h12 * cby)
    T22 = S22 - (h21 * cbx + h22 * cby + cbt)
    v1 = zr - r
    far = bound * (1.0 + 1e-6)
    if v1 * v1 > far * T11:
        return np.inf, v1, 0.0, S11, S12, S22, h11, h12, h21, h22
    cr = abs(so * h11 - co * h12) - 1e-12
    if cr > 0.0 and cr * cr > far * T22:
        return np.inf, v1, 0.0, S11, S12, S22, h11, h12, h21, h22
    v2 = wrap(zb - wrap(math.atan2(dy, dx) - pth))
    return (_maha(v1, v2, T11, T12, T22, T11 * T22 - T12 * T12), v1, v2, S11, S12, S22, h11, h12,
            h21, h22)


@kernel(types.Tuple((types.int64, types.float64))(types.float64, types.float64, types.float64,
                                                types.int64, _F3, _F3, types.int64, types.float64,
                                                types.float64, types.float64, types.float64, _F,
                                                types.float64),
      cache=True)
def nearest_landmark(px, py, pth, i, mu, sig, nl, zr, zb, Rr, Rb, pc, bound):
    """(index, squared distance) of particle i's landmark nearest (Mahalanobis, with the pose
    uncertainty pc, see ``mahalanobis2``) to the observation among its nl landmarks, exact where
    that distance is at most ``bound``; (-1, inf) when none is within it (every caller treats
    a distance beyond its largest gate alike, so that is what it passes)."""
    r = nearest_innovation(px, py, pth, i, mu, sig, nl, zr, zb, Rr, Rb, pc, bound)
    return np.int64(r[0]), r[1]


@kernel(types.UniTuple(types.float64, 11)(types.float64, types.float64, types.float64,
                                        types.int64, _F3, _F3, types.int64, types.float64,
                                        types.float64, types.float64, types.float64, _F,
                                        types.float64), cache=True, inline="always")
def nearest_innovation(px, py, pth, i, mu, sig, nl, zr, zb, Rr, Rb, pc, bound):
    """``nearest_landmark`` (its index as a float, its distance) with the nearest one's
    innovation as ``innovation`` computes it (v1, v2, S11, S12, S22, h11, h12, h21, h22), so that
    its update (``ekf_apply``) need not compute it again."""
    best = -1.0
    bd = np.inf
    b1 = b2 = bS12 = bh11 = bh12 = bh21 = bh22 = 0.0
    bS11 = bS22 = 1.0
    so, co = vm.sincos(pth + zb)
    for m in range(nl):
        d2, v1, v2, S11, S12, S22, h11, h12, h21, h22 = mahalanobis2_within(
            px, py, pth, mu[i, m, 0], mu[i, m, 1], sig[i, m, 0], sig[i, m, 1], sig[i, m, 2], zr,
            zb, Rr, Rb, pc, co, so, bound)
        if d2 < bd:
            bd = d2
            best = float(m)
            b1, b2, bS11, bS12, bS22, bh11, bh12, bh21, bh22 = v1, v2, S11, S12, S22, h11, h12, \
                h21, h22
    return best, bd, b1, b2, bS11, bS12, bS22, bh11, bh12, bh21, bh22


@kernel(types.void(types.float64, types.float64, types.float64, types.float64, types.float64,
                 types.float64, types.float64, _F, _F), cache=True)
def init_landmark(px, py, pth, zr, zb, Rr, Rb, mu, sig):
    """New landmark from the observation [zr, zb]: mean by the inverse model, covariance
    G R G^T with G its Jacobian with respect to the measurement."""
    ang = pth + zb
    cs, sn = math.cos(ang), math.sin(ang)
    mu[0] = px + zr * cs
    mu[1] = py + zr * sn
    # G = [[cs, -zr sn], [sn, zr cs]]
    sig[0] = cs * cs * Rr + zr * zr * sn * sn * Rb
    sig[1] = cs * sn * Rr - zr * zr * sn * cs * Rb
    sig[2] = sn * sn * Rr + zr * zr * cs * cs * Rb


@kernel(types.float64(types.float64, types.float64, types.float64, types.int64, _F3, _F3, _B2, _I,
                    _F2, types.int64, types.float64, types.float64, types.int64, types.int64,
                    types.float64, _F2), cache=True)
def pose_loglik(px, py, pth, i, mu, sig, seen, ids, zs, n, Rr, Rb, assoc, nl, gate, pc):
    """Fitness of a candidate pose of particle i for the swarm moves (its map is not changed).
    assoc 0: the log-likelihood of the n observations (ids, zs) of landmarks already in its map.
    assoc 1: -1/2 sum_j min(d2_j, gate), d2_j the squared distance (with the pose uncertainty
    pc[i], see ``mahalanobis2``) of observation j to its nearest landmark among the particle's nl
    (inf without one), gate = the new-landmark gate: every observation counts, so a pose cannot
    gain by pushing an observation out of the gates (afsa2014's fitness, the Gaussian kernel
    without its normalising constant)."""
    acc = 0.0
    for j in range(n):
        if assoc:
            _, d2 = nearest_landmark(px, py, pth, i, mu, sig, nl, zs[j, 0], zs[j, 1], Rr, Rb,
                                     pc[i], gate)
            acc -= 0.5 * min(d2, gate)
            continue
        m = ids[j]
        if not seen[i, m]:
            continue
        v1, v2, S11, S12, S22, det, _, _, _, _, ok = innovation(
            px, py, pth, mu[i, m, 0], mu[i, m, 1], sig[i, m, 0], sig[i, m, 1], sig[i, m, 2],
            zs[j, 0], zs[j, 1], Rr, Rb)
        if ok != 0.0:
            acc += (-0.5 * _maha(v1, v2, S11, S12, S22, det)
                    - 0.5 * (2.0 * LOG_2PI + math.log(det)))
    return acc


@kernel(types.void(_F2, _F3, _F3, _B2, _I, _F2, types.int64, types.float64, types.float64, _F,
                 types.int64, _I, types.float64, _F2), cache=True)
def _fitness(P, mu, sig, seen, ids, zs, n, Rr, Rb, out, assoc, nl, gate, pc):
    for i in range(P.shape[0]):
        out[i] = pose_loglik(P[i, 0], P[i, 1], P[i, 2], i, mu, sig, seen, ids, zs, n, Rr, Rb,
                             assoc, nl[i], gate, pc)


@kernel(types.void(_F, _F2, _F3, _F3, _B2, _I, _I2, _F, _F2, _F2, types.int8[::1], types.int64,
                 _I, _F, DIRECTIONAL_NOISE, types.int64, STATE, _F2, _F3, _F3, _B2, _I, _I2),
        cache=True)
def directional_resample(W, P, mu, sig, seen, nl, src, bP, bmu, bsig, bseen, bnl, bsrc, shift,
                         noise, scheme, s, P2, mu2, sig2, seen2, nl2, src2):
    """Directional resampling (afsa2014): the lower-weight half of the particles is replaced by
    copies of the bulletin-board particle (pose bP with its map bmu, bsig, bseen, bnl, bsrc: the
    best particle of the previous observation) moved by ``shift`` (the change of the weighted pose
    estimate since then) plus Gaussian noise (``noise``, a ``DirectionalNoise``); the upper half
    is resampled by weight (``scheme``) among itself. Writes the new set into the *2 arrays (every
    map a copy, none shared). W (N,) normalised weights."""
    N = W.size
    order = np.argsort(-W, kind="mergesort")
    n_keep = N - N // 2
    wk = np.empty(n_keep)
    S = 0.0
    for i in range(n_keep):
        wk[i] = W[order[i]]
        S += wk[i]
    idx = np.empty(n_keep, dtype=np.int64)
    resample(scheme, wk, S, s, idx)
    for i in range(n_keep):
        j = order[idx[i]]
        P2[i] = P[j]
        mu2[i] = mu[j]
        sig2[i] = sig[j]
        seen2[i] = seen[j]
        nl2[i] = nl[j]
        src2[i] = src[j]
    for i in range(n_keep, N):
        P2[i, 0] = bP[0] + shift[0] + noise.m * normal(s)
        P2[i, 1] = bP[1] + shift[1] + noise.m * normal(s)
        P2[i, 2] = bP[2] + shift[2] + noise.rad * normal(s)
        P2[i, 2] = wrap(P2[i, 2])
        mu2[i] = bmu
        sig2[i] = bsig
        seen2[i] = bseen
        nl2[i] = bnl
        src2[i] = bsrc


@kernel(types.void(_F, _F, _F, _F3, _F3, _B2, _I, _F2, types.int64, types.float64, types.float64,
                 _F, types.int64, _I, types.float64, _F2), cache=True)
def _fitness_scaled(Xn, mean, scale, mu, sig, seen, ids, zs, n, Rr, Rb, out, assoc, nl, gate, pc):
    """Fitness of poses given in scaled coordinates (pose = mean + scale * x), row r of Xn (flat,
    3 per row) belonging to particle r mod N (its map)."""
    N = mu.shape[0]
    for r in range(out.size):
        i = r % N
        out[r] = pose_loglik(mean[0] + scale[0] * Xn[3 * r], mean[1] + scale[1] * Xn[3 * r + 1],
                             mean[2] + scale[2] * Xn[3 * r + 2], i, mu, sig, seen, ids, zs, n,
                             Rr, Rb, assoc, nl[i], gate, pc)


@kernel(types.float64(_F2), cache=True)
def circular_mean(P):
    """Circular mean of the headings P[:, 2]."""
    cs = 0.0
    sn = 0.0
    for i in range(P.shape[0]):
        cs += math.cos(P[i, 2])
        sn += math.sin(P[i, 2])
    return math.atan2(sn, cs)


@kernel(types.float64(_F), cache=True)
def _pairwise_abs_sum(v):
    """sum_{i<j} |v_i - v_j| in O(n log n): over the sorted values, v_(k) (2k - n + 1). (Sorted
    by the merge sort pose_diversity uses too: one sort to compile, the same sorted values.)"""
    u = v[np.argsort(v, kind="mergesort")]
    n = u.size
    acc = 0.0
    for k in range(n):
        acc += u[k] * (2 * k - n + 1)
    return acc


@kernel(types.int64(_F2,), cache=True)
def pose_distinct(P):
    """The number of distinct poses of P (N, 3), exactly: sorted by x, then compared pairwise
    within runs of equal x. (A sort: FastSLAM's sets are small, tens to hundreds, and a copy's
    pose can repeat another's exactly: without predict noise, or a directional copy without
    copy noise, so the count from the ancestors would not be exact.)"""
    N = P.shape[0]
    order = np.argsort(P[:, 0], kind="mergesort")
    distinct = 0
    a = 0
    while a < N:
        b = a + 1
        while b < N and P[order[b], 0] == P[order[a], 0]:
            b += 1
        for u in range(a, b):
            i = order[u]
            dup = False
            for w in range(a, u):
                j = order[w]
                if P[i, 1] == P[j, 1] and P[i, 2] == P[j, 2]:
                    dup = True
                    break
            distinct += not dup
        a = b
    return distinct


@kernel(types.UniTuple(types.float64, 2)(_F2,), cache=True)
def pose_diversity(P):
    """(mean pairwise L1 distance |dx| + |dy| + |dtheta| of the poses P (N, 3), fraction of
    distinct poses): afsa2014's 'mean Hamming distance', read as L1 on poses. Headings are taken
    relative to the cloud's circular mean (exact while the cloud spans less than pi); O(N log N)."""
    N = P.shape[0]
    if N < 2:
        return 0.0, 1.0
    th0 = circular_mean(P)
    h = np.empty(N)
    for i in range(N):
        h[i] = wrap(P[i, 2] - th0)
    acc = (_pairwise_abs_sum(np.ascontiguousarray(P[:, 0]))
           + _pairwise_abs_sum(np.ascontiguousarray(P[:, 1])) + _pairwise_abs_sum(h))
    return acc / (N * (N - 1) / 2), pose_distinct(P) / N


@kernel(types.float64(_F, _F3, _B2, _I, _I2, types.int64, _F2, types.int8[::1]), cache=True)
def map_error(W, mu, seen, nl, src, assoc, lm_true, first):
    """Mean distance of the highest-weight particle's landmarks to the true ones (NaN before any
    is mapped): by identity, or (nearest) each true landmark by the first slot started from it."""
    b = 0
    for i in range(W.size):
        if W[i] > W[b]:
            b = i
    acc = 0.0
    cnt = 0
    if assoc:
        first[:] = 0
        for m in range(nl[b]):
            t_id = src[b, m]
            if first[t_id] == 0:
                first[t_id] = 1
                acc += math.hypot(mu[b, m, 0] - lm_true[t_id, 0], mu[b, m, 1] - lm_true[t_id, 1])
                cnt += 1
    else:
        for m in range(lm_true.shape[0]):
            if seen[b, m]:
                acc += math.hypot(mu[b, m, 0] - lm_true[m, 0], mu[b, m, 1] - lm_true[m, 1])
                cnt += 1
    return acc / cnt if cnt else np.nan


class Options(NamedTuple):
    """FastSLAM's settings, as the jitted steps read them (``options`` builds it from a config).

    every : control steps per observation; N : particles; M : map slots per particle
    dt, L : the steered vehicle's time step and wheelbase; motion : 0 steered vehicle, 1 odometry
    q0, q1 : the control noise each particle draws (steered: sigma_V, sigma_G; odometry:
        sigma_xy, sigma_theta); predict_noise : 1 to draw it
    Rr, Rb : the variances of the range and bearing noise the filter assumes
    joseph : 1 Joseph-form landmark updates, 0 the symmetrised simple form
    assoc : 0 known identities, 1 nearest neighbour with gate_reject and gate_augment; gate_pose :
        1 the gates' distance includes the pose uncertainty since the last update
    refine : a swarm algorithm (swarm.ALGORITHMS) or NO_SWARM; iters : its iterations
    scheme : a resampling code, EWA or DIRECTIONAL; threshold : resample when ESS < threshold;
        ewa_beta, ewa_mu, ewa_printed, ewa_copies : the stepwise EWA's settings
    diag : the diagnostics' flags (pfbench.diagnostics.Diag): DIAG_DISTINCT the fraction of
        distinct poses after each resampling, DIAG_DIVERSITY their mean pairwise L1 distance too,
        DIAG_MAP_TRACE the map-error trace
    step_unit : the unit of the swarm's random steps (codes.STEP_UNITS): the predicted cloud's
        spread per coordinate, or fixed, unit_m (m) in x and y and unit_rad (rad) in the heading
    brightness : IFA's brightness of a pose (codes.POSE_BRIGHTNESS)
    dir_scheme : the resampling code of directional resampling's kept half; dir_map : the map its
        copies carry (codes.DIRECTIONAL_MAPS)
    """

    every: int
    N: int
    M: int
    dt: float
    L: float
    motion: int
    q0: float
    q1: float
    predict_noise: int
    Rr: float
    Rb: float
    joseph: int
    assoc: int
    gate_reject: float
    gate_augment: float
    gate_pose: int
    refine: int
    iters: int
    scheme: int
    threshold: float
    ewa_beta: float
    ewa_mu: float
    ewa_printed: int
    diag: int
    ewa_copies: int
    step_unit: int
    unit_m: float
    unit_rad: float
    brightness: int
    dir_scheme: int
    dir_map: int


OPTIONS = typeof(Options(1, 1, 1, 1.0, 1.0, 0, 1.0, 1.0, 1, 1.0, 1.0, 1, 0, 1.0, 1.0, 1, 0, 1, 0,
                         1.0, 1.0, 1.0, 0, 1, 0, 0, 1.0, 1.0, 0, 1, 0))


class ParticleSet(NamedTuple):
    """Particles with their maps: pose P (N, 3); per map slot the landmark's EKF, mean mu (N, M, 2)
    and covariance sig (N, M, 3: xx, xy, yy), whether it is in use, seen (N, M); nl (N,) the slots
    in use (nearest-neighbour association); src (N, M) the true landmark each slot was started
    from (for the association statistics)."""

    P: np.ndarray
    mu: np.ndarray
    sig: np.ndarray
    seen: np.ndarray
    nl: np.ndarray
    src: np.ndarray


PARTICLES = types.NamedTuple((_F2, _F3, _F3, _B2, _I, _I2), ParticleSet)


@kernel(PARTICLES(types.int64, types.int64, _F), cache=True)
def new_particles(N, M, start):
    """N particles at the pose ``start`` with empty maps of M slots."""
    P = np.empty((N, 3))
    for i in range(N):
        P[i, 0], P[i, 1], P[i, 2] = start[0], start[1], start[2]
    return ParticleSet(P, np.zeros((N, M, 2)), np.zeros((N, M, 3)),
                       np.zeros((N, M), dtype=np.int8), np.zeros(N, dtype=np.int64),
                       np.full((N, M), -1, dtype=np.int64))


@kernel(types.void(PARTICLES, types.int64, PARTICLES, types.int64), cache=True)
def copy_particle(a, i, b, j):
    """Particle i of a becomes particle j of b (its pose and its map)."""
    b.P[j] = a.P[i]
    b.mu[j] = a.mu[i]
    b.sig[j] = a.sig[i]
    b.seen[j] = a.seen[i]
    b.nl[j] = a.nl[i]
    b.src[j] = a.src[i]


@kernel(types.void(_F2, _F2, types.float64, types.float64, OPTIONS, STATE), cache=True)
def predict(P, pc, Vc, Gc, o, s):
    """Move every particle by the controls (Vc, Gc), each with its own draw of the control noise,
    and grow its pose uncertainty pc (N, 6: xx, xy, xt, yy, yt, tt) by the motion's."""
    N = P.shape[0]
    if o.motion == SLAM_ODOMETRY:
        # the simulator's order: the heading noise turns this step's move
        for i in range(N):
            th = P[i, 2] + Gc
            if o.predict_noise:
                th += o.q1 * normal(s)
            P[i, 0] += Vc * math.cos(th)
            P[i, 1] += Vc * math.sin(th)
            if o.predict_noise:
                P[i, 0] += o.q0 * normal(s)
                P[i, 1] += o.q0 * normal(s)
            P[i, 2] = wrap(th)
        if o.gate_pose:
            # C <- F C F^T + G Q G^T, F = d(pose)/d(pose), G Q G^T of the heading noise
            # turning the move and the additive position noise
            for i in range(N):
                c, sn_ = math.cos(P[i, 2]), math.sin(P[i, 2])
                fx, fy = -Vc * sn_, Vc * c
                propagate_pose_cov(pc[i], fx, fy, fx, fy, 1.0, o.q1 ** 2, 0.0, 0.0, 0.0,
                                   0.0, o.q0 ** 2)
        return
    dt, L = o.dt, o.L
    for i in range(N):
        v, g = Vc, Gc
        if o.predict_noise:
            v += o.q0 * normal(s)
            g += o.q1 * normal(s)
        P[i, 0] += v * dt * math.cos(P[i, 2] + g)
        P[i, 1] += v * dt * math.sin(P[i, 2] + g)
        P[i, 2] = wrap(P[i, 2] + v * dt * math.sin(g) / L)
    if o.gate_pose:
        # the control noise (sigma_V, sigma_G) through the steered model's Jacobian
        cg, sg = math.cos(Gc), math.sin(Gc)
        for i in range(N):
            ca, sa = math.cos(P[i, 2] + Gc), math.sin(P[i, 2] + Gc)
            propagate_pose_cov(pc[i], -Vc * dt * sa, Vc * dt * ca, dt * ca, dt * sa,
                               dt * sg / L, o.q0 ** 2, -Vc * dt * sa, Vc * dt * ca,
                               Vc * dt * cg / L, o.q1 ** 2, 0.0)


@kernel(types.void(_F2, SWARM_WORK), cache=True)
def cloud_units(P, wk):
    """Headings as continuous values around the cloud's circular mean; the cloud's mean and
    spread per coordinate (the unit of each coordinate's random step) into wk.mean, wk.scale."""
    N = P.shape[0]
    th0 = circular_mean(P)
    for i in range(N):
        P[i, 2] = th0 + wrap(P[i, 2] - th0)
    for d in range(3):
        m1 = 0.0
        m2 = 0.0
        for i in range(N):
            m1 += P[i, d]
            m2 += P[i, d] * P[i, d]
        m1 /= N
        wk.mean[d] = m1
        wk.scale[d] = math.sqrt(max(m2 / N - m1 * m1, 1e-12))


@kernel(types.void(_F2, _F, types.float64, _F, types.int64), cache=True)
def cloud_distance_brightness(P, ll, M0, fit, kind):
    """IFA's brightness of the poses P (N, 3) into fit, from their log-likelihoods ll (M0 the
    largest) and their distance d from the predicted cloud's mean in units of its spread per
    coordinate (codes.POSE_BRIGHTNESS): combined exp(ll - M0 - d^2 / 2) (the innovations'
    likelihood times the pose's Gaussian distance), likelihood exp(ll - M0) (the innovations
    alone, d unused), inverse 1 / (1 + D) with D^2 = -2 (ll - M0) + d^2 (the whole distance,
    smaller brighter)."""
    N = P.shape[0]
    if kind == POSE_BRIGHTNESS_LIKELIHOOD:
        shifted_exp(ll, M0, fit)
        return
    mx = 0.0
    my = 0.0
    mt = 0.0
    for i in range(N):
        mx += P[i, 0]
        my += P[i, 1]
        mt += P[i, 2]
    mx /= N
    my /= N
    mt /= N
    vx = 1e-12
    vy = 1e-12
    vt = 1e-12
    for i in range(N):
        vx += (P[i, 0] - mx) ** 2 / N
        vy += (P[i, 1] - my) ** 2 / N
        vt += (P[i, 2] - mt) ** 2 / N
    for i in range(N):
        d2 = ((P[i, 0] - mx) ** 2 / vx + (P[i, 1] - my) ** 2 / vy + (P[i, 2] - mt) ** 2 / vt)
        if kind == POSE_BRIGHTNESS_INVERSE:
            fit[i] = 1.0 / (1.0 + math.sqrt(-2.0 * (ll[i] - M0) + d2))
        else:
            fit[i] = 0.5 * d2
    if kind == POSE_BRIGHTNESS_COMBINED:
        shifted_exp_less(ll, M0, fit, fit)


_OBS = (_I, _F2, types.int64)      # a step's observations: ids, zs (n, 2), n


@kernel(types.int64(types.int64, PARTICLES, _F2, *_OBS, OPTIONS, SWARM_WORK), cache=True)
def pose_fitness(request, ps, pc, ids, zs, n, o, wk):
    """What ``swarm.swarm_move`` asks (``request``): the log-likelihood of the step's
    observations at the poses it names, each under its particle's map (AFSA's, given in units of
    the cloud's spread, ``_fitness_scaled``), or IFA's brightness; returns the likelihood
    evaluations."""
    P, N = ps.P, ps.P.shape[0]
    if request == FIT_X:
        _fitness(P, ps.mu, ps.sig, ps.seen, ids, zs, n, o.Rr, o.Rb, wk.ll, o.assoc, ps.nl,
                 o.gate_augment, pc)
    elif request == FIT_CANDIDATES:
        _fitness(wk.C[:3 * N].reshape((N, 3)), ps.mu, ps.sig, ps.seen, ids, zs, n, o.Rr, o.Rb,
                 wk.llC[:N], o.assoc, ps.nl, o.gate_augment, pc)
    elif request == FIT_CENTRES:
        _fitness_scaled(wk.Xc, wk.mean, wk.scale, ps.mu, ps.sig, ps.seen, ids, zs, n, o.Rr, o.Rb,
                        wk.llc, o.assoc, ps.nl, o.gate_augment, pc)
    elif request == FIT_BEHAVIOURS:
        _fitness_scaled(wk.C, wk.mean, wk.scale, ps.mu, ps.sig, ps.seen, ids, zs, n, o.Rr, o.Rb,
                        wk.llC, o.assoc, ps.nl, o.gate_augment, pc)
    elif request == FIT_BRIGHTNESS:
        cloud_distance_brightness(P, wk.ll, wk.ll.max(), wk.fit, o.brightness)
    return evaluations(request, N)


@kernel(types.void(_F2, SWARM_WORK, types.boolean), cache=True)
def pose_units(P, wk, inward):
    """The poses P (N, 3) into wk.Xu, in units of the cloud's spread around its mean (inward),
    or back from them."""
    for i in range(P.shape[0]):
        for d in range(3):
            if inward:
                wk.Xu[3 * i + d] = (P[i, d] - wk.mean[d]) / wk.scale[d]
            else:
                P[i, d] = wk.mean[d] + wk.scale[d] * wk.Xu[3 * i + d]


@kernel(types.int64(PARTICLES, _F2, *_OBS, OPTIONS, SWARM_PARAMS, SWARM_WORK, STATE), cache=True)
def refine_poses(ps, pc, ids, zs, n, o, sp, wk, s):
    """The swarm refinement of the predicted poses (ifa2021, afsa2014): ``o.iters`` iterations of
    the swarm algorithm ``o.refine`` (parameters sp, a swarm.SwarmParams; ``swarm.swarm_move``), the
    fitness of a pose its observations' likelihood under the particle's own map
    (``pose_fitness``); the random steps (FA's and IFA's random term, BA's local walk) and AFSA's
    moves (visual and step too) are in units of the predicted cloud's spread per coordinate, or of
    fixed metres and radians (o.step_unit). Returns the likelihood evaluations."""
    P, N = ps.P, ps.P.shape[0]
    cloud_units(P, wk)
    if o.step_unit == STEP_UNIT_FIXED:
        wk.scale[0] = o.unit_m
        wk.scale[1] = o.unit_m
        wk.scale[2] = o.unit_rad
    X = P.reshape(3 * N)
    _fitness(P, ps.mu, ps.sig, ps.seen, ids, zs, n, o.Rr, o.Rb, wk.ll, o.assoc, ps.nl,
             o.gate_augment, pc)
    nev = N
    afsa = o.refine == AFSA
    for it in range(o.iters):
        if afsa:
            pose_units(P, wk, True)
        Xm = wk.Xu if afsa else X
        phase = 0
        while True:
            request = swarm_move(o.refine, AFSA_FISH_SHIFT, phase, Xm, 3, sp, o.Rr, it, wk, s)
            if request == DONE:
                break
            nev += pose_fitness(request, ps, pc, ids, zs, n, o, wk)
            phase += 1
        if afsa:
            pose_units(P, wk, False)
    for i in range(N):
        P[i, 2] = wrap(P[i, 2])
    return nev


@kernel(types.float64(PARTICLES, _F2, *_OBS, OPTIONS, _F, _F), cache=True)
def update_maps(ps, pc, ids, zs, n, o, lw, stats):
    """Each particle's map takes the step's observations: a landmark already mapped gets an EKF
    update and multiplies the particle's weight (lw, log) by the innovation's likelihood; a new one
    is started by the inverse model. Nearest-neighbour association (o.assoc) joins an observation
    to the nearest landmark within gate_reject, starts one beyond gate_augment, drops it in
    between or when the map is full; stats (4,) counts [associations, wrong ones, dropped,
    started]. Returns the largest log-weight."""
    mx = -np.inf
    M = ps.mu.shape[1]
    far = max(o.gate_reject, o.gate_augment)    # beyond it, how far makes no difference
    for i in range(ps.P.shape[0]):
        px, py, pth = ps.P[i, 0], ps.P[i, 1], ps.P[i, 2]
        for j in range(n):
            if o.assoc:
                fm, d2, v1, v2, S11, S12, S22, h11, h12, h21, h22 = nearest_innovation(
                    px, py, pth, i, ps.mu, ps.sig, ps.nl[i], zs[j, 0], zs[j, 1], o.Rr, o.Rb,
                    pc[i], far)
                m = np.int64(fm)
                if d2 <= o.gate_reject:
                    stats[0] += 1.0
                    if ps.src[i, m] != ids[j]:
                        stats[1] += 1.0
                    # the update ekf_landmark_update makes, from the innovation the search found
                    lw[i] += ekf_apply(ps.mu[i, m], ps.sig[i, m], v1, v2, S11, S12, S22,
                                       S11 * S22 - S12 * S12, h11, h12, h21, h22, o.Rr, o.Rb,
                                       o.joseph)
                    continue
                if d2 <= o.gate_augment or ps.nl[i] >= M:
                    stats[2] += 1.0     # between the gates (ambiguous), or the map is full
                    continue
                m = ps.nl[i]
                ps.nl[i] += 1
                stats[3] += 1.0
                ps.src[i, m] = ids[j]
            else:
                m = ids[j]
                if ps.seen[i, m]:
                    lw[i] += ekf_landmark_update(px, py, pth, ps.mu[i, m], ps.sig[i, m], zs[j, 0],
                                                 zs[j, 1], o.Rr, o.Rb, o.joseph)
                    continue
            init_landmark(px, py, pth, zs[j, 0], zs[j, 1], o.Rr, o.Rb, ps.mu[i, m], ps.sig[i, m])
            ps.seen[i, m] = 1
        mx = max(mx, lw[i])
    return mx


@kernel(types.void(_F, PARTICLES, PARTICLES, _F), cache=True)
def note_board(Wn, ps, board, xbar):
    """Directional resampling's bookkeeping: this observation's weighted pose estimate into xbar
    and its best particle onto the board (a set of one)."""
    N = Wn.size
    xbar[0] = 0.0
    xbar[1] = 0.0
    cs = 0.0
    sn = 0.0
    b = 0
    for i in range(N):
        xbar[0] += Wn[i] * ps.P[i, 0]
        xbar[1] += Wn[i] * ps.P[i, 1]
        cs += Wn[i] * math.cos(ps.P[i, 2])
        sn += Wn[i] * math.sin(ps.P[i, 2])
        if Wn[i] > Wn[b]:
            b = i
    xbar[2] = math.atan2(sn, cs)
    copy_particle(ps, b, board, 0)


@kernel(types.void(PARTICLES, PARTICLES, _F2, _F, _F, _F, types.float64, OPTIONS, PARTICLES,
                 PARTICLES, _F, _F, DIRECTIONAL_NOISE, _I, types.int8[::1], STATE), cache=True)
def resample_set(ps, out, pc, pcm, Wn, w, Ssum, o, board, best, xbar, xbar_prev, dnoise, idx,
                 mutant, s):
    """Draw the new particle set into ``out`` (maps copied with their particles): directional
    resampling from the board, the stepwise EWA's plan with its mutations, or a standard scheme.
    pc: the new particles' pose uncertainty (a copy's noise; zero otherwise); pcm: the cloud's
    mean uncertainty at the update. Directional resampling: the copies' pose from the board (the
    previous observation's best particle), their map the board's or (o.dir_map) that of ``best``,
    this observation's best particle; the kept half resampled by the scheme o.dir_scheme."""
    N = Wn.size
    if o.scheme == DIRECTIONAL:
        shift = np.empty(3)
        shift[0] = xbar[0] - xbar_prev[0]
        shift[1] = xbar[1] - xbar_prev[1]
        shift[2] = wrap(xbar[2] - xbar_prev[2])
        mp = board if o.dir_map == DIRECTIONAL_MAP_BOARD else best
        directional_resample(Wn, ps.P, ps.mu, ps.sig, ps.seen, ps.nl, ps.src, board.P[0],
                             mp.mu[0], mp.sig[0], mp.seen[0], mp.nl[0], mp.src[0],
                             shift, dnoise, o.dir_scheme, s, out.P, out.mu, out.sig, out.seen,
                             out.nl, out.src)
        if o.gate_pose:
            # a copy sits off the board's map by the board's motion since its update and by the
            # copy's noise
            for i in range(N - N // 2, N):
                pc[i] = pcm
                pc[i, 0] += dnoise.m ** 2
                pc[i, 3] += dnoise.m ** 2
                pc[i, 5] += dnoise.rad ** 2
        return
    if o.scheme == EWA:
        stepwise_ewa_plan(Wn, o.ewa_beta, o.ewa_printed, o.ewa_copies, idx, mutant)
    else:
        resample(o.scheme, w, Ssum, s, idx)
        mutant[:] = 0
    P, P2 = ps.P, out.P
    M = ps.mu.shape[1]
    for i in range(N):
        j = idx[i]
        for d in range(3):
            P2[i, d] = P[j, d]
        # a map's slots: all of them with known identities; with nearest-neighbour association
        # the first nl, the ones in use (a slot beyond is written before it is ever read)
        used = ps.nl[j] if o.assoc else M
        for m in range(used):
            out.mu[i, m, 0] = ps.mu[j, m, 0]
            out.mu[i, m, 1] = ps.mu[j, m, 1]
            out.sig[i, m, 0] = ps.sig[j, m, 0]
            out.sig[i, m, 1] = ps.sig[j, m, 1]
            out.sig[i, m, 2] = ps.sig[j, m, 2]
            out.seen[i, m] = ps.seen[j, m]
            out.src[i, m] = ps.src[j, m]
        out.nl[i] = ps.nl[j]
        if mutant[i]:
            for d in range(3):
                P2[i, d] = ewa_mutant(P2[i, d], o.ewa_mu, s)
            P2[i, 2] = wrap(P2[i, 2])
            if o.gate_pose:
                for d in range(3):
                    pc[i, (0, 3, 5)[d]] = (P[j, d] * o.ewa_mu) ** 2


@kernel(types.void(PARTICLES, _F, OPTIONS, _F2, _I, _F), cache=True)
def final_map(ps, Wn, o, lm_est, lm_seen, assoc_stats):
    """The final map into lm_est (M_true, 2), lm_seen. Known identities: per landmark, the
    weighted mean over the particles that have it. Nearest neighbour: the highest-weight
    particle's map, each true landmark by the first slot started from it; assoc_stats[4] the
    slots started from a true landmark that already had one (duplicates)."""
    N, M = ps.mu.shape[0], ps.mu.shape[1]
    if o.assoc:
        b = 0
        for i in range(N):
            if Wn[i] > Wn[b]:
                b = i
        lm_seen[:] = 0
        lm_est[:] = np.nan
        dup = 0
        for m in range(ps.nl[b]):
            t_id = ps.src[b, m]
            if lm_seen[t_id] == 0:      # the first slot started from it
                lm_seen[t_id] = 1
                lm_est[t_id, 0] = ps.mu[b, m, 0]
                lm_est[t_id, 1] = ps.mu[b, m, 1]
            else:
                dup += 1
        assoc_stats[4] = dup
        return
    for m in range(M):
        wsum = 0.0
        ax = 0.0
        ay = 0.0
        for i in range(N):
            if ps.seen[i, m]:
                wsum += Wn[i]
                ax += Wn[i] * ps.mu[i, m, 0]
                ay += Wn[i] * ps.mu[i, m, 1]
        lm_seen[m] = 1 if wsum > 0.0 else 0
        lm_est[m, 0] = ax / wsum if wsum > 0.0 else np.nan
        lm_est[m, 1] = ay / wsum if wsum > 0.0 else np.nan


@kernel(types.void(_F2, _F, OPTIONS), cache=True)
def settle_pose_cov(pc, pcm, o):
    """After the maps' update: the cloud's mean pose uncertainty pcm (6,) of pc (N, 6) when the
    gates use it (o.gate_pose), and pc zeroed (the poses are tied to their maps again)."""
    if o.gate_pose:
        for d in range(6):
            pcm[d] = pc[:, d].mean()
    pc[:] = 0.0         # the poses are now tied to their maps again


@kernel(types.UniTuple(types.float64, 3)(_F, _F, _F, _F2, types.float64), cache=True)
def map_weights(lw, w, Wn, P, mx):
    """The particles' weights after their maps' update (``weights.normalise``): w = exp(lw - mx) (lw
    shifted in place, mx its maximum), Wn = w over their sum. P (N, 3) the poses. Returns (the
    weights' sum, the ESS, 1.0 when every weight underflowed and was reset, else 0.0)."""
    Ssum, S2, sx, under = normalise(lw, w, P[:, 0].copy(), mx)
    ess = ess_of(Ssum, S2)
    divide(w, Ssum, Wn)
    return Ssum, ess, under


@kernel(types.void(PARTICLES, OPTIONS, _F), cache=True)
def resampled_diversity(ps, o, div_k):
    """The diversity diagnostics of a resampled set into div_k (2,) where o.diag asks for them:
    the mean pairwise L1 pose distance and the fraction of distinct poses."""
    if o.diag & DIAG_DIVERSITY:
        div_k[0], div_k[1] = pose_diversity(ps.P)
    elif o.diag & DIAG_DISTINCT:
        div_k[1] = pose_distinct(ps.P) / o.N


FASTSLAM_SIG = types.int64(
    _F2, OBSERVATIONS, OPTIONS, _F, SWARM_PARAMS, DIRECTIONAL_NOISE, _F2, STATE, _F2, _F, _I, _F2,
    _I, _F, _F, _F2, _F)


@kernel(FASTSLAM_SIG, cache=True)
def fastslam_kernel(ctrl, obs, o, start, sp, dnoise, lm_true, s, est, ess,
                    resampled, lm_est, lm_seen, evals, assoc_stats, div, lm_trace):
    """Run FastSLAM over one trial (controls ctrl (T, 2), K observations obs (``Observations``)
    every o.every control steps; settings o, see ``Options``); fill est (T+1, 3) the weighted pose
    estimate at every control step, ess / resampled / evals (K,) per observation, lm_est (M, 2)
    and lm_seen (M,) the final map. Returns the number of observation steps whose weights all
    underflowed.

    sp : the swarm's parameters (``swarm.SwarmParams``); dnoise : the noise of directional
        resampling's copies (``DirectionalNoise``) (see ``directional_resample``)
    assoc_stats (5,) : [associations, wrong associations (the slot was started from another true
        landmark), observations dropped, landmarks started] summed over particles and
        observations, and the final map's duplicates (see ``final_map``)
    lm_true (M_true, 2) : the true landmarks, for lm_trace (K,): the mean distance of the
        highest-weight particle's mapped landmarks to the true ones after each observation's
        update, and for the duplicates
    div (K, 2) : after each observation that resampled, the particles' mean pairwise L1 pose
        distance and the fraction of distinct poses (NaN where it did not resample). Each is
        filled only where o.diag asks for it (NaN otherwise), and so is lm_trace.
    """
    T, K, N, M = ctrl.shape[0], obs.n.shape[0], o.N, o.M
    ps, spare = new_particles(N, M, start), new_particles(N, M, start)
    pc = np.zeros((N, 6))     # pose uncertainty since the last update: [xx, xy, xt, yy, yt, tt]
    pcm = np.zeros(6)         # the cloud's mean of it at the last observation
    wk = new_swarm_work(N, 3)
    # directional resampling's bulletin boards: the best particle of the last observation, in
    # use, and of this one, for the next; the weighted estimates xbar_prev and xbar
    board, next_board = new_particles(1, M, start), new_particles(1, M, start)
    have_board = False
    xbar_prev = np.zeros(3)
    xbar = np.zeros(3)
    first = np.zeros(lm_true.shape[0], dtype=np.int8)
    stats = np.zeros(4)
    lw = np.zeros(N)
    w = np.full(N, 1.0)
    Wn = np.full(N, 1.0 / N)
    idx = np.empty(N, dtype=np.int64)
    mutant = np.empty(N, dtype=np.int8)
    events = 0
    est[0, 0], est[0, 1], est[0, 2] = start[0], start[1], start[2]
    k = 0
    for t in range(T):
        predict(ps.P, pc, ctrl[t, 0], ctrl[t, 1], o, s)
        if (t + 1) % o.every == 0 and k < K:
            n, ids, zs = obs.n[k], obs.ids[k], obs.z[k]
            nev = 0
            if o.refine != NO_SWARM and o.iters > 0:
                nev += refine_poses(ps, pc, ids, zs, n, o, sp, wk, s)
            mx = update_maps(ps, pc, ids, zs, n, o, lw, stats)
            evals[k] = nev + N
            settle_pose_cov(pc, pcm, o)
            Ssum, ess[k], under = map_weights(lw, w, Wn, ps.P, mx)
            events += int(under)
            lm_trace[k] = (map_error(Wn, ps.mu, ps.seen, ps.nl, ps.src, o.assoc, lm_true, first)
                           if o.diag & DIAG_MAP_TRACE else np.nan)
            resampled[k] = 0
            div[k, 0], div[k, 1] = np.nan, np.nan
            if o.scheme == DIRECTIONAL:
                note_board(Wn, ps, next_board, xbar)
                if not have_board:
                    copy_particle(next_board, 0, board, 0)
                    xbar_prev[:] = xbar
                    have_board = True
            if ess[k] < o.threshold:
                resample_set(ps, spare, pc, pcm, Wn, w, Ssum, o, board, next_board, xbar,
                             xbar_prev, dnoise, idx, mutant, s)
                ps, spare = spare, ps       # the new set becomes the current one
                lw[:] = 0.0
                Wn[:] = 1.0 / N
                resampled[k] = 1
                resampled_diversity(ps, o, div[k])
            if o.scheme == DIRECTIONAL:     # the board for the next observation
                board, next_board = next_board, board
                xbar_prev[:] = xbar
            k += 1
        estimate_pose(ps.P, Wn, N, est[t + 1], False)
    assoc_stats[:4] = stats
    final_map(ps, Wn, o, lm_est, lm_seen, assoc_stats)
    return events


# AFSA's refinement and directional resampling (afsa2014) are the costliest kernels to compile. The
# kernel for every other setting, fastslam_kernel_without_afsa2014, is a variant whose branches for
# them call stubs it never reaches (run() picks it only then), so an experiment without them does
# not compile them; its arithmetic is the full kernel's, and its trials are the same bit for bit.
def _no_afsa(phase, X, D, p, wk, s):
    return 0


def _no_directional(W, P, mu, sig, seen, nl, src, bP, bmu, bsig, bseen, bnl, bsrc, shift, noise,
                    scheme, s, P2, mu2, sig2, seen2, nl2, src2):
    pass


def _no_board(Wn, ps, board, xbar):
    pass


_WITHOUT = "_without_afsa2014"
swarm_move_without_afsa = variant(swarm_move, _WITHOUT,
                                  afsa_joint_shift=stub(afsa_joint_shift, _no_afsa),
                                  afsa_fish_shift=stub(afsa_fish_shift, _no_afsa))
refine_poses_without_afsa = variant(refine_poses, _WITHOUT, swarm_move=swarm_move_without_afsa)
resample_set_without_directional = variant(
    resample_set, _WITHOUT, directional_resample=stub(directional_resample, _no_directional))
fastslam_kernel_without_afsa2014 = variant(
    fastslam_kernel, _WITHOUT, refine_poses=refine_poses_without_afsa,
    resample_set=resample_set_without_directional, note_board=stub(note_board, _no_board))


def options(model, params, particles, diag=True) -> Options:
    """The kernel's settings (``Options``) for a filter run of ``particles`` on ``model``."""
    M_true = model.landmarks.shape[0]
    nearest = params["association"] == "nearest"
    M = (params["max_landmarks"] or 3 * M_true) if nearest else M_true
    deg = math.pi / 180.0

    def pick(key, default):
        v = params.get(key)
        return float(default if v is None else v)

    motion = getattr(model, "motion", SLAM_STEERED)
    if motion == SLAM_ODOMETRY:     # odometry form: the pose noise of the scenario
        qctrl = np.array([model.noise.drive, model.noise.turn])
    else:
        qctrl = np.array([pick("speed_noise_mps", model.noise.drive),
                          pick("steer_noise_deg", model.noise.turn / deg) * deg])
    R = np.array([pick("range_noise_m", model.noise.range) ** 2,
                  (pick("bearing_noise_deg", model.noise.bearing / deg) * deg) ** 2])
    scheme = {"stepwise_ewa": EWA, "directional": DIRECTIONAL, **SCHEME_CODES}[params["resampling"]]
    threshold = ess_threshold(params, particles)
    return Options(
        every=int(model.sensor.every), N=int(particles), M=int(M), dt=float(model.vehicle.dt),
        L=float(model.vehicle.wheelbase), motion=int(motion), q0=float(qctrl[0]), q1=float(qctrl[1]),
        predict_noise=int(params["predict_noise"]), Rr=float(R[0]), Rb=float(R[1]),
        joseph=int(params["update"] == "joseph"), assoc=int(nearest),
        gate_reject=float(params["gate_reject"]), gate_augment=float(params["gate_augment"]),
        gate_pose=int(params["gate_pose"] and nearest),
        refine=ALGORITHMS.get(params["refine"], NO_SWARM), iters=int(params["iterations"]),
        scheme=int(scheme), threshold=float(threshold), ewa_beta=float(params["ewa_beta"]),
        ewa_mu=float(params["ewa_mu"]), ewa_printed=int(params["ewa_correction"] == "as_printed"),
        diag=int(flags(diag)), ewa_copies=EWA_COPIES[params["ewa_copies"]],
        step_unit=int(STEP_UNITS[params["step_unit"]]),
        unit_m=float(params["step_unit_m"]), unit_rad=float(params["step_unit_rad"]),
        brightness=int(POSE_BRIGHTNESS[params["pose_brightness"]]),
        dir_scheme=int(SCHEME_CODES[params["directional_scheme"]]),
        dir_map=int(DIRECTIONAL_MAPS[params["directional_map"]]))


def directional_noise(params) -> DirectionalNoise:
    """Directional resampling's noise (``DirectionalNoise``) from a filter run's keys."""
    return DirectionalNoise(float(params["directional_noise_m"]),
                            float(params["directional_noise_deg"] * (math.pi / 180.0)))


def run(model, data, params, particles, state, diag=True):
    """Run FastSLAM (with the configured refinement) on a course trial; return the traces (the
    diagnostics 'div_l1', 'distinct' and 'lm_trace' where ``diag`` asks for them:
    pfbench.diagnostics.flags)."""
    diag = int(flags(diag))
    T = data.ctrl.shape[0]
    K = data.obs_n.shape[0]
    M_true = model.landmarks.shape[0]
    o = options(model, params, particles, diag)
    dnoise = directional_noise(params)
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(K),
           "resampled": np.zeros(K, dtype=np.int64), "lm_est": np.empty((M_true, 2)),
           "lm_seen": np.zeros(M_true, dtype=np.int64)}
    evals = np.zeros(K)
    stats = np.zeros(5)
    div = np.empty((K, 2))
    out["lm_trace"] = np.empty(K)
    full = o.refine == AFSA or o.scheme == DIRECTIONAL
    out["underflow_steps"] = (fastslam_kernel if full else fastslam_kernel_without_afsa2014)(
        data.ctrl, observations(data), o, model.start, swarm_params(params["refine"], params),
        dnoise, np.ascontiguousarray(model.landmarks, dtype=np.float64), state, out["pose"],
        out["ess"], out["resampled"], out["lm_est"], out["lm_seen"], evals, stats, div,
        out["lm_trace"])
    out["div_l1"], out["distinct"] = div[:, 0], div[:, 1]
    drop_unasked(out, diag)
    if not diag & DIAG_MAP_TRACE:
        del out["lm_trace"]
    out["lik_evals_per_step"] = float(evals.mean()) if K else 0.0
    if o.assoc:
        out["association_errors"] = stats[1] / stats[0] if stats[0] else 0.0
        total = stats[0] + stats[2] + stats[3]
        out["dropped_frac"] = stats[2] / total if total else 0.0
        out["started_per_particle"] = stats[3] / particles
        out["map_duplicates"] = stats[4]
    return out


def _refinement_keys() -> dict:
    """The keys of the swarm refinement's readings: the unit of its random steps and IFA's
    brightness of a pose."""
    return {
        "step_unit": Key("choice", "cloud_spread", "the unit of the refinement's random steps "
                         "(FA's and IFA's random term, BA's local walk, AFSA's visual range and "
                         "step): 'cloud_spread' the predicted cloud's spread per coordinate (our "
                         "reading: a heading is not stepped in metres; the dimmest of N fireflies "
                         "takes up to N - 1 kicks of that size), 'fixed' step_unit_m in x and y and "
                         "step_unit_rad in the heading (ifa2021 writes the random term in the "
                         "state's own units)", choices=tuple(STEP_UNITS)),
        "step_unit_m": Key("float", 1.0, "step_unit fixed: the unit in x and y, m (default 1: "
                           "the state's own unit, as ifa2021's random term reads)", min=0.0,
                           min_exclusive=True),
        "step_unit_rad": Key("float", 1.0, "step_unit fixed: the unit in the heading, rad "
                             "(default 1: the state's own unit)", min=0.0, min_exclusive=True),
        "pose_brightness": Key("choice", "combined", "IFA: a pose's brightness, from its "
                               "innovations' log-likelihood ll (under its own map) and its "
                               "distance d from the predicted cloud in units of its spread: "
                               "'combined' exp(ll - max ll - d^2 / 2) (our reading of ifa2021's "
                               "distance between (predicted observation, predicted state) and "
                               "(observation, state)), 'likelihood' exp(ll - max ll) (the "
                               "innovations alone: the fitness a PF weighs with), 'inverse' "
                               "1 / (1 + D), D^2 = -2 (ll - max ll) + d^2 (the same distance, "
                               "smaller brighter without a Gaussian); ifa2021 leaves it open",
                               choices=tuple(POSE_BRIGHTNESS)),
    }


def _directional_keys() -> dict:
    """The keys of afsa2014's directional resampling: its copies' noise, the scheme of the
    kept half and the map a copy carries."""
    return {
        "directional_noise_m": Key("float", 0.05, "directional resampling: position noise of the "
                                   "board's copies (afsa2014 gives none; our default)", min=0.0),
        "directional_noise_deg": Key("float", 0.5, "directional resampling: heading noise of the "
                                     "board's copies", min=0.0),
        "directional_scheme": Key("choice", "systematic", "directional resampling: how the kept "
                                  "half is resampled by weight ('systematic' ours; afsa2014 "
                                  "describes inverse-transform draws of independent uniforms, "
                                  "'multinomial')", choices=tuple(SCHEME_CODES)),
        "directional_map": Key("choice", "board", "directional resampling: the map each copy "
                               "carries, 'board' the board particle's as of the previous "
                               "observation (ours: the particle eq. 10 moves) or 'best' this "
                               "observation's highest-weight particle's, updated by it; afsa2014 "
                               "does not say", choices=tuple(DIRECTIONAL_MAPS)),
    }


def fastslam_keys() -> dict:
    swarm = {}
    for algo in ("fa", "ba", "afsa", "pso"):     # IFA takes FA's keys but alpha
        swarm.update(keys(algo, unit="in units of step_unit: the predicted cloud's spread by "
                                "default", prefix=True))
    return {
        "refine": Key("choice", "none", "swarm refinement of the predicted poses at each "
                      "observation (ifa2021: BA-, FA-, IFA-FastSLAM; afsa2014: PSO-, AFSA-FastSLAM)",
                      choices=("none",) + tuple(ALGORITHMS)),
        "iterations": Key("int", 1, "swarm iterations per observation", min=0),
        **swarm,
        **_refinement_keys(),
        "predict_noise": Key("bool", True, "each particle draws its own noisy controls (FastSLAM "
                             "1.0 needs it; the classic simulator's default turns it off)"),
        "speed_noise_mps": Key("float", None, "speed noise the particles draw (default: the "
                               "scenario's)", min=0.0, nullable=True),
        "steer_noise_deg": Key("float", None, "steering noise the particles draw (default: the "
                               "scenario's)", min=0.0, nullable=True),
        "range_noise_m": Key("float", None, "range noise the filter assumes (default: the "
                             "scenario's)", min=0.0, min_exclusive=True, nullable=True),
        "bearing_noise_deg": Key("float", None, "bearing noise the filter assumes (default: the "
                                 "scenario's)", min=0.0, min_exclusive=True, nullable=True),
        "association": Key("choice", "known", "data association: 'known' (the sensor reports "
                           "landmark identities) or 'nearest' (nearest neighbour in Mahalanobis "
                           "distance, with the two gates)", choices=("known", "nearest")),
        "gate_reject": Key("float", 4.0, "nearest: squared Mahalanobis distance up to which an "
                           "observation joins a landmark (the classic simulator's 4)", min=0.0,
                           min_exclusive=True),
        "gate_augment": Key("float", 25.0, "nearest: squared distance beyond which it starts a new "
                            "landmark; in between it is dropped (the classic simulator's 25)",
                            min=0.0, min_exclusive=True),
        "gate_pose": Key("bool", True, "nearest: the gates' distance includes the pose "
                         "uncertainty each particle gained since its last update (motion noise, "
                         "a resampled copy's noise); false: the plain FastSLAM 1.0 distance, "
                         "which rejects true matches when the motion noise exceeds the sensor's"),
        "max_landmarks": Key("int", 0, "nearest: map capacity per particle (0: three times the "
                             "world's landmarks)", min=0),
        "update": Key("choice", "joseph", "landmark covariance update: 'joseph' form or "
                      "'symmetric' ((I - KH) P, symmetrised)", choices=("joseph", "symmetric")),
        "resampling": Key("choice", "systematic", "resampling scheme ('stepwise_ewa': ifa2021's; "
                          "'directional': afsa2014's bulletin-board resampling)",
                          choices=tuple(SCHEMES) + ("stepwise_ewa", "directional")),
        **_directional_keys(),
        "resample": Key("choice", "neff", "'neff': when ESS < neff_ratio * N; 'always'",
                        choices=("neff", "always")),
        "neff_ratio": pf_keys()["neff_ratio"],
        **ewa_keys(),
    }


FASTSLAM = FilterType("fastslam", "FastSLAM 1.0 with per-landmark EKFs, optional swarm pose "
                      "refinement (FA, IFA, BA, PSO, AFSA)", fastslam_keys(), run, kind="slam",
                      needs=("gaussian_measurement", "jacobians"))   # the landmark EKFs'

