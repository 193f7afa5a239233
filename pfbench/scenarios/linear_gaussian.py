"""Scalar linear-Gaussian model, the exactness check of every filter (Kalman filter is optimal).

    x_t = a x_{t-1} + w_t,  w_t ~ N(0, Q);   y_t = c x_t + v_t,  v_t ~ N(0, R)

theta = [a, c].
"""
from __future__ import annotations

import numpy as np
from .._lazy import kernel

from ..schema import Key
from ..models.scalar import MODEL_SIG, simulate, NOISE_GAUSSIAN, ScalarModel

NAME = "linear_gaussian"
KIND = "scalar"
# what its model gives the filters beyond the kind (pfbench.protocols.NEEDS)
PROVIDES = ("jacobians", "gaussian_measurement", "likelihood", "linear")
DESCRIPTION = "scalar linear-Gaussian model; the exact Kalman filter ('kf') is the reference"

SCHEMA = {
    "steps": Key("int", 50, "number of time steps T", min=1),
    "a": Key("float", 0.9, "transition coefficient"),
    "c": Key("float", 1.0, "observation coefficient"),
    "process_noise_var": Key("float", 1.0, "Q, variance of w_t", min=0.0, min_exclusive=True),
    "measurement_noise_var": Key("float", 1.0, "R, variance of v_t", min=0.0, min_exclusive=True),
    "x0": Key("float", 0.0, "true initial state x_0"),
    "prior_mean": Key("float", None, "mean of the filters' Gaussian prior for x_0 (default: x0)",
                      nullable=True),
    "prior_var": Key("float", 1.0, "variance of the filters' prior for x_0", min=0.0,
                     min_exclusive=True),
}


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate"]


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition(x, t, theta, out):
    """f(x) = a x."""
    for i in range(x.size):
        out[i] = theta[0] * x[i]


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition_jac(x, t, theta, out):
    for i in range(x.size):
        out[i] = theta[0]


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe_jac(x, t, theta, out):
    for i in range(x.size):
        out[i] = theta[1]


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe(x, t, theta, out):
    """h(x) = c x."""
    for i in range(x.size):
        out[i] = theta[1] * x[i]


def build(p) -> ScalarModel:
    """Turn validated scenario parameters into a :class:`ScalarModel`."""
    theta = np.array([p["a"], p["c"]], dtype=np.float64)
    noise = np.array([NOISE_GAUSSIAN, p["process_noise_var"], 0.0, p["measurement_noise_var"]])
    prior_mean = p["x0"] if p["prior_mean"] is None else p["prior_mean"]
    return ScalarModel(transition, observe, theta, noise, float(p["x0"]), float(prior_mean),
                       float(p["prior_var"]), int(p["steps"]), transition_jac, observe_jac)
