"""Mixture MCL on the beacon field (Thrun, Fox, Burgard and Dellaert 2001, "Robust Monte Carlo
localization for mobile robots", Artificial Intelligence 128; the review2007 MCL family): a
mixture of regular MCL and dual MCL.

Each step the resampled set moves by the odometry (MCL's move, the same draws), a sample of the
predicted belief bel_(x). Then each particle is, with probability ``phi``, replaced by a dual
sample: a pose drawn from the measurement (one of the step's observations chosen at random, its
range circle around the beacon, the heading by its bearing or uniform: MCL's draw from the sensor
model for SRL and augmented MCL, ``sensor_pose``), weighed by the predicted belief at that pose,
estimated from the moved particles (``density``). The others are MCL's samples, weighed by the
likelihood p(z | x). The estimate is the weighted mean (circular heading) of the mixed set, which
is resampled every step. A step without observations draws no dual sample.

Choices, each a key:
- ``phi``, the mixing ratio: 0.1, the small ratio the paper recommends (our reading);
- ``density``: the paper estimates bel_(x) with a kd-tree over the predicted particles; 'kde'
  (ours) is a Gaussian kernel of standard deviations ``bandwidth_m`` (x, y) and ``bandwidth_deg``
  (heading, wrapped), log-sum-exp'd so that a pose far from every particle still has a finite,
  ordered weight; 'histogram' a piecewise-constant density over regular cells of ``bandwidth_m``
  x ``bandwidth_m`` x ``bandwidth_deg`` (a kd-tree's leaves made regular; an empty cell weighs
  zero);
- ``dual_weight``: 'belief', w = bel_(x), the paper's (its dual proposal samples in proportion
  to p(z | x)); 'importance', w = bel_(x) p(z | x) / q(x | z), q the density of pfbench's draw
  (the mixture over the step's observations of p(r) / (2 pi r) in position, r the range to the
  beacon, times the bearing's Gaussian or 1 / (2 pi) in heading): the importance weight of the
  target p(z | x) bel_(x) under the draw, which takes the observations not drawn from and the
  draw's 1 / r crowding near the beacon into account;
- ``combine``, left open by the paper: 'separate' (ours) normalises each set to its share of the
  particles (the dual set's weights sum to k / (N - k) times the MCL set's, k dual samples), so
  that weights in units of a density and of a likelihood never meet; 'joint' keeps them as they
  are, valid with ``dual_weight: importance`` only (then both are importance weights of one
  target).
MCL's set whose weights all underflow (log-weights -inf or NaN) weighs its particles equally
and counts in ``underflow_steps`` (MCL's rule); a dual set whose every pose has zero density (a
histogram's empty cells) weighs zero. With ``phi: 0`` no draw decides a particle's kind and
the filter is MCL (reset none, resample always) draw for draw.

The kernel (``mixture_kernel``) runs each step as named steps: move (``move_particles``), draw
the dual samples (``dual_draws``), weigh them by the predicted belief (``kde_logdensity`` or
``histogram_logdensity``, then ``importance_correction``), weigh the set (``mixture_weights``),
estimate (``weighted_sums``), resample (``ancestors``, ``gather_rows``): MCL's steps where they are
the same.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..codes import (COMBINE_JOINT, COMBINES, DENSITIES, DENSITY_KDE, DUAL_IMPORTANCE,
                     DUAL_WEIGHTS, RESET_NONE, SCHEME_CODES, SENSOR_RANGE_BEARING)
from ..resampling import SCHEMES
from ..rng import STATE, fill_normal, uniform
from ..models.beacons import SCAN_MODEL, pose_loglik, sensor_pose
from ..models.observations import OBSERVATIONS, observations
from ..models.odometry import MOTION_NOISE
from ..models.pose import INITIAL_BELIEF, SNAPSHOTS, snapshot, snapshot_arrays
from ..schema import Key
from .mcl import (KldParams, MCL_OPTIONS, MclOptions, ancestors, gather_rows, initial_set,
                  mean_likelihood, move_particles, new_mcl_work, particle_logliks, trig_pass,
                  weighted_sums)
from .types import FilterType
from .weights import exp_pass, exp_sum

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_I = types.int64[::1]
_U8 = types.uint8[::1]
LOG_2PI = math.log(2.0 * math.pi)
HIST_MAX_CELLS = 2**17      # cells along x or y of the histogram, at most (its keys stay exact)


class MixtureParams(NamedTuple):
    """Mixture MCL's parameters: the mixing ratio phi, the density estimate (codes.DENSITIES)
    with its bandwidths bw_m (m) and bw_rad (rad), how dual samples are weighed
    (codes.DUAL_WEIGHTS) and how the two sets are combined (codes.COMBINES)."""

    phi: float
    density: int
    bw_m: float
    bw_rad: float
    dual_weight: int
    combine: int


MIXTURE_PARAMS = typeof(MixtureParams(0.1, 0, 1.0, 1.0, 0, 0))
KLD_NONE = KldParams(1.0, 1.0, 1.0, 1.0, 1.0)      # MCL's scratch without KLD-sampling's histogram


class DualWork(NamedTuple):
    """The dual samples' scratch for a set of N particles.

    dual (N,) : 1 where particle i is a dual sample; didx (N,) : their indices, in order
    dobs (N,) : the observation each was drawn from; D (3, N) : their poses (rows x, y, heading)
    logd (N,) : their log-weights; E (max(N, B),) : a pass's scratch
    keys (N,) : the histogram's sorted cell keys of the predicted set
    ids1 (1,), zs1 (1, 2), pose (3,) : one observation, one pose
    """

    dual: np.ndarray
    didx: np.ndarray
    dobs: np.ndarray
    D: np.ndarray
    logd: np.ndarray
    E: np.ndarray
    keys: np.ndarray
    ids1: np.ndarray
    zs1: np.ndarray
    pose: np.ndarray


DUAL_WORK = types.NamedTuple((_U8, _I, _I, _F2, _F, _F, _F, _I, _F2, _F), DualWork)


@kernel(DUAL_WORK(types.int64, types.int64), cache=True)
def new_dual_work(N, B):
    """The scratch (``DualWork``) of a set of N particles on a field of B beacons."""
    return DualWork(np.zeros(N, dtype=np.uint8), np.empty(N, dtype=np.int64),
                    np.empty(N, dtype=np.int64), np.empty((3, N)), np.empty(N),
                    np.empty(max(N, B)),
                    np.empty(N), np.empty(1, dtype=np.int64), np.empty((1, 2)), np.empty(3))


@kernel(types.int64(types.int64, _F, _F2, types.int64, _I, _F2, MCL_OPTIONS, types.float64,
                    DUAL_WORK, STATE), cache=True, error_model="numpy")
def dual_draws(N, area, bc, m, ids, zs, o, phi, dw, s):
    """Choose the dual samples (each of the N particles with probability phi, a uniform draw
    each, in order) and draw their poses from the sensor model of the step's m observations
    (ids, zs): for each, one observation chosen uniformly (its index into dw.dobs), then
    ``sensor_pose`` of that observation alone, into dw.D[:, r]. Returns their count k
    (dw.didx[:k] their indices, dw.dual their mask)."""
    k = 0
    for i in range(N):
        if uniform(s) < phi:
            dw.dual[i] = 1
            dw.didx[k] = i
            k += 1
        else:
            dw.dual[i] = 0
    for r in range(k):
        j = min(int(uniform(s) * m), m - 1)
        dw.dobs[r] = j
        dw.ids1[0] = ids[j]
        dw.zs1[0, 0], dw.zs1[0, 1] = zs[j, 0], zs[j, 1]
        sensor_pose(area, o.sensor, bc, 1, dw.ids1, dw.zs1, o.sr, o.sb, dw.pose, s)
        dw.D[0, r], dw.D[1, r], dw.D[2, r] = dw.pose[0], dw.pose[1], dw.pose[2]
    return k


@kernel(types.void(_F2, types.int64, _F2, types.int64, types.float64, types.float64, _F, _F),
        cache=True, error_model="numpy")
def kde_logdensity(P, N, D, k, bw_m, bw_rad, E, out):
    """out[r] = log of the Gaussian kernel density of the N particles P (rows x, y, heading) at
    the pose D[:, r], r < k: log (1/N) sum_i N(x - x_i; 0, bw_m^2 I) N(wrap(th - th_i); 0,
    bw_rad^2) (m^-2 rad^-1), by log-sum-exp over the particles (E (N,) scratch): finite however
    far the pose is from every particle."""
    cst = -math.log(N) - LOG_2PI - 2.0 * math.log(bw_m) - 0.5 * LOG_2PI - math.log(bw_rad)
    am, ar = 0.5 / (bw_m * bw_m), 0.5 / (bw_rad * bw_rad)
    for r in range(k):
        x, y, th = D[0, r], D[1, r], D[2, r]
        mx = -np.inf
        for i in range(N):
            dx, dy, dh = x - P[0, i], y - P[1, i], wrap(th - P[2, i])
            e = -am * (dx * dx + dy * dy) - ar * dh * dh
            E[i] = e
            mx = max(mx, e)
        out[r] = mx + math.log(exp_sum(E, mx, N, E)) + cst


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64,
                      types.float64), cache=True, inline="always")
def cell_key(x, y, th, bw_m, bw_rad, ncell):
    """The histogram cell of a pose as a float key, exact below 2^53: cells of bw_m along x and
    y, clamped to [0, ncell) (ncell at most HIST_MAX_CELLS), and of bw_rad in heading from -pi."""
    cx = min(max(math.floor(x / bw_m), 0.0), ncell - 1.0)
    cy = min(max(math.floor(y / bw_m), 0.0), ncell - 1.0)
    nt = math.ceil(2.0 * math.pi / bw_rad)
    ct = min(max(math.floor((th + math.pi) / bw_rad), 0.0), nt - 1.0)
    return (cx * ncell + cy) * nt + ct


@kernel(types.void(_F2, types.int64, _F2, types.int64, types.float64, types.float64, _F, _F, _F),
        cache=True, error_model="numpy")
def histogram_logdensity(P, N, D, k, bw_m, bw_rad, area, keys, out):
    """out[r] = log of the histogram density of the N particles P at the pose D[:, r], r < k:
    log(count in its cell / (N bw_m^2 bw_rad)), -inf in an empty cell. The cells (``cell_key``)
    tile the field (``area``) from its corner, those outside it clamped to its edge; keys (N,)
    scratch: the particles' keys, sorted, each count two binary searches."""
    ncell = float(min(math.ceil(max(area[0], area[1]) / bw_m), HIST_MAX_CELLS))
    for i in range(N):
        keys[i] = cell_key(P[0, i], P[1, i], P[2, i], bw_m, bw_rad, ncell)
    keys.sort()
    cst = math.log(N) + 2.0 * math.log(bw_m) + math.log(bw_rad)
    for r in range(k):
        key = cell_key(D[0, r], D[1, r], D[2, r], bw_m, bw_rad, ncell)
        c = np.searchsorted(keys, key, side="right") - np.searchsorted(keys, key, side="left")
        out[r] = math.log(c) - cst if c > 0 else -np.inf


