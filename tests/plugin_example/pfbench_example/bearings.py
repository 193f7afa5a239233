"""Bearings-only tracking of a target on a straight road, a scalar pfbench scenario.

A sensor stands ``offset_m`` beside a straight road, across from the road's point ``sensor_at_m``.
The target's position x_t along the road moves at a known speed with Gaussian jitter, and the
sensor measures only the bearing to it:

    x_t = x_{t-1} + speed dt + w_t,           w_t ~ N(0, Q)
    y_t = atan2(x_t - sensor_at, offset) + v_t,  v_t ~ N(0, R)   (radians)

Near the sensor a bearing pins the target down; far away the bearings flatten out (dh/dx falls as
offset / (offset^2 + (x - s)^2)) and the position is barely observable. A filter that linearises
h there (the EKF) now and then loses the target, which shows in the spread of its errors.

The model functions are numba ``@njit`` functions with pfbench's scalar signature
(``pfbench.models.scalar.MODEL_SIG``): pfbench's compiled filters call them for the whole
particle set at once. ``cache=True`` keeps them in numba's on-disk cache beside pfbench's kernels.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from pfbench.models.scalar import MODEL_SIG, NOISE_GAUSSIAN, ScalarModel, simulate
from pfbench.schema import Key

NAME = "bearings_road"
KIND = "scalar"
DESCRIPTION = ("bearings-only tracking of a target on a straight road from a sensor beside it "
               "(an example plug-in)")

SCHEMA = {
    "steps": Key("int", 60, "number of time steps T", min=1),
    "dt_s": Key("float", 1.0, "time step (s)", min=0.0, min_exclusive=True),
    "speed_mps": Key("float", 2.0, "the target's known speed along the road (m/s)"),
    "process_noise_var": Key("float", 4.0, "Q, variance of the position jitter w_t (m^2)",
                             min=0.0, min_exclusive=True),
    "bearing_noise_deg": Key("float", 2.0, "standard deviation of the bearing noise v_t (deg)",
                             min=0.0, min_exclusive=True),
    "offset_m": Key("float", 2.0, "the sensor's distance from the road (m)", min=0.0,
                    min_exclusive=True),
    "sensor_at_m": Key("float", 60.0, "the road point across from the sensor (m)"),
    "x0": Key("float", 0.0, "true initial position x_0 (m)"),
    "prior_var": Key("float", 100.0, "variance of the filters' Gaussian prior for x_0, centred on "
                     "x0 (m^2)", min=0.0, min_exclusive=True),
}

__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate"]

# theta = [speed dt, sensor_at, offset]


@njit(MODEL_SIG, cache=True)
def transition(x, t, theta, out):
    """f(x) = x + speed dt."""
    for i in range(x.size):
        out[i] = x[i] + theta[0]


@njit(MODEL_SIG, cache=True)
def transition_jac(x, t, theta, out):
    """df/dx = 1."""
    for i in range(x.size):
        out[i] = 1.0


@njit(MODEL_SIG, cache=True)
def observe(x, t, theta, out):
    """h(x) = atan2(x - sensor_at, offset)."""
    for i in range(x.size):
        out[i] = math.atan2(x[i] - theta[1], theta[2])


@njit(MODEL_SIG, cache=True)
def observe_jac(x, t, theta, out):
    """dh/dx = offset / (offset^2 + (x - sensor_at)^2)."""
    for i in range(x.size):
        d = x[i] - theta[1]
        out[i] = theta[2] / (theta[2] * theta[2] + d * d)


def build(p) -> ScalarModel:
    """Turn validated scenario parameters into pfbench's ScalarModel."""
    theta = np.array([p["speed_mps"] * p["dt_s"], p["sensor_at_m"], p["offset_m"]])
    noise = np.array([NOISE_GAUSSIAN, p["process_noise_var"], 0.0,
                      math.radians(p["bearing_noise_deg"]) ** 2])
    return ScalarModel(transition, observe, theta, noise, float(p["x0"]), float(p["x0"]),
                       float(p["prior_var"]), int(p["steps"]), transition_jac, observe_jac)
