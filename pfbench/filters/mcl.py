"""Monte Carlo localization on the beacon field, with the particle-injection schemes that let it
recover from a wrong belief (review2007, asrl2008):

- ``reset: none``: plain MCL (sample from the motion model, weigh, resample);
- ``srl``: sensor resetting (Lenser and Veloso): when the mean likelihood p_mean of the particles
  falls below ``srl_threshold``, ``srl_fraction`` of the resampled set is replaced by poses drawn
  from the sensor model (``srl_rule: fixed_fraction``), or N (1 - p_mean / srl_threshold) of it
  (``lenser_veloso``, the original paper's count);
- ``asrl``: adaptive sensor resetting (asrl2008): n_s = N max(0, 1 - p_mean / (mu p_t^c)) are
  replaced, c the number of measurement components at the step (2 per range-bearing observation,
  1 per range), p_mean the mean likelihood;
- ``augmented``: augmented MCL (Thrun, Burgard and Fox): short- and long-term averages of p_mean,
  w_fast and w_slow, and each particle replaced with probability max(0, 1 - w_fast / w_slow), by a
  pose drawn uniformly over the field or from the sensor model (``inject``). The averages follow
  p_mean^(1/c), c the measurement components of the step (a step that sees three beacons has a
  likelihood of another dimension than one that sees one), and skip steps without observations.

``sampling: kld`` is KLD-sampling MCL (Fox 2003): each step draws particles one at a time from the
weighted set and moves them, counting the histogram bins (``kld_bin_m`` x ``kld_bin_m`` x
``kld_bin_deg``) they fall in, until the count reaches
    n_chi(k) = (k - 1) / (2 eps) (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k - 1))) z_(1-delta))^3
(k occupied bins; the Wilson-Hilferty form of chi^2_(k-1, 1-delta) / (2 eps)) and at least
``kld_min``, at most ``particles``. It resamples every step; with ``reset: augmented`` a drawn
particle is, with the injection probability, a pose from the field or the sensor model instead.

Particles start uniform over the field and heading (the pose is unknown), or around the start
(scenario ``initial: known``). Each step every particle
moves by the odometry with its own draw of the scenario's motion noise; the likelihood is the
product over the step's observations of Gaussians in range (and wrapped bearing), or the model's
own log-likelihood where it brings one (``FieldModel.loglik``: every weighing, resets and
KLD-sampling included, goes through it; poses drawn from the sensor model still use the sensor's
Gaussian, sr and sb, as a proposal). The estimate is
the weighted mean (circular for the heading) before resampling. A pose drawn from the sensor model
is consistent with one observation of the step: on its range circle around the beacon (range
sensor: heading uniform), or, with a bearing, also heading so that the beacon is seen at that
bearing.

The kernel (``mcl_kernel``) runs each step as named steps: move (``move_particles``, or
KLD-sampling's ``kld_step``), weigh (``weigh_observations``), estimate (``weighted_sums``),
resample (``ancestors``), inject (``inject``); the passes behind them are documented as contracts
in their docstrings. Their design and what each speed-up took: docs/internals/kernels.md.
"""
from __future__ import annotations

import math
from statistics import NormalDist
from typing import NamedTuple

import numba
import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..codes import (MOTION_ODOMETRY, MOTION_ROT_TRANS_ROT, RESET, RESET_ASRL, RESET_AUGMENTED,
                     RESET_NONE, RESET_SRL, SCHEME_CODES, SCHEME_SYSTEMATIC, SENSOR_RANGE_BEARING,
                     SRL_LENSER_VELOSO, SRL_RULES)
from ..resampling import ess_threshold, resample, systematic_from_sums
from ..rng import (STATE, _layer, fill_normal, in_layer_rectangle, load_local, next_local,
                   normal_off_rectangle, store_local, uniform, unit)
from .. import vecmath as vm
from ..models.beacons import SCAN_MODEL, loglik_const, sensor_pose
from ..models.odometry import MOTION_NOISE, _odometry, odometry_with
from ..models.observations import OBSERVATIONS, observations
from ..models.pose import INITIAL_BELIEF, SNAPSHOTS, init_particles, snapshot, snapshot_arrays
from ..schema import Key
from .keys import pf_keys
from .weights import ess as ess_of, exp_pass, exp_sum, reset_unless_finite
from .types import FilterType

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]



class ResetParams(NamedTuple):
    """The injection's parameters (``reset``), as the config names them: SRL's fraction and
    threshold, ASRL's mu and p_t, augmented MCL's averaging rates alpha_slow, alpha_fast; SRL's
    rule (a code of codes.SRL_RULES, as a float)."""

    srl_fraction: float
    srl_threshold: float
    asrl_mu: float
    asrl_pt: float
    alpha_slow: float
    alpha_fast: float
    srl_rule: float


class KldParams(NamedTuple):
    """KLD-sampling's parameters: the bound's epsilon and z_(1-delta) (the standard normal
    quantile of 1 - kld_delta), the histogram's bin sizes (bin_m m x bin_m m x bin_rad rad), and
    the least count n_min (kld_min, at most the particles; a float)."""

    epsilon: float
    z: float
    bin_m: float
    bin_rad: float
    n_min: float


RESET_PARAMS = typeof(ResetParams(0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0))
KLD_PARAMS = typeof(KldParams(1.0, 1.0, 1.0, 1.0, 1.0))


@kernel(types.void(_F2, types.int64, types.int64, _F2), cache=True, error_model="numpy")
def trig_pass(P, i0, i1, CS):
    """CS[:, i] = cos, sin of the heading P[2, i] for i0 <= i < i1.

    P (3, N) the particles as rows x, y, heading; CS (2, N); 0 <= i0 <= i1 <= N. One loop of
    ``vecmath.sincos`` (branch-free, fused multiply-adds) that the compiler vectorises: the
    cosines and sines kept with the particles spare the move and the estimate recomputing them."""
    for i in range(i0, i1):
        CS[1, i], CS[0, i] = vm.sincos(P[2, i])


@kernel(types.void(_F, _F, _F, _F, _F, types.int64, types.float64, types.float64, types.float64,
                 types.float64, types.float64), cache=True, inline="always")
def _advance(X, Y, H, C, S, i, a1, a2, a3, ct, st):
    """Particle i drives a2 along the direction (ct, st) = cos, sin(H[i] + a1), then turns to
    H[i] + a1 + a3; (C, S)[i] follow."""
    X[i] += a2 * ct
    Y[i] += a2 * st
    h = vm.wrap(H[i] + a1 + a3)
    H[i] = h
    S[i], C[i] = vm.sincos(h)


_MOVE_SIG = types.void(_F, _F, _F, _F, _F, _F, types.float64, types.float64, types.float64,
                       MOTION_NOISE, types.int64)


@kernel(_MOVE_SIG, cache=True, error_model="numpy")
def _move_odometry(X, Y, H, C, S, Z, rot1, trans, rot2, mnoise, n):
    """Move the particles (X, Y, H)[:n] by sspf2008's (T, dtheta) odometry, particle i's noise
    the draws Z[2 i], Z[2 i + 1]; (C, S) follow the headings. One pass the vectoriser takes
    (separate rows, a fixed stride, no branch): without a first turn the cached cosines and sines
    give the direction of the move."""
    for i in range(n):
        a1, a2, a3 = odometry_with(rot1, trans, rot2, MOTION_ODOMETRY, mnoise, Z, 2 * i)
        if rot1 == 0.0:
            _advance(X, Y, H, C, S, i, a1, a2, a3, C[i], S[i])
        else:
            st, ct = vm.sincos(H[i] + a1)
            _advance(X, Y, H, C, S, i, a1, a2, a3, ct, st)


