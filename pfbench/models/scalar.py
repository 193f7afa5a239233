"""The scalar state-space model shared by the generic filter kernels.

    x_t = f(x_{t-1}, t) + w_t,   y_t = h(x_t, t) + v_t,   v_t ~ N(0, R),   t = 1..T

unless the model brings its own measurement model: a log-likelihood ``loglik`` (``LIK_SIG``) that
the particle filters weight by instead of the Gaussian of y_t - h(x_t), and a sampler ``sample``
(``SAMPLE_SIG``) that simulates y_t given x_t instead of h(x_t) + v_t. Each is optional; without
them the additive-Gaussian measurement is the (fast, inline) default.

Model functions are module-level numba functions with the signature ``MODEL_SIG`` (``@njit(MODEL_SIG)``,
or, in pfbench, ``@kernel(MODEL_SIG, by_address=True)`` of pfbench._lazy, which compiles when a
model first uses it, with the entry a function taken by address needs): they take an
array of states and fill ``out`` (one call per step for the whole particle set; a per-particle call
through a function pointer costs several times more). Their parameters travel in ``theta``. The
process noise w_t is described by ``noise``: float64[4] = [kind, a, b, R] with kind 0 = N(0, a) and
kind 1 = Gamma(shape a, rate b). Gaussian filters (EKF, UKF, the UPF's proposals) use the Gaussian
with the noise's mean and variance (``gaussian_noise``) unless their config overrides it.

A model's own measurement functions are numba functions too, called once per step for the whole
particle set, with one more argument before ``out`` than a model function:

- ``LIK_SIG``, ``loglik(x, t, theta, y, out)``: out[i] = log p(y_t = y | x_t = x[i]), the log
  density with its constants (the weights need it only up to a constant, a likelihood floor
  compares it with the floor). -inf where a state cannot have produced y; a step where every
  particle's is -inf (or NaN) is counted as an underflow step and leaves the weights uniform;
  +inf (a density without bound at y) counts as the largest double: those particles take the
  weight.
- ``SAMPLE_SIG``, ``sample(x, t, theta, s, out)``: out[i] = a draw of y_t given x_t = x[i], its
  random numbers from the generator state ``s`` (``pfbench.rng``: ``normal(s)``, ``uniform(s)``).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import types
from numba.core.errors import NumbaError

from numba.core.types.function_type import CompileResultWAP
from numba.core.typing.typeof import typeof_impl

from .._lazy import LazyKernel, kernel
from ..errors import UserError
from ..codes import NOISE_GAMMA, NOISE_GAUSSIAN  # noqa: F401 (NOISE_GAMMA: re-exported)
from ..rng import STATE, add_normal, normal, standard_gamma

MODEL_SIG = types.void(types.float64[::1], types.float64, types.float64[::1], types.float64[::1])
ModelFn = types.FunctionType(MODEL_SIG)
# a model's own measurement model (see the module): log-likelihood and sampler
LIK_SIG = types.void(types.float64[::1], types.float64, types.float64[::1], types.float64,
                     types.float64[::1])
LikFn = types.FunctionType(LIK_SIG)
SAMPLE_SIG = types.void(types.float64[::1], types.float64, types.float64[::1], STATE,
                        types.float64[::1])
SampleFn = types.FunctionType(SAMPLE_SIG)


class ModelFunction(CompileResultWAP):
    """A model function as the kernels take it: the address of its compiled ``MODEL_SIG`` entry,
    looked up once.

    Handing a numba dispatcher to a kernel as a first-class function costs about 50 us a call
    (numba types it, then looks its compiled entry up through LLVM, on every call); this object
    carries the address and its numba type is fixed, so the call costs what any other argument
    does. It calls like the function from Python and pickles as the function it wraps."""

    SIG, SIG_NAME, WHAT = MODEL_SIG, "MODEL_SIG", "model function"
    ARGS = "(x: float64[::1], t: float64, theta: float64[::1], out: float64[::1]) -> void"

    def __init__(self, fn):
        disp = fn.dispatcher if isinstance(fn, (LazyKernel, ModelFunction)) else fn
        need = f"a {self.WHAT} of {self.SIG_NAME} {self.ARGS}"
        if not hasattr(disp, "get_compile_result"):
            raise ModelFunctionError(f"{_name(fn)} is not {need}: not a numba function "
                                     f"(@njit({self.SIG_NAME}, cache=True))")
        try:
            cres = disp.get_compile_result(self.SIG)
        except (NumbaError, TypeError, ValueError):  # numba's own message: many lines
            sigs = "; ".join("(" + ", ".join(map(str, sig)) + ")"
                             for sig in getattr(disp, "signatures", ())) or "none"
            raise ModelFunctionError(f"{_name(fn)} is not {need}: it compiles for the "
                                     f"arguments {sigs}") from None
        super().__init__(cres)
        if not self.address:        # compiled without numba's C-callable wrapper
            raise ModelFunctionError(f"{_name(fn)} is not {need}: it was compiled without the "
                                     f"entry a function taken by address needs (a pfbench "
                                     f"kernel declared without by_address=True)")
        self.dispatcher = disp

    def __reduce__(self):
        return type(self), (self.dispatcher,)

    def __repr__(self) -> str:
        return f"<{self.WHAT} {getattr(self.dispatcher, '__qualname__', self.dispatcher)}>"


class LikelihoodFunction(ModelFunction):
    """A model's log-likelihood (``LIK_SIG``) as the kernels take it (see ``ModelFunction``)."""

    SIG, SIG_NAME, WHAT = LIK_SIG, "LIK_SIG", "log-likelihood"
    ARGS = ("(x: float64[::1], t: float64, theta: float64[::1], y: float64, out: float64[::1]) "
            "-> void")