@kernel(types.float64(types.float64, types.float64, types.float64, _F2, types.int64, _I, _F2,
                      MCL_OPTIONS, DUAL_WORK), cache=True, error_model="numpy")
def draw_logdensity(x, y, th, bc, m, ids, zs, o, dw):
    """log q(x | z) of pfbench's draw from the sensor model at the pose (x, y, th): the mean over
    the step's m observations (each chosen with probability 1/m) of p(r) / (2 pi r) in position
    (r the pose's range to the beacon, p(r) the range's Gaussian about the measured one; the
    angle about the beacon uniform) times the bearing's Gaussian (range and bearing) or
    1 / (2 pi) (range) in heading. The truncation of the drawn range at 0 is left out. dw: the
    scratch of one observation (ids1, zs1) and of the m terms (E)."""
    mx = -np.inf
    vals = dw.E
    for j in range(m):
        b = ids[j]
        r = max(math.hypot(bc[b, 0] - x, bc[b, 1] - y), 1e-300)
        dw.ids1[0] = b
        dw.zs1[0, 0], dw.zs1[0, 1] = zs[j, 0], zs[j, 1]
        v = pose_loglik(x, y, th, bc, 1, dw.ids1, dw.zs1, o.sensor, o.sr, o.sb)
        v -= LOG_2PI + math.log(r)
        if o.sensor != SENSOR_RANGE_BEARING:
            v -= LOG_2PI
        vals[j] = v
        mx = max(mx, v)
    if not np.isfinite(mx):
        return mx
    return mx + math.log(exp_sum(vals, mx, m, vals) / m)