@kernel(_MOVE_SIG, cache=True, error_model="numpy")
def _move_rot_trans_rot(X, Y, H, C, S, Z, rot1, trans, rot2, mnoise, n):
    """_move_odometry for asrl2008's (rot1, trans, rot2) odometry: the draws Z[3 i:3 i + 3]."""
    for i in range(n):
        a1, a2, a3 = odometry_with(rot1, trans, rot2, MOTION_ROT_TRANS_ROT, mnoise, Z, 3 * i)
        st, ct = vm.sincos(H[i] + a1)
        _advance(X, Y, H, C, S, i, a1, a2, a3, ct, st)


@kernel(types.void(_F, _F, _F, types.int64, _F2, types.int64, _I, _F2, types.int64,
                 types.float64, types.float64, types.float64, _F), cache=True,
      error_model="numpy")
def loglik_pass(X, Y, H, n, bc, m, ids, zs, sensor, sr, sb, cst, ll):
    """ll[:n] = log p(z | particle i) of the step's m observations (pose_quad's sum, in its
    order, + cst, the constant ``loglik_const(m, sensor, sr, sb)``).

    X, Y, H (>= n,) the particles' x, y, heading; bc (B, 2) the beacons; ids (>= m,) and zs
    (>= m, 2) the observations' beacons and [range, bearing]; sensor 1: ranges and bearings,
    0: ranges; sr, sb > 0 their noise levels; ll (>= n,) written. An observation at a time over
    all particles: passes the vectoriser takes (vecmath's arctangent and wrap for the
    bearings), multiplying by the reciprocals of the noise levels. The first pass starts each
    sum from zero and the last adds the constant (no passes of their own for either)."""
    rr, rb = 1.0 / sr, 1.0 / sb
    if m == 0:
        for i in range(n):
            ll[i] = 0.0 + cst
    for j in range(m):
        bx, by, z, zb = bc[ids[j], 0], bc[ids[j], 1], zs[j, 0], zs[j, 1]
        first, last = j == 0, j == m - 1
        if sensor == SENSOR_RANGE_BEARING:
            for i in range(n):
                dx, dy = bx - X[i], by - Y[i]
                v = (z - math.sqrt(dx * dx + dy * dy)) * rr
                u = vm.wrap(zb - (vm.atan2(dy, dx) - H[i])) * rb
                a = (0.0 if first else ll[i]) - 0.5 * v * v
                a -= 0.5 * u * u
                ll[i] = a + cst if last else a
        else:
            for i in range(n):
                dx, dy = bx - X[i], by - Y[i]
                v = (z - math.sqrt(dx * dx + dy * dy)) * rr
                a = (0.0 if first else ll[i]) - 0.5 * v * v
                ll[i] = a + cst if last else a


KLD_COUNT_MAX = 2 ** 62    # kld_count saturates here (any bound past the particles is the same)
KLD_DENSE_BINS = 1 << 22   # histograms of more bins count the occupied ones in a hash set


@kernel(types.int64(types.int64, types.float64, types.float64), cache=True)
def kld_count(k, eps, z):
    """Fox's sample count for k occupied bins: the (1 - delta) quantile of chi^2 with k - 1 degrees
    of freedom over 2 eps (Wilson-Hilferty), rounded up; 0 for one bin, 0 where the quantile's
    cube is not positive (delta near 1), and KLD_COUNT_MAX for a count past it (a tiny eps):
    non-increasing in eps and delta, never wrapped."""
    if k <= 1:
        return 0
    d = k - 1.0
    a = 2.0 / (9.0 * d)
    b = 1.0 - a + math.sqrt(a) * z
    if not (b > 0.0):
        return 0
    v = d / (2.0 * eps) * b ** 3
    if not (v < KLD_COUNT_MAX):         # inf (eps so small the quotient overflows) or past it
        return KLD_COUNT_MAX
    return int(math.ceil(v))


def kld_quantile(delta: float) -> float:
    """z_(1-delta), the standard normal's (1 - delta) quantile, for any delta in (0, 1): as
    ``NormalDist().inv_cdf(1 - delta)`` down to delta = 2^-20, below it from delta itself (1 -
    delta keeps too few of delta's bits there, and is 1 below 1.1e-16), so that it keeps rising
    as delta falls toward 0."""
    lo = 2.0 ** -20
    if not 0.0 < delta < 1.0:
        raise ValueError(f"kld_delta must lie in (0, 1), got {delta!r}")
    if delta >= lo:
        return NormalDist().inv_cdf(1.0 - delta)
    return max(-NormalDist().inv_cdf(delta), NormalDist().inv_cdf(1.0 - lo))


@kernel(types.UniTuple(types.float64, 3)(_F, KLD_PARAMS), cache=True, inline="always")
def kld_grid(area, kp):
    """The histogram's cells along x, y and the heading (kp.bin_m m x kp.bin_m m x kp.bin_rad rad
    over the field), as floats (at least 1; infinite when the quotient overflows)."""
    return (max(np.ceil(area[0] / kp.bin_m), 1.0), max(np.ceil(area[1] / kp.bin_m), 1.0),
            max(np.ceil(2.0 * math.pi / kp.bin_rad), 1.0))


@kernel(types.UniTuple(types.int64, 3)(_F, KLD_PARAMS), cache=True, inline="always")
def kld_cells(area, kp):
    """KLD-sampling's histogram: cells along x, y and the heading (kp.bin_m m x kp.bin_m m x
    kp.bin_rad rad over the field); each saturates at KLD_COUNT_MAX (only grids of at most
    KLD_DENSE_BINS bins are indexed by them)."""
    fx, fy, ft = kld_grid(area, kp)
    lim = float(KLD_COUNT_MAX)
    return (int(min(fx, lim)), int(min(fy, lim)), int(min(ft, lim)))


@kernel(types.int64(types.float64, types.float64, types.int64), cache=True, inline="always")
def _cell_index(v, size, n):
    """floor(v / size) clamped to [0, n - 1] (NaN: 0), clamped before it becomes an integer."""
    c = np.floor(v / size)
    if not (c > 0.0):
        return 0
    if c >= n - 1.0:
        return n - 1
    return int(c)


@kernel(types.int64(types.float64, types.float64, types.float64, types.float64, types.float64,
                    types.int64, types.int64, types.int64), cache=True, inline="always")
def kld_cell(x, y, th, bm, br, nx, ny, nt):
    """``kld_bin`` with the bin sizes (bm m, br rad) and the histogram's cells (``kld_cells``)
    given."""
    ix = _cell_index(x, bm, nx)
    iy = _cell_index(y, bm, ny)
    it = _cell_index(th + math.pi, br, nt)
    return (ix * ny + iy) * nt + it


@kernel(types.int64(types.float64, types.float64, types.float64, _F, KLD_PARAMS), cache=True)
def kld_bin(x, y, th, area, kp):
    """Histogram bin of a pose: cells of kp.bin_m m x kp.bin_m m x kp.bin_rad rad over the field
    (poses outside it fall into the edge cells), on a grid of at most KLD_DENSE_BINS bins."""
    nx, ny, nt = kld_cells(area, kp)
    return kld_cell(x, y, th, kp.bin_m, kp.bin_rad, nx, ny, nt)


@kernel(types.int64(_F, KLD_PARAMS), cache=True)
def kld_bins(area, kp):
    """Size of the dense histogram KLD-sampling keeps over the field: its number of bins, or 0
    when there are more than KLD_DENSE_BINS (then it counts the occupied bins in a hash set of
    at most twice the particles' slots, whatever the bin sizes)."""
    fx, fy, ft = kld_grid(area, kp)
    if not (fx * fy * ft <= KLD_DENSE_BINS):
        return 0
    nx, ny, nt = kld_cells(area, kp)
    return nx * ny * nt


def kld_histogram_bytes(particles: int) -> int:
    """Memory KLD-sampling's histogram takes at most, for a set of at most ``particles``: the
    dense histogram (a byte a bin, at most KLD_DENSE_BINS) or the hash set, and the list of the
    occupied bins."""
    slots = 1 << max(2 * int(particles), 1).bit_length()
    return max(KLD_DENSE_BINS, slots * 25) + 8 * int(particles)


