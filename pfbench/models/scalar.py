"""The scalar state-space model shared by the generic filter kernels.

    x_t = f(x_{t-1}, t) + w_t,   y_t = h(x_t, t) + v_t,   v_t ~ N(0, R),   t = 1..T

Model functions are module-level numba functions with the signature ``MODEL_SIG`` (``@njit(MODEL_SIG)``,
or ``@kernel(MODEL_SIG)`` of pfbench._lazy, which compiles when a model first uses it): they take an
array of states and fill ``out`` (one call per step for the whole particle set; a per-particle call
through a function pointer costs several times more). Their parameters travel in ``theta``. The
process noise w_t is described by ``noise``: float64[4] = [kind, a, b, R] with kind 0 = N(0, a) and
kind 1 = Gamma(shape a, rate b). Gaussian filters (EKF, UKF, the UPF's proposals) use the Gaussian
with the noise's mean and variance (``gaussian_noise``) unless their config overrides it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import types

from numba.core.types.function_type import CompileResultWAP
from numba.core.typing.typeof import typeof_impl

from .._lazy import LazyKernel, kernel
from ..codes import NOISE_GAMMA, NOISE_GAUSSIAN  # noqa: F401 (NOISE_GAMMA: re-exported)
from ..rng import STATE, add_normal, normal, standard_gamma

MODEL_SIG = types.void(types.float64[::1], types.float64, types.float64[::1], types.float64[::1])
ModelFn = types.FunctionType(MODEL_SIG)


class ModelFunction(CompileResultWAP):
    """A model function as the kernels take it: the address of its compiled ``MODEL_SIG`` entry,
    looked up once.

    Handing a numba dispatcher to a kernel as a first-class function costs about 50 us a call
    (numba types it, then looks its compiled entry up through LLVM, on every call); this object
    carries the address and its numba type is fixed, so the call costs what any other argument
    does. It calls like the function from Python and pickles as the function it wraps."""

    def __init__(self, fn):
        disp = fn.dispatcher if isinstance(fn, (LazyKernel, ModelFunction)) else fn
        super().__init__(disp.get_compile_result(MODEL_SIG))
        self.dispatcher = disp

    def __reduce__(self):
        return ModelFunction, (self.dispatcher,)

    def __repr__(self) -> str:
        return f"<model function {getattr(self.dispatcher, '__qualname__', self.dispatcher)}>"


@typeof_impl.register(ModelFunction)
def _typeof_model_function(val, c):
    return ModelFn


def model_function(fn):
    """``fn`` (a numba function of ``MODEL_SIG``, lazily built or not) as the kernels take it;
    None stays None."""
    return fn if fn is None or isinstance(fn, ModelFunction) else ModelFunction(fn)



@dataclass(frozen=True)
class ScalarModel:
    """A scalar model ready for the kernels.

    transition, observe : @njit functions with ``MODEL_SIG`` (f and h above); the model holds
        them as ``ModelFunction``
    theta : (p,) float64 parameters handed to both
    noise : (4,) float64 [kind, a, b, R]
    x0 : true initial state; prior_mean, prior_var : the filters' Gaussian prior for x_0
    steps : T
    transition_jac, observe_jac : @njit functions with ``MODEL_SIG`` filling df/dx and dh/dx
        (needed by the EKF; None where the scenario has none)
    """

    transition: Any
    observe: Any
    theta: np.ndarray
    noise: np.ndarray
    x0: float
    prior_mean: float
    prior_var: float
    steps: int
    transition_jac: Any = None
    observe_jac: Any = None

    def __post_init__(self):
        # the model functions are handed to the filters as ModelFunction: a lazily built kernel
        # compiles now, when a scenario builds a model that uses it, not when its module is
        # imported (the derivatives, which only the EKF uses, when it asks: see ``jacobians``)
        for name in ("transition", "observe"):
            object.__setattr__(self, name, model_function(getattr(self, name)))

    def jacobians(self) -> tuple:
        """(transition_jac, observe_jac) as the kernels take them (ModelFunction)."""
        return tuple(model_function(fn) for fn in (self.transition_jac, self.observe_jac))

    @property
    def process_mean(self) -> float:
        """Mean of the process noise w_t."""
        kind, a, b = self.noise[0], self.noise[1], self.noise[2]
        return 0.0 if kind == NOISE_GAUSSIAN else float(a / b)

    @property
    def process_var(self) -> float:
        """Variance of the process noise w_t."""
        kind, a, b = self.noise[0], self.noise[1], self.noise[2]
        return float(a) if kind == NOISE_GAUSSIAN else float(a / (b * b))

    @property
    def measurement_var(self) -> float:
        return float(self.noise[3])


@kernel(types.void(STATE, types.float64[::1], types.float64[::1]), cache=True)
def add_process_noise(s, noise, x):
    """x += w with w drawn from the process noise described by ``noise``."""
    if noise[0] == NOISE_GAUSSIAN:
        add_normal(s, math.sqrt(noise[1]), x)
    else:
        scale = 1.0 / noise[2]
        for i in range(x.size):
            x[i] += scale * standard_gamma(s, noise[1])


@kernel(types.float64(types.float64[::1], types.float64), cache=True)
def process_logpdf(noise, w):
    """log density of the process noise at w (the transition density p(x_t | x_{t-1}) at
    w = x_t - f(x_{t-1}))."""
    a = noise[1]
    if noise[0] == NOISE_GAUSSIAN:
        return -0.5 * w * w / a - 0.5 * math.log(2.0 * math.pi * a)
    if not (w > 0.0):
        return -np.inf
    b = noise[2]
    return (a - 1.0) * math.log(w) - b * w + a * math.log(b) - math.lgamma(a)


@kernel(types.void(ModelFn, ModelFn, types.float64[::1], types.float64[::1], types.float64, STATE,
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
