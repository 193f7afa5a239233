"""SSPF for localization on the beacon field (sspf2008): an unscented particle filter whose
resampling is triggered by the weight change, followed by a Metropolis-Hastings move.

Each particle i carries a pose x_i and a covariance P_i (3 x 3). Per step an augmented UKF
(L = 6: the pose and the three odometry noises [rot1, trans, rot2]; scaled sigma points) run from
(x_i, P_i) with the step's odometry and observations gives N(m_i, Pn_i); the particle is drawn from
it, P_i becomes Pn_i, and the weight is multiplied by p(z | x) p(x | x_prev) / q(x | x_prev, z).
The measurement noise is additive, so it enters the UKF's innovation covariance directly (the same
as augmenting it). A field model with its own log-likelihood (``FieldModel.loglik``) weighs the
particles and the MH moves by it; the UKFs' proposals still take the sensor's Gaussian (sr, sb) as
the measurement's noise, a proposal that the weights correct.

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

A step whose log-weights are all -inf or NaN (observations no pose can have produced, such as a
range of 1e200: each UKF's proposal follows them there) ignores its observations: the particles
are drawn again from the transition density N(f(x_prev, u), G M G^T + J) that the weights use,
each UKF's covariance is its prediction (the update skipped), the weights stay those of the
previous step and there is no MH move (``prior_draws``). The step counts in ``underflow_steps``;
every other step is untouched.

The kernel (``sspf_field_kernel``) keeps the particles as rows (pose (3, N), each 3 x 3 matrix
nine rows) and runs their UKFs a chunk at a time: predict (``predict_moments``), update
(``sensor_update``: sigma observations, predicted observation, innovation covariances, Kalman gain,
mean, covariance), draw (``draw_particles``), weigh (``weights_and_change``), resample and move
(``copy_resampled``, ``mh_moves``). Their design and speed record: docs/internals/kernels.md.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..codes import (MOTION_ODOMETRY, SCHEME_CODES, SENSOR_RANGE_BEARING, TRIGGER_ALWAYS,
                     TRIGGER_NEFF, TRIGGER_WEIGHT_CHANGE, TRIGGERS)
from ..resampling import ess_threshold, resample
from ..rng import STATE, fill_normal, normal, uniform
from .. import vecmath as vm
from ..models.beacons import SCAN_MODEL, pose_loglik
from ..models.observations import OBSERVATIONS, observations
from ..models.odometry import MOTION_NOISE
from ..models.pose import (INITIAL_BELIEF, SNAPSHOTS, estimate_pose, init_particles, snapshot,
                           snapshot_arrays)
from ..schema import Key
from .keys import sigma_check, sigma_keys
from .types import FilterType
from .ukf import ut_weights
from .upf import upf_keys
from .weights import ess as ess_of, normalised

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]
LOG_2PI = math.log(2.0 * math.pi)


class SigmaParams(NamedTuple):
    """The unscented transform's parameters of every particle's UKF (keys alpha, beta, kappa)."""

    alpha: float
    beta: float
    kappa: float


class PoseStd(NamedTuple):
    """A pose's standard deviations: m along x and y, rad in the heading (the UKFs' initial
    covariance, keys init_std_m and init_std_deg; the jitter, jitter_m and jitter_deg)."""

    m: float
    rad: float


SIGMA_PARAMS = typeof(SigmaParams(1.0, 2.0, 0.0))
POSE_STD = typeof(PoseStd(1.0, 1.0))


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


@kernel(types.void(_F, types.int64, MOTION_NOISE, _F), cache=True)
def noise_sd(u, motion, mnoise, out):
    """Standard deviations of the three odometry noises at a step with odometry u."""
    if motion == MOTION_ODOMETRY:
        out[0], out[1], out[2] = 0.0, mnoise.trans, mnoise.turn
    else:
        a1, a2, a3, a4 = mnoise.alpha1, mnoise.alpha2, mnoise.alpha3, mnoise.alpha4
        out[0] = a1 * abs(u[0]) + a2 * abs(u[1])
        out[1] = a3 * abs(u[1]) + a4 * (abs(u[0]) + abs(u[2]))
        out[2] = a1 * abs(u[2]) + a2 * abs(u[1])


@kernel(types.void(types.float64, types.float64, types.float64, _F, _F, POSE_STD, _F2), cache=True)
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
    Q[0, 0] += jit.m * jit.m
    Q[1, 1] += jit.m * jit.m
    Q[2, 2] += jit.rad * jit.rad


class FieldOptions(NamedTuple):
    """The SSPF's settings, as the jitted steps read them.

    motion : the odometry noise model (codes.MOTION_*; mnoise, a ``MotionNoise``, its parameters)
    sensor : codes.SENSOR_RANGE or SENSOR_RANGE_BEARING; sr, sb their noise standard deviations
    N : particles; trigger : resample always (codes.TRIGGER_ALWAYS), when ESS < threshold
    (TRIGGER_NEFF), when the weight change K > threshold (TRIGGER_WEIGHT_CHANGE); scheme : the
    resampling code; mh_steps : MH moves per particle after it
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


