"""Beliefs over a robot's pose (x, y, heading) on a field [0, area[0]] x [0, area[1]]: the
filters' initial particles, the weighted mean pose, and snapshots of a particle set."""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..rng import STATE, normal, uniform

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]


class InitialBelief(NamedTuple):
    """The filters' initial belief over the pose: uniform over the field and heading (known 0),
    or Gaussian around the start (x, y, heading) with spreads sd_m (m) and sd_rad (rad)
    (known 1)."""

    known: int
    x: float
    y: float
    heading: float
    sd_m: float
    sd_rad: float


INITIAL_BELIEF = typeof(InitialBelief(0, 0.0, 0.0, 0.0, 1.0, 1.0))
_I = types.int64[::1]


@kernel(types.void(_F2, _F, INITIAL_BELIEF, STATE), cache=True)
def init_particles(P, area, init, s):
    """The filters' initial particles P (N, 3) drawn from the initial belief ``init``
    (``InitialBelief``)."""
    for i in range(P.shape[0]):
        if not init.known:
            P[i, 0] = area[0] * uniform(s)
            P[i, 1] = area[1] * uniform(s)
            P[i, 2] = math.pi * (2.0 * uniform(s) - 1.0)
        else:
            P[i, 0] = init.x + init.sd_m * normal(s)
            P[i, 1] = init.y + init.sd_m * normal(s)
            P[i, 2] = wrap(init.heading + init.sd_rad * normal(s))


@kernel(types.void(_F2, _F, types.int64, _F, types.boolean), cache=True)
def estimate_pose(P, W, n, out, rows):
    """The weighted mean pose of P[:n] (P[:, :n] with ``rows``: stored as rows x, y, heading;
    circular mean heading) into out."""
    ex = 0.0
    ey = 0.0
    ec = 0.0
    es = 0.0
    for i in range(n):
        x, y, th = (P[0, i], P[1, i], P[2, i]) if rows else (P[i, 0], P[i, 1], P[i, 2])
        ex += W[i] * x
        ey += W[i] * y
        ec += W[i] * math.cos(th)
        es += W[i] * math.sin(th)
    out[0], out[1], out[2] = ex, ey, math.atan2(es, ec)


class Snapshots(NamedTuple):
    """The particles at some steps: steps (S,) increasing, poses (S, N, 3) the particles at
    each, counts (S,) how many of them there were."""

    steps: np.ndarray
    poses: np.ndarray
    counts: np.ndarray


SNAPSHOTS = types.NamedTuple((_I, _F3, _I), Snapshots)


@kernel(types.int64(types.int64, _F2, types.int64, SNAPSHOTS, types.int64, types.boolean),
      cache=True)
def snapshot(t, P, n, snap, si, rows):
    """Copy the particles P[:n] (P[:, :n] with ``rows``: stored as rows x, y, heading) into
    snap.poses[si] (N, 3) when step t is the next snapshot step; return the index of the next
    snapshot."""
    if si < snap.steps.size and snap.steps[si] == t:
        if rows:
            snap.poses[si, :n] = P[:, :n].T
        else:
            snap.poses[si, :n] = P[:n]
        snap.counts[si] = n
        return si + 1
    return si


def snapshot_arrays(snapshots, particles: int) -> Snapshots:
    """(steps, particles (S, N, 3), counts (S,)) buffers for the snapshots at ``snapshots``."""
    steps = np.asarray(sorted(set(snapshots)), dtype=np.int64)
    return Snapshots(steps, np.zeros((steps.size, particles, 3)),
                     np.zeros(steps.size, dtype=np.int64))
