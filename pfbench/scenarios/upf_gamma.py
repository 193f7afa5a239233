"""The Gamma-noise benchmark of van der Merwe, Doucet, de Freitas & Wan, "The Unscented Particle
Filter" (2000), whose settings and values match ``sspf2008`` Table 1
(configs/papers/sspf2008.yaml).

    x_t = 1 + sin(w pi t) + 0.5 x_{t-1} + v_t,   v_t ~ Gamma(shape 3, rate 2)
    y_t = x_t^2 / 5 + n_t   (t <= 30),   y_t = x_t / 2 - 2 + n_t   (t > 30),   n_t ~ N(0, 1e-5)

with w = 0.04, x_1 = 1 and t = 2..60. Our step k = 1..59 is the paper's t = k + time_offset.
theta = [time_offset, sin_frequency, switch_time].
"""
from __future__ import annotations

import math

import numpy as np
from .._lazy import kernel

from ..schema import Key
from ..models.scalar import MODEL_SIG, simulate, NOISE_GAMMA, ScalarModel

NAME = "upf_gamma"
KIND = "scalar"
# what its model gives the filters beyond the kind (pfbench.protocols.NEEDS)
PROVIDES = ("jacobians", "gaussian_measurement", "likelihood")
DESCRIPTION = "van der Merwe et al. (2000) Gamma-noise benchmark (sspf2008 Table 1's source)"

SCHEMA = {
    "steps": Key("int", 59, "number of steps (the paper's t = 2..60)", min=1),
    "x0": Key("float", 1.0, "true initial state (the paper's x_1)"),
    "gamma_shape": Key("float", 3.0, "shape of the Gamma process noise", min=0.0,
                       min_exclusive=True),
    "gamma_rate": Key("float", 2.0, "rate of the Gamma process noise (mean shape / rate)", min=0.0,
                      min_exclusive=True),
    "measurement_noise_var": Key("float", 1.0e-5, "R, variance of n_t", min=0.0,
                                 min_exclusive=True),
    "switch_time": Key("float", 30.0, "last time (paper's t) of the quadratic observation"),
    "sin_frequency": Key("float", 0.04, "w in sin(w pi t)"),
    "time_offset": Key("int", 1, "paper's t = our step + time_offset"),
    "prior_mean": Key("float", None, "mean of the filters' Gaussian prior for x_0 (default: x0)",
                      nullable=True),
    "prior_var": Key("float", 0.75, "variance of the filters' prior (the benchmark's P0 = 3/4)",
                     min=0.0, min_exclusive=True),
}


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate"]


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition(x, t, theta, out):
    """f(x, t) = 1 + sin(w pi t) + 0.5 x (the noise mean is not included)."""
    c = 1.0 + math.sin(theta[1] * math.pi * (t + theta[0]))
    for i in range(x.size):
        out[i] = c + 0.5 * x[i]


@kernel(MODEL_SIG, cache=True, by_address=True)
def transition_jac(x, t, theta, out):
    for i in range(x.size):
        out[i] = 0.5


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe(x, t, theta, out):
    """h(x, t) = x^2 / 5 up to the switch time, x / 2 - 2 after it."""
    if t + theta[0] <= theta[2]:
        for i in range(x.size):
            out[i] = x[i] * x[i] / 5.0
    else:
        for i in range(x.size):
            out[i] = 0.5 * x[i] - 2.0


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe_jac(x, t, theta, out):
    if t + theta[0] <= theta[2]:
        for i in range(x.size):
            out[i] = 0.4 * x[i]
    else:
        for i in range(x.size):
            out[i] = 0.5


def build(p) -> ScalarModel:
    theta = np.array([float(p["time_offset"]), p["sin_frequency"], p["switch_time"]])
    noise = np.array([NOISE_GAMMA, p["gamma_shape"], p["gamma_rate"], p["measurement_noise_var"]])
    prior_mean = p["x0"] if p["prior_mean"] is None else p["prior_mean"]
    return ScalarModel(transition, observe, theta, noise, float(p["x0"]), float(prior_mean),
                       float(p["prior_var"]), int(p["steps"]), transition_jac, observe_jac)