@kernel(types.int64(_F2, types.int64, FIELD_OPTIONS, _F, _I), cache=True)
def observation_vector(zs, m, o, zobs, isb):
    """The step's m observations as one vector zobs (ranges, and bearings flagged in isb);
    returns its length."""
    r = 0
    for j in range(m):
        zobs[r] = zs[j, 0]
        isb[r] = 0
        r += 1
        if o.sensor == SENSOR_RANGE_BEARING:
            zobs[r] = zs[j, 1]
            isb[r] = 1
            r += 1
    return r


@kernel(types.UniTuple(types.float64, 3)(_F, _F, _F, types.float64), cache=True)
def weights_and_change(lw, W, Wprev, mx):
    """Normalised weights W from the log-weights lw (max mx; ``weights.normalised``); returns
    (1 when they underflowed, the ESS, the weight change K = sum W (W - Wprev)^2)."""
    under = normalised(lw, W, mx)
    S2 = 0.0
    Kc = 0.0
    for i in range(lw.size):
        S2 += W[i] * W[i]
        dw = W[i] - Wprev[i]
        Kc += W[i] * dw * dw
    return under, ess_of(1.0, S2), Kc     # 1 / S2 (normalised weights), exactly


@kernel(types.float64(types.float64, types.float64, types.float64, SCAN_MODEL, types.int64, _I,
                      _F2, FIELD_OPTIONS, _F2), cache=True)
def field_loglik(x, y, th, sm, m, ids, zs, o, one):
    """log p(z | pose) of the step's m observations (ids, zs) of the beacons sm.bc seen from
    (x, y, th): the model's own log-likelihood sm.loglik (``SCAN_LIK_SIG``) where sm.use,
    called on a set of one particle (one (4, 1): scratch), else the Gaussian sensor's
    ``pose_loglik``."""
    if sm.use:
        one[0, 0], one[1, 0], one[2, 0] = x, y, th
        sm.loglik(one[0], one[1], one[2], sm.bc, m, ids, zs, sm.theta, one[3])
        return one[3, 0]
    return pose_loglik(x, y, th, sm.bc, m, ids, zs, o.sensor, o.sr, o.sb)


SSPF_SIG = types.int64(
    _F2, OBSERVATIONS, SCAN_MODEL, _F, FIELD_OPTIONS, MOTION_NOISE, SIGMA_PARAMS, POSE_STD,
    POSE_STD, INITIAL_BELIEF, STATE, _F2, _F, _I, _F, SNAPSHOTS)


# --- the kernel, in rows -------------------------------------------------------------------------
# Every per-particle quantity is a row over the particles (a 3 x 3 matrix nine rows, entry (a, b)
# in row 3 a + b), and each step of the particles' UKFs is a loop over the particles of a chunk,
# which the compiler vectorises with vecmath's sine, cosine, arctangent and wrap. Each particle's
# arithmetic is that of a UKF run for it alone, operation for operation.

SSPF_CHUNK = 256        # particles per round of the UKF's passes (its work rows stay in cache)


class FieldRows(NamedTuple):
    """The particles as rows: pose X (3, N), covariance Pc (9, N); the proposal each was drawn
    from, mean mprop (3, N) and Cholesky factor Lprop (9, N); the transition density's mean fpre
    (3, N) and factor Lq (9, N); ltgt (N,) log p(z | x) + log p(x | x_prev) and lqs (N,) log q(x)
    at the particle; Ppred (9, N) the UKF's predicted covariance of the step (``prior_draws``)."""

    X: np.ndarray
    Pc: np.ndarray
    mprop: np.ndarray
    Lprop: np.ndarray
    fpre: np.ndarray
    Lq: np.ndarray
    ltgt: np.ndarray
    lqs: np.ndarray
    Ppred: np.ndarray


FIELD_ROWS = types.NamedTuple((_F2, _F2, _F2, _F2, _F2, _F2, _F, _F, _F2), FieldRows)


@kernel(FIELD_ROWS(types.int64), cache=True)
def new_rows(N):
    return FieldRows(np.empty((3, N)), np.zeros((9, N)), np.empty((3, N)), np.zeros((9, N)),
                     np.empty((3, N)), np.zeros((9, N)), np.empty(N), np.empty(N),
                     np.zeros((9, N)))


