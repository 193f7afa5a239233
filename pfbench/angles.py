"""The one angle wrap, used for innovations, pose differences and heading errors."""
from __future__ import annotations

import math

from numba import njit, types


@njit(types.float64(types.float64), cache=True)
def wrap(a):
    """a wrapped to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi
