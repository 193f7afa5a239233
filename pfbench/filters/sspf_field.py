"""SSPF for localization on the beacon field (sspf2008): an unscented particle filter whose
resampling is triggered by the weight change, followed by a Metropolis-Hastings move.

Each particle i carries a pose x_i and a covariance P_i (3 x 3). Per step an augmented UKF
(L = 6: the pose and the three odometry noises [rot1, trans, rot2]; scaled sigma points) run from
(x_i, P_i) with the step's odometry and observations gives N(m_i, Pn_i); the particle is drawn from
it, P_i becomes Pn_i, and the weight is multiplied by p(z | x) p(x | x_prev) / q(x | x_prev, z).
The measurement noise is additive, so it enters the UKF's innovation covariance directly (the same
as augmenting it).

Choices the paper leaves open, each a key:
- the transition density p(x | x_prev) in the weight is the motion model linearised in its noise,
  N(f(x_prev, u), G M G^T + J), J = diag(jitter_m^2, jitter_m^2, jitter_deg^2): the odometry model
  of ``motion: odometry`` moves a pose along a two-dimensional surface, whose density in the three
  pose coordinates does not exist without some J. The UKF's process noise includes J too;
- the initial covariance of every particle, diag(init_std_m^2, init_std_m^2, init_std_deg^2)
  (the particles start as MCL's: uniform over the field and heading, or around a known start);
- sspf2008 uses the odometry also as a measurement ([range, T, dtheta] + noise); here it is the
  motion model's input, as for every other filter of the field, so the UKF measures the ranges
  (and bearings) alone.

Resampling (residual by default) when K = sum_i W_k^i (W_k^i - W_{k-1}^i)^2 > sigma / N^2
(``resample: weight_change``), and then ``mh_steps`` independence MH moves per particle with the
ancestor's proposal: accept x* ~ N(m_a, Pn_a) with probability
min(1, p(z|x*) p(x*|x_prev) q(x) / (p(z|x) p(x|x_prev) q(x*))). The estimate is the weighted mean
(circular heading) before resampling.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..resampling import SCHEME_CODES, resample
from ..rng import STATE, normal, uniform
from ..models.beacons import pose_loglik
from ..models.pose import estimate_pose, init_particles, snapshot, snapshot_arrays
from ..schema import Key
from .keys import sigma_check, sigma_keys
from .types import FilterType
from .ukf import ut_weights
from .upf import upf_keys

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]
LOG_2PI = math.log(2.0 * math.pi)
TRIGGERS = {"always": 0, "neff": 1, "weight_change": 2}


@kernel(types.boolean(_F2, types.int64, _F2), cache=True)
def chol(A, n, L):
    """Lower Cholesky factor of A[:n, :n] into L[:n, :n]; False when A is not positive definite."""
    for j in range(n):
        d = A[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if not d > 0.0:
            return False
        L[j, j] = math.sqrt(d)
        for i in range(j + 1, n):
            v = A[i, j]
            for k in range(j):
                v -= L[i, k] * L[j, k]
            L[i, j] = v / L[j, j]
        for i in range(j):
            L[i, j] = 0.0
    return True


@kernel(types.void(_F2, types.int64, _F), cache=True)
def chol_solve(L, n, b):
    """Solve (L L^T) x = b[:n] in place."""
    for i in range(n):
        v = b[i]
        for k in range(i):
            v -= L[i, k] * b[k]
        b[i] = v / L[i, i]
    for i in range(n - 1, -1, -1):
        v = b[i]
        for k in range(i + 1, n):
            v -= L[k, i] * b[k]
        b[i] = v / L[i, i]


@kernel(types.float64(types.float64, types.float64, types.float64, _F2), cache=True)
def lognormal3(dx, dy, dth, L):
    """log N(d; 0, L L^T) of a pose difference d (the heading difference already wrapped)."""
    y0 = dx / L[0, 0]
    y1 = (dy - L[1, 0] * y0) / L[1, 1]
    y2 = (dth - L[2, 0] * y0 - L[2, 1] * y1) / L[2, 2]
    return (-0.5 * (y0 * y0 + y1 * y1 + y2 * y2) - math.log(L[0, 0] * L[1, 1] * L[2, 2])
            - 1.5 * LOG_2PI)


@kernel(types.UniTuple(types.float64, 3)(types.float64, types.float64, types.float64, _F,
                                       types.float64, types.float64, types.float64), cache=True)
def move(x, y, th, u, w0, w1, w2):
    """The odometry motion with noise w: turn rot1 + w0, drive trans + w1, turn rot2 + w2."""
    t1 = th + u[0] + w0
    return x + (u[1] + w1) * math.cos(t1), y + (u[1] + w1) * math.sin(t1), wrap(t1 + u[2] + w2)


@kernel(types.void(_F, types.int64, _F, _F), cache=True)
def noise_sd(u, motion, mnoise, out):
    """Standard deviations of the three odometry noises at a step with odometry u."""
    if motion == 0:
        out[0], out[1], out[2] = 0.0, mnoise[0], mnoise[1]
    else:
        a1, a2, a3, a4 = mnoise[0], mnoise[1], mnoise[2], mnoise[3]
        out[0] = a1 * abs(u[0]) + a2 * abs(u[1])
        out[1] = a3 * abs(u[1]) + a4 * (abs(u[0]) + abs(u[2]))
        out[2] = a1 * abs(u[2]) + a2 * abs(u[1])


@kernel(types.void(types.float64, types.float64, types.float64, _F, _F, _F, _F2), cache=True)
def transition_cov(x, y, th, u, sd, jit, Q):
    """G M G^T + J: the motion's noise covariance linearised at a pose, plus the jitter."""
    t1 = th + u[0]
    c, s = math.cos(t1), math.sin(t1)
    g = ((-u[1] * s, u[1] * c, 1.0), (c, s, 0.0), (0.0, 0.0, 1.0))
    for a in range(3):
        for b in range(3):
            v = 0.0
            for k in range(3):
                v += sd[k] * sd[k] * g[k][a] * g[k][b]
            Q[a, b] = v
    Q[0, 0] += jit[0] * jit[0]
    Q[1, 1] += jit[0] * jit[0]
    Q[2, 2] += jit[1] * jit[1]