class ChunkWork(NamedTuple):
    """A chunk's UKF work rows (CH = SSPF_CHUNK columns): the sigma points through the motion Y
    (13 * 3, CH) and the sensor Z (13 * nzmax, CH); the predicted mean xm (3, CH), covariance
    Pm (9, CH), updated Pn (9, CH), a Cholesky factor L3 (9, CH); the sensor's mean zm
    (nzmax, CH), covariance S and its factor LS (nzmax^2, CH), cross-covariance C and gain K
    (3 nzmax, CH); scratch d (3 + nzmax, CH) and b (nzmax, CH); ok (CH,) flags."""

    Y: np.ndarray
    Z: np.ndarray
    xm: np.ndarray
    Pm: np.ndarray
    Pn: np.ndarray
    L3: np.ndarray
    zm: np.ndarray
    S: np.ndarray
    LS: np.ndarray
    C: np.ndarray
    K: np.ndarray
    d: np.ndarray
    b: np.ndarray
    ok: np.ndarray


CHUNK_WORK = types.NamedTuple((_F2,) * 13 + (types.boolean[::1],), ChunkWork)


@kernel(CHUNK_WORK(types.int64, types.int64), cache=True)
def new_chunk_work(CH, nzmax):
    nz = max(nzmax, 1)
    return ChunkWork(np.empty((39, CH)), np.empty((13 * nz, CH)), np.empty((3, CH)),
                     np.empty((9, CH)), np.empty((9, CH)), np.zeros((9, CH)), np.empty((nz, CH)),
                     np.empty((nz * nz, CH)), np.zeros((nz * nz, CH)), np.empty((3 * nz, CH)),
                     np.empty((3 * nz, CH)), np.empty((3 + nz, CH)), np.empty((nz, CH)),
                     np.empty(CH, dtype=np.bool_))


@kernel(types.void(_F2, types.int64, types.int64, _F2, types.boolean[::1]), cache=True,
        inline="always", error_model="numpy")
def chol_rows(A, n, c, L, ok):
    """chol (above) of the n x n matrices A[n i + j, p] (rows), p < c, into L (rows of n x n,
    the upper triangle zero); ok[p]: positive definite. Where it is not, L holds what the
    arithmetic gave (NaN from the square root of a negative number), not chol's partial
    factor."""
    for p in range(c):
        ok[p] = True
    for j in range(n):
        for p in range(c):
            d = A[n * j + j, p]
            for k in range(j):
                d -= L[n * j + k, p] * L[n * j + k, p]
            ok[p] = ok[p] and d > 0.0
            L[n * j + j, p] = math.sqrt(d)
        for i in range(j + 1, n):
            for p in range(c):
                v = A[n * i + j, p]
                for k in range(j):
                    v -= L[n * i + k, p] * L[n * j + k, p]
                L[n * i + j, p] = v / L[n * j + j, p]
        for i in range(j):
            for p in range(c):
                L[n * i + j, p] = 0.0


@kernel(types.void(FIELD_ROWS, types.int64, types.int64, _F, types.float64, _F, POSE_STD,
                   CHUNK_WORK, _F, _F), cache=True, error_model="numpy")
def predict_moments(pr, i0, c, u, sq, sd, jit, wk, Wm, Wc):
    """For the particles i0 .. i0 + c (pose pr.X, covariance pr.Pc; where it is not positive
    definite, the jitter's): the sigma points of [pose, odometry noise] (the noises' deviations
    sd; scaled by sq, weights Wm, Wc) through the motion u into wk.Y, their mean wk.xm
    (circular for the heading) and covariance wk.Pm (plus the jitter jit, a ``PoseStd``)."""
    X, L3, Y, ok = pr.X, wk.L3, wk.Y, wk.ok
    # Pc's rows are columns i0 .. i0 + c of the particles' rows: copy them into Pm as scratch
    for a in range(9):
        for p in range(c):
            wk.Pm[a, p] = pr.Pc[a, i0 + p]
    chol_rows(wk.Pm, 3, c, L3, ok)
    for p in range(c):
        if not ok[p]:
            for a in range(9):
                L3[a, p] = 0.0
            L3[0, p] = L3[4, p] = jit.m
            L3[8, p] = jit.rad
    for j in range(13):
        k = (j - 1) % 6 if j > 0 else -1
        sgn = 1.0 if j <= 6 else -1.0
        for p in range(c):
            i = i0 + p
            px, py, pt = X[0, i], X[1, i], X[2, i]
            w0 = w1 = w2 = 0.0
            if 0 <= k < 3:
                px += sgn * sq * L3[k, p]
                py += sgn * sq * L3[3 + k, p]
                pt += sgn * sq * L3[6 + k, p]
            elif k == 3:
                w0 = sgn * sq * sd[0]
            elif k == 4:
                w1 = sgn * sq * sd[1]
            elif k == 5:
                w2 = sgn * sq * sd[2]
            t1 = pt + u[0] + w0
            st, ct = vm.sincos(t1)
            Y[3 * j, p] = px + (u[1] + w1) * ct
            Y[3 * j + 1, p] = py + (u[1] + w1) * st
            Y[3 * j + 2, p] = vm.wrap(t1 + u[2] + w2)
    xm, Pm, d = wk.xm, wk.Pm, wk.d
    for p in range(c):
        xm[0, p] = 0.0
        xm[1, p] = 0.0
        d[0, p] = 0.0           # dt
    for j in range(13):
        for p in range(c):
            xm[0, p] += Wm[j] * Y[3 * j, p]
            xm[1, p] += Wm[j] * Y[3 * j + 1, p]
            d[0, p] += Wm[j] * vm.wrap(Y[3 * j + 2, p] - Y[2, p])
    for p in range(c):
        xm[2, p] = vm.wrap(Y[2, p] + d[0, p])
    for a in range(9):
        for p in range(c):
            Pm[a, p] = 0.0
    for j in range(13):
        for p in range(c):
            d0 = Y[3 * j, p] - xm[0, p]
            d1 = Y[3 * j + 1, p] - xm[1, p]
            d2 = vm.wrap(Y[3 * j + 2, p] - xm[2, p])
            Pm[0, p] += Wc[j] * d0 * d0
            Pm[1, p] += Wc[j] * d0 * d1
            Pm[2, p] += Wc[j] * d0 * d2
            Pm[3, p] += Wc[j] * d1 * d0
            Pm[4, p] += Wc[j] * d1 * d1
            Pm[5, p] += Wc[j] * d1 * d2
            Pm[6, p] += Wc[j] * d2 * d0
            Pm[7, p] += Wc[j] * d2 * d1
            Pm[8, p] += Wc[j] * d2 * d2
    for p in range(c):
        Pm[0, p] += jit.m * jit.m
        Pm[4, p] += jit.m * jit.m
        Pm[8, p] += jit.rad * jit.rad


