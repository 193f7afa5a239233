"""The beacon sensor: ranges (sensor 0) or ranges and bearings (sensor 1) to known beacons
bc (B, 2), with Gaussian noise of standard deviations sr (m) and sb (rad). A world simulates
what the robot sees (``sense_beacons``); a filter weighs a pose by the likelihood of a step's
observations (``pose_loglik``) and draws poses consistent with them (``sensor_pose``).

A field model may bring its own measurement model instead of the Gaussian (``FieldModel.loglik``
and ``.sample``): numba functions on arrays of particles, of the signatures

- ``SCAN_LIK_SIG``, ``loglik(X, Y, H, bc, m, ids, zs, theta, out)``: out[i] = log p(z | pose i),
  the log density of the step's m observations (beacons ids[:m], [range, bearing] zs[:m]) seen
  from the pose (X[i], Y[i], H[i]) (m, m, rad), for i < X.size, with its constants (MCL's
  resets compare the mean likelihood with thresholds); -inf where a pose cannot have produced
  them (a step where every particle's is -inf or NaN counts as an underflow step);
- ``SCAN_SAMPLE_SIG``, ``sample(x, y, th, bc, theta, s, ids, zs) -> n``: the observations seen
  from the true pose (x, y, th) into ids[:n], zs[:n] (each [range, bearing]; a range sensor's
  bearing 0), its random numbers from the generator state ``s`` (``pfbench.rng``); returns n.

``theta`` (float64[::1]) is the model's own parameters (``FieldModel.theta``). The built-in
``mixture_loglik`` / ``mixture_sample`` are Thrun, Burgard and Fox's beam model reduced to its
hit and random parts: a range is, with probability eps, an outlier uniform over [0, rmax], else
the true range with Gaussian noise (the beacon field's key ``range_outliers``); a range-bearing
sensor's bearing, independently, with probability eps_b uniform over the field of view, else the
true bearing with Gaussian noise (``bearing_outliers``).
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from numba.core.typing.typeof import typeof_impl
from .._lazy import kernel

from ..angles import wrap
from ..codes import SENSOR_RANGE, SENSOR_RANGE_BEARING
from ..rng import STATE, normal, uniform
from .scalar import ModelFunction

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]


class BeaconSensor(NamedTuple):
    """What the robot's sensor sees of the beacons: those within max_range (m) and half_fov
    (rad) of its heading, with Gaussian noise of standard deviations sr (range, m) and sb
    (bearing, rad); a range sensor's one answer is the nearest beacon in range when ``nearest``
    is 1, else one of them at random."""

    max_range: float
    half_fov: float
    sr: float
    sb: float
    nearest: int


BEACON_SENSOR = typeof(BeaconSensor(1.0, 1.0, 1.0, 1.0, 0))
_I = types.int64[::1]

LOG_2PI = math.log(2.0 * math.pi)


@kernel(types.int64(_F2, types.float64, types.float64, types.float64, types.int64, BEACON_SENSOR,
                    STATE, _I, _F2), cache=True)
def sense_beacons(bc, x, y, th, sensor, sense, s, ids, zs):
    """Fill the observations seen from (x, y, th) into ids / zs; return how many."""
    return _scan(bc, x, y, th, sensor, sense, 0, 0.0, 0.0, 0.0, s, ids, zs)


@kernel(types.float64(types.float64, types.float64, types.float64, _F2, types.int64, _I, _F2,
                    types.int64, types.float64, types.float64), cache=True)
def pose_quad(x, y, th, bc, n, ids, zs, sensor, sr, sb):
    """-1/2 the sum of the squared normalised residuals of the n observations (ids, zs) of a step
    seen from a pose: log p(z | pose) up to loglik_const."""
    acc = 0.0
    for j in range(n):
        b = ids[j]
        dx, dy = bc[b, 0] - x, bc[b, 1] - y
        v = (zs[j, 0] - math.sqrt(dx * dx + dy * dy)) / sr
        acc -= 0.5 * v * v
        if sensor == SENSOR_RANGE_BEARING:
            u = wrap(zs[j, 1] - (math.atan2(dy, dx) - th)) / sb
            acc -= 0.5 * u * u
    return acc


@kernel(types.float64(types.int64, types.int64, types.float64, types.float64), cache=True)
def loglik_const(n, sensor, sr, sb):
    """The Gaussian normalisation of n observations' log-likelihood."""
    c = -math.log(sr) - 0.5 * LOG_2PI
    if sensor == SENSOR_RANGE_BEARING:
        c += -math.log(sb) - 0.5 * LOG_2PI
    return n * c


