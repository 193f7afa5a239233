"""A trial's observations as the localization and SLAM kernels take them: one record of the
three arrays a scenario's data holds (``obs_n``, ``obs_id``, ``obs_z``)."""
from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import types


class Observations(NamedTuple):
    """Step k's (or observation k's) n[k] observations: ids[k, :n[k]] the beacons' or
    landmarks' identities, z[k, :n[k]] their [range, bearing]."""

    n: np.ndarray       # (K,) int64
    ids: np.ndarray     # (K, B) int64
    z: np.ndarray       # (K, B, 2) float64


OBSERVATIONS = types.NamedTuple((types.int64[::1], types.int64[:, ::1], types.float64[:, :, ::1]),
                                Observations)


def observations(data) -> Observations:
    """The observations of a trial's data (a ``FieldData`` or a ``CourseData``)."""
    return Observations(data.obs_n, data.obs_id, data.obs_z)