@kernel(types.void(_F2, _I, _F2, types.int64, types.int64, FIELD_OPTIONS, _F, _I, CHUNK_WORK, _F,
                   _F, types.int64), cache=True, error_model="numpy")
def sensor_update(bc, ids, zs, m, nz, o, zobs, isb, wk, Wm, Wc, c):
    """For a chunk's c particles, after predict_moments: the UKF's measurement update of wk.xm
    and wk.Pn (from wk.Pm) by the step's observations zobs (nz,) (bearings flagged in isb);
    both stay predicted where the innovation covariance is not positive definite."""
    sigma_observations(bc, ids, m, nz, o, wk, c)
    predicted_observation(nz, isb, wk, Wm, c)
    innovation_covariances(nz, o, isb, wk, Wc, c)
    kalman_gain(nz, wk, c)
    update_mean(nz, zobs, isb, wk, c)
    update_covariance(nz, wk, c)


_UPDATE_PASS = dict(cache=True, error_model="numpy")


@kernel(types.void(_F2, _I, types.int64, types.int64, FIELD_OPTIONS, CHUNK_WORK, types.int64),
        **_UPDATE_PASS)
def sigma_observations(bc, ids, m, nz, o, wk, c):
    """The 13 sigma points wk.Y (rows 3 j .. 3 j + 2) through the sensor of the step's m
    observations (beacons bc[ids]): row nz j + r of wk.Z the r-th measurement component (a
    range, then a bearing with o.sensor 1) of sigma point j."""
    Y, Z = wk.Y, wk.Z
    for j in range(13):
        r = 0
        for q in range(m):
            bx, by = bc[ids[q], 0], bc[ids[q], 1]
            for p in range(c):
                dx = bx - Y[3 * j, p]
                dy = by - Y[3 * j + 1, p]
                Z[nz * j + r, p] = math.sqrt(dx * dx + dy * dy)
            r += 1
            if o.sensor == SENSOR_RANGE_BEARING:
                for p in range(c):
                    dx = bx - Y[3 * j, p]
                    dy = by - Y[3 * j + 1, p]
                    Z[nz * j + r, p] = vm.wrap(vm.atan2(dy, dx) - Y[3 * j + 2, p])
                r += 1


@kernel(types.void(types.int64, _I, CHUNK_WORK, _F, types.int64), **_UPDATE_PASS)
def predicted_observation(nz, isb, wk, Wm, c):
    """The predicted measurement wk.zm (nz, c): the sigma observations' mean with weights Wm
    (a bearing's as sigma point 0's plus the weighted mean of the wrapped differences)."""
    Z, zm = wk.Z, wk.zm
    for r in range(nz):
        for p in range(c):
            zm[r, p] = 0.0
        for j in range(13):
            if isb[r]:
                for p in range(c):
                    zm[r, p] += Wm[j] * vm.wrap(Z[nz * j + r, p] - Z[r, p])
            else:
                for p in range(c):
                    zm[r, p] += Wm[j] * Z[nz * j + r, p]
        if isb[r]:
            for p in range(c):
                zm[r, p] = vm.wrap(Z[r, p] + zm[r, p])