@kernel(types.float64(_F, types.int64, _U8, types.boolean), cache=True, error_model="numpy")
def subset_max(a, n, dual, of_dual):
    """The largest a[i], i < n, over the dual samples (of_dual) or the others; -inf for none.
    A NaN loses every comparison."""
    mx = -np.inf
    for i in range(n):
        if (dual[i] == 1) == of_dual:
            mx = max(mx, a[i])
    return mx


@kernel(types.int64(_F, _F, types.int64, types.int64, DUAL_WORK, MIXTURE_PARAMS),
        cache=True, error_model="numpy")
def mixture_weights(ll, W, N, k, dw, mp):
    """The mixed set's weights W (not normalised) from the log-likelihoods ll (N,) and the k dual
    samples' log-weights (dw.logd[:k], at dw.didx[:k]): MCL's samples exp(ll - their largest);
    with ``combine: separate`` the dual samples' exp(logd - their largest), scaled so that the
    two sets' sums are in the ratio k : N - k; with 'joint' exp(logd) on the MCL samples' scale
    (both shifted by the larger of the two largest).
    MCL's set whose log-weights all are -inf or NaN weighs equally (MCL's rule); such a dual set
    (no dual sample in the predicted belief's support: a histogram's empty cells) weighs zero,
    unless it is the whole set (phi 1), then equally. With k = 0, MCL's weights exactly
    (``exp_pass``). Returns the number of sets that weighed equally so."""
    under = 0
    mx = subset_max(ll, N, dw.dual, False) if k < N else -np.inf
    if k < N:
        if np.isfinite(mx):
            exp_pass(ll, mx, N, W)
        else:
            W[:] = 1.0
            mx = 0.0
            under += 1
    if k == 0:
        return under
    S_m = 0.0
    for i in range(N):
        if dw.dual[i] == 0:
            S_m += W[i]
    md = -np.inf
    for r in range(k):
        md = max(md, dw.logd[r])
    if not np.isfinite(md):
        if k < N:           # no dual sample has support in the predicted belief: none weighs
            for r in range(k):
                W[dw.didx[r]] = 0.0
            return under
        for r in range(k):
            dw.logd[r] = 0.0
        md = 0.0
        under += 1
    if mp.combine == COMBINE_JOINT and k < N:
        if md > mx:         # shift both sets by the larger maximum (no weight overflows)
            f = math.exp(mx - md)
            for i in range(N):
                W[i] *= f
            mx = md
        exp_pass(dw.logd, mx, k, dw.E)
        for r in range(k):
            W[dw.didx[r]] = dw.E[r]
        return under
    S_d = exp_sum(dw.logd, md, k, dw.E)
    f = S_m / S_d * k / (N - k) if k < N else 1.0
    for r in range(k):
        W[dw.didx[r]] = dw.E[r] * f
    return under