_SPLIT = 2.0 ** 53      # cells past it along an axis are finer than the doubles there


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64),
        cache=True, inline="always")
def _cell_key(v, size, n, ext):
    """The cell of v along an axis of n cells of ``size`` (extent ``ext``), clamped to its edge
    cells, as a float key: floor(v / size), or, where that passes 2^53 (cells finer than the
    spacing of the doubles there, so that each value lies in a cell of its own), -1 - v (v at
    most ext): distinct keys for distinct cells, however fine, with no integer to overflow."""
    c = np.floor(v / size)
    if not (c > 0.0):
        return 0.0
    if c < _SPLIT:
        return c if c <= n - 1.0 else n - 1.0
    if n - 1.0 < _SPLIT:
        return n - 1.0
    return -1.0 - min(v, ext)


@kernel(types.int64(_F2, types.uint8[::1], types.float64, types.float64, types.float64),
        cache=True)
def _hash_insert(hk, hused, a, b, c):
    """Insert the key (a, b, c) into the open-addressing set (hk (cap, 3), hused (cap,), cap a
    power of two); return its slot when it is new, else -1."""
    mask = hused.size - 1
    h = np.uint64(0x9E3779B97F4A7C15)
    for v in (a, b, c):
        f, e = math.frexp(v)
        h = (h ^ np.uint64(np.int64(f * 9007199254740992.0) & 0x7FFFFFFFFFFFFFFF)) \
            * np.uint64(0xBF58476D1CE4E5B9)
        h = (h ^ np.uint64(e + 2048)) * np.uint64(0x94D049BB133111EB)
        h ^= h >> np.uint64(31)
    j = np.int64(h & np.uint64(mask))
    while hused[j]:
        if hk[j, 0] == a and hk[j, 1] == b and hk[j, 2] == c:
            return -1
        j = (j + 1) & mask
    hused[j] = 1
    hk[j, 0], hk[j, 1], hk[j, 2] = a, b, c
    return j


KLD_CHUNK = 256     # particles KLD-sampling draws per round of its passes, at most


@kernel(types.float64(_F, types.int64, _I), cache=True)
def guide_table(cum, n, guide):
    """A guide table (Chen and Asau) for searching the running sums cum[:n] (non-decreasing,
    cum[n - 1] > 0): guide[g] = #{i < n : cum[i] <= g acc / n}, acc = cum[n - 1]. Returns
    n / acc, for ``guided_upper_bound``."""
    acc = cum[n - 1]
    gstep = acc / n
    j = 0
    for g in range(n):
        t = g * gstep
        while j < n and cum[j] <= t:
            j += 1
        guide[g] = j
    return n / acc


@kernel(types.int64(_F, types.int64, _I, types.float64, types.float64), cache=True,
        inline="always")
def guided_upper_bound(cum, n, guide, ginv, v):
    """#{i < n : cum[i] <= v} for v >= 0 (np.searchsorted(cum[:n], v, side="right")), from the
    guide table: v lies above (g - 1) acc / n for g = floor(v n / acc) (a whole cell of margin
    for the rounding), so the count starts at guide[g - 1], which cannot pass it, and walks up.
    The walk passes about two running sums on average, whatever the weights: a binary search's
    fourteen steps at n = 10,000, each a likely misprediction, cost about five times as much."""
    j = guide[min(max(int(v * ginv) - 1, 0), n - 1)]
    while j < n and cum[j] <= v:
        j += 1
    return j


@kernel(types.UniTuple(types.int64, 2)(
    _F2, _F, types.int64, _F, types.int64, MOTION_NOISE, _F, KLD_PARAMS, types.int64,
    types.uint8[::1], _I, types.float64, types.int64, types.int64, _F2, types.int64, _I, _F2,
    types.float64, types.float64, STATE, _F2), cache=True, error_model="numpy")
def kld_sample(P, cum, n, u, motion, mnoise, area, kp, nmax, occ, touched, prob, inject_sensor,
               sensor, bc, nobs, ids, zs, sr, sb, s, out):
    """KLD-sampling: draw particles from the weighted set (P[:, :n] as rows, cum[:n] the running
    sums of its weights, added in order: ``weighted_sums``'s) one at a time, move each by the
    odometry u (3,) with its own noise, into out, until their count reaches the bound for
    the bins they occupy (kp: ``KldParams``) or nmax. With
    probability ``prob`` a draw is a new pose (uniform, or from the sensor model of the
    observations (ids, zs)[:nobs] when inject_sensor) instead of a copy. occ (``kld_bins``,) must
    be all zero; it is left so (a histogram of more bins, or an occ too small for it, counts the
    occupied bins in a hash set instead: the same count). Returns (count, injected).

    It runs in rounds over up to KLD_CHUNK particles (at least the count the bound still asks
    for): draw (``kld_draws``), copy (``kld_copies``), move and bin (``kld_moves``), count
    (``kld_tally``, which stops at the bound and takes back the draws past it), so that the
    particles, their order and the generator's state are those of one particle at a time."""
    nmin = int(kp.n_min)
    target, k, m, injected = nmin, 0, 0, 0
    rd = new_kld_round(KLD_CHUNK)
    guide = np.empty(n, dtype=np.int64)
    ginv = guide_table(cum, n, guide)
    nb = kld_bins(area, kp)
    dense = 0 < nb <= occ.size
    cap = 1
    while cap < 2 * nmax and not dense:
        cap *= 2
    hk = np.empty((cap, 3))                 # the hash set of occupied bins (sparse histograms)
    hused = np.zeros(cap, dtype=np.uint8)
    while m < nmax:
        c = min(KLD_CHUNK, nmax - m, max(target - m, 32))
        X, Y, H = out[0, m:m + c], out[1, m:m + c], out[2, m:m + c]     # the round's particles
        kld_draws(rd, c, X, Y, H, cum[n - 1], prob, u, motion, mnoise, area, sensor, bc,
                  nobs if inject_sensor else 0, ids, zs, sr, sb, s)
        kld_copies(rd, c, X, Y, H, P, cum, n, guide, ginv)
        kld_moves(rd, c, X, Y, H, area, kp, dense)
        m, k, target, injected = kld_tally(rd, c, X, Y, H, m, k, target, injected, nmin, area,
                                           kp, dense, occ, touched, hk, hused, s)
        if m >= target:
            break
    if dense:
        for r in range(k):
            occ[touched[r]] = 0
    return m, injected


class KldRound(NamedTuple):
    """A round of KLD-sampling's draws (CH = KLD_CHUNK at most), particle r's:
    src (CH,) : the particle copied, -1 for a new pose (0 until ``kld_copies`` finds it)
    pos (CH,) : the position drawn in [0, the weights' sum) for a copy
    odo (3, CH) : the noisy odometry
    kept (CH, 4) : the generator's state after its draws
    bins (CH,) : its histogram bin (dense histograms)
    pose (3,) : scratch for a pose drawn from the sensor model
    """

    src: np.ndarray
    pos: np.ndarray
    odo: np.ndarray
    kept: np.ndarray
    bins: np.ndarray
    pose: np.ndarray


KLD_ROUND = types.NamedTuple((_I, _F, _F2, types.uint64[:, ::1], _I, _F), KldRound)


@kernel(KLD_ROUND(types.int64), cache=True)
def new_kld_round(CH):
    """The scratch of a round of up to CH draws."""
    return KldRound(np.empty(CH, dtype=np.int64), np.empty(CH), np.empty((3, CH)),
                    np.empty((CH, 4), dtype=np.uint64), np.empty(CH, dtype=np.int64),
                    np.empty(3))