@kernel(types.void(_F2, types.int64, _F, _F), cache=True, inline="always")
def _pose_diff(Y, j, xm, d):
    """d = sigma point Y[j] - the mean pose xm, the heading wrapped."""
    d[0] = Y[j, 0] - xm[0]
    d[1] = Y[j, 1] - xm[1]
    d[2] = wrap(Y[j, 2] - xm[2])


class FieldOptions(NamedTuple):
    """The SSPF's settings, as the jitted steps read them.

    motion : the odometry noise model (0 additive, 1 rot-trans-rot; mnoise its parameters)
    sensor : 0 ranges, 1 ranges and bearings; sr, sb their noise standard deviations
    N : particles; trigger : resample 0 always, 1 when ESS < threshold, 2 when the weight change
    K > threshold; scheme : the resampling code; mh_steps : MH moves per particle after it
    """

    motion: int
    sensor: int
    sr: float
    sb: float
    N: int
    trigger: int
    threshold: float
    scheme: int
    mh_steps: int


FIELD_OPTIONS = typeof(FieldOptions(0, 0, 1.0, 1.0, 1, 0, 1.0, 0, 1))


class Proposals(NamedTuple):
    """The particles: pose X (N, 3) and covariance Pc (N, 3, 3); the proposal each was drawn from,
    mean mprop (N, 3) and Cholesky factor Lprop (N, 3, 3); the transition density's mean
    f(x_prev, u) fpre (N, 3) and Cholesky factor Lq (N, 3, 3); ltgt (N,) log p(z | x) +
    log p(x | x_prev) and lqs (N,) log q(x) at the particle."""

    X: np.ndarray
    Pc: np.ndarray
    mprop: np.ndarray
    Lprop: np.ndarray
    fpre: np.ndarray
    Lq: np.ndarray
    ltgt: np.ndarray
    lqs: np.ndarray


PROPOSALS = types.NamedTuple((_F2, _F3, _F2, _F3, _F2, _F3, _F, _F), Proposals)


