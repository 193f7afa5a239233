"""Stochastic volatility (SV) model of Kim, Shephard and Chib (1998), a model whose measurement
is not y = h(x) + Gaussian noise: it brings its own log-likelihood and measurement sampler.

    x_t = phi x_{t-1} + sigma v_t,   y_t = beta exp(x_t / 2) e_t,   v_t, e_t ~ N(0, 1)

x_t is the log-volatility, y_t the (mean-corrected) return. The true x_0 is drawn from the
stationary distribution N(0, sigma^2 / (1 - phi^2)), which is also the filters' prior. The
measurement's log-likelihood is log N(y; 0, beta^2 exp(x)).

The defaults are the posterior means Kim, Shephard and Chib (1998) report for daily pound/dollar
exchange-rate returns (phi about 0.978, sigma about 0.158, beta about 0.647), rounded.

For the filters that assume a Gaussian measurement (EKF, UKF) the model still has h(x) = 0, the
measurement's mean, and R = beta^2 exp(s^2 / 2), the variance of y_t (s^2 the stationary
variance): they learn nothing from y_t about x_t, and estimate the prior's mean.
theta = [phi, beta].
"""
from __future__ import annotations

import math

import numpy as np
from numba import types

from .._lazy import kernel
from ..models.scalar import (LIK_SIG, MODEL_SIG, NOISE_GAUSSIAN, SAMPLE_SIG, ScalarModel,
                             simulate_scalar)
from ..rng import STATE, normal
from ..schema import ConfigError, Key
from .linear_gaussian import transition  # f(x) = theta[0] x: phi x here, theta = [phi, beta]

NAME = "sv"
KIND = "scalar"
PROVIDES = ("likelihood",)    # its own log-likelihood of y_t (not y = h(x) + Gaussian noise)
DESCRIPTION = ("stochastic volatility (Kim, Shephard and Chib 1998): y_t = beta exp(x_t/2) e_t, "
               "its own likelihood")

SCHEMA = {
    "steps": Key("int", 100, "number of time steps T (measurements at t = 1..T)", min=1),
    "phi": Key("float", 0.98, "persistence of the log-volatility, below 1 in absolute value "
               "(default rounded from Kim, Shephard and Chib 1998's pound/dollar posterior mean, "
               "about 0.978)",
               min=-1.0, min_exclusive=True, max=1.0),
    "sigma": Key("float", 0.16, "standard deviation of the log-volatility's innovation (KSC 1998: "
                 "about 0.158)", min=0.0, min_exclusive=True),
    "beta": Key("float", 0.65, "scale of the returns, beta exp(x_t / 2) their standard deviation "
                "(KSC 1998: about 0.647)", min=0.0, min_exclusive=True),
}


__all__ = ["DESCRIPTION", "KIND", "NAME", "PROVIDES", "SCHEMA", "build", "resolve", "simulate"]


def resolve(params: dict, base_dir) -> dict:
    """Refuse phi = 1 (the schema's bound is inclusive): a random walk has no stationary
    distribution to start from."""
    if not abs(params["phi"]) < 1.0:
        raise ConfigError("scenario.phi", f"must be below 1 in absolute value (a stationary "
                          f"log-volatility), got {params['phi']:g}")
    return params


def stationary_var(phi: float, sigma: float) -> float:
    """The stationary variance of x_t, sigma^2 / (1 - phi^2)."""
    return sigma * sigma / (1.0 - phi * phi)


@kernel(MODEL_SIG, cache=True, by_address=True)
def observe(x, t, theta, out):
    """h(x) = 0, the mean of y_t given x_t (for the filters that assume a Gaussian measurement)."""
    for i in range(x.size):
        out[i] = 0.0


@kernel(LIK_SIG, cache=True, by_address=True)
def loglik(x, t, theta, y, out):
    """log N(y; 0, beta^2 exp(x)) = -log(2 pi)/2 - log(beta) - x/2 - y^2 / (2 beta^2 exp(x))."""
    beta = theta[1]
    c = -0.5 * math.log(2.0 * math.pi) - math.log(beta)
    q = 0.5 * y * y / (beta * beta)
    for i in range(x.size):
        out[i] = c - 0.5 * x[i] - q * math.exp(-x[i])


@kernel(SAMPLE_SIG, cache=True, by_address=True)
def sample(x, t, theta, s, out):
    """y = beta exp(x / 2) e, e ~ N(0, 1)."""
    for i in range(x.size):
        out[i] = theta[1] * math.exp(0.5 * x[i]) * normal(s)


def build(p) -> ScalarModel:
    """Turn validated scenario parameters into a :class:`ScalarModel` with its own likelihood."""
    phi, sigma, beta = float(p["phi"]), float(p["sigma"]), float(p["beta"])
    var0 = stationary_var(phi, sigma)
    noise = np.array([NOISE_GAUSSIAN, sigma * sigma, 0.0, beta * beta * math.exp(0.5 * var0)])
    return ScalarModel(transition, observe, np.array([phi, beta]), noise, 0.0, 0.0, var0,
                       int(p["steps"]), loglik=loglik, sample=sample)


@kernel(types.void(STATE, types.float64[::1]), cache=True)
def _draw_normal(s, out):
    out[0] = normal(s)


def simulate(model: ScalarModel, state: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x, y), each (T+1,): x_0 drawn from the stationary distribution (the filters' prior),
    then the model's transition and sampler."""
    z = np.empty(1)
    _draw_normal(state, z)
    x0 = model.prior_mean + math.sqrt(model.prior_var) * float(z[0])
    x = np.empty(model.steps + 1)
    y = np.empty(model.steps + 1)
    simulate_scalar(model.transition, model.observe, *model.sampler(), model.theta, model.noise,
                    x0, state, x, y)
    return x, y