@kernel(types.void(KLD_ROUND, types.int64, _F, _F, _F, types.float64, types.float64, _F,
                   types.int64, MOTION_NOISE, _F, types.int64, _F2, types.int64, _I, _F2,
                   types.float64, types.float64, STATE), cache=True, error_model="numpy")
def kld_draws(rd, c, X, Y, H, acc, prob, u, motion, mnoise, area, sensor, bc, nobs, ids, zs, sr, sb,
              s):
    """The random draws of c particles, in the order of the one-at-a-time loop, the generator's
    state in registers (``rng.next_local``) and kept after each particle (rd.kept): whether it
    is a new pose (probability prob: drawn from the sensor model of (ids, zs)[:nobs], uniform
    when nobs is 0, into (X, Y, H)[r]), else its position in [0, acc); then its noisy odometry
    (the ziggurat's step of ``rng``, 2 or 3 draws by the motion model) into rd.odo."""
    q = load_local(s)
    for r in range(c):
        new = False
        if prob > 0.0:
            bits, q = next_local(q)
            new = unit(bits) < prob
        if new:
            store_local(s, q)
            sensor_pose(area, sensor, bc, nobs, ids, zs, sr, sb, rd.pose, s)
            q = load_local(s)
            X[r], Y[r], H[r] = rd.pose[0], rd.pose[1], rd.pose[2]
            rd.src[r] = -1
        else:
            bits, q = next_local(q)
            rd.pos[r] = unit(bits) * acc
            rd.src[r] = 0
        n1 = n2 = n3 = 0.0
        for d in range(2 if motion == MOTION_ODOMETRY else 3):     # noisy_odometry's normal draws
            bits, q = next_local(q)
            layer, rabs, x = _layer(bits)
            if not in_layer_rectangle(layer, rabs):
                x, q = normal_off_rectangle(s, q, layer, rabs, x)
            if d == 0:
                n1 = x
            elif d == 1:
                n2 = x
            else:
                n3 = x
        rd.odo[0, r], rd.odo[1, r], rd.odo[2, r] = _odometry(u[0], u[1], u[2], motion, mnoise,
                                                             n1, n2, n3)
        rd.kept[r, 0], rd.kept[r, 1], rd.kept[r, 2], rd.kept[r, 3] = q
    store_local(s, q)


@kernel(types.void(KLD_ROUND, types.int64, _F, _F, _F, _F2, _F, types.int64, _I,
                   types.float64),
        cache=True, error_model="numpy")
def kld_copies(rd, c, X, Y, H, P, cum, n, guide, ginv):
    """The copies of the round: for each drawn position, the first particle of P[:, :n] whose
    running weight cum passes it (``guided_upper_bound`` on the guide table), into X, Y, H."""
    for r in range(c):
        if rd.src[r] >= 0:
            j = min(guided_upper_bound(cum, n, guide, ginv, rd.pos[r]), n - 1)
            rd.src[r] = j
            X[r], Y[r], H[r] = P[0, j], P[1, j], P[2, j]


@kernel(types.void(KLD_ROUND, types.int64, _F, _F, _F, _F, KLD_PARAMS, types.boolean), cache=True,
        error_model="numpy")
def kld_moves(rd, c, X, Y, H, area, kp, dense):
    """The round's particles (X, Y, H)[:c] moved by their odometry rd.odo (vecmath's sine,
    cosine and wrap, a pass the compiler vectorises, as plain MCL's move), and, for a dense
    histogram, their bins (``kld_cell``) into rd.bins."""
    odo = rd.odo
    for r in range(c):      # two loops: one has too many arrays for the vectoriser
        th = H[r] + odo[0, r]
        st, ct = vm.sincos(th)
        X[r] += odo[1, r] * ct
        Y[r] += odo[1, r] * st
        H[r] = vm.wrap(th + odo[2, r])
    if dense:
        nx, ny, nt = kld_cells(area, kp)
        for r in range(c):
            rd.bins[r] = kld_cell(X[r], Y[r], H[r], kp.bin_m, kp.bin_rad, nx, ny, nt)


@kernel(types.UniTuple(types.int64, 4)(
    KLD_ROUND, types.int64, _F, _F, _F, types.int64, types.int64, types.int64, types.int64,
    types.int64, _F, KLD_PARAMS, types.boolean, types.uint8[::1], _I, _F2, types.uint8[::1],
    STATE), cache=True, error_model="numpy")
def kld_tally(rd, c, X, Y, H, m, k, target, injected, nmin, area, kp, dense, occ, touched, hk,
              hused, s):
    """Count the round's particles one at a time (m drawn so far, k occupied bins, listed in
    touched; target the bound for them, at least nmin) until the count reaches the bound: a
    particle in a new bin (the dense histogram occ, else the hash set hk, hused) raises it to
    ``kld_count``. Where it stops before the round's end, the generator's state goes back to
    the one kept after the stopping particle. Returns (m, k, target, injected)."""
    if not dense:
        fx, fy, ft = kld_grid(area, kp)
    else:
        fx = fy = ft = 1.0
    for r in range(c):
        if dense:
            b = rd.bins[r]
            new_bin = occ[b] == 0
            if new_bin:
                occ[b] = 1
        else:
            b = _hash_insert(hk, hused, _cell_key(X[r], kp.bin_m, fx, area[0]),
                             _cell_key(Y[r], kp.bin_m, fy, area[1]),
                             _cell_key(H[r] + math.pi, kp.bin_rad, ft, 2.0 * math.pi))
            new_bin = b >= 0
        if new_bin:
            touched[k] = b
            k += 1
            target = max(nmin, kld_count(k, kp.epsilon, kp.z))
        if rd.src[r] < 0:
            injected += 1
        m += 1
        if m >= target:
            if r < c - 1:       # take back the draws of the particles after this one
                kept = rd.kept
                store_local(s, (kept[r, 0], kept[r, 1], kept[r, 2], kept[r, 3]))
            break
    return m, k, target, injected


class MclOptions(NamedTuple):
    """MCL's settings, as the jitted steps read them.

    motion : the odometry noise model (codes.MOTION_*; mnoise, a ``MotionNoise``, its parameters)
    sensor : 0 ranges, 1 ranges and bearings; sr, sb their noise standard deviations
    N : particles (KLD-sampling: the most); threshold : resample when ESS < threshold; scheme :
    the resampling code; reset : RESET's code of the injection; inject_sensor : augmented MCL
    draws injected poses from the sensor model (else uniform over the field); kld : 1 for
    KLD-sampling
    """

    motion: int
    sensor: int
    sr: float
    sb: float
    N: int
    threshold: float
    scheme: int
    reset: int
    inject_sensor: int
    kld: int


MCL_OPTIONS = typeof(MclOptions(0, 0, 1.0, 1.0, 1, 1.0, 0, 0, 0, 0))


@kernel(types.void(_F2, _F2, _F2, _F2, types.int64, types.int64), cache=True, inline="always")
def _copy_particle(P, CS, P2, CS2, i, k):
    """(P2, CS2)[:, i] = (P, CS)[:, k]: particle k of a set stored as rows, with its heading's
    cosine and sine, becomes particle i of another (k >= 0: read as unsigned, so the loop has
    no negative index to wrap around)."""
    k = np.uint64(k)
    P2[0, i], P2[1, i], P2[2, i] = P[0, k], P[1, k], P[2, k]
    CS2[0, i], CS2[1, i] = CS[0, k], CS[1, k]


@numba.njit(cache=True, error_model="numpy")
def _draws_copying(s, Z, per, P, CS, idx, P2, CS2, n):
    """fill_normal(s, Z) (per draws a particle, n particles), and meanwhile the resampled set:
    (P2, CS2)[:, i] = (P, CS)[:, idx[i]]. The draws wait on the generator, one step after
    another; the copy's loads and stores fill that wait, and cost far less there than in a pass
    of their own. The draws are ``fill_normal``'s (the ziggurat's step of ``rng``). Compiled for
    each ``per`` it is called with (a constant: the loop over a particle's draws unrolls)."""
    q = load_local(s)
    for i in range(n):
        _copy_particle(P, CS, P2, CS2, i, idx[i])
        for d in range(per):
            r, q = next_local(q)
            layer, rabs, x = _layer(r)
            if not in_layer_rectangle(layer, rabs):
                x, q = normal_off_rectangle(s, q, layer, rabs, x)
            Z[per * i + d] = x
    store_local(s, q)