@kernel(PROPOSALS(types.int64), cache=True)
def new_proposals(N):
    return Proposals(np.empty((N, 3)), np.zeros((N, 3, 3)), np.empty((N, 3)), np.zeros((N, 3, 3)),
                     np.empty((N, 3)), np.zeros((N, 3, 3)), np.empty(N), np.empty(N))


class UkfWork(NamedTuple):
    """One particle's UKF: weights Wm, Wc (13,) and the points' spread sq (1,), sqrt(L + lambda)
    (L = 6: the pose and the three odometry noises); sigma points through the motion Y (13, 3) and
    the sensor Z (13, nz); predicted mean xm (3,) and covariance Pm, updated Pn, a Cholesky
    factor L3; the step's observations zobs (nz,), which are bearings isb (nz,), their predicted
    mean zm, covariance S with its factor LS, cross-covariance C (3, nz) and gain K (3, nz);
    scratch rowb (nz,), Q (3, 3), d (3,); the odometry noises' standard deviations sd (3,)."""

    Wm: np.ndarray
    Wc: np.ndarray
    sq: np.ndarray
    Y: np.ndarray
    Z: np.ndarray
    xm: np.ndarray
    Pm: np.ndarray
    Pn: np.ndarray
    L3: np.ndarray
    zobs: np.ndarray
    isb: np.ndarray
    zm: np.ndarray
    S: np.ndarray
    LS: np.ndarray
    C: np.ndarray
    K: np.ndarray
    rowb: np.ndarray
    Q: np.ndarray
    d: np.ndarray
    sd: np.ndarray


UKF_WORK = types.NamedTuple((_F, _F, _F, _F2, _F2, _F, _F2, _F2, _F2, _F, _I, _F, _F2, _F2, _F2, _F2,
                             _F, _F2, _F, _F), UkfWork)


@kernel(UKF_WORK(types.int64, types.int64), cache=True)
def new_ukf_work(ns, nzmax):
    return UkfWork(np.empty(ns), np.empty(ns), np.empty(1), np.empty((ns, 3)), np.empty((ns, nzmax)),
                   np.empty(3), np.empty((3, 3)), np.empty((3, 3)), np.zeros((3, 3)),
                   np.empty(nzmax), np.zeros(nzmax, dtype=np.int64), np.empty(nzmax),
                   np.empty((nzmax, nzmax)), np.zeros((nzmax, nzmax)), np.empty((3, nzmax)),
                   np.empty((3, nzmax)), np.empty(nzmax), np.empty((3, 3)), np.empty(3),
                   np.empty(3))


@kernel(types.int64(_F2, types.int64, FIELD_OPTIONS, UKF_WORK), cache=True)
def observation_vector(zs, m, o, wk):
    """The step's m observations as one vector wk.zobs (ranges, and bearings flagged in wk.isb);
    returns its length."""
    r = 0
    for j in range(m):
        wk.zobs[r] = zs[j, 0]
        wk.isb[r] = 0
        r += 1
        if o.sensor == 1:
            wk.zobs[r] = zs[j, 1]
            wk.isb[r] = 1
            r += 1
    return r


