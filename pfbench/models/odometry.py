"""The odometry motion model of a wheeled robot: each step reports [rot1, trans, rot2] (turn,
drive, turn), and the motion noise ``mnoise`` perturbs it.

MOTION_ODOMETRY (odometry with additive noise): trans + mnoise.trans n1, rot2 + mnoise.turn n2
(rot1 exact); MOTION_ROT_TRANS_ROT (Thrun, Burgard and Fox, Probabilistic Robotics 5.4): each
part's standard deviation grows with the motion, a1 |rot| + a2 |trans| for a turn and
a3 |trans| + a4 (|rot1| + |rot2|) for the drive, a1..a4 = mnoise.alpha1..alpha4.
"""
from __future__ import annotations

from typing import NamedTuple

from numba import typeof, types
from .._lazy import kernel

from ..codes import MOTION_ODOMETRY
from ..rng import STATE, normal

_F = types.float64[::1]
_ODO = types.UniTuple(types.float64, 3)


class MotionNoise(NamedTuple):
    """The odometry's noise: standard deviations trans (m) and turn (rad) of the additive model
    (MOTION_ODOMETRY), or alpha1..alpha4 of rot-trans-rot (MOTION_ROT_TRANS_ROT); the other
    model's fields are zero."""

    trans: float
    turn: float
    alpha1: float
    alpha2: float
    alpha3: float
    alpha4: float

    @classmethod
    def additive(cls, trans: float, turn: float) -> "MotionNoise":
        return cls(float(trans), float(turn), 0.0, 0.0, 0.0, 0.0)

    @classmethod
    def rot_trans_rot(cls, a1: float, a2: float, a3: float, a4: float) -> "MotionNoise":
        return cls(0.0, 0.0, float(a1), float(a2), float(a3), float(a4))


MOTION_NOISE = typeof(MotionNoise(1.0, 1.0, 1.0, 1.0, 1.0, 1.0))


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, MOTION_NOISE,
             types.float64, types.float64, types.float64), cache=True, inline="always")
def _odometry(rot1, trans, rot2, motion, mnoise, n1, n2, n3):
    """The odometry [rot1, trans, rot2] with the motion noise made of standard normal draws n1,
    n2 (and n3 for rot-trans-rot) (see the module)."""
    if motion == MOTION_ODOMETRY:
        return rot1, trans + mnoise.trans * n1, rot2 + mnoise.turn * n2
    a1, a2, a3, a4 = mnoise.alpha1, mnoise.alpha2, mnoise.alpha3, mnoise.alpha4
    return (rot1 + (a1 * abs(rot1) + a2 * abs(trans)) * n1,
            trans + (a3 * abs(trans) + a4 * (abs(rot1) + abs(rot2))) * n2,
            rot2 + (a1 * abs(rot2) + a2 * abs(trans)) * n3)


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, MOTION_NOISE, _F,
             types.int64), cache=True, inline="always")
def odometry_with(rot1, trans, rot2, motion, mnoise, z, o):
    """The odometry with the noise of the draws z[o], z[o + 1] (and z[o + 2] for
    rot-trans-rot), in order."""
    return _odometry(rot1, trans, rot2, motion, mnoise, z[o], z[o + 1],
                     z[o + 2] if motion != MOTION_ODOMETRY else 0.0)


@kernel(_ODO(types.float64, types.float64, types.float64, types.int64, MOTION_NOISE, STATE),
        cache=True, inline="always")
def noisy_odometry(rot1, trans, rot2, motion, mnoise, s):
    """The odometry [rot1, trans, rot2] with one draw of the motion noise (see the module)."""
    n1 = normal(s)
    n2 = normal(s)
    return _odometry(rot1, trans, rot2, motion, mnoise, n1, n2,
                     normal(s) if motion != MOTION_ODOMETRY else 0.0)
