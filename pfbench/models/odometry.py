"""The odometry motion model of a wheeled robot: each step reports [rot1, trans, rot2] (turn,
drive, turn), and the motion noise ``mnoise`` perturbs it.

motion 0 (odometry with additive noise): trans + mnoise[0] n1, rot2 + mnoise[1] n2 (rot1 exact);
motion 1 (rot-trans-rot, Thrun, Burgard and Fox, Probabilistic Robotics 5.4): each part's
standard deviation grows with the motion, a1 |rot| + a2 |trans| for a turn and
a3 |trans| + a4 (|rot1| + |rot2|) for the drive, mnoise = [a1, a2, a3, a4].
"""
from __future__ import annotations

from numba import types
from .._lazy import kernel

from ..codes import MOTION_ODOMETRY
from ..rng import STATE, normal

_F = types.float64[::1]
_ODO = types.UniTuple(types.float64, 3)


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, _F, types.float64,
           types.float64, types.float64), cache=True, inline="always")
def _odometry(rot1, trans, rot2, motion, mnoise, n1, n2, n3):
    """The odometry [rot1, trans, rot2] with the motion noise made of standard normal draws n1,
    n2 (and n3 for rot-trans-rot) (see the module)."""
    if motion == MOTION_ODOMETRY:
        return rot1, trans + mnoise[0] * n1, rot2 + mnoise[1] * n2
    a1, a2, a3, a4 = mnoise[0], mnoise[1], mnoise[2], mnoise[3]
    return (rot1 + (a1 * abs(rot1) + a2 * abs(trans)) * n1,
            trans + (a3 * abs(trans) + a4 * (abs(rot1) + abs(rot2))) * n2,
            rot2 + (a1 * abs(rot2) + a2 * abs(trans)) * n3)


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, _F, _F, types.int64),
      cache=True, inline="always")
def odometry_with(rot1, trans, rot2, motion, mnoise, z, o):
    """The odometry with the noise of the draws z[o], z[o + 1] (and z[o + 2] for
    rot-trans-rot), in order."""
    return _odometry(rot1, trans, rot2, motion, mnoise, z[o], z[o + 1],
                     z[o + 2] if motion != MOTION_ODOMETRY else 0.0)


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, _F, STATE), cache=True,
      inline="always")
def noisy_odometry(rot1, trans, rot2, motion, mnoise, s):
    """The odometry [rot1, trans, rot2] with one draw of the motion noise (see the module)."""
    n1 = normal(s)
    n2 = normal(s)
    return _odometry(rot1, trans, rot2, motion, mnoise, n1, n2,
                     normal(s) if motion != MOTION_ODOMETRY else 0.0)