@kernel(types.void(_F, _F2, _F, _F, UKF_WORK), cache=True, inline="always")
def predict_moments(x, P, u, jit, wk):
    """The sigma points of [pose, odometry noise] (pose x, covariance P; the noises' deviations
    wk.sd) through the motion u into wk.Y, and their mean wk.xm and covariance wk.Pm (plus the
    jitter jit [m, rad])."""
    Lg = 6
    ns = 2 * Lg + 1
    L3, Y, sq = wk.L3, wk.Y, wk.sq[0]
    if not chol(P, 3, L3):
        for a in range(3):
            for b in range(3):
                L3[a, b] = 0.0
        L3[0, 0] = L3[1, 1] = jit[0]
        L3[2, 2] = jit[1]
    for j in range(ns):
        px, py, pt = x[0], x[1], x[2]
        w0 = w1 = w2 = 0.0
        if j > 0:
            k = (j - 1) % Lg
            sgn = 1.0 if j <= Lg else -1.0
            if k < 3:
                px += sgn * sq * L3[0, k]
                py += sgn * sq * L3[1, k]
                pt += sgn * sq * L3[2, k]
            elif k == 3:
                w0 = sgn * sq * wk.sd[0]
            elif k == 4:
                w1 = sgn * sq * wk.sd[1]
            else:
                w2 = sgn * sq * wk.sd[2]
        Y[j, 0], Y[j, 1], Y[j, 2] = move(px, py, pt, u, w0, w1, w2)
    xm, Pm, Wm, Wc, d = wk.xm, wk.Pm, wk.Wm, wk.Wc, wk.d
    xm[0] = 0.0
    xm[1] = 0.0
    dt = 0.0
    for j in range(ns):
        xm[0] += Wm[j] * Y[j, 0]
        xm[1] += Wm[j] * Y[j, 1]
        dt += Wm[j] * wrap(Y[j, 2] - Y[0, 2])
    xm[2] = wrap(Y[0, 2] + dt)
    for a in range(3):
        for b in range(3):
            Pm[a, b] = 0.0
    for j in range(ns):
        _pose_diff(Y, j, xm, d)
        for a in range(3):
            for b in range(3):
                Pm[a, b] += Wc[j] * d[a] * d[b]
    Pm[0, 0] += jit[0] * jit[0]
    Pm[1, 1] += jit[0] * jit[0]
    Pm[2, 2] += jit[1] * jit[1]


@kernel(types.void(_F2, _I, _F2, types.int64, types.int64, FIELD_OPTIONS, UKF_WORK), cache=True, inline="always")
def sensor_moments(bc, ids, zs, m, nz, o, wk):
    """The sigma points through the sensor (wk.Z), their mean wk.zm, covariance wk.S (plus the
    sensor noise) and cross-covariance with the pose wk.C."""
    ns = wk.Y.shape[0]
    Y, Z, zm, S, C, isb, Wm, Wc, d = wk.Y, wk.Z, wk.zm, wk.S, wk.C, wk.isb, wk.Wm, wk.Wc, wk.d
    for j in range(ns):
        r = 0
        for q in range(m):
            dx = bc[ids[q], 0] - Y[j, 0]
            dy = bc[ids[q], 1] - Y[j, 1]
            Z[j, r] = math.hypot(dx, dy)
            r += 1
            if o.sensor == 1:
                Z[j, r] = wrap(math.atan2(dy, dx) - Y[j, 2])
                r += 1
    for r in range(nz):
        v = 0.0
        for j in range(ns):
            v += Wm[j] * (wrap(Z[j, r] - Z[0, r]) if isb[r] else Z[j, r])
        zm[r] = wrap(Z[0, r] + v) if isb[r] else v
    for a in range(nz):
        for b in range(nz):
            S[a, b] = 0.0
        S[a, a] = o.sb * o.sb if isb[a] else o.sr * o.sr
        for b in range(3):
            C[b, a] = 0.0
    for j in range(ns):
        _pose_diff(Y, j, wk.xm, d)
        for a in range(nz):
            da = wrap(Z[j, a] - zm[a]) if isb[a] else Z[j, a] - zm[a]
            for b in range(nz):
                db = wrap(Z[j, b] - zm[b]) if isb[b] else Z[j, b] - zm[b]
                S[a, b] += Wc[j] * da * db
            for b in range(3):
                C[b, a] += Wc[j] * d[b] * da


@kernel(types.void(types.int64, UKF_WORK), cache=True, inline="always")
def kalman_update(nz, wk):
    """The UKF's measurement update of wk.xm, wk.Pn (from wk.Pm) with gain K = C S^-1; leaves
    them predicted when S is not positive definite."""
    xm, Pn, Pm, K, C, zm, isb = wk.xm, wk.Pn, wk.Pm, wk.K, wk.C, wk.zm, wk.isb
    if not chol(wk.S, nz, wk.LS):
        return
    for b in range(3):
        for a in range(nz):
            wk.rowb[a] = C[b, a]
        chol_solve(wk.LS, nz, wk.rowb)
        for a in range(nz):
            K[b, a] = wk.rowb[a]
    for b in range(3):
        v = 0.0
        for a in range(nz):
            inn = wk.zobs[a] - zm[a]
            if isb[a]:
                inn = wrap(inn)
            v += K[b, a] * inn
        xm[b] += v
    xm[2] = wrap(xm[2])
    for a in range(3):
        for b in range(3):
            v = 0.0
            for q in range(nz):
                v += K[a, q] * C[b, q]
            Pn[a, b] = Pm[a, b] - v
    for a in range(3):
        for b in range(a):
            v = 0.5 * (Pn[a, b] + Pn[b, a])
            Pn[a, b] = v
            Pn[b, a] = v