@kernel(types.void(types.int64, FIELD_OPTIONS, _I, CHUNK_WORK, _F, types.int64), **_UPDATE_PASS)
def innovation_covariances(nz, o, isb, wk, Wc, c):
    """The innovation covariance wk.S (nz x nz rows, the sensor noise on its diagonal) and the
    cross-covariance wk.C of pose and measurement (row nz b + a: pose b, component a), with
    weights Wc over the sigma points (wk.d their deviations: pose, then measurement)."""
    Y, Z, zm, S, C, d, xm = wk.Y, wk.Z, wk.zm, wk.S, wk.C, wk.d, wk.xm
    for a in range(nz):
        for b in range(nz):
            v = (o.sb * o.sb if isb[a] else o.sr * o.sr) if a == b else 0.0
            for p in range(c):
                S[nz * a + b, p] = v
        for b in range(3):
            for p in range(c):
                C[nz * b + a, p] = 0.0
    for j in range(13):
        for p in range(c):
            d[0, p] = Y[3 * j, p] - xm[0, p]
            d[1, p] = Y[3 * j + 1, p] - xm[1, p]
            d[2, p] = vm.wrap(Y[3 * j + 2, p] - xm[2, p])
        for a in range(nz):
            if isb[a]:
                for p in range(c):
                    d[3 + a, p] = vm.wrap(Z[nz * j + a, p] - zm[a, p])
            else:
                for p in range(c):
                    d[3 + a, p] = Z[nz * j + a, p] - zm[a, p]
        for a in range(nz):
            for b in range(nz):
                for p in range(c):
                    S[nz * a + b, p] += Wc[j] * d[3 + a, p] * d[3 + b, p]
            for b in range(3):
                for p in range(c):
                    C[nz * b + a, p] += Wc[j] * d[b, p] * d[3 + a, p]


@kernel(types.void(types.int64, CHUNK_WORK, types.int64), **_UPDATE_PASS)
def kalman_gain(nz, wk, c):
    """The gain wk.K = C S^-1 (row nz b + a), row by row: S's Cholesky factor wk.LS (wk.ok: S
    positive definite) and chol_solve's two substitutions in wk.b."""
    S, C, K, ok, LS, rb = wk.S, wk.C, wk.K, wk.ok, wk.LS, wk.b
    chol_rows(S, nz, c, LS, ok)
    for b in range(3):
        for a in range(nz):
            for p in range(c):
                rb[a, p] = C[nz * b + a, p]
        for i in range(nz):
            for p in range(c):
                v = rb[i, p]
                for k in range(i):
                    v -= LS[nz * i + k, p] * rb[k, p]
                rb[i, p] = v / LS[nz * i + i, p]
        for i in range(nz - 1, -1, -1):
            for p in range(c):
                v = rb[i, p]
                for k in range(i + 1, nz):
                    v -= LS[nz * k + i, p] * rb[k, p]
                rb[i, p] = v / LS[nz * i + i, p]
        for a in range(nz):
            for p in range(c):
                K[nz * b + a, p] = rb[a, p]


@kernel(types.void(types.int64, _F, _I, CHUNK_WORK, types.int64), **_UPDATE_PASS)
def update_mean(nz, zobs, isb, wk, c):
    """xm += K (z - zm) (bearing innovations wrapped, the heading wrapped) where wk.ok; the new
    mean goes through wk.d."""
    zm, K, d, xm, ok = wk.zm, wk.K, wk.d, wk.xm, wk.ok
    for b in range(3):
        for p in range(c):
            v = 0.0
            for a in range(nz):
                inn = zobs[a] - zm[a, p]
                if isb[a]:
                    inn = vm.wrap(inn)
                v += K[nz * b + a, p] * inn
            d[b, p] = xm[b, p] + v
    for p in range(c):
        if ok[p]:
            xm[0, p] = d[0, p]
            xm[1, p] = d[1, p]
            xm[2, p] = vm.wrap(d[2, p])


@kernel(types.void(types.int64, CHUNK_WORK, types.int64), **_UPDATE_PASS)
def update_covariance(nz, wk, c):
    """wk.Pn = Pm - K C^T, symmetrised, where wk.ok; Pm elsewhere."""
    C, K, ok, Pm, Pn = wk.C, wk.K, wk.ok, wk.Pm, wk.Pn
    for a in range(3):
        for b in range(3):
            for p in range(c):
                v = 0.0
                for q in range(nz):
                    v += K[nz * a + q, p] * C[nz * b + q, p]
                Pn[3 * a + b, p] = Pm[3 * a + b, p] - v if ok[p] else Pm[3 * a + b, p]
    for a in range(3):
        for b in range(a):
            for p in range(c):
                if ok[p]:
                    v = 0.5 * (Pn[3 * a + b, p] + Pn[3 * b + a, p])
                    Pn[3 * a + b, p] = v
                    Pn[3 * b + a, p] = v


@kernel(types.float64(FIELD_ROWS, types.int64, types.int64, _F, SCAN_MODEL, _I, _F2, types.int64,
                      FIELD_OPTIONS, _F2, CHUNK_WORK, _F, POSE_STD, _F, _F, _F, _F3), cache=True,
        error_model="numpy")
