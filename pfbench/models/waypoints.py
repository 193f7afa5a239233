"""Driving a closed path of waypoints: the waypoint a robot heads for, and the laps it has
driven. Every robot world of pfbench (the SLAM courses, the beacon fields) drives this way."""
from __future__ import annotations

from numba import types
from .._lazy import kernel

_F2 = types.float64[:, ::1]


@kernel(types.UniTuple(types.int64, 2)(_F2, types.int64, types.int64, types.float64, types.float64,
                                     types.float64), cache=True)
def next_waypoint(wp, iw, lap, x, y, radius):
    """(waypoint to drive to, laps completed) from (x, y): the next waypoint once the current one
    is within ``radius``, the lap count growing when the path closes."""
    dx, dy = wp[iw, 0] - x, wp[iw, 1] - y
    if dx * dx + dy * dy < radius * radius:
        iw += 1
        if iw == wp.shape[0]:
            iw = 0
            lap += 1
    return iw, lap