@kernel(types.void(STATE, _F, types.int64, _F2, _F2, _I, _F2, _F2, types.int64), cache=True,
        error_model="numpy")
def draws_copying(s, Z, motion, P, CS, idx, P2, CS2, n):
    """``_draws_copying`` with the draws a particle of the motion model (see ``odometry_with``:
    2 for motion 0, else 3), each compiled for its count."""
    if motion == MOTION_ODOMETRY:
        _draws_copying(s, Z, 2, P, CS, idx, P2, CS2, n)
    else:
        _draws_copying(s, Z, 3, P, CS, idx, P2, CS2, n)


@kernel(types.void(_F2, _F2, _F, _F, MCL_OPTIONS, MOTION_NOISE), cache=True,
        error_model="numpy")
def move_particles(P, CS, Z, u, o, mnoise):
    """Move every particle (rows P, CS) by the odometry u, particle i with the motion noise of
    its draws in Z (2 or 3 a particle, see ``odometry_with``)."""
    if o.motion == MOTION_ODOMETRY:
        _move_odometry(P[0], P[1], P[2], CS[0], CS[1], Z, u[0], u[1], u[2], mnoise, o.N)
    else:
        _move_rot_trans_rot(P[0], P[1], P[2], CS[0], CS[1], Z, u[0], u[1], u[2], mnoise, o.N)


@kernel(types.void(_F2, types.int64, SCAN_MODEL, types.int64, _I, _F2, MCL_OPTIONS, _F),
        cache=True, error_model="numpy")
def particle_logliks(P, n, sm, m, ids, zs, o, ll):
    """ll[:n] = log p(z | particle i) of the step's m observations of the beacons sm.bc: the
    model's own log-likelihood sm.loglik (``SCAN_LIK_SIG``, parameters sm.theta) where sm.use,
    else the Gaussian sensor of o (``loglik_pass``)."""
    if sm.use:
        sm.loglik(P[0, :n], P[1, :n], P[2, :n], sm.bc, m, ids, zs, sm.theta, ll[:n])
    else:
        loglik_pass(P[0], P[1], P[2], n, sm.bc, m, ids, zs, o.sensor, o.sr, o.sb,
                    loglik_const(m, o.sensor, o.sr, o.sb), ll)


@kernel(types.Tuple((types.float64, types.float64, types.float64, types.boolean))(
    _F2, types.int64, SCAN_MODEL, types.int64, _I, _F2, MCL_OPTIONS, _F, _F, _F, types.boolean),
    cache=True, error_model="numpy")
def weigh_observations(P, n, sm, m, ids, zs, o, lw, W, ll, equal_weights):
    """Weigh the n particles by the step's m observations of the beacons sm.bc
    (``particle_logliks``: the model's own log-likelihood where sm.use, else the Gaussian
    sensor; sm: ``ScanModel``): log-weights lw, weights W (as they
    are: W = exp(lw - max lw), never normalised; ``weighted_sums`` divides by their sum where it
    matters). Returns (1 when every weight underflowed and was reset, else 0; the largest
    log-likelihood lmax; the sum of exp(ll - lmax); whether W holds those very terms). The mean
    likelihood of the moved particles is exp(lmax) times that sum over n (``mean_likelihood``);
    when W holds the terms, their sum is not computed here: ``weighted_sums``'s running sums end
    with it. ``equal_weights``: the set was just resampled or drawn (its log-weights all zero, whatever
    lw holds), so the likelihoods are the weights, and lw is left as it is: unless every weight
    underflowed (then lw is all zero), the log-weights are ll, and the caller swaps the two
    arrays."""
    particle_logliks(P, n, sm, m, ids, zs, o, ll)
    # the two maxima in four lanes each (the same maxima: a NaN loses every comparison)
    m0 = m1 = m2 = m3 = -np.inf
    l0 = l1 = l2 = l3 = -np.inf
    top = n - n % 4
    if equal_weights:   # the log-weights are the log-likelihoods: the caller takes ll as lw
        for i in range(0, top, 4):
            l0, l1 = max(l0, ll[i]), max(l1, ll[i + 1])
            l2, l3 = max(l2, ll[i + 2]), max(l3, ll[i + 3])
        for i in range(top, n):
            l0 = max(l0, ll[i])
        m0, m1, m2, m3 = l0, l1, l2, l3
    else:
        for i in range(0, top, 4):
            a0, a1, a2, a3 = lw[i] + ll[i], lw[i + 1] + ll[i + 1], lw[i + 2] + ll[i + 2], \
                lw[i + 3] + ll[i + 3]
            lw[i], lw[i + 1], lw[i + 2], lw[i + 3] = a0, a1, a2, a3
            m0, m1, m2, m3 = max(m0, a0), max(m1, a1), max(m2, a2), max(m3, a3)
            l0, l1 = max(l0, ll[i]), max(l1, ll[i + 1])
            l2, l3 = max(l2, ll[i + 2]), max(l3, ll[i + 3])
        for i in range(top, n):
            lw[i] += ll[i]
            m0 = max(m0, lw[i])
            l0 = max(l0, ll[i])
    mx = max(max(m0, m1), max(m2, m3))
    lmax = max(max(l0, l1), max(l2, l3))
    if equal_weights and np.isfinite(mx):   # the weights are the likelihood's terms
        exp_pass(ll, lmax, n, W)
        return 0.0, lmax, 0.0, True
    acc = exp_sum(ll, lmax, n, W)       # W as scratch
    mx, under = reset_unless_finite(lw, n, mx)
    exp_pass(lw, mx, n, W)
    return under, lmax, acc, False


@kernel(types.float64(types.float64, types.float64, types.int64), cache=True)
def mean_likelihood(lmax, acc, n):
    """p_mean, the mean likelihood of n particles, from the largest log-likelihood lmax and
    acc, the sum of the likelihoods over exp(lmax) (log-sum-exp); 0 when lmax is not finite."""
    return math.exp(lmax) * acc / n if np.isfinite(lmax) else 0.0


_F4 = types.UniTuple(types.float64, 4)


@kernel(_F4(types.float64, types.float64, types.float64, types.float64, _F, types.int64,
            types.float64, types.float64, types.float64, types.float64), cache=True,
        inline="always")
def _fma_lanes(w0, w1, w2, w3, A, i, s0, s1, s2, s3):
    """The four lanes' partial sums s_l += w_l A[i + l] (fused multiply-adds), l = 0 .. 3."""
    return (vm.fma(w0, A[i], s0), vm.fma(w1, A[i + 1], s1), vm.fma(w2, A[i + 2], s2),
            vm.fma(w3, A[i + 3], s3))


