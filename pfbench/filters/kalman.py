"""Exact Kalman filter for a scalar linear-Gaussian model (theta = [a, c], a scenario that
provides 'linear': linear_gaussian): the reference."""
from __future__ import annotations

import numpy as np
from numba import types
from .._lazy import kernel
from .types import FilterType

_F = types.float64[::1]


@kernel(types.void(_F, types.float64, types.float64, types.float64, types.float64, types.float64,
                 types.float64, _F, _F, _F, _F), cache=True)
def kalman_kernel(y, a, c, Q, R, prior_mean, prior_var, xhat, pvar, innov, innov_var):
    """Posterior mean xhat and variance pvar (T+1,) of x_t = a x + w, y_t = c x + v, with the
    innovation y_t - c m_t|t-1 and its predicted variance S_t (innov, innov_var (T+1,); NaN at
    t = 0, which has no measurement)."""
    m = prior_mean
    P = prior_var
    xhat[0] = m
    pvar[0] = P
    innov[0] = np.nan
    innov_var[0] = np.nan
    for t in range(1, y.size):
        mp = a * m
        Pp = a * a * P + Q
        S = c * c * Pp + R
        K = Pp * c / S
        m = mp + K * (y[t] - c * mp)
        innov[t] = y[t] - c * mp
        innov_var[t] = S
        P = (1.0 - K * c) * Pp
        xhat[t] = m
        pvar[t] = P


def run(model, y, params, particles, state, diag=True):
    """Run the exact Kalman filter (on a linear model: theta = [a, c])."""
    out = {k: np.empty(y.size) for k in ("xhat", "pvar", "innov", "innov_var")}
    a, c = float(model.theta[0]), float(model.theta[1])
    kalman_kernel(y, a, c, model.process_var, model.measurement_var, model.prior_mean,
                  model.prior_var, out["xhat"], out["pvar"], out["innov"], out["innov_var"])
    out["lik_evals_per_step"] = 1.0
    return out


KF = FilterType("kf", "exact Kalman filter (on scenarios that provide a linear model: "
                "linear_gaussian)", {}, run, particles=False, cost="1",
                needs=("linear", "gaussian_measurement"), reports=("nees", "nis"))
