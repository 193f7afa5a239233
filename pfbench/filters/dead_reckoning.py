"""Dead reckoning: the pose integrated from the odometry alone, from the true start pose, with no
measurement. It is the baseline a localization filter must beat: what the robot knows without its
sensor. Deterministic (no particles, no random draws): every trial gives the same path.

Each step applies the odometry [rot1, trans, rot2] as the field's motion models do:
    theta += rot1,  x += trans cos(theta),  y += trans sin(theta),  theta += rot2,
without noise. It starts from the true start pose (``FieldModel.start``) whatever the filters'
initial belief: on a global-localization scenario it is the path a robot that knew its start
would dead-reckon.
"""
from __future__ import annotations

import math

import numpy as np

from .types import FilterType


def integrate(start: np.ndarray, ctrl: np.ndarray) -> np.ndarray:
    """The poses (T+1, 3) (m, m, rad in [-pi, pi)) reached from ``start`` (3,) by the odometry
    ``ctrl`` (T, 3) [rot1, trans, rot2]."""
    pose = np.empty((ctrl.shape[0] + 1, 3))
    x, y, th = (float(v) for v in start)
    pose[0] = x, y, th
    for t, (r1, tr, r2) in enumerate(ctrl):
        th += r1
        x += tr * math.cos(th)
        y += tr * math.sin(th)
        th = math.remainder(th + r2, 2.0 * math.pi)
        pose[t + 1] = x, y, th
    pose[:, 2] = np.where(pose[:, 2] >= math.pi, pose[:, 2] - 2.0 * math.pi, pose[:, 2])
    return pose


def run(model, data, params, particles, state, diag=True, snapshots=()):
    """The dead-reckoned path of a localization trial (the particle count and generator state
    are unused)."""
    return {"pose": integrate(model.start, data.ctrl), "lik_evals_per_step": 0.0}


DEAD_RECKONING = FilterType(
    "dead_reckoning", "dead reckoning: the odometry integrated from the true start pose, no "
    "measurement (the baseline of a localization scenario)", {}, run, particles=False, cost="1",
    kind="localization", needs=())