@kernel(types.float64(_F, types.int64, types.int64, _F, _F), cache=True, error_model="numpy")
def mixed_mean_likelihood(ll, N, k, cum, E):
    """p_mean, the mean likelihood of the N particles of log-likelihoods ll (E (N,) scratch);
    with no dual sample (k = 0), MCL's (the weights' sum cum[N - 1] is that of the likelihoods
    over the largest)."""
    lmax = ll[:N].max()
    if k == 0:
        return mean_likelihood(lmax, cum[N - 1], N)
    return mean_likelihood(lmax, exp_sum(ll, lmax, N, E), N)


MIX_SIG = types.int64(
    _F2, OBSERVATIONS, SCAN_MODEL, _F, MCL_OPTIONS, MOTION_NOISE, MIXTURE_PARAMS, INITIAL_BELIEF,
    STATE, _F2, _F, _I, _I, _F, _I, SNAPSHOTS)


@kernel(types.void(_F2, _F2, types.int64, types.int64, _F, MIXTURE_PARAMS, DUAL_WORK),
        cache=True, error_model="numpy")
def weigh_duals(P, CS, N, k, area, mp, dw):
    """The k dual samples (dw.D) weighed by the predicted belief, the density of the moved set
    P[:, :N] (``kde_logdensity`` or ``histogram_logdensity``) into dw.logd, then put in their
    places in P (CS follow). With ``dual_weight: importance`` their log-weights then take
    log p(z | x) - log q(x | z) (``importance_correction``)."""
    if mp.density == DENSITY_KDE:
        kde_logdensity(P, N, dw.D, k, mp.bw_m, mp.bw_rad, dw.E, dw.logd)
    else:
        histogram_logdensity(P, N, dw.D, k, mp.bw_m, mp.bw_rad, area, dw.keys, dw.logd)
    for r in range(k):
        i = dw.didx[r]
        P[0, i], P[1, i], P[2, i] = dw.D[0, r], dw.D[1, r], dw.D[2, r]
        trig_pass(P, i, i + 1, CS)