@kernel(types.float64(_F2, _F, types.int64, _F2, _F, _F), cache=True, error_model="numpy")
def weighted_sums(P, W, n, CS, cum, out):
    """One pass over the n weighted particles (rows P, their headings' cosines and sines CS;
    weights W, not normalised): the weights' running sums into cum (summed in order, for the
    resampling; cum[n - 1] is their sum S), the estimate into out (``estimate_pose``'s weighted
    mean and circular mean heading) and, returned, the ESS S^2 / sum W^2. The estimate's four
    sums and the ESS's are each in four partial sums (``weights.lane_sum``'s) of fused multiply-adds
    (``vm.fma``), divided by S once at the end. The running sum waits on each addition before
    the next; the rest is done in that wait."""
    X, Y, C, S = P[0], P[1], CS[0], CS[1]
    x0 = x1 = x2 = x3 = y0 = y1 = y2 = y3 = 0.0
    c0 = c1 = c2 = c3 = s0 = s1 = s2 = s3 = 0.0
    q0 = q1 = q2 = q3 = 0.0
    acc = 0.0
    top = n - n % 4
    for i in range(0, top, 4):
        w0, w1, w2, w3 = W[i], W[i + 1], W[i + 2], W[i + 3]
        acc += w0
        cum[i] = acc
        acc += w1
        cum[i + 1] = acc
        acc += w2
        cum[i + 2] = acc
        acc += w3
        cum[i + 3] = acc
        x0, x1, x2, x3 = _fma_lanes(w0, w1, w2, w3, X, i, x0, x1, x2, x3)
        y0, y1, y2, y3 = _fma_lanes(w0, w1, w2, w3, Y, i, y0, y1, y2, y3)
        c0, c1, c2, c3 = _fma_lanes(w0, w1, w2, w3, C, i, c0, c1, c2, c3)
        s0, s1, s2, s3 = _fma_lanes(w0, w1, w2, w3, S, i, s0, s1, s2, s3)
        q0, q1, q2, q3 = _fma_lanes(w0, w1, w2, w3, W, i, q0, q1, q2, q3)   # W[i:i+4] = w
    for i in range(top, n):
        acc += W[i]
        cum[i] = acc
        x0 = vm.fma(W[i], X[i], x0)
        y0 = vm.fma(W[i], Y[i], y0)
        c0 = vm.fma(W[i], C[i], c0)
        s0 = vm.fma(W[i], S[i], s0)
        q0 = vm.fma(W[i], W[i], q0)
    out[0], out[1] = ((x0 + x1) + (x2 + x3)) / acc, ((y0 + y1) + (y2 + y3)) / acc
    out[2] = math.atan2((s0 + s1) + (s2 + s3), (c0 + c1) + (c2 + c3))
    return ess_of(acc, (q0 + q1) + (q2 + q3))


@kernel(types.UniTuple(types.float64, 3)(types.float64, types.float64, types.float64, types.int64,
                                       MCL_OPTIONS, RESET_PARAMS), cache=True, error_model="numpy")
def likelihood_averages(w_slow, w_fast, pm, m, o, rp):
    """Augmented MCL's long- and short-term averages after a step with m observations and mean
    likelihood pm; returns them with the injection probability max(0, 1 - w_fast / w_slow). The
    averages follow the likelihood per measurement component, pm^(1/c): steps see different
    numbers of beacons, and a product over more of them is not less likely in the sense the
    averages compare."""
    q = pm ** (1.0 / (m * (2 if o.sensor == SENSOR_RANGE_BEARING else 1)))
    if w_slow == 0.0:
        w_slow = q
        w_fast = q
    else:
        w_slow += rp.alpha_slow * (q - w_slow)
        w_fast += rp.alpha_fast * (q - w_fast)
    return w_slow, w_fast, max(0.0, 1.0 - w_fast / w_slow) if w_slow > 0.0 else 0.0


@kernel(types.void(_F, _F, MCL_OPTIONS, _I, _I, STATE), cache=True, error_model="numpy")
def ancestors(W, cum, o, idx, scratch, s):
    """The resampled set's ancestors idx of the weights W (cum: their running sums, from
    ``weighted_sums``; their sum cum[-1]) by the scheme of o."""
    S = cum[cum.size - 1]
    if o.scheme == SCHEME_SYSTEMATIC:
        systematic_from_sums(W, cum, S, s, idx, scratch)
    else:
        resample(o.scheme, W, S, s, idx)


@kernel(types.void(_F2, _F2, _F2, _F2, _I, types.int64), cache=True, error_model="numpy")
def gather_rows(P, CS, P2, CS2, idx, n):
    """The resampled set (rows, with the headings' cosines and sines) into P2, CS2."""
    for i in range(n):
        _copy_particle(P, CS, P2, CS2, i, idx[i])


@kernel(types.int64(types.int64, types.float64, RESET_PARAMS), cache=True, error_model="numpy")
def srl_resets(N, pm, rp):
    """How many of N particles SRL replaces by sensor draws at a step whose mean likelihood is
    pm: none unless pm < srl_threshold; then srl_fraction of N (fixed_fraction, rounded) or, as
    Lenser and Veloso (2000) define it, N (1 - pm / srl_threshold) (lenser_veloso, rounded, at
    most N)."""
    if not pm < rp.srl_threshold:
        return 0
    if rp.srl_rule == SRL_LENSER_VELOSO:
        return min(int(round(N * (1.0 - pm / rp.srl_threshold))), N)
    return int(round(rp.srl_fraction * N))


@kernel(types.int64(_F2, _F2, _F, _F2, types.int64, _I, _F2, MCL_OPTIONS, RESET_PARAMS,
                    types.float64, types.float64, _I, _F, STATE), cache=True, error_model="numpy")
def inject(P, CS, area, bc, m, ids, zs, o, rp, pm, prob, perm, pose, s):
    """Replace particles by poses drawn from the sensor model (or the field): augmented MCL each
    with probability prob; SRL when pm < srl_threshold srl_fraction of them (fixed_fraction) or
    N (1 - pm / srl_threshold) (lenser_veloso, ``srl_resets``); ASRL
    n_s = N max(0, 1 - pm / (mu p_t^c)) of them. Returns how many."""
    N = o.N
    k = 0
    if o.reset == RESET_AUGMENTED:
        drawn_from = m if o.inject_sensor else 0      # no observation: uniform over the field
        for i in range(N):
            if uniform(s) < prob:
                sensor_pose(area, o.sensor, bc, drawn_from, ids, zs, o.sr, o.sb, pose, s)
                P[0, i], P[1, i], P[2, i] = pose[0], pose[1], pose[2]
                trig_pass(P, i, i + 1, CS)
                k += 1
        return k
    if m == 0 or not (o.reset == RESET_SRL or o.reset == RESET_ASRL):
        return 0
    if o.reset == RESET_SRL:
        k = srl_resets(N, pm, rp)
    else:
        c = m * (2 if o.sensor == SENSOR_RANGE_BEARING else 1)
        k = min(int(round(N * max(0.0, 1.0 - pm / (rp.asrl_mu * rp.asrl_pt ** c)))), N)
    # replace k particles chosen at random (a partial Fisher-Yates shuffle: resampling leaves
    # the set ordered by its sources)
    for i in range(N):
        perm[i] = i
    for r in range(k):
        j = r + min(int(uniform(s) * (N - r)), N - r - 1)
        perm[r], perm[j] = perm[j], perm[r]
        sensor_pose(area, o.sensor, bc, m, ids, zs, o.sr, o.sb, pose, s)
        P[0, perm[r]], P[1, perm[r]], P[2, perm[r]] = pose[0], pose[1], pose[2]
        trig_pass(P, perm[r], perm[r] + 1, CS)
    return k


class MclWork(NamedTuple):
    """MCL's scratch for a set of at most N particles.

    idx (N,) : the resampled set's ancestors; scratch (N,) : the resampling scheme's
    perm (N,) : the injection's random choice of particles; pose (3,) : a pose drawn for it
    occ (``kld_bins``,) : KLD-sampling's dense histogram, all zero between steps (1 without it)
    touched (N,) : the bins KLD-sampling occupied in a step
    Z (2 N or 3 N,) : the move's normal draws, 2 or 3 a particle by the motion model
    """

    idx: np.ndarray
    scratch: np.ndarray
    perm: np.ndarray
    pose: np.ndarray
    occ: np.ndarray
    touched: np.ndarray
    Z: np.ndarray


MCL_WORK = types.NamedTuple((_I, _I, _I, _F, types.uint8[::1], _I, _F), MclWork)