@kernel(types.float64(types.float64, types.float64, types.float64, _F2, types.int64, _I, _F2,
                    types.int64, types.float64, types.float64), cache=True)
def pose_loglik(x, y, th, bc, n, ids, zs, sensor, sr, sb):
    """log p(z | pose) of the n observations (ids, zs) of a step."""
    return pose_quad(x, y, th, bc, n, ids, zs, sensor, sr, sb) + loglik_const(n, sensor, sr, sb)


@kernel(types.void(_F, types.int64, _F2, types.int64, _I, _F2, types.float64, types.float64, _F,
                 STATE), cache=True)
def sensor_pose(area, sensor, bc, n, ids, zs, sr, sb, out, s):
    """A pose drawn from the sensor model of the step's observations into out (3,): consistent
    with one observation chosen at random (uniform over the field when there is none)."""
    if n == 0:
        out[0] = area[0] * uniform(s)
        out[1] = area[1] * uniform(s)
        out[2] = math.pi * (2.0 * uniform(s) - 1.0)
        return
    j = min(int(uniform(s) * n), n - 1)
    b = ids[j]
    r = max(zs[j, 0] + sr * normal(s), 0.0)
    a = math.pi * (2.0 * uniform(s) - 1.0)        # direction from the robot to the beacon
    out[0] = bc[b, 0] - r * math.cos(a)
    out[1] = bc[b, 1] - r * math.sin(a)
    if sensor == SENSOR_RANGE_BEARING:
        out[2] = wrap(a - (zs[j, 1] + sb * normal(s)))
    else:
        out[2] = math.pi * (2.0 * uniform(s) - 1.0)


# --- a field model's own measurement model (see the module's docstring) ------------------------

SCAN_LIK_SIG = types.void(_F, _F, _F, _F2, types.int64, _I, _F2, _F, _F)
ScanLikFn = types.FunctionType(SCAN_LIK_SIG)
SCAN_SAMPLE_SIG = types.int64(types.float64, types.float64, types.float64, _F2, _F, STATE, _I,
                              _F2)
ScanSampleFn = types.FunctionType(SCAN_SAMPLE_SIG)


class ScanLikelihoodFunction(ModelFunction):
    """A field model's log-likelihood of a step's observations (``SCAN_LIK_SIG``) as the kernels
    take it: the address of its compiled entry (see ``pfbench.models.scalar.ModelFunction``)."""

    SIG, SIG_NAME, WHAT = SCAN_LIK_SIG, "SCAN_LIK_SIG", "scan log-likelihood"
    ARGS = ("(X: float64[::1], Y: float64[::1], H: float64[::1], bc: float64[:, ::1], m: int64, "
            "ids: int64[::1], zs: float64[:, ::1], theta: float64[::1], out: float64[::1]) "
            "-> void")


class ScanSamplerFunction(ModelFunction):
    """A field model's sampler of a step's observations (``SCAN_SAMPLE_SIG``) as the kernels
    take it."""

    SIG, SIG_NAME, WHAT = SCAN_SAMPLE_SIG, "SCAN_SAMPLE_SIG", "scan sampler"
    ARGS = ("(x: float64, y: float64, th: float64, bc: float64[:, ::1], theta: float64[::1], "
            "s: uint64[::1], ids: int64[::1], zs: float64[:, ::1]) -> int64")


@typeof_impl.register(ScanLikelihoodFunction)
def _typeof_scan_likelihood(val, c):
    return ScanLikFn


@typeof_impl.register(ScanSamplerFunction)
def _typeof_scan_sampler(val, c):
    return ScanSampleFn


class ScanModel(NamedTuple):
    """What weighs a step's observations, as the localization kernels take it: the beacons bc
    (B, 2), the model's own log-likelihood ``loglik`` (a ``ScanLikelihoodFunction``, or the
    placeholder), ``use`` 1 to weigh by it (0: the Gaussian sensor, inline) and its parameters
    theta (``FieldModel.scan_model``)."""

    bc: np.ndarray
    loglik: object
    use: int
    theta: np.ndarray