def draw_particles(pr, i0, c, u, sm, ids, zs, m, o, one, wk, sd, jit, z, lw, xm, T3):
    """For a chunk's c particles, one at a time (each particle's factor, densities and
    transition are a few scalar steps): particle i0 + p is drawn from N(wk.xm, wk.Pn) (where Pn
    is numerically indefinite, the predicted wk.Pm) with
    the normal draws z[3 i: 3 i + 3], its proposal kept with it, and lw[i] += log p(z | x) +
    log p(x | x_prev) - log q(x) (p(z | x): ``field_loglik``). xm (3,), T3 (5, 3, 3), one (4, 1):
    scratch. Returns the largest lw."""
    Pn, Pm, L3, Q, Lt = T3[0], T3[1], T3[2], T3[3], T3[4]
    X = pr.X
    mx = -np.inf
    for p in range(c):
        i = i0 + p
        for a in range(3):
            xm[a] = wk.xm[a, p]
            for b in range(3):
                Pn[a, b] = wk.Pn[3 * a + b, p]
                Pm[a, b] = wk.Pm[3 * a + b, p]
        if not chol(Pn, 3, L3):     # numerically indefinite: keep the predicted covariance
            Pn[:, :] = Pm
            chol(Pn, 3, L3)
        n0, n1, n2 = z[3 * i], z[3 * i + 1], z[3 * i + 2]
        nx = xm[0] + L3[0, 0] * n0
        ny = xm[1] + L3[1, 0] * n0 + L3[1, 1] * n1
        nt = wrap(xm[2] + L3[2, 0] * n0 + L3[2, 1] * n1 + L3[2, 2] * n2)
        lq = lognormal3(nx - xm[0], ny - xm[1], wrap(nt - xm[2]), L3)
        fx, fy, ft = move(X[0, i], X[1, i], X[2, i], u, 0.0, 0.0, 0.0)
        transition_cov(X[0, i], X[1, i], X[2, i], u, sd, jit, Q)
        chol(Q, 3, Lt)
        lp = lognormal3(nx - fx, ny - fy, wrap(nt - ft), Lt)
        ll = field_loglik(nx, ny, nt, sm, m, ids, zs, o, one)
        X[0, i], X[1, i], X[2, i] = nx, ny, nt
        for a in range(3):
            pr.mprop[a, i] = xm[a]
            for b in range(3):
                pr.Pc[3 * a + b, i] = Pn[a, b]
                pr.Ppred[3 * a + b, i] = Pm[a, b]
                pr.Lprop[3 * a + b, i] = L3[a, b]
                pr.Lq[3 * a + b, i] = Lt[a, b]
        pr.fpre[0, i], pr.fpre[1, i], pr.fpre[2, i] = fx, fy, ft
        pr.ltgt[i] = ll + lp
        pr.lqs[i] = lq
        lw[i] += ll + lp - lq
        if lw[i] > mx:
            mx = lw[i]
    return mx


@kernel(types.void(FIELD_ROWS, FIELD_ROWS, _I), cache=True, error_model="numpy")
def copy_resampled(pr, out, idx):
    """out's columns i = pr's columns idx[i], every row."""
    for src, dst in ((pr.X, out.X), (pr.mprop, out.mprop), (pr.fpre, out.fpre)):
        for a in range(3):
            for i in range(idx.size):
                dst[a, i] = src[a, idx[i]]
    for src, dst in ((pr.Pc, out.Pc), (pr.Lprop, out.Lprop), (pr.Lq, out.Lq)):
        for a in range(9):
            for i in range(idx.size):
                dst[a, i] = src[a, idx[i]]
    for i in range(idx.size):
        out.ltgt[i] = pr.ltgt[idx[i]]
        out.lqs[i] = pr.lqs[idx[i]]


@kernel(types.float64(FIELD_ROWS, _F, STATE, _F, _F), cache=True, error_model="numpy")
def prior_draws(pr, Wprev, s, z, lw):
    """A step that ignores its observations (every log-weight -inf or NaN): each particle drawn
    again, with new normal draws z (3 N,), from the transition density N(pr.fpre, Lq Lq^T) its
    weight uses (from the previous pose), its covariance pr.Pc its UKF's prediction pr.Ppred, lw
    the log of the previous step's normalised weights Wprev. Returns the largest log-weight."""
    fill_normal(s, z)
    X, F, L = pr.X, pr.fpre, pr.Lq
    mx = -np.inf
    for i in range(X.shape[1]):
        n0, n1, n2 = z[3 * i], z[3 * i + 1], z[3 * i + 2]
        X[0, i] = F[0, i] + L[0, i] * n0
        X[1, i] = F[1, i] + L[3, i] * n0 + L[4, i] * n1
        X[2, i] = wrap(F[2, i] + L[6, i] * n0 + L[7, i] * n1 + L[8, i] * n2)
        for a in range(9):
            pr.Pc[a, i] = pr.Ppred[a, i]
        lw[i] = math.log(Wprev[i]) if Wprev[i] > 0.0 else -np.inf
        if lw[i] > mx:
            mx = lw[i]
    return mx


