"""The scalar state-space model shared by the generic filter kernels.

    x_t = f(x_{t-1}, t) + w_t,   y_t = h(x_t, t) + v_t,   v_t ~ N(0, R),   t = 1..T

Model functions are module-level ``@njit`` functions with the signature ``MODEL_SIG``: they take an
array of states and fill ``out`` (one call per step for the whole particle set; a per-particle call
through a function pointer costs several times more). Their parameters travel in ``theta``. The
process noise w_t is described by ``noise``: float64[4] = [kind, a, b, R], kind 0 = N(0, a).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit, types

from ..rng import STATE, add_normal, normal

MODEL_SIG = types.void(types.float64[::1], types.float64, types.float64[::1], types.float64[::1])
ModelFn = types.FunctionType(MODEL_SIG)

NOISE_GAUSSIAN = 0


@dataclass(frozen=True)
class ScalarModel:
    """A scalar model ready for the kernels.

    transition, observe : @njit functions with ``MODEL_SIG`` (f and h above)
    theta : (p,) float64 parameters handed to both
    noise : (4,) float64 [kind, a, b, R]
    x0 : true initial state; prior_mean, prior_var : the filters' Gaussian prior for x_0
    steps : T
    """

    transition: Any
    observe: Any
    theta: np.ndarray
    noise: np.ndarray
    x0: float
    prior_mean: float
    prior_var: float
    steps: int

    @property
    def process_var(self) -> float:
        return float(self.noise[1])

    @property
    def measurement_var(self) -> float:
        return float(self.noise[3])


@njit(types.void(STATE, types.float64[::1], types.float64[::1]), cache=True)
def add_process_noise(s, noise, x):
    """x += w with w drawn from the process noise described by ``noise``."""
    add_normal(s, math.sqrt(noise[1]), x)


@njit(types.void(ModelFn, ModelFn, types.float64[::1], types.float64[::1], types.float64, STATE,
                 types.float64[::1], types.float64[::1]), cache=True)
def simulate_scalar(f, h, theta, noise, x0, s, x, y):
    """Simulate truth x (T+1,) from x[0] = x0 and measurements y (T+1,); y[0] is unused (0)."""
    T = x.size - 1
    x[0] = x0
    y[0] = 0.0
    buf = np.empty(1)
    out = np.empty(1)
    sr = math.sqrt(noise[3])
    for t in range(1, T + 1):
        buf[0] = x[t - 1]
        f(buf, float(t), theta, out)
        add_process_noise(s, noise, out)
        x[t] = out[0]
        buf[0] = x[t]
        h(buf, float(t), theta, out)
        y[t] = out[0] + sr * normal(s)


def simulate(model: ScalarModel, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (x, y), each (T+1,), for ``model`` using generator ``state``."""
    x = np.empty(model.steps + 1)
    y = np.empty(model.steps + 1)
    simulate_scalar(model.transition, model.observe, model.theta, model.noise, model.x0, state, x, y)
    return x, y
