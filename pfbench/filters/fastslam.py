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

import numpy as np
from numba import njit, types

from ..angles import wrap
from ..resampling import SCHEME_CODES, SCHEMES, resample, stepwise_ewa_plan
from ..rng import STATE, normal
from ..schema import Key
from ._common import normalise
from .keys import ewa_keys, pf_keys
from .swarm import (AFSA, ALGORITHMS, BA, FA, IFA, NO_SWARM, afsa_centres, afsa_propose,
                    afsa_select, argmax, ba_accept, ba_propose, fa_move, ifa_move, keys, pack,
                    pso_accept, pso_propose)
from .types import FilterType

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]
_B2 = types.int8[:, ::1]

EWA = len(SCHEME_CODES)
DIRECTIONAL = EWA + 1
_SYSTEMATIC = SCHEME_CODES["systematic"]
LOG_2PI = math.log(2.0 * math.pi)


@njit(types.UniTuple(types.float64, 7)(types.float64, types.float64, types.float64,
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


@njit(types.UniTuple(types.float64, 11)(types.float64, types.float64, types.float64, types.float64,
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
    p11 = h11 * a + h12 * c
    p12 = h11 * c + h12 * d
    p21 = h21 * a + h22 * c
    p22 = h21 * c + h22 * d
    S11 = p11 * h11 + p12 * h12 + Rr
    S12 = p11 * h21 + p12 * h22
    S22 = p21 * h21 + p22 * h22 + Rb
    return (zr - r, wrap(zb - b), S11, S12, S22, S11 * S22 - S12 * S12, h11, h12, h21, h22, 1.0)


@njit(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64,
                    types.float64), cache=True, inline="always")
def _maha(v1, v2, S11, S12, S22, det):
    return (v1 * (S22 * v1 - S12 * v2) + v2 * (S11 * v2 - S12 * v1)) / det


@njit(types.float64(types.float64, types.float64, types.float64, _F, _F, types.float64,
                    types.float64, types.float64, types.float64, types.int64), cache=True)
def ekf_landmark_update(px, py, pth, mu, sig, zr, zb, Rr, Rb, joseph):
    """Update one landmark's EKF (mean mu (2,), covariance sig (3,) = [s11, s12, s22]) with the
    observation [zr, zb] from pose (px, py, pth); return the log-likelihood of the innovation,
    log N(v; 0, S). joseph: 1 = Joseph form, 0 = (I - KH) P symmetrised."""
    a, c, d = sig[0], sig[1], sig[2]
    v1, v2, S11, S12, S22, det, h11, h12, h21, h22, ok = innovation(
        px, py, pth, mu[0], mu[1], a, c, d, zr, zb, Rr, Rb)
    if ok == 0.0:
        return 0.0
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


@njit(types.float64(types.float64, types.float64, types.float64, _F, _F, types.float64,
                    types.float64, types.float64, types.float64, _F), cache=True)
def mahalanobis2(px, py, pth, mu, sig, zr, zb, Rr, Rb, pc):
    """Squared Mahalanobis distance of the observation [zr, zb] to the landmark (mu, sig) seen
    from the pose (inf where the landmark sits on the pose), with the pose's own uncertainty pc
    (6,) = [xx, xy, xt, yy, yt, tt] added to the innovation covariance: S + Hx C Hx^T, Hx the
    Jacobian with respect to the pose (all zeros: the plain FastSLAM 1.0 distance)."""
    v1, v2, S11, S12, S22, det, h11, h12, h21, h22, ok = innovation(
        px, py, pth, mu[0], mu[1], sig[0], sig[1], sig[2], zr, zb, Rr, Rb)
    if ok == 0.0:
        return np.inf
    # Hx = [[a], [b]] = [[-h11, -h12, 0], [-h21, -h22, -1]]; S += [[aCa, aCb], [aCb, bCb]]
    cax = -(h11 * pc[0] + h12 * pc[1])
    cay = -(h11 * pc[1] + h12 * pc[3])
    cbx = -(h21 * pc[0] + h22 * pc[1] + pc[2])
    cby = -(h21 * pc[1] + h22 * pc[3] + pc[4])
    cbt = -(h21 * pc[2] + h22 * pc[4] + pc[5])
    S11 -= h11 * cax + h12 * cay
    S12 -= h11 * cbx + h12 * cby
    S22 -= h21 * cbx + h22 * cby + cbt
    return _maha(v1, v2, S11, S12, S22, S11 * S22 - S12 * S12)


@njit(types.void(_F, types.float64, types.float64, types.float64, types.float64, types.float64,
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


@njit(types.Tuple((types.int64, types.float64))(types.float64, types.float64, types.float64,
                                                types.int64, _F3, _F3, types.int64, types.float64,
                                                types.float64, types.float64, types.float64, _F),
      cache=True)
def nearest_landmark(px, py, pth, i, mu, sig, nl, zr, zb, Rr, Rb, pc):
    """(index, squared distance) of particle i's landmark nearest (Mahalanobis, with the pose
    uncertainty pc, see ``mahalanobis2``) to the observation among its nl landmarks; (-1, inf)
    when it has none at a finite distance."""
    best = -1
    bd = np.inf
    for m in range(nl):
        d2 = mahalanobis2(px, py, pth, mu[i, m], sig[i, m], zr, zb, Rr, Rb, pc)
        if d2 < bd:
            bd = d2
            best = m
    return best, bd


@njit(types.void(types.float64, types.float64, types.float64, types.float64, types.float64,
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


@njit(types.float64(types.float64, types.float64, types.float64, types.int64, _F3, _F3, _B2, _I,
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
                                     pc[i])
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


@njit(types.void(_F2, _F3, _F3, _B2, _I, _F2, types.int64, types.float64, types.float64, _F,
                 types.int64, _I, types.float64, _F2), cache=True)
def _fitness(P, mu, sig, seen, ids, zs, n, Rr, Rb, out, assoc, nl, gate, pc):
    for i in range(P.shape[0]):
        out[i] = pose_loglik(P[i, 0], P[i, 1], P[i, 2], i, mu, sig, seen, ids, zs, n, Rr, Rb,
                             assoc, nl[i], gate, pc)


@njit(types.void(_F, _F2, _F3, _F3, _B2, _I, _I2, _F, _F2, _F2, types.int8[::1], types.int64,
                 _I, _F, _F, types.int64, STATE, _F2, _F3, _F3, _B2, _I, _I2), cache=True)
def directional_resample(W, P, mu, sig, seen, nl, src, bP, bmu, bsig, bseen, bnl, bsrc, shift,
                         noise, scheme, s, P2, mu2, sig2, seen2, nl2, src2):
    """Directional resampling (afsa2014): the lower-weight half of the particles is replaced by
    copies of the bulletin-board particle (pose bP with its map bmu, bsig, bseen, bnl, bsrc: the
    best particle of the previous observation) moved by ``shift`` (the change of the weighted pose
    estimate since then) plus Gaussian noise (standard deviations ``noise`` (3,)); the upper half
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
        for d in range(3):
            P2[i, d] = bP[d] + shift[d] + noise[d] * normal(s)
        P2[i, 2] = wrap(P2[i, 2])
        mu2[i] = bmu
        sig2[i] = bsig
        seen2[i] = bseen
        nl2[i] = bnl
        src2[i] = bsrc


@njit(types.void(_F, _F, _F, _F3, _F3, _B2, _I, _F2, types.int64, types.float64, types.float64,
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


@njit(types.float64(_F2), cache=True)
def circular_mean(P):
    """Circular mean of the headings P[:, 2]."""
    cs = 0.0
    sn = 0.0
    for i in range(P.shape[0]):
        cs += math.cos(P[i, 2])
        sn += math.sin(P[i, 2])
    return math.atan2(sn, cs)


@njit(types.float64(_F), cache=True)
def _pairwise_abs_sum(v):
    """sum_{i<j} |v_i - v_j| in O(n log n): over the sorted values, v_(k) (2k - n + 1)."""
    u = np.sort(v)
    n = u.size
    acc = 0.0
    for k in range(n):
        acc += u[k] * (2 * k - n + 1)
    return acc


@njit(types.UniTuple(types.float64, 2)(_F2,), cache=True)
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
    # distinct poses: sorted by x, then pairwise within runs of equal x
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
    return acc / (N * (N - 1) / 2), distinct / N


@njit(types.float64(_F, _F3, _B2, _I, _I2, types.int64, _F2, types.int8[::1]), cache=True)
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


FASTSLAM_SIG = types.int64(
    _F2, _I, _I2, _F3, _F, types.int64, _F, _F, _F, types.int64, types.int64, types.int64,
    types.int64, types.int64, types.float64, types.int64, _F, types.int64, types.float64,
    types.float64, types.int64, _F, types.int64, types.float64, types.float64, types.int64,
    types.int64, STATE, _F2, _F, _I, _F2, _I, _F, _F, _F2, _F2, _F, types.int64)


@njit(FASTSLAM_SIG, cache=True)
def fastslam_kernel(ctrl, obs_n, obs_id, obs_z, veh, every, qctrl, R, start, M, N, predict_noise,
                    joseph, scheme, threshold, refine, sp, iters, ewa_beta, ewa_mu, ewa_printed,
                    dnoise, assoc, gate_reject, gate_augment, gate_pose, motion, s, est, ess,
                    resampled, lm_est, lm_seen, evals, assoc_stats, lm_true, div, lm_trace,
                    diag):
    """Run FastSLAM over one trial; fill est (T+1, 3) the weighted pose estimate at every control
    step, ess / resampled / evals (K,) per observation, lm_est (M, 2) and lm_seen (M,) the final
    weighted map. Returns the number of observation steps whose weights all underflowed.

    motion : 0 = the steered vehicle, ctrl = [V, G], qctrl = [sigma_V, sigma_G] the noise each
    particle draws on its controls (veh : [V, dt, L, ...]); 1 = odometry form, ctrl = [ds, dtheta]
    per step, theta += dtheta, x += ds cos(theta), y += ds sin(theta), each particle adding pose
    noise qctrl = [sigma_xy, sigma_theta]. R : [sigma_r^2, sigma_b^2]; refine : a swarm
    algorithm (swarm.ALGORITHMS) or NO_SWARM, with its parameters sp (swarm.pack); scheme : a resampling code, EWA, or DIRECTIONAL (afsa2014's directional
    resampling with the bulletin board, copies' noise dnoise (3,); see ``directional_resample``).
    assoc : 0 = known identities (M = the number of landmarks, slot = identity); 1 = nearest
        neighbour (M = the map capacity): an observation joins the landmark nearest in Mahalanobis
        distance if its squared distance is <= gate_reject, starts a new landmark if every one
        is > gate_augment, and is dropped in between. assoc_stats (5,) gets [associations,
        wrong associations (the slot was started from another true landmark), observations
        dropped as ambiguous, landmarks started] summed over particles and observations, and
        the final map's duplicates (see lm_true).
    lm_true (M_true, 2): the true landmarks, for lm_trace (K,): the mean distance of the
        highest-weight particle's mapped landmarks to the true ones after each observation's update
        (nearest: each true landmark by the first slot started from it), and for assoc_stats[4]:
        the slots of the final map started from a true landmark that already had one (duplicates).
    div (K, 2): after each observation that resampled, the particles' mean pairwise L1 pose
        distance (|dx| + |dy| + |wrapped dtheta|) and the fraction of distinct poses (NaN where it
        did not resample). div and lm_trace are filled only with diag = 1 (NaN otherwise).
    gate_pose : 1 = the gates' distance includes each particle's pose uncertainty since its last
        observation update (see ``mahalanobis2``): the motion noise it drew since then, plus the
        noise of a directional or mutated copy; 0 = the plain FastSLAM 1.0 distance.
    """
    T = ctrl.shape[0]
    K = obs_n.shape[0]
    dt, L = veh[1], veh[2]
    Rr, Rb = R[0], R[1]
    P = np.empty((N, 3))
    for i in range(N):
        P[i, 0], P[i, 1], P[i, 2] = start[0], start[1], start[2]
    mu = np.zeros((N, M, 2))
    sig = np.zeros((N, M, 3))
    seen = np.zeros((N, M), dtype=np.int8)
    mu2 = np.zeros((N, M, 2))
    sig2 = np.zeros((N, M, 3))
    seen2 = np.zeros((N, M), dtype=np.int8)
    nl = np.zeros(N, dtype=np.int64)          # landmarks in each particle's map (nearest mode)
    nl2 = np.zeros(N, dtype=np.int64)
    src = np.full((N, M), -1, dtype=np.int64)  # the true landmark each slot was started from
    src2 = np.full((N, M), -1, dtype=np.int64)
    pc = np.zeros((N, 6))     # pose uncertainty since the last update: [xx, xy, xt, yy, yt, tt]
    pcm = np.zeros(6)         # the cloud's mean of it at the last observation
    M_true = lm_true.shape[0]
    first = np.zeros(M_true, dtype=np.int8)
    n_assoc = 0.0
    n_wrong = 0.0
    n_drop = 0.0
    n_new = 0.0
    # bulletin boards (directional resampling): the best particle of the last observation, in
    # use, and of this one, for the next
    bP = np.zeros(3)
    bmu = np.zeros((M, 2))
    bsig = np.zeros((M, 3))
    bseen = np.zeros(M, dtype=np.int8)
    bsrc = np.full(M, -1, dtype=np.int64)
    nP = np.zeros(3)
    nmu = np.zeros((M, 2))
    nsig = np.zeros((M, 3))
    nseen = np.zeros(M, dtype=np.int8)
    nsrc = np.full(M, -1, dtype=np.int64)
    bnl = 0
    nnl = 0
    have_board = False
    xbar_prev = np.zeros(3)
    xbar = np.zeros(3)
    shift = np.zeros(3)
    P2 = np.empty((N, 3))
    lw = np.zeros(N)
    w = np.full(N, 1.0)
    Wn = np.full(N, 1.0 / N)
    idx = np.empty(N, dtype=np.int64)
    mutant = np.empty(N, dtype=np.int8)
    ll = np.empty(N)
    llc = np.empty(N)
    fit = np.empty(N)
    V = np.empty(3 * N)
    Pb = np.empty(3 * N)
    Pfit = np.empty(N)
    A = np.empty(N)
    rr = np.empty(N)
    C = np.empty(3 * N)
    scale = np.ones(3)
    mean = np.zeros(3)
    Xs = np.empty(3 * N)          # AFSA: poses in units of the cloud's spread
    Xc = np.empty(3 * N)
    nf = np.empty(N)
    fitc = np.empty(N)
    C3 = np.empty(9 * N)
    ll3 = np.empty(3 * N)
    fit3 = np.empty(3 * N)
    events = 0
    est[0, 0], est[0, 1], est[0, 2] = start[0], start[1], start[2]
    k = 0
    for t in range(T):
        Vc, Gc = ctrl[t, 0], ctrl[t, 1]
        if motion == 1:
            # the simulator's order: the heading noise turns this step's move
            for i in range(N):
                th = P[i, 2] + Gc
                if predict_noise:
                    th += qctrl[1] * normal(s)
                P[i, 0] += Vc * math.cos(th)
                P[i, 1] += Vc * math.sin(th)
                if predict_noise:
                    P[i, 0] += qctrl[0] * normal(s)
                    P[i, 1] += qctrl[0] * normal(s)
                P[i, 2] = wrap(th)
            if gate_pose:
                # C <- F C F^T + G Q G^T, F = d(pose)/d(pose), G Q G^T of the heading noise
                # turning the move and the additive position noise
                for i in range(N):
                    c, sn_ = math.cos(P[i, 2]), math.sin(P[i, 2])
                    fx, fy = -Vc * sn_, Vc * c
                    propagate_pose_cov(pc[i], fx, fy, fx, fy, 1.0, qctrl[1] ** 2, 0.0, 0.0, 0.0,
                                       0.0, qctrl[0] ** 2)
        else:
            for i in range(N):
                v, g = Vc, Gc
                if predict_noise:
                    v += qctrl[0] * normal(s)
                    g += qctrl[1] * normal(s)
                P[i, 0] += v * dt * math.cos(P[i, 2] + g)
                P[i, 1] += v * dt * math.sin(P[i, 2] + g)
                P[i, 2] = wrap(P[i, 2] + v * dt * math.sin(g) / L)
            if gate_pose:
                # the control noise (sigma_V, sigma_G) through the steered model's Jacobian
                cg, sg = math.cos(Gc), math.sin(Gc)
                for i in range(N):
                    ca, sa = math.cos(P[i, 2] + Gc), math.sin(P[i, 2] + Gc)
                    propagate_pose_cov(pc[i], -Vc * dt * sa, Vc * dt * ca, dt * ca, dt * sa,
                                       dt * sg / L, qctrl[0] ** 2, -Vc * dt * sa, Vc * dt * ca,
                                       Vc * dt * cg / L, qctrl[1] ** 2, 0.0)
        if (t + 1) % every == 0 and k < K:
            n = obs_n[k]
            ids = obs_id[k]
            zs = obs_z[k]
            nev = 0
            if refine != NO_SWARM and iters > 0:
                # headings as continuous values around the cloud's circular mean
                th0 = circular_mean(P)
                for i in range(N):
                    P[i, 2] = th0 + wrap(P[i, 2] - th0)
                X = P.reshape(3 * N)
                # the unit of each coordinate's random step: the predicted cloud's spread
                for d in range(3):
                    m1 = 0.0
                    m2 = 0.0
                    for i in range(N):
                        m1 += P[i, d]
                        m2 += P[i, d] * P[i, d]
                    m1 /= N
                    mean[d] = m1
                    scale[d] = math.sqrt(max(m2 / N - m1 * m1, 1e-12))
                _fitness(P, mu, sig, seen, ids, zs, n, Rr, Rb, ll, assoc, nl, gate_augment, pc)
                nev += N
                for it in range(iters):
                    M0 = ll.max()
                    if refine == FA or refine == IFA:
                        if refine == FA:
                            for i in range(N):
                                fit[i] = math.exp(ll[i] - M0)
                            fa_move(X, fit, 3, sp[0], sp[1], sp[2], scale, s)
                        else:
                            # IFA brightness: innovations' Mahalanobis sum and the pose's
                            # distance from the predicted cloud in units of its spread
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
                                d2 = ((P[i, 0] - mx) ** 2 / vx + (P[i, 1] - my) ** 2 / vy
                                      + (P[i, 2] - mt) ** 2 / vt)
                                fit[i] = math.exp(ll[i] - M0 - 0.5 * d2)
                            ifa_move(X, fit, 3, sp[0], sp[1], Rr, scale, s)
                        _fitness(P, mu, sig, seen, ids, zs, n, Rr, Rb, ll, assoc, nl, gate_augment,
                                 pc)
                        nev += N
                    elif refine == BA:
                        if it == 0:
                            V[:] = 0.0
                            A[:] = sp[2]
                            rr[:] = sp[3]
                        g = argmax(ll)
                        ba_propose(X, V, A, rr, C, 3, g, sp[0], sp[1], scale, s)
                        Cp = C.reshape((N, 3))
                        _fitness(Cp, mu, sig, seen, ids, zs, n, Rr, Rb, llc, assoc, nl,
                                 gate_augment, pc)
                        nev += N
                        ba_accept(X, ll, C, llc, A, rr, 3, sp[4], sp[5], sp[3], it + 1, s)
                    elif refine == AFSA:
                        # AFSA in units of the predicted cloud's spread (visual and step too)
                        for i in range(N):
                            for d in range(3):
                                Xs[3 * i + d] = (P[i, d] - mean[d]) / scale[d]
                            fit[i] = math.exp(ll[i] - M0)
                        afsa_centres(Xs, fit, 3, sp[0], Xc, nf)
                        _fitness_scaled(Xc, mean, scale, mu, sig, seen, ids, zs, n, Rr, Rb, llc,
                                        assoc, nl, gate_augment, pc)
                        for i in range(N):
                            fitc[i] = math.exp(llc[i] - M0)
                        afsa_propose(Xs, fit, Xc, fitc, nf, 3, sp[0], sp[1], sp[2], int(sp[3]), s,
                                     C3)
                        _fitness_scaled(C3, mean, scale, mu, sig, seen, ids, zs, n, Rr, Rb, ll3,
                                        assoc, nl, gate_augment, pc)
                        for r in range(3 * N):
                            fit3[r] = math.exp(ll3[r] - M0)
                        afsa_select(Xs, fit, C3, fit3, 3, int(sp[4]))
                        for i in range(N):
                            for d in range(3):
                                P[i, d] = mean[d] + scale[d] * Xs[3 * i + d]
                            ll[i] = math.log(fit[i]) + M0 if fit[i] > 0.0 else -np.inf
                        nev += 4 * N
                    else:   # PSO
                        if it == 0:
                            V[:] = 0.0
                            Pb[:] = X
                            Pfit[:] = ll
                        g = argmax(Pfit)
                        pso_propose(X, V, Pb, Pfit, 3, g, sp[0], sp[1], sp[2], s)
                        _fitness(P, mu, sig, seen, ids, zs, n, Rr, Rb, ll, assoc, nl, gate_augment,
                                 pc)
                        nev += N
                        pso_accept(X, ll, Pb, Pfit, 3)
                for i in range(N):
                    P[i, 2] = wrap(P[i, 2])
            # weights and map updates
            mx = -np.inf
            for i in range(N):
                px, py, pth = P[i, 0], P[i, 1], P[i, 2]
                for j in range(n):
                    if assoc:
                        m, d2 = nearest_landmark(px, py, pth, i, mu, sig, nl[i], zs[j, 0],
                                                 zs[j, 1], Rr, Rb, pc[i])
                        if d2 <= gate_reject:
                            n_assoc += 1.0
                            if src[i, m] != ids[j]:
                                n_wrong += 1.0
                            lw[i] += ekf_landmark_update(px, py, pth, mu[i, m], sig[i, m],
                                                         zs[j, 0], zs[j, 1], Rr, Rb, joseph)
                            continue
                        if d2 <= gate_augment:   # between the gates: ambiguous, dropped
                            n_drop += 1.0
                            continue
                        if nl[i] >= M:          # the map is full: the observation is dropped
                            n_drop += 1.0
                            continue
                        m = nl[i]
                        nl[i] += 1
                        n_new += 1.0
                        src[i, m] = ids[j]
                        init_landmark(px, py, pth, zs[j, 0], zs[j, 1], Rr, Rb, mu[i, m],
                                      sig[i, m])
                        seen[i, m] = 1
                        continue
                    m = ids[j]
                    if seen[i, m]:
                        lw[i] += ekf_landmark_update(px, py, pth, mu[i, m], sig[i, m], zs[j, 0],
                                                     zs[j, 1], Rr, Rb, joseph)
                    else:
                        init_landmark(px, py, pth, zs[j, 0], zs[j, 1], Rr, Rb, mu[i, m],
                                      sig[i, m])
                        seen[i, m] = 1
                mx = max(mx, lw[i])
            nev += N
            evals[k] = nev
            if gate_pose:
                for d in range(6):
                    pcm[d] = pc[:, d].mean()
            pc[:] = 0.0         # the poses are now tied to their maps again
            Ssum, S2, sx, under = normalise(lw, w, P[:, 0].copy(), mx)
            events += int(under)
            ess[k] = Ssum * Ssum / S2
            for i in range(N):
                Wn[i] = w[i] / Ssum
            lm_trace[k] = (map_error(Wn, mu, seen, nl, src, assoc, lm_true, first) if diag
                           else np.nan)
            resampled[k] = 0
            if scheme == DIRECTIONAL:
                # this observation's weighted estimate and best particle (the next board)
                xbar[0] = 0.0
                xbar[1] = 0.0
                cs = 0.0
                sn = 0.0
                b = 0
                for i in range(N):
                    xbar[0] += Wn[i] * P[i, 0]
                    xbar[1] += Wn[i] * P[i, 1]
                    cs += Wn[i] * math.cos(P[i, 2])
                    sn += Wn[i] * math.sin(P[i, 2])
                    if Wn[i] > Wn[b]:
                        b = i
                xbar[2] = math.atan2(sn, cs)
                nP[:] = P[b]
                nmu[:] = mu[b]
                nsig[:] = sig[b]
                nseen[:] = seen[b]
                nsrc[:] = src[b]
                nnl = nl[b]
                if not have_board:
                    bP[:] = nP
                    bmu[:] = nmu
                    bsig[:] = nsig
                    bseen[:] = nseen
                    bsrc[:] = nsrc
                    bnl = nnl
                    xbar_prev[:] = xbar
                    have_board = True
            if ess[k] < threshold:
                if scheme == DIRECTIONAL:
                    shift[0] = xbar[0] - xbar_prev[0]
                    shift[1] = xbar[1] - xbar_prev[1]
                    shift[2] = wrap(xbar[2] - xbar_prev[2])
                    directional_resample(Wn, P, mu, sig, seen, nl, src, bP, bmu, bsig, bseen, bnl,
                                         bsrc, shift, dnoise, _SYSTEMATIC, s, P2,
                                         mu2, sig2, seen2, nl2, src2)
                    if gate_pose:
                        # a copy sits off the board's map by the board's motion since its
                        # update and by the copy's noise
                        for i in range(N - N // 2, N):
                            pc[i] = pcm
                            pc[i, 0] += dnoise[0] ** 2
                            pc[i, 3] += dnoise[1] ** 2
                            pc[i, 5] += dnoise[2] ** 2
                else:
                    if scheme == EWA:
                        stepwise_ewa_plan(Wn, ewa_beta, ewa_printed, idx, mutant)
                    else:
                        resample(scheme, w, Ssum, s, idx)
                        mutant[:] = 0
                    for i in range(N):
                        j = idx[i]
                        for d in range(3):
                            P2[i, d] = P[j, d]
                        if mutant[i]:
                            for d in range(3):
                                P2[i, d] += P2[i, d] * ewa_mu * normal(s)
                            P2[i, 2] = wrap(P2[i, 2])
                            if gate_pose:
                                for d in range(3):
                                    pc[i, (0, 3, 5)[d]] = (P[j, d] * ewa_mu) ** 2
                        mu2[i] = mu[j]
                        sig2[i] = sig[j]
                        seen2[i] = seen[j]
                        nl2[i] = nl[j]
                        src2[i] = src[j]
                P, P2 = P2, P           # the new set becomes the current one
                mu, mu2 = mu2, mu
                sig, sig2 = sig2, sig
                seen, seen2 = seen2, seen
                nl, nl2 = nl2, nl
                src, src2 = src2, src
                lw[:] = 0.0
                Wn[:] = 1.0 / N
                resampled[k] = 1
                if diag:
                    div[k, 0], div[k, 1] = pose_diversity(P)
                else:
                    div[k, 0], div[k, 1] = np.nan, np.nan
            else:
                div[k, 0], div[k, 1] = np.nan, np.nan
            if scheme == DIRECTIONAL:     # the board for the next observation
                bP, nP = nP, bP
                bmu, nmu = nmu, bmu
                bsig, nsig = nsig, bsig
                bseen, nseen = nseen, bseen
                bsrc, nsrc = nsrc, bsrc
                bnl = nnl
                xbar_prev[:] = xbar
            k += 1
        # the weighted pose estimate (circular mean for the heading)
        ex = 0.0
        ey = 0.0
        ec = 0.0
        es = 0.0
        for i in range(N):
            ex += Wn[i] * P[i, 0]
            ey += Wn[i] * P[i, 1]
            ec += Wn[i] * math.cos(P[i, 2])
            es += Wn[i] * math.sin(P[i, 2])
        est[t + 1, 0], est[t + 1, 1], est[t + 1, 2] = ex, ey, math.atan2(es, ec)
    assoc_stats[0], assoc_stats[1], assoc_stats[2], assoc_stats[3] = n_assoc, n_wrong, n_drop, n_new
    if assoc:
        # the final map: the highest-weight particle's, each slot compared with the true landmark
        # it was started from (lm_est has a row per true landmark)
        b = 0
        for i in range(N):
            if Wn[i] > Wn[b]:
                b = i
        lm_seen[:] = 0
        lm_est[:] = np.nan
        dup = 0
        for m in range(nl[b]):
            t_id = src[b, m]
            if lm_seen[t_id] == 0:      # the first slot started from it
                lm_seen[t_id] = 1
                lm_est[t_id, 0] = mu[b, m, 0]
                lm_est[t_id, 1] = mu[b, m, 1]
            else:
                dup += 1
        assoc_stats[4] = dup
        return events
    # the final map: per landmark, the weighted mean over the particles that have it
    for m in range(M):
        wsum = 0.0
        ax = 0.0
        ay = 0.0
        for i in range(N):
            if seen[i, m]:
                wsum += Wn[i]
                ax += Wn[i] * mu[i, m, 0]
                ay += Wn[i] * mu[i, m, 1]
        lm_seen[m] = 1 if wsum > 0.0 else 0
        lm_est[m, 0] = ax / wsum if wsum > 0.0 else np.nan
        lm_est[m, 1] = ay / wsum if wsum > 0.0 else np.nan
    return events


def run(model, data, params, particles, state, diag=True):
    """Run FastSLAM (with the configured refinement) on a course trial; return the traces."""
    T = data.ctrl.shape[0]
    K = data.obs_n.shape[0]
    M_true = model.landmarks.shape[0]
    nearest = params["association"] == "nearest"
    M = (params["max_landmarks"] or 3 * M_true) if nearest else M_true
    deg = math.pi / 180.0

    def pick(key, default):
        v = params.get(key)
        return float(default if v is None else v)

    motion = getattr(model, "motion", 0)
    if motion == 1:     # odometry form: the pose noise of the scenario
        qctrl = np.array([model.noise[0], model.noise[1]])
    else:
        qctrl = np.array([pick("speed_noise_mps", model.noise[0]),
                          pick("steer_noise_deg", model.noise[1] / deg) * deg])
    R = np.array([pick("range_noise_m", model.noise[2]) ** 2,
                  (pick("bearing_noise_deg", model.noise[3] / deg) * deg) ** 2])
    refine = params["refine"]
    scheme = {"stepwise_ewa": EWA, "directional": DIRECTIONAL, **SCHEME_CODES}[params["resampling"]]
    threshold = np.inf if params["resample"] == "always" else params["neff_ratio"] * particles
    dnoise = np.array([params["directional_noise_m"], params["directional_noise_m"],
                       params["directional_noise_deg"] * deg])
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(K),
           "resampled": np.zeros(K, dtype=np.int64), "lm_est": np.empty((M_true, 2)),
           "lm_seen": np.zeros(M_true, dtype=np.int64)}
    evals = np.zeros(K)
    stats = np.zeros(5)
    div = np.empty((K, 2))
    out["lm_trace"] = np.empty(K)
    out["underflow_steps"] = fastslam_kernel(
        data.ctrl, data.obs_n, data.obs_id, data.obs_z, model.vehicle, int(model.sensor[2]), qctrl,
        R, model.start, M, particles, int(params["predict_noise"]),
        int(params["update"] == "joseph"), scheme, threshold, ALGORITHMS.get(refine, NO_SWARM), pack(refine, params), params["iterations"],
        params["ewa_beta"], params["ewa_mu"], int(params["ewa_correction"] == "as_printed"),
        dnoise, int(nearest), params["gate_reject"], params["gate_augment"],
        int(params["gate_pose"] and nearest), motion, state,
        out["pose"], out["ess"], out["resampled"], out["lm_est"], out["lm_seen"], evals, stats,
        np.ascontiguousarray(model.landmarks, dtype=np.float64), div, out["lm_trace"], int(diag))
    out["div_l1"], out["distinct"] = div[:, 0], div[:, 1]
    out["lik_evals_per_step"] = float(evals.mean()) if K else 0.0
    if nearest:
        out["association_errors"] = stats[1] / stats[0] if stats[0] else 0.0
        total = stats[0] + stats[2] + stats[3]
        out["dropped_frac"] = stats[2] / total if total else 0.0
        out["started_per_particle"] = stats[3] / particles
        out["map_duplicates"] = stats[4]
    return out


def fastslam_keys() -> dict:
    swarm = {}
    for algo in ("fa", "ba", "afsa", "pso"):     # IFA takes FA's keys but alpha
        swarm.update(keys(algo, unit="in units of the predicted cloud's spread", prefix=True))
    return {
        "refine": Key("choice", "none", "swarm refinement of the predicted poses at each "
                      "observation (ifa2021: BA-, FA-, IFA-FastSLAM; afsa2014: PSO-, AFSA-FastSLAM)",
                      choices=("none",) + tuple(ALGORITHMS)),
        "iterations": Key("int", 1, "swarm iterations per observation", min=0),
        **swarm,
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
        "directional_noise_m": Key("float", 0.05, "directional resampling: position noise of the "
                                   "board's copies (afsa2014 gives none; our default)", min=0.0),
        "directional_noise_deg": Key("float", 0.5, "directional resampling: heading noise of the "
                                     "board's copies", min=0.0),
        "resample": Key("choice", "neff", "'neff': when ESS < neff_ratio * N; 'always'",
                        choices=("neff", "always")),
        "neff_ratio": pf_keys()["neff_ratio"],
        **ewa_keys(),
    }


FASTSLAM = FilterType("fastslam", "FastSLAM 1.0 with per-landmark EKFs, optional swarm pose "
                      "refinement (FA, IFA, BA, PSO, AFSA)", fastslam_keys(), run, kind="slam")