@kernel(types.void(_F2, types.int64, _F2, types.int64, _I, _F2, MCL_OPTIONS, DUAL_WORK, _F),
        cache=True, error_model="numpy")
def importance_correction(P, k, bc, m, ids, zs, o, dw, ll):
    """dw.logd[r] += log p(z | x) - log q(x | z) for the k dual samples (``draw_logdensity``),
    x the pose of particle dw.didx[r] of P, ll its log-likelihood."""
    for r in range(k):
        i = dw.didx[r]
        dw.logd[r] += ll[i] - draw_logdensity(P[0, i], P[1, i], P[2, i], bc, m, ids, zs, o, dw)


@kernel(MIX_SIG, cache=True, error_model="numpy")
def mixture_kernel(ctrl, obs, sm, area, o, mnoise, mp, init, s, est, ess, resampled, injected,
                   pmean, count, snap):
    """Run Mixture MCL over one trial (o: MCL's settings, ``MclOptions``; mp:
    ``MixtureParams``); est (T+1, 3) the weighted pose estimate (est[0]: of the initial cloud),
    ess / resampled / injected (the dual samples) / pmean (the mean likelihood of the mixed set)
    / count (T,) per step; snapshots as ``mcl_kernel``'s. Returns the steps where a set's
    weights all underflowed.

    Each step: move, draw the dual samples and weigh them by the moved set's density, weigh
    (MCL's samples by the likelihood), estimate, resample."""
    T, N = ctrl.shape[0], o.N
    bc = sm.bc
    P, CS = initial_set(area, init, N, s)
    P2, CS2 = np.empty((3, N)), np.empty((2, N))
    W, ll, cum = np.ones(N), np.empty(N), np.empty(N)
    wk = new_mcl_work(o, area, KLD_NONE)
    dw = new_dual_work(N, bc.shape[0])
    events = 0
    weighted_sums(P, W, N, CS, cum, est[0])
    si = snapshot(0, P, N, snap, 0, True)
    for t in range(T):
        fill_normal(s, wk.Z)
        move_particles(P, CS, wk.Z, ctrl[t], o, mnoise)
        count[t] = N
        m, ids, zs = obs.n[t], obs.ids[t], obs.z[t]
        k = 0
        if mp.phi > 0.0 and m > 0:
            k = dual_draws(N, area, bc, m, ids, zs, o, mp.phi, dw, s)
            weigh_duals(P, CS, N, k, area, mp, dw)
        else:
            dw.dual[:] = 0
        injected[t] = k
        particle_logliks(P, N, sm, m, ids, zs, o, ll)
        if mp.dual_weight == DUAL_IMPORTANCE and k > 0:
            importance_correction(P, k, bc, m, ids, zs, o, dw, ll)
        events += min(mixture_weights(ll, W, N, k, dw, mp), 1)
        ess[t] = weighted_sums(P, W, N, CS, cum, est[t + 1])
        pmean[t] = mixed_mean_likelihood(ll, N, k, cum, dw.E)
        si = snapshot(t + 1, P, N, snap, si, True)
        ancestors(W, cum, o, wk.idx, wk.scratch, s)
        gather_rows(P, CS, P2, CS2, wk.idx, N)
        P, P2, CS, CS2 = P2, P, CS2, CS
        resampled[t] = 1
    return events


def mixture_params(params) -> MixtureParams:
    """Mixture MCL's parameters (``MixtureParams``) from a filter run's keys."""
    return MixtureParams(
        phi=float(params["phi"]), density=DENSITIES[params["density"]],
        bw_m=float(params["bandwidth_m"]), bw_rad=float(math.radians(params["bandwidth_deg"])),
        dual_weight=DUAL_WEIGHTS[params["dual_weight"]], combine=COMBINES[params["combine"]])