class SamplerFunction(ModelFunction):
    """A model's measurement sampler (``SAMPLE_SIG``) as the kernels take it."""

    SIG, SIG_NAME, WHAT = SAMPLE_SIG, "SAMPLE_SIG", "measurement sampler"
    ARGS = ("(x: float64[::1], t: float64, theta: float64[::1], s: uint64[::1], "
            "out: float64[::1]) -> void")


class ModelFunctionError(UserError, TypeError):
    """A model's function that is not of the signature its place needs (one line; a TypeError
    to the API, a user's error to the command line)."""


def _name(fn) -> str:
    disp = getattr(fn, "dispatcher", fn)
    func = getattr(disp, "py_func", disp)
    return f"'{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', repr(func))}'"


@typeof_impl.register(ModelFunction)
def _typeof_model_function(val, c):
    return ModelFn


@typeof_impl.register(LikelihoodFunction)
def _typeof_likelihood_function(val, c):
    return LikFn


@typeof_impl.register(SamplerFunction)
def _typeof_sampler_function(val, c):
    return SampleFn


def model_function(fn, cls=ModelFunction):
    """``fn`` (a numba function of ``cls.SIG``, lazily built or not) as the kernels take it (a
    ``cls``: ModelFunction, LikelihoodFunction or SamplerFunction); None stays None."""
    return fn if fn is None or type(fn) is cls else cls(fn)



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
    loglik : @njit function with ``LIK_SIG``, the log-likelihood of a measurement, or None: the
        Gaussian N(y; h(x), R) (R = noise[3]), computed inline by the kernels
    sample : @njit function with ``SAMPLE_SIG`` drawing a measurement given the state, or None:
        y = h(x) + v, v ~ N(0, R)
    A model with its own ``loglik`` keeps ``observe`` and R: the Gaussian filters (EKF, UKF) and
    the swarms' scales read them (h: the measurement's mean, R: its variance, as best it can say).
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
    loglik: Any = None
    sample: Any = None

    def __post_init__(self):
        # the model functions are handed to the filters as ModelFunction: a lazily built kernel
        # compiles now, when a scenario builds a model that uses it, not when its module is
        # imported (the derivatives, which only the EKF uses, when it asks: see ``jacobians``)
        for name in ("transition", "observe"):
            object.__setattr__(self, name, model_function(getattr(self, name)))
        object.__setattr__(self, "loglik", model_function(self.loglik, LikelihoodFunction))
        object.__setattr__(self, "sample", model_function(self.sample, SamplerFunction))

    @property
    def has_likelihood(self) -> bool:
        """Whether the model brings its own log-likelihood (else: the Gaussian of y - h(x))."""
        return self.loglik is not None

    def likelihood(self) -> tuple:
        """(loglik, 1) as the kernels take them, or (a placeholder, 0) where the model has none
        (the kernels then weigh by the Gaussian inline)."""
        if self.loglik is None:
            return _placeholder(LikelihoodFunction), 0
        return self.loglik, 1

    def sampler(self) -> tuple:
        """(sample, 1) as ``simulate_scalar`` takes them, or (a placeholder, 0): h(x) + v."""
        if self.sample is None:
            return _placeholder(SamplerFunction), 0
        return self.sample, 1

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


@functools.cache
def _placeholder(cls):
    """The placeholder of a ``cls`` (LikelihoodFunction or SamplerFunction), looked up once (a
    lookup costs tens of microseconds, a trial of a small filter not many more)."""
    return cls(no_loglik if cls is LikelihoodFunction else no_sample)


@kernel(LIK_SIG, cache=True, by_address=True)
def no_loglik(x, t, theta, y, out):
    """The placeholder of a model without its own log-likelihood (the kernels never call it)."""
    out[:] = np.nan


@kernel(SAMPLE_SIG, cache=True, by_address=True)
def no_sample(x, t, theta, s, out):
    """The placeholder of a model without its own sampler (never called)."""
    out[:] = np.nan


@kernel(types.void(STATE, types.float64[::1], types.float64[::1]), cache=True, by_address=True)
def add_process_noise(s, noise, x):
    """x += w with w drawn from the process noise described by ``noise``."""
    if noise[0] == NOISE_GAUSSIAN:
        add_normal(s, math.sqrt(noise[1]), x)
    else:
        scale = 1.0 / noise[2]
        for i in range(x.size):
            x[i] += scale * standard_gamma(s, noise[1])


@kernel(types.float64(types.float64[::1], types.float64), cache=True, by_address=True)
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


@kernel(types.void(ModelFn, ModelFn, SampleFn, types.int64, types.float64[::1], types.float64[::1],
                   types.float64, STATE, types.float64[::1], types.float64[::1]), cache=True)
def simulate_scalar(f, h, sample, use_sample, theta, noise, x0, s, x, y):
    """Simulate truth x (T+1,) from x[0] = x0 and measurements y (T+1,); y[0] is unused (0).
    The measurements: y_t = h(x_t) + v_t, or, with ``use_sample``, drawn by ``sample``."""
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
        if use_sample:
            sample(buf, float(t), theta, s, out)
            y[t] = out[0]
        else:
            h(buf, float(t), theta, out)
            y[t] = out[0] + sr * normal(s)


def simulate(model: ScalarModel, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return (x, y), each (T+1,), for ``model`` using generator ``state``."""
    x = np.empty(model.steps + 1)
    y = np.empty(model.steps + 1)
    simulate_scalar(model.transition, model.observe, *model.sampler(), model.theta, model.noise,
                    model.x0, state, x, y)
    return x, y
