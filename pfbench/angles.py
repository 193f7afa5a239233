"""The one angle wrap, used for innovations, pose differences and heading errors.

``pfbench.vecmath.wrap`` is the same wrap written so that a loop calling it vectorises (a floor
instead of the remainder: outside [-pi, pi) the two may differ in the last bit); MCL's passes use
it.
"""
from __future__ import annotations

import math

from numba import types
from ._lazy import kernel


@kernel(types.float64(types.float64), cache=True, by_address=True)
def wrap(a):
    """a wrapped to [-pi, pi); an angle already inside is returned as it is (exact, and the
    common case is fast)."""
    if -math.pi <= a < math.pi:
        return a
    return (a + math.pi) % (2.0 * math.pi) - math.pi
