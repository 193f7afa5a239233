"""The beacon sensor: ranges (sensor 0) or ranges and bearings (sensor 1) to known beacons
bc (B, 2), with Gaussian noise of standard deviations sr (m) and sb (rad). A world simulates
what the robot sees (``sense_beacons``); a filter weighs a pose by the likelihood of a step's
observations (``pose_loglik``) and draws poses consistent with them (``sensor_pose``).
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..codes import SENSOR_RANGE, SENSOR_RANGE_BEARING
from ..rng import STATE, normal, uniform

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
    rmax, half_fov, sr, sb, nearest = (sense.max_range, sense.half_fov, sense.sr, sense.sb,
                                       sense.nearest)
    n = 0
    best = -1
    bd = np.inf
    cand = 0
    for b in range(bc.shape[0]):
        dx, dy = bc[b, 0] - x, bc[b, 1] - y
        r = math.hypot(dx, dy)
        if r > rmax:
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
        zs[n, 0] = r + sr * normal(s)
        zs[n, 1] = wrap(brg + sb * normal(s))
        n += 1
    if sensor == SENSOR_RANGE and best >= 0:
        ids[0] = best
        zs[0, 0] = math.hypot(bc[best, 0] - x, bc[best, 1] - y) + sr * normal(s)
        zs[0, 1] = 0.0
        n = 1
    return n


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
