"""Univariate nonlinear growth model (UNGM), the benchmark of ifa2021 Table 1 and sspf2008.

    x_t = 0.5 x_{t-1} + 25 x_{t-1} / (1 + x_{t-1}^2) + 8 cos(1.2 t') + w_t,   w_t ~ N(0, Q)
    y_t = x_t^2 / 20 + v_t,                                                 v_t ~ N(0, R)

``ifa2021`` (Table 1) prints the denominator as ``1 - x^2`` (a typo: every filter diverges) and the
cosine argument as t' = t - 1; ``sspf2008`` (Table 1) uses ``1 + x^2`` and t' = t. Both are keys.
theta = [sign, cos_shift]: denominator 1 + sign x^2, t' = t - cos_shift.
"""
from __future__ import annotations

import math

import numpy as np
from .._lazy import kernel

from ..schema import Key
from ..models.scalar import MODEL_SIG, simulate, NOISE_GAUSSIAN, ScalarModel

NAME = "ungm"
KIND = "scalar"
# what its model gives the filters beyond the kind (pfbench.protocols.NEEDS)
PROVIDES = ("jacobians", "gaussian_measurement", "likelihood")
DESCRIPTION = "univariate nonlinear growth model (ifa2021, sspf2008 Table 1)"

SCHEMA = {
    "steps": Key("int", 100, "number of time steps T (measurements at t = 1..T)", min=1),
    "process_noise_var": Key("float", 1.0, "Q, variance of w_t", min=0.0, min_exclusive=True),
    "measurement_noise_var": Key("float", 1.0, "R, variance of v_t", min=0.0, min_exclusive=True),
    "x0": Key("float", 0.0, "true initial state x_0"),
    "denominator": Key("choice", "plus", "'plus': 1 + x^2 (the standard model); 'minus': 1 - x^2 "
                       "as ifa2021 prints it", choices=("plus", "minus")),
    "cosine_time": Key("choice", "t", "argument of the cosine: 't' (8 cos(1.2 t)) or 't_minus_1' "
                       "(8 cos(1.2 (t-1)), as ifa2021 prints it)", choices=("t", "t_minus_1")),
    "prior_mean": Key("float", None, "mean of the filters' Gaussian prior for x_0 (default: x0); "
                      "neither paper states it", nullable=True),
    "prior_var": Key("float", 1.0, "variance of the filters' prior for x_0 (not stated by either "
                     "paper)", min=0.0, min_exclusive=True),
}


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate"]


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition(x, t, theta, out):
    """f(x, t) = 0.5 x + 25 x / (1 + sign x^2) + 8 cos(1.2 (t - shift))."""
    sign = theta[0]
    c = 8.0 * math.cos(1.2 * (t - theta[1]))
    for i in range(x.size):
        xi = x[i]
        out[i] = 0.5 * xi + 25.0 * xi / (1.0 + sign * xi * xi) + c


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition_jac(x, t, theta, out):
    """df/dx = 0.5 + 25 (1 - sign x^2) / (1 + sign x^2)^2."""
    sign = theta[0]
    for i in range(x.size):
        x2 = x[i] * x[i]
        d = 1.0 + sign * x2
        out[i] = 0.5 + 25.0 * (1.0 - sign * x2) / (d * d)


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe(x, t, theta, out):
    """h(x) = x^2 / 20."""
    for i in range(x.size):
        out[i] = x[i] * x[i] / 20.0


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe_jac(x, t, theta, out):
    """dh/dx = x / 10."""
    for i in range(x.size):
        out[i] = x[i] / 10.0


def build(p) -> ScalarModel:
    """Turn validated scenario parameters into a :class:`ScalarModel`."""
    theta = np.array([1.0 if p["denominator"] == "plus" else -1.0,
                      0.0 if p["cosine_time"] == "t" else 1.0])
    noise = np.array([NOISE_GAUSSIAN, p["process_noise_var"], 0.0, p["measurement_noise_var"]])
    prior_mean = p["x0"] if p["prior_mean"] is None else p["prior_mean"]
    return ScalarModel(transition, observe, theta, noise, float(p["x0"]), float(prior_mean),
                       float(p["prior_var"]), int(p["steps"]), transition_jac, observe_jac)
