"""Exact Kalman filter for a scalar linear-Gaussian model (theta = [a, c], a scenario that
provides 'linear': linear_gaussian): the reference."""
from __future__ import annotations

import numpy as np
from numba import types
from .._lazy import kernel
from .types import FilterType

_F = types.float64[::1]


@kernel(types.void(_F, types.float64, types.float64, types.float64, types.float64, types.float64,
                 types.float64, _F, _F), cache=True)
def kalman_kernel(y, a, c, Q, R, prior_mean, prior_var, xhat, pvar):
    """Posterior mean xhat and variance pvar (T+1,) of x_t = a x + w, y_t = c x + v."""
    m = prior_mean
    P = prior_var
    xhat[0] = m
    pvar[0] = P
    for t in range(1, y.size):
        mp = a * m
        Pp = a * a * P + Q
        S = c * c * Pp + R
        K = Pp * c / S
        m = mp + K * (y[t] - c * mp)
        P = (1.0 - K * c) * Pp
        xhat[t] = m
        pvar[t] = P


def run(model, y, params, particles, state, diag=True):
    """Run the exact Kalman filter (on a linear model: theta = [a, c])."""
    out = {"xhat": np.empty(y.size), "pvar": np.empty(y.size)}
    a, c = float(model.theta[0]), float(model.theta[1])
    kalman_kernel(y, a, c, model.process_var, model.measurement_var, model.prior_mean,
                  model.prior_var, out["xhat"], out["pvar"])
    out["lik_evals_per_step"] = 1.0
    return out


KF = FilterType("kf", "exact Kalman filter (on scenarios that provide a linear model: "
                "linear_gaussian)", {}, run, particles=False, cost="1",
                needs=("linear", "gaussian_measurement"))