@kernel(MCL_WORK(MCL_OPTIONS, _F, KLD_PARAMS), cache=True, error_model="numpy")
def new_mcl_work(o, area, kp):
    """The scratch (``MclWork``) of MCL with settings o on the field ``area`` (KLD: kp)."""
    N = o.N
    return MclWork(np.empty(N, dtype=np.int64), np.empty(N, dtype=np.int64),
                   np.empty(N, dtype=np.int64), np.empty(3),
                   np.zeros(kld_bins(area, kp) if o.kld else 1, dtype=np.uint8),
                   np.empty(N, dtype=np.int64),
                   np.empty(N * (2 if o.motion == MOTION_ODOMETRY else 3)))


@kernel(types.Tuple((_F2, _F2))(_F, INITIAL_BELIEF, types.int64, STATE), cache=True,
        error_model="numpy")
def initial_set(area, init, N, s):
    """The initial belief's N particles (``init_particles``) as rows x, y, heading (3, N), so
    that the passes over them vectorise, and their headings' cosines and sines (2, N)."""
    P0 = np.empty((N, 3))
    init_particles(P0, area, init, s)
    P = np.ascontiguousarray(P0.T)
    CS = np.empty((2, N))
    trig_pass(P, 0, N, CS)
    return P, CS


@kernel(types.UniTuple(types.int64, 2)(
    _F2, _F, types.int64, _F, MCL_OPTIONS, MOTION_NOISE, _F, KLD_PARAMS, MCL_WORK, types.float64,
    _F2, types.int64, _I, _F2, STATE, _F2), cache=True, error_model="numpy")
def kld_step(P, cum, n, u, o, mnoise, area, kp, wk, prob, bc, m, ids, zs, s, out):
    """KLD-sampling's step: resample the last step's weighted set (P[:, :n], running sums cum)
    and move by the odometry u in one loop (``kld_sample``), the new set into out, injecting
    with probability prob from the last step's m observations (ids, zs). Returns (the new
    count, how many were injected)."""
    return kld_sample(P, cum, n, u, o.motion, mnoise, area, kp, o.N, wk.occ, wk.touched, prob,
                      o.inject_sensor, o.sensor, bc, m, ids, zs, o.sr, o.sb, s, out)


MCL_SIG = types.int64(
    _F2, OBSERVATIONS, SCAN_MODEL, _F, MCL_OPTIONS, MOTION_NOISE, RESET_PARAMS, KLD_PARAMS,
    INITIAL_BELIEF, STATE, _F2, _F, _I, _I, _F, _I, SNAPSHOTS)


@kernel(MCL_SIG, cache=True, error_model="numpy")
def mcl_kernel(ctrl, obs, sm, area, o, mnoise, rp, kp, init, s, est, ess, resampled, injected,
               pmean, count, snap):
    """Run MCL over one trial (settings o, see ``MclOptions``); est (T+1, 3) the weighted pose
    estimate (est[0]: of the initial cloud), ess / resampled / injected / pmean / count (T,) per
    step. rp: the injection's parameters (``ResetParams``). o.kld: KLD-sampling
    with kp (``KldParams``), o.N the largest count; init: the initial belief (``InitialBelief``).
    obs: the observations (``Observations``); sm: the beacons sm.bc and the model's own
    log-likelihood, which weighs where sm.use (``ScanModel``, ``FieldModel.scan_model``).
    snap.steps: increasing steps at which the particles
    (after the step's move, before resampling; step 0: the initial cloud) are copied into
    snap.poses (S, N, 3), their count into snap.counts. Returns
    the steps whose weights all underflowed.

    Each step: move (sample the motion model), weigh, estimate, resample, inject; KLD-sampling
    resamples and moves in one loop at the start of the next step instead."""
    T, N = ctrl.shape[0], o.N
    bc = sm.bc
    P, CS = initial_set(area, init, N, s)       # particles as rows, their headings' cos, sin
    P2, CS2 = np.empty((3, N)), np.empty((2, N))    # the next set, swapped in when built
    lw, W, ll, cum = np.zeros(N), np.ones(N), np.empty(N), np.empty(N)
    wk = new_mcl_work(o, area, kp)
    n, events = N, 0
    w_slow = w_fast = prob = 0.0
    equal_weights = True    # the log-weights are all zero (an initial, resampled or drawn set)
    copy_due = False        # the set to move is the last step's resampled by wk.idx, not copied
    weighted_sums(P, W, N, CS, cum, est[0])
    si = snapshot(0, P, N, snap, 0, True)
    for t in range(T):
        if o.kld:       # resample (by the running sums in cum) and move, as many as bins ask
            tp = max(t - 1, 0)
            n, injected[t] = kld_step(P, cum, n, ctrl[t], o, mnoise, area, kp, wk, prob, bc,
                                      obs.n[tp] if t > 0 else 0, obs.ids[tp], obs.z[tp], s, P2)
            P, P2 = P2, P
            trig_pass(P, 0, n, CS)
            equal_weights = True
            resampled[t] = 1
        else:
            if copy_due:    # the resampled set is copied while the noise is drawn
                draws_copying(s, wk.Z, o.motion, P, CS, wk.idx, P2, CS2, N)
                P, P2, CS, CS2 = P2, P, CS2, CS
                copy_due = False
            else:
                fill_normal(s, wk.Z)
            move_particles(P, CS, wk.Z, ctrl[t], o, mnoise)
        count[t] = n
        m, ids, zs = obs.n[t], obs.ids[t], obs.z[t]
        under, lmax, acc, w_is_terms = weigh_observations(P, n, sm, m, ids, zs, o, lw, W, ll,
                                                          equal_weights)
        if equal_weights and under == 0.0:
            lw, ll = ll, lw         # the log-weights of such a set are its log-likelihoods
        events += int(under)
        equal_weights = False
        ess[t] = weighted_sums(P, W, n, CS, cum, est[t + 1])
        pm = mean_likelihood(lmax, cum[n - 1] if w_is_terms else acc, n)
        pmean[t] = pm
        si = snapshot(t + 1, P, n, snap, si, True)
        if o.reset == RESET_AUGMENTED and m > 0:
            w_slow, w_fast, prob = likelihood_averages(w_slow, w_fast, pm, m, o, rp)
        if o.kld:
            continue            # the next step's sampling resamples (and injects)
        resampled[t] = 0
        if ess[t] < o.threshold:
            ancestors(W, cum, o, wk.idx, wk.scratch, s)
            copy_due = o.reset == RESET_NONE    # nothing injected: the next step's draws copy it
            if not copy_due:
                gather_rows(P, CS, P2, CS2, wk.idx, N)
                P, P2, CS, CS2 = P2, P, CS2, CS
            equal_weights = True
            resampled[t] = 1
        injected[t] = inject(P, CS, area, bc, m, ids, zs, o, rp, pm, prob, wk.perm, wk.pose, s)
        if injected[t] > 0 and resampled[t] == 0:
            equal_weights = True    # injected particles join a set of equal weights
    return events


def reset_params(params) -> ResetParams:
    """The injection's parameters (``ResetParams``) from a filter run's keys."""
    return ResetParams(
        srl_fraction=float(params["srl_fraction"]), srl_threshold=float(params["srl_threshold"]),
        asrl_mu=float(params["asrl_mu"]), asrl_pt=float(params["asrl_pt"]),
        alpha_slow=float(params["alpha_slow"]), alpha_fast=float(params["alpha_fast"]),
        srl_rule=float(SRL_RULES[params["srl_rule"]]))


def kld_params(params, particles: int) -> KldParams:
    """KLD-sampling's parameters (``KldParams``) from a filter run's keys, for a set of at most
    ``particles``."""
    return KldParams(
        epsilon=float(params["kld_epsilon"]), z=float(kld_quantile(params["kld_delta"])),
        bin_m=float(params["kld_bin_m"]), bin_rad=float(math.radians(params["kld_bin_deg"])),
        n_min=float(min(params["kld_min"], particles)))


