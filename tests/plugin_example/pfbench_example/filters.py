"""A bootstrap particle filter with Metropolis resampling (Murray, Lee and Jacob 2016), in plain
numpy, for pfbench's scalar scenarios.

Metropolis resampling needs no sum of the weights: each particle i starts a chain at itself and,
``iterations`` times, proposes a particle j uniformly and moves to it with probability
min(1, w_j / w_k). With enough iterations the chain's end is drawn (almost) in proportion to the
weights; with few it is biased toward the start, the price of never summing the weights (which
parallel hardware makes costly).
"""
from __future__ import annotations

import math

import numpy as np

from pfbench.filters import FilterType
from pfbench.schema import Key

SCHEMA = {
    "iterations": Key("int", 20, "Metropolis steps per particle and resampling (B in Murray, "
                      "Lee and Jacob 2016)", min=1),
}


def run(model, y, params, particles, state, diag=True):
    """Filter the measurements ``y`` (T+1,) of a scalar model; return the estimates.

    model : pfbench's scalar model (transition and observe fill arrays; noise = [kind, a, b, R])
    state : (4,) uint64, this run's seed material: the same state gives the same run
    Returns {"xhat": (T+1,) posterior means, "lik_evals_per_step": N, "underflow_steps": count}.
    """
    rng = np.random.default_rng(np.asarray(state, dtype=np.uint64))
    N, T = particles, y.size - 1
    kind, a, b, R = model.noise
    x = rng.normal(model.prior_mean, math.sqrt(model.prior_var), N)
    fx, hx = np.empty(N), np.empty(N)
    xhat = np.empty(T + 1)
    xhat[0] = x.mean()
    underflow = 0
    for t in range(1, T + 1):
        model.transition(x, float(t), model.theta, fx)
        fx += rng.normal(0.0, math.sqrt(a), N) if kind == 0 else rng.gamma(a, 1.0 / b, N)
        model.observe(fx, float(t), model.theta, hx)
        lw = -0.5 * (y[t] - hx) ** 2 / R
        lw[~np.isfinite(lw)] = -np.inf
        if not np.isfinite(lw.max()):
            underflow += 1
            w = np.ones(N)
        else:
            w = np.exp(lw - lw.max())
        xhat[t] = float(np.sum(w * fx) / np.sum(w))
        k = np.arange(N)
        for _ in range(params["iterations"]):
            j = rng.integers(0, N, N)
            k = np.where(rng.random(N) * w[k] <= w[j], j, k)
        x = fx[k]
    return {"xhat": xhat, "lik_evals_per_step": float(N), "underflow_steps": underflow}


METROPOLIS_PF = FilterType(
    "metropolis_pf", "bootstrap PF with Metropolis resampling (Murray, Lee and Jacob 2016; "
    "plain numpy, an example plug-in)", SCHEMA, run)