@kernel(types.float64(PROPOSALS, types.int64, _F, _F2, _I, _F2, types.int64, FIELD_OPTIONS,
                    UKF_WORK, _F, STATE), cache=True, inline="always")
def draw_particle(pp, i, u, bc, ids, zs, m, o, wk, jit, s):
    """Draw particle i from its proposal N(wk.xm, wk.Pn) and keep the proposal with it; returns
    its weight's log factor p(z | x) p(x | x_prev) / q(x)."""
    Pn, L3, xm = wk.Pn, wk.L3, wk.xm
    if not chol(Pn, 3, L3):     # numerically indefinite: keep the predicted covariance
        for a in range(3):
            for b in range(3):
                Pn[a, b] = wk.Pm[a, b]
        chol(Pn, 3, L3)
    n0, n1, n2 = normal(s), normal(s), normal(s)
    nx = xm[0] + L3[0, 0] * n0
    ny = xm[1] + L3[1, 0] * n0 + L3[1, 1] * n1
    nt = wrap(xm[2] + L3[2, 0] * n0 + L3[2, 1] * n1 + L3[2, 2] * n2)
    lq = lognormal3(nx - xm[0], ny - xm[1], wrap(nt - xm[2]), L3)
    X = pp.X
    fx, fy, ft = move(X[i, 0], X[i, 1], X[i, 2], u, 0.0, 0.0, 0.0)
    transition_cov(X[i, 0], X[i, 1], X[i, 2], u, wk.sd, jit, wk.Q)
    Li = pp.Lq[i]
    chol(wk.Q, 3, Li)
    lp = lognormal3(nx - fx, ny - fy, wrap(nt - ft), Li)
    ll = pose_loglik(nx, ny, nt, bc, m, ids, zs, o.sensor, o.sr, o.sb)
    X[i, 0], X[i, 1], X[i, 2] = nx, ny, nt
    for a in range(3):
        pp.mprop[i, a] = xm[a]
        for b in range(3):
            pp.Pc[i, a, b] = Pn[a, b]
            pp.Lprop[i, a, b] = L3[a, b]
    pp.fpre[i, 0], pp.fpre[i, 1], pp.fpre[i, 2] = fx, fy, ft
    pp.ltgt[i] = ll + lp
    pp.lqs[i] = lq
    return ll + lp - lq


@kernel(types.UniTuple(types.float64, 3)(_F, _F, _F, types.float64), cache=True)
def weigh(lw, W, Wprev, mx):
    """Normalised weights W from the log-weights lw (max mx; all -inf: reset to uniform); returns
    (1 when they underflowed, the ESS, the weight change K = sum W (W - Wprev)^2)."""
    N = lw.size
    under = 0.0
    if not np.isfinite(mx):
        under = 1.0
        lw[:] = 0.0
        mx = 0.0
    tot = 0.0
    for i in range(N):
        W[i] = math.exp(lw[i] - mx) if np.isfinite(lw[i]) else 0.0
        tot += W[i]
    S2 = 0.0
    Kc = 0.0
    for i in range(N):
        W[i] /= tot
        S2 += W[i] * W[i]
        dw = W[i] - Wprev[i]
        Kc += W[i] * dw * dw
    return under, 1.0 / S2, Kc


@kernel(types.void(PROPOSALS, PROPOSALS, _I), cache=True)
def copy_resampled(pp, out, idx):
    """out[i] = pp[idx[i]], every field."""
    for i in range(idx.size):
        a = idx[i]
        out.X[i] = pp.X[a]
        out.Pc[i] = pp.Pc[a]
        out.mprop[i] = pp.mprop[a]
        out.Lprop[i] = pp.Lprop[a]
        out.fpre[i] = pp.fpre[a]
        out.Lq[i] = pp.Lq[a]
        out.ltgt[i] = pp.ltgt[a]
        out.lqs[i] = pp.lqs[a]