def run(model, data, params, particles, state, diag=True, snapshots=()):
    """Run MCL (with the configured injection) on a beacon-field trial; return the traces (with
    'snapshots': (steps, particles, counts) of the particles at the steps ``snapshots``)."""
    T = data.ctrl.shape[0]
    threshold = ess_threshold(params, particles)
    rp = reset_params(params)
    out = {"pose": np.empty((T + 1, 3)), "ess": np.empty(T),
           "resampled": np.zeros(T, dtype=np.int64), "injected": np.zeros(T, dtype=np.int64),
           "pmean": np.empty(T)}
    kld = params["sampling"] == "kld"
    kp = kld_params(params, particles)
    out["n"] = np.empty(T, dtype=np.int64)
    out["snapshots"] = snapshot_arrays(snapshots, particles)
    o = MclOptions(
        motion=int(model.motion), sensor=int(model.sensor), sr=model.sense.sr,
        sb=model.sense.sb, N=int(particles), threshold=float(threshold),
        scheme=SCHEME_CODES[params["resampling"]], reset=RESET[params["reset"]],
        inject_sensor=int(params["inject"] == "sensor"), kld=int(kld))
    out["underflow_steps"] = mcl_kernel(
        data.ctrl, observations(data), model.scan_model(), model.area, o, model.mnoise,
        rp, kp, model.init, state, out["pose"], out["ess"], out["resampled"], out["injected"],
        out["pmean"], out["n"], out["snapshots"])
    out["lik_evals_per_step"] = float(np.mean(out["n"]))
    return out


# The limits of KLD-sampling's keys, where its arithmetic stops making sense: the histogram (one
# byte a bin) must fit in memory and its index in int64; the bound n_chi (k - 1) / (2 epsilon)
# (...)^3 must fit in int64 for every k up to the bins; 1 - delta must differ from 1 by delta to
# a few digits in float64 (its normal quantile z is taken from it).
KLD_MAX_BINS = 2**26            # 64 MiB of histogram per worker
KLD_EPSILON_MIN = 1e-6
KLD_DELTA_MIN = 1e-9            # z_(1 - delta) ~ 6.0
KLD_BIN_M_MIN = 1e-3            # a millimetre
KLD_BIN_DEG_MIN = 1e-2


def mcl_keys() -> dict:
    pf = pf_keys()
    return {
        "resampling": pf["resampling"],
        "resample": pf["resample"],
        "neff_ratio": pf["neff_ratio"],
        "reset": Key("choice", "none", "particle injection: 'none' (MCL), 'srl' (sensor "
                     "resetting), 'asrl' (adaptive sensor resetting, asrl2008), 'augmented' "
                     "(augmented MCL with alpha_slow / alpha_fast)",
                     choices=("none", "srl", "asrl", "augmented")),
        "srl_rule": Key("choice", "fixed_fraction", "srl: how many particles are replaced by "
                        "sensor draws when the mean likelihood p_mean is below srl_threshold: "
                        "'fixed_fraction' srl_fraction of them (ours; asrl2008 never defines the "
                        "SRL it compares with), 'lenser_veloso' N (1 - p_mean / srl_threshold), "
                        "the count of the original sensor-resetting paper (Lenser and Veloso "
                        "2000)", choices=tuple(SRL_RULES)),
        "srl_fraction": Key("float", 0.1, "srl: fraction of the particles replaced by sensor "
                            "draws when the mean likelihood is below srl_threshold "
                            "(srl_rule fixed_fraction)", min=0.0, max=1.0),
        "srl_threshold": Key("float", 0.01, "srl: mean-likelihood threshold (a density in the "
                             "measurement's units)", min=0.0),
        "asrl_mu": Key("float", 1.0, "asrl: gain mu of n_s = N max(0, 1 - p_mean / (mu "
                       "p_t^c))", min=0.0, min_exclusive=True),
        "asrl_pt": Key("float", 0.5, "asrl: per-component likelihood threshold p_t", min=0.0,
                       min_exclusive=True),
        "alpha_slow": Key("float", 0.05, "augmented: rate of the long-term likelihood average",
                          min=0.0, max=1.0),
        "alpha_fast": Key("float", 0.5, "augmented: rate of the short-term average (> "
                          "alpha_slow)", min=0.0, max=1.0),
        "inject": Key("choice", "uniform", "augmented: injected poses uniform over the field or "
                      "drawn from the sensor model", choices=("uniform", "sensor")),
        "sampling": Key("choice", "fixed", "'fixed': the particle count stays at 'particles'; "
                        "'kld': KLD-sampling (Fox 2003), the count adapts each step, at most "
                        "'particles' (with reset none or augmented)", choices=("fixed", "kld")),
        "kld_epsilon": Key("float", 0.05, "kld: bound epsilon on the Kullback-Leibler error "
                           f"(at least {KLD_EPSILON_MIN:g}: the bound n ~ k / (2 epsilon) of k "
                           "bins then stays below 2^63 for every histogram allowed)",
                           min=KLD_EPSILON_MIN),
        "kld_delta": Key("float", 0.01, "kld: probability delta that the error exceeds it (at "
                         f"least {KLD_DELTA_MIN:g}: smaller, 1 - delta rounds in float64 before "
                         "its normal quantile is taken)", min=KLD_DELTA_MIN, max=0.5),
        "kld_bin_m": Key("float", 0.5, "kld: histogram bin size in x and y (Fox 2003: 0.5 m; at "
                         f"least {KLD_BIN_M_MIN:g} m, and the bins over the field at most "
                         f"2^{KLD_MAX_BINS.bit_length() - 1})", min=KLD_BIN_M_MIN),
        "kld_bin_deg": Key("float", 10.0, "kld: histogram bin size in heading (Fox 2003: 10 deg; "
                           f"at least {KLD_BIN_DEG_MIN:g} deg)", min=KLD_BIN_DEG_MIN,
                           max=360.0),
        "kld_min": Key("int", 50, "kld: fewest particles a step draws", min=1),
    }


def mcl_check(params) -> tuple[str, str] | None:
    """Cross-key rules of mcl: (key, message) of the first one broken."""
    if params["sampling"] == "kld" and params["reset"] in ("srl", "asrl"):
        return "reset", ("KLD-sampling resamples while it draws; it combines with reset 'none' "
                         "or 'augmented', not with sensor resetting")
    if params["reset"] == "augmented" and params["alpha_fast"] <= params["alpha_slow"]:
        return "alpha_fast", (f"expected alpha_fast > alpha_slow ({params['alpha_slow']!r}), "
                              f"got {params['alpha_fast']!r}")
    return None


def mcl_scenario_check(params, scenario: dict) -> tuple[str, str] | None:
    """Rules of mcl that need the scenario: KLD-sampling's histogram over the field (its
    ``area``) has at most KLD_MAX_BINS bins."""
    area = scenario.get("area")
    if params["sampling"] != "kld" or area is None or len(area) != 2:
        return None
    cells = [math.ceil(float(a) / params["kld_bin_m"]) for a in area]
    cells.append(math.ceil(360.0 / params["kld_bin_deg"]))
    bins = math.prod(cells)
    if bins > KLD_MAX_BINS:
        return "kld_bin_m", (f"a histogram of {' x '.join(map(str, cells))} = {bins:,} bins over "
                             f"the {float(area[0]):g} m x {float(area[1]):g} m field; at most "
                             f"{KLD_MAX_BINS:,} (2^{KLD_MAX_BINS.bit_length() - 1}): larger "
                             "kld_bin_m or kld_bin_deg")
    return None


MCL = FilterType("mcl", "Monte Carlo localization, optionally with sensor resetting (SRL, ASRL) "
                 "or augmented-MCL injection, or KLD-sampling", mcl_keys(), run,
                 kind="localization", check=mcl_check, snapshots=True,
                 check_scenario=mcl_scenario_check, needs=())