@kernel(types.int64(FIELD_ROWS, SCAN_MODEL, _I, _F2, types.int64, FIELD_OPTIONS, _F2, STATE, _F3),
        cache=True)
def mh_moves(pr, sm, ids, zs, m, o, one, s, T3):
    """o.mh_steps independence Metropolis-Hastings moves per particle with its ancestor's
    proposal (T3 (5, 3, 3): scratch); returns the moves accepted."""
    acc = 0
    X, mprop, fpre = pr.X, pr.mprop, pr.fpre
    Lp, Lq = T3[0], T3[1]
    for i in range(X.shape[1]):
        for a in range(3):
            for b in range(3):
                Lp[a, b] = pr.Lprop[3 * a + b, i]
                Lq[a, b] = pr.Lq[3 * a + b, i]
        for _ in range(o.mh_steps):
            n0, n1, n2 = normal(s), normal(s), normal(s)
            nx = mprop[0, i] + Lp[0, 0] * n0
            ny = mprop[1, i] + Lp[1, 0] * n0 + Lp[1, 1] * n1
            nt = wrap(mprop[2, i] + Lp[2, 0] * n0 + Lp[2, 1] * n1 + Lp[2, 2] * n2)
            lq = lognormal3(nx - mprop[0, i], ny - mprop[1, i], wrap(nt - mprop[2, i]), Lp)
            lt = (field_loglik(nx, ny, nt, sm, m, ids, zs, o, one)
                  + lognormal3(nx - fpre[0, i], ny - fpre[1, i], wrap(nt - fpre[2, i]), Lq))
            la = (lt - lq) - (pr.ltgt[i] - pr.lqs[i])
            if la >= 0.0 or uniform(s) < math.exp(la):
                X[0, i], X[1, i], X[2, i] = nx, ny, nt
                pr.ltgt[i] = lt
                pr.lqs[i] = lq
                acc += 1
    return acc


@kernel(types.float64(FIELD_ROWS, _F, SCAN_MODEL, _I, _F2, types.int64, types.int64,
                      FIELD_OPTIONS, _F2, _F, _I, CHUNK_WORK, _F, _F, types.float64, _F, POSE_STD,
                      _F, _F, _F, _F3), cache=True, error_model="numpy")
def propose_and_draw(pr, u, sm, ids, zs, m, nz, o, one, zobs, isb, wk, Wm, Wc, sq, sd, jit, z, lw,
                     xm3, T3):
    """Every particle's UKF proposal for the step (odometry u, the m observations as zobs (nz,)),
    a chunk of wk's columns at a time: predict (``predict_moments``), update
    (``sensor_update``; without observations the prediction), then the draws from them and their
    log-weights lw (``draw_particles``, from the normal draws z). Returns the largest
    log-weight."""
    N, CH = pr.X.shape[1], wk.ok.size
    mx = -np.inf
    for i0 in range(0, N, CH):
        c = min(CH, N - i0)
        predict_moments(pr, i0, c, u, sq, sd, jit, wk, Wm, Wc)
        if nz > 0:
            sensor_update(sm.bc, ids, zs, m, nz, o, zobs, isb, wk, Wm, Wc, c)
        else:
            wk.Pn[:, :c] = wk.Pm[:, :c]
        mx = max(mx, draw_particles(pr, i0, c, u, sm, ids, zs, m, o, one, wk, sd, jit, z, lw, xm3,
                                    T3))
    return mx


@kernel(types.boolean(FIELD_OPTIONS, types.float64, types.float64), cache=True)
def resample_due(o, ess, Kc):
    """Whether the step resamples (o.trigger, ``TRIGGERS``): every step, the ESS below
    o.threshold, or sspf2008's weight change K above it."""
    return (o.trigger == TRIGGER_ALWAYS or (o.trigger == TRIGGER_NEFF and ess < o.threshold)
            or (o.trigger == TRIGGER_WEIGHT_CHANGE and Kc > o.threshold))