@kernel(types.int64(PROPOSALS, _F2, _I, _F2, types.int64, FIELD_OPTIONS, STATE), cache=True)
def mh_moves(pp, bc, ids, zs, m, o, s):
    """o.mh_steps independence Metropolis-Hastings moves per particle with its ancestor's
    proposal; returns the moves accepted."""
    acc = 0
    X, mprop, fpre = pp.X, pp.mprop, pp.fpre
    for i in range(X.shape[0]):
        Lp = pp.Lprop[i]
        for _ in range(o.mh_steps):
            n0, n1, n2 = normal(s), normal(s), normal(s)
            nx = mprop[i, 0] + Lp[0, 0] * n0
            ny = mprop[i, 1] + Lp[1, 0] * n0 + Lp[1, 1] * n1
            nt = wrap(mprop[i, 2] + Lp[2, 0] * n0 + Lp[2, 1] * n1 + Lp[2, 2] * n2)
            lq = lognormal3(nx - mprop[i, 0], ny - mprop[i, 1], wrap(nt - mprop[i, 2]), Lp)
            lt = (pose_loglik(nx, ny, nt, bc, m, ids, zs, o.sensor, o.sr, o.sb)
                  + lognormal3(nx - fpre[i, 0], ny - fpre[i, 1], wrap(nt - fpre[i, 2]),
                               pp.Lq[i]))
            la = (lt - lq) - (pp.ltgt[i] - pp.lqs[i])
            if la >= 0.0 or uniform(s) < math.exp(la):
                X[i, 0], X[i, 1], X[i, 2] = nx, ny, nt
                pp.ltgt[i] = lt
                pp.lqs[i] = lq
                acc += 1
    return acc


SSPF_SIG = types.int64(
    _F2, _I, _I2, _F3, _F2, _F, FIELD_OPTIONS, _F, _F, _F, _F, _F, STATE, _F2, _F, _I, _F, _I, _F3,
    _I)


@kernel(SSPF_SIG, cache=True)
def sspf_field_kernel(ctrl, obs_n, obs_id, obs_z, bc, area, o, mnoise, up, init, jit, start, s,
                      est, ess, resampled, accepted, snap_t, snap, snap_n):
    """Run the SSPF over one trial (settings o, see ``FieldOptions``). up: [alpha, beta, kappa] of
    the sigma points; init: initial standard deviations [m, rad]; jit: the jitter [m, rad];
    start: the initial belief (init_particles). Fills est (T+1, 3), ess / resampled / accepted
    (MH acceptance rate, NaN without a move) (T,); snapshots as mcl_kernel's. Returns the steps
    whose weights all underflowed."""
    T, N = ctrl.shape[0], o.N
    wk = new_ukf_work(13, 2 * bc.shape[0])
    wk.sq[0] = ut_weights(6, up[0], up[1], up[2], wk.Wm, wk.Wc)
    pp, spare = new_proposals(N), new_proposals(N)
    init_particles(pp.X, area, start, s)
    for i in range(N):
        pp.Pc[i, 0, 0] = init[0] * init[0]
        pp.Pc[i, 1, 1] = init[0] * init[0]
        pp.Pc[i, 2, 2] = init[1] * init[1]
    lw = np.zeros(N)
    W = np.full(N, 1.0 / N)
    Wprev = np.full(N, 1.0 / N)
    idx = np.empty(N, dtype=np.int64)
    events = 0
    estimate_pose(pp.X, W, N, est[0])
    si = snapshot(0, pp.X, N, snap_t, snap, snap_n, 0, False)
    for t in range(T):
        u, m, ids, zs = ctrl[t], obs_n[t], obs_id[t], obs_z[t]
        noise_sd(u, o.motion, mnoise, wk.sd)
        nz = observation_vector(zs, m, o, wk)
        mx = -np.inf
        for i in range(N):      # each particle's UKF proposal, and a draw from it
            predict_moments(pp.X[i], pp.Pc[i], u, jit, wk)
            wk.Pn[:] = wk.Pm
            if nz > 0:
                sensor_moments(bc, ids, zs, m, nz, o, wk)
                kalman_update(nz, wk)
            lw[i] += draw_particle(pp, i, u, bc, ids, zs, m, o, wk, jit, s)
            if lw[i] > mx:
                mx = lw[i]
        under, ess[t], Kc = weigh(lw, W, Wprev, mx)
        events += int(under)
        estimate_pose(pp.X, W, N, est[t + 1])
        si = snapshot(t + 1, pp.X, N, snap_t, snap, snap_n, si, False)
        accepted[t] = np.nan
        resampled[t] = 0
        if not (o.trigger == 0 or (o.trigger == 1 and ess[t] < o.threshold)
                or (o.trigger == 2 and Kc > o.threshold)):
            Wprev[:] = W
            continue
        resample(o.scheme, W, 1.0, s, idx)
        copy_resampled(pp, spare, idx)
        pp, spare = spare, pp
        lw[:] = 0.0
        W[:] = 1.0 / N
        Wprev[:] = W
        resampled[t] = 1
        acc = mh_moves(pp, bc, ids, zs, m, o, s)
        if o.mh_steps > 0:
            accepted[t] = acc / (N * o.mh_steps)
    return events