SCAN_MODEL = types.NamedTuple((_F2, ScanLikFn, types.int64, _F), ScanModel)


@functools.cache
def scan_placeholder(cls):
    """The placeholder of a ``cls`` (ScanLikelihoodFunction or ScanSamplerFunction) that the
    kernels take where the model has none (and never call), looked up once."""
    return cls(no_scan_loglik if cls is ScanLikelihoodFunction else no_scan_sample)


@kernel(SCAN_LIK_SIG, cache=True, by_address=True)
def no_scan_loglik(X, Y, H, bc, m, ids, zs, theta, out):
    """The placeholder of a field model without its own log-likelihood (never called)."""
    out[:] = np.nan


@kernel(SCAN_SAMPLE_SIG, cache=True, by_address=True)
def no_scan_sample(x, y, th, bc, theta, s, ids, zs):
    """The placeholder of a field model without its own sampler (never called)."""
    return 0


# theta of the built-in mixture: the sensor, its visibility and noise, the outliers
(MIX_SENSOR, MIX_MAX_RANGE, MIX_HALF_FOV, MIX_SR, MIX_SB, MIX_NEAREST, MIX_EPS, MIX_RMAX,
 MIX_EPS_B) = range(9)


def mixture_theta(sensor: int, sense: BeaconSensor, eps: float, rmax: float,
                  eps_b: float = 0.0) -> np.ndarray:
    """theta of ``mixture_loglik`` / ``mixture_sample``: the sensor code, its ``BeaconSensor``,
    the range outlier probability eps, the outliers' largest range rmax (m) and the bearing
    outlier probability eps_b (a range-bearing sensor's)."""
    return np.array([sensor, sense.max_range, sense.half_fov, sense.sr, sense.sb, sense.nearest,
                     eps, rmax, eps_b], dtype=np.float64)


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64),
        cache=True, inline="always")
def mixture_range_logpdf(z, r, sr, eps, rmax):
    """log((1 - eps) N(z; r, sr^2) + eps U(z; 0, rmax)): a measured range z (m) of the true range
    r under the hit-and-random mixture."""
    v = (z - r) / sr
    hit = math.log1p(-eps) - 0.5 * v * v - math.log(sr) - 0.5 * LOG_2PI
    if not (eps > 0.0 and 0.0 <= z <= rmax):
        return hit
    rnd = math.log(eps / rmax)
    hi, lo = (hit, rnd) if hit > rnd else (rnd, hit)
    return hi + math.log1p(math.exp(lo - hi))


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64),
        cache=True, inline="always")
def mixture_bearing_logpdf(z, b, sb, eps, half_fov):
    """log((1 - eps) N(wrap(z - b); 0, sb^2) + eps U(z; -half_fov, half_fov)): a measured
    bearing z (rad) of the true bearing b under the hit-and-random mixture over the field of
    view [-half_fov, half_fov]."""
    u = wrap(z - b) / sb
    hit = math.log1p(-eps) - 0.5 * u * u - math.log(sb) - 0.5 * LOG_2PI
    if not (eps > 0.0 and abs(z) <= half_fov):
        return hit
    rnd = math.log(eps / (2.0 * half_fov))
    hi, lo = (hit, rnd) if hit > rnd else (rnd, hit)
    return hi + math.log1p(math.exp(lo - hi))