@kernel(SSPF_SIG, cache=True, error_model="numpy")
def sspf_field_kernel(ctrl, obs, sm, area, o, mnoise, up, init, jit, start, s, est, ess, resampled,
                      accepted, snap):
    """Run the SSPF over one trial (settings o, see ``FieldOptions``). up: the sigma points'
    parameters (``SigmaParams``); init: the UKFs' initial standard deviations, jit: the jitter
    (``PoseStd``); obs: the observations (``Observations``); start: the initial belief
    (``InitialBelief``); sm: the beacons sm.bc and the model's own log-likelihood, which weighs
    the particles where sm.use (``ScanModel``, ``FieldModel.scan_model``). Fills est (T+1, 3), ess / resampled / accepted (MH acceptance rate, NaN
    without a move) (T,); snapshots as mcl_kernel's. Returns the steps
    whose weights all underflowed, which ignore their observations (``prior_draws``). The particles' UKFs run in passes over chunks of SSPF_CHUNK
    particles (see the section's comment)."""
    T, N = ctrl.shape[0], o.N
    nzmax = 2 * sm.bc.shape[0]
    Wm, Wc = np.empty(13), np.empty(13)
    sq = ut_weights(6, up.alpha, up.beta, up.kappa, Wm, Wc)
    CH = min(SSPF_CHUNK, N)
    wk = new_chunk_work(CH, nzmax)
    zobs, isb, sd = np.empty(nzmax), np.zeros(nzmax, dtype=np.int64), np.empty(3)
    pr, spare = new_rows(N), new_rows(N)
    P0 = np.empty((N, 3))
    init_particles(P0, area, start, s)
    for i in range(N):
        pr.X[0, i], pr.X[1, i], pr.X[2, i] = P0[i, 0], P0[i, 1], P0[i, 2]
        pr.Pc[0, i] = init.m * init.m
        pr.Pc[4, i] = init.m * init.m
        pr.Pc[8, i] = init.rad * init.rad
    lw = np.zeros(N)
    W = np.full(N, 1.0 / N)
    Wprev = np.full(N, 1.0 / N)
    idx = np.empty(N, dtype=np.int64)
    z = np.empty(3 * N)
    xm3 = np.empty(3)
    T3 = np.zeros((5, 3, 3))
    one = np.zeros((4, 1))
    events = 0
    estimate_pose(pr.X, W, N, est[0], True)
    si = snapshot(0, pr.X, N, snap, 0, True)
    for t in range(T):
        u, m, ids, zs = ctrl[t], obs.n[t], obs.ids[t], obs.z[t]
        noise_sd(u, o.motion, mnoise, sd)
        nz = observation_vector(zs, m, o, zobs, isb)
        fill_normal(s, z)      # the draws of the particles' proposals, in particle order
        mx = propose_and_draw(pr, u, sm, ids, zs, m, nz, o, one, zobs, isb, wk, Wm, Wc, sq, sd, jit,
                              z, lw, xm3, T3)
        skip = not np.isfinite(mx)          # the observations are ignored
        if skip:
            mx = prior_draws(pr, Wprev, s, z, lw)
            events += 1
        _, ess[t], Kc = weights_and_change(lw, W, Wprev, mx)
        estimate_pose(pr.X, W, N, est[t + 1], True)
        si = snapshot(t + 1, pr.X, N, snap, si, True)
        accepted[t] = np.nan
        resampled[t] = 0
        if not resample_due(o, ess[t], Kc):
            Wprev[:] = W
            continue
        resample(o.scheme, W, 1.0, s, idx)
        copy_resampled(pr, spare, idx)
        pr, spare = spare, pr
        lw[:] = 0.0
        W[:] = 1.0 / N
        Wprev[:] = W
        resampled[t] = 1
        if skip:
            continue
        acc = mh_moves(pr, sm, ids, zs, m, o, one, s, T3)
        if o.mh_steps > 0:
            accepted[t] = acc / (N * o.mh_steps)
    return events


def sspf_params(params) -> tuple[SigmaParams, PoseStd, PoseStd]:
    """The SSPF's parameter records from a filter run's keys: the sigma points', the UKFs'
    initial standard deviations, the jitter."""
    return (SigmaParams(float(params["alpha"]), float(params["beta"]), float(params["kappa"])),
            PoseStd(float(params["init_std_m"]), float(math.radians(params["init_std_deg"]))),
            PoseStd(float(params["jitter_m"]), float(math.radians(params["jitter_deg"]))))


def run(model, data, params, particles, state, diag=True, snapshots=()):
    """Run the SSPF on a beacon-field trial; return the traces (snapshots as mcl.run's)."""
    T = data.ctrl.shape[0]
    N = particles
    trig = TRIGGERS[params["resample"]]
    threshold = {TRIGGER_ALWAYS: 0.0, TRIGGER_NEFF: ess_threshold(params, N),
                 TRIGGER_WEIGHT_CHANGE: params["sigma"] / (N * N)}[trig]
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(T),
           "resampled": np.zeros(T, dtype=np.int64), "mh_accept": np.empty(T),
           "snapshots": snapshot_arrays(snapshots, N)}
    o = FieldOptions(
        motion=int(model.motion), sensor=int(model.sensor), sr=model.sense.sr,
        sb=model.sense.sb, N=int(N), trigger=int(trig), threshold=float(threshold),
        scheme=SCHEME_CODES[params["resampling"]], mh_steps=int(params["mh_steps"]))
    out["underflow_steps"] = sspf_field_kernel(
        data.ctrl, observations(data), model.scan_model(), model.area, o,
        model.mnoise, *sspf_params(params), model.init, state,
        out["pose"], out["ess"], out["resampled"], out["mh_accept"], out["snapshots"])
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
    snapshots=True, needs=())