def run(model, data, params, particles, state, diag=True, snapshots=()):
    """Run the SSPF on a beacon-field trial; return the traces (snapshots as mcl.run's)."""
    T = data.ctrl.shape[0]
    N = particles
    trig = TRIGGERS[params["resample"]]
    threshold = {0: 0.0, 1: params["neff_ratio"] * N, 2: params["sigma"] / (N * N)}[trig]
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(T),
           "resampled": np.zeros(T, dtype=np.int64), "mh_accept": np.empty(T),
           "snapshots": snapshot_arrays(snapshots, N)}
    o = FieldOptions(
        motion=int(model.motion), sensor=int(model.sensor), sr=float(model.sense[2]),
        sb=float(model.sense[3]), N=int(N), trigger=int(trig), threshold=float(threshold),
        scheme=SCHEME_CODES[params["resampling"]], mh_steps=int(params["mh_steps"]))
    out["underflow_steps"] = sspf_field_kernel(
        data.ctrl, data.obs_n, data.obs_id, data.obs_z, model.beacons, model.area, o,
        model.mnoise, np.array([params["alpha"], params["beta"], params["kappa"]]),
        np.array([params["init_std_m"], math.radians(params["init_std_deg"])]),
        np.array([params["jitter_m"], math.radians(params["jitter_deg"])]), model.init, state,
        out["pose"], out["ess"], out["resampled"], out["mh_accept"], *out["snapshots"])
    out["n"] = np.full(T, N)
    # the likelihood at the drawn particle, plus the UKF's sigma points, plus the MH proposals
    out["lik_evals_per_step"] = float(N * (1 + 13) + N * params["mh_steps"]
                                      * np.mean(out["resampled"]))
    return out


def sspf_field_keys() -> dict:
    upf = upf_keys("weight_change", 1)
    return {
        **{k: upf[k] for k in ("resampling", "resample", "neff_ratio", "sigma", "mh_steps")},
        **sigma_keys(),
        "init_std_m": Key("float", 1.0, "initial position standard deviation of every particle's "
                          "UKF (the particles start uniform over the field; our choice)", min=0.0,
                          min_exclusive=True),
        "init_std_deg": Key("float", 30.0, "initial heading standard deviation of every "
                            "particle's UKF (our choice)", min=0.0, min_exclusive=True),
        "jitter_m": Key("float", 0.05, "position noise added to the motion model's (the weight's "
                        "transition density needs it: odometry moves a pose along a surface)",
                        min=0.0, min_exclusive=True),
        "jitter_deg": Key("float", 1.0, "heading noise added likewise", min=0.0,
                          min_exclusive=True),
    }


SSPF_FIELD = FilterType(
    "sspf_field", "SSPF for localization (sspf2008): a UKF proposal per particle (pose and "
    "odometry noise), weight-change-triggered residual resampling, MH move; 'type: sspf' on a "
    "localization scenario", sspf_field_keys(), run, kind="localization", check=sigma_check,
    snapshots=True)