@kernel(SCAN_LIK_SIG, cache=True, by_address=True, error_model="numpy")
def mixture_loglik(X, Y, H, bc, m, ids, zs, theta, out):
    """log p(z | pose) of the hit-and-random range mixture (theta: ``mixture_theta``); the
    bearings of a range-bearing sensor Gaussian as the plain sensor's, or with bearing outliers
    (eps_b > 0) their mixture (``mixture_bearing_logpdf``)."""
    sensor, sr, sb = int(theta[MIX_SENSOR]), theta[MIX_SR], theta[MIX_SB]
    eps, rmax = theta[MIX_EPS], theta[MIX_RMAX]
    eps_b, half_fov = theta[MIX_EPS_B], theta[MIX_HALF_FOV]
    cb = -math.log(sb) - 0.5 * LOG_2PI
    for i in range(X.size):
        acc = 0.0
        for j in range(m):
            b = ids[j]
            dx, dy = bc[b, 0] - X[i], bc[b, 1] - Y[i]
            acc += mixture_range_logpdf(zs[j, 0], math.sqrt(dx * dx + dy * dy), sr, eps, rmax)
            if sensor == SENSOR_RANGE_BEARING and eps_b > 0.0:
                acc += mixture_bearing_logpdf(zs[j, 1], math.atan2(dy, dx) - H[i], sb, eps_b,
                                              half_fov)
            elif sensor == SENSOR_RANGE_BEARING:
                u = wrap(zs[j, 1] - (math.atan2(dy, dx) - H[i])) / sb
                acc += cb - 0.5 * u * u
        out[i] = acc


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, STATE),
        cache=True)
def mixture_range(r, sr, eps, rmax, s):
    """A range measured of the true range r: with probability eps uniform over [0, rmax], else
    r + sr N(0, 1)."""
    if uniform(s) < eps:
        return rmax * uniform(s)
    return r + sr * normal(s)


@kernel(types.int64(_F2, types.float64, types.float64, types.float64, types.int64, BEACON_SENSOR,
                    types.int64, types.float64, types.float64, types.float64, STATE, _I, _F2),
        cache=True, inline="always")
def _scan(bc, x, y, th, sensor, sense, mix, eps, rmax, eps_b, s, ids, zs):
    """The observations seen from (x, y, th) into ids / zs (``sense_beacons``); each range r
    measured as r + sr N(0, 1), or with ``mix`` from the hit-and-random mixture
    (``mixture_range``: eps, rmax); each bearing b as b + sb N(0, 1), or with probability eps_b
    (> 0) uniform over the field of view. Returns how many."""
    rmax_see, half_fov, sr, sb, nearest = (sense.max_range, sense.half_fov, sense.sr, sense.sb,
                                           sense.nearest)
    n = 0
    best = -1
    bd = np.inf
    cand = 0
    for b in range(bc.shape[0]):
        dx, dy = bc[b, 0] - x, bc[b, 1] - y
        r = math.hypot(dx, dy)
        if r > rmax_see:
            continue
        if sensor == SENSOR_RANGE:
            # one answer: the nearest, or uniformly among those in range (reservoir sampling)
            if nearest:
                if r < bd:
                    bd = r
                    best = b
            else:
                cand += 1
                if uniform(s) * cand < 1.0:
                    best = b
            continue
        brg = wrap(math.atan2(dy, dx) - th)
        if abs(brg) > half_fov:
            continue
        ids[n] = b
        zs[n, 0] = mixture_range(r, sr, eps, rmax, s) if mix else r + sr * normal(s)
        if eps_b > 0.0 and uniform(s) < eps_b:
            zs[n, 1] = half_fov * (2.0 * uniform(s) - 1.0)
        else:
            zs[n, 1] = wrap(brg + sb * normal(s))
        n += 1
    if sensor == SENSOR_RANGE and best >= 0:
        ids[0] = best
        r = math.hypot(bc[best, 0] - x, bc[best, 1] - y)
        zs[0, 0] = mixture_range(r, sr, eps, rmax, s) if mix else r + sr * normal(s)
        zs[0, 1] = 0.0
        n = 1
    return n


@kernel(SCAN_SAMPLE_SIG, cache=True, by_address=True)
def mixture_sample(x, y, th, bc, theta, s, ids, zs):
    """``sense_beacons`` (the same beacons seen, the same bearings' noise) with each range drawn
    from the hit-and-random mixture (``mixture_range``), and each bearing with probability eps_b
    uniform over the field of view; theta: ``mixture_theta``."""
    sense = BeaconSensor(theta[MIX_MAX_RANGE], theta[MIX_HALF_FOV], theta[MIX_SR], theta[MIX_SB],
                         1 if theta[MIX_NEAREST] != 0.0 else 0)
    return _scan(bc, x, y, th, int(theta[MIX_SENSOR]), sense, 1, theta[MIX_EPS],
                 theta[MIX_RMAX], theta[MIX_EPS_B], s, ids, zs)