def run(model, data, params, particles, state, diag=True, snapshots=()):
    """Run Mixture MCL on a beacon-field trial; return the traces (with 'snapshots' as MCL's)."""
    T = data.ctrl.shape[0]
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(T),
           "resampled": np.zeros(T, dtype=np.int64), "injected": np.zeros(T, dtype=np.int64),
           "pmean": np.empty(T), "n": np.empty(T, dtype=np.int64),
           "snapshots": snapshot_arrays(snapshots, particles)}
    o = MclOptions(
        motion=int(model.motion), sensor=int(model.sensor), sr=model.sense.sr,
        sb=model.sense.sb, N=int(particles), threshold=float(np.inf),
        scheme=SCHEME_CODES[params["resampling"]], reset=RESET_NONE, inject_sensor=0, kld=0)
    out["underflow_steps"] = mixture_kernel(
        data.ctrl, observations(data), model.scan_model(), model.area, o, model.mnoise,
        mixture_params(params), model.init, state, out["pose"], out["ess"], out["resampled"],
        out["injected"], out["pmean"], out["n"], out["snapshots"])
    out["lik_evals_per_step"] = float(particles)
    return out


BW_M_MIN = 1e-3         # a millimetre
BW_DEG_MIN = 1e-2


def mixture_keys() -> dict:
    return {
        "resampling": Key("choice", "systematic", "resampling scheme (every step)",
                          choices=tuple(SCHEMES)),
        "phi": Key("float", 0.1, "mixing ratio: each particle is a dual sample (drawn from the "
                   "measurement, weighed by the predicted belief) with probability phi, else an "
                   "MCL sample (0: plain MCL, draw for draw; 1: dual MCL alone). 0.1: the small "
                   "ratio the paper recommends (our reading)", min=0.0, max=1.0),
        "density": Key("choice", "kde", "estimate of the predicted belief at a dual sample, from "
                       "the moved particles: 'kde' a Gaussian kernel (ours; the paper uses a "
                       "kd-tree), 'histogram' a piecewise-constant density over regular cells of "
                       "bandwidth_m x bandwidth_m x bandwidth_deg (a kd-tree's leaves made "
                       "regular)", choices=tuple(DENSITIES)),
        "bandwidth_m": Key("float", 1.0, "the density's bandwidth in x and y, m: the kernel's "
                           "standard deviation or the cell's side (ours; the paper's kd-tree "
                           f"adapts its own; at least {BW_M_MIN:g} m)", min=BW_M_MIN),
        "bandwidth_deg": Key("float", 20.0, "the density's bandwidth in heading, deg: the "
                             "kernel's standard deviation or the cell's width (ours; at least "
                             f"{BW_DEG_MIN:g} deg)", min=BW_DEG_MIN, max=360.0),
        "dual_weight": Key("choice", "belief", "how a dual sample is weighed: 'belief' by the "
                           "predicted belief alone (the paper's, whose dual proposal samples in "
                           "proportion to p(z | x)); 'importance' by belief x p(z | x) / q(x | "
                           "z), q the density of the draw from the sensor model (one observation "
                           "at a time), the importance weight of the same target",
                           choices=tuple(DUAL_WEIGHTS)),
        "combine": Key("choice", "separate", "how the two sets' weights meet (the paper leaves "
                       "it open): 'separate' (ours) normalises each to its share of the "
                       "particles; 'joint' keeps them as they are (dual_weight importance "
                       "only: both are then importance weights of p(z | x) bel(x))",
                       choices=tuple(COMBINES)),
    }


def mixture_check(params) -> tuple[str, str] | None:
    """Cross-key rules of mixture_mcl: (key, message) of the first one broken."""
    if params["combine"] == "joint" and params["dual_weight"] != "importance":
        return "combine", ("'joint' adds the dual samples' weights to the likelihoods as they "
                           "are: it needs dual_weight 'importance' (a belief alone is a density "
                           "of other units)")
    return None


MIXTURE_MCL = FilterType(
    "mixture_mcl", "Mixture MCL (Thrun, Fox, Burgard and Dellaert 2001): MCL's samples mixed "
    "with dual samples drawn from the measurement and weighed by the predicted belief",
    mixture_keys(), run, kind="localization", check=mixture_check, snapshots=True, needs=())
