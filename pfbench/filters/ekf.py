"""Extended Kalman filter on a scalar model (first-order linearisation by the model's Jacobians)."""
from __future__ import annotations

import numpy as np
from numba import types
from .._lazy import kernel
from ..errors import UserError

from ..models.scalar import ModelFn
from .keys import gaussian_noise_keys
from .types import FilterType

_F = types.float64[::1]

EKF_SIG = types.int64(ModelFn, ModelFn, ModelFn, ModelFn, _F, _F, types.float64, types.float64,
                      types.float64, types.float64, types.float64, _F, _F, _F, _F)


@kernel(EKF_SIG, cache=True)
def ekf_kernel(f, h, fj, hj, theta, y, prior_mean, prior_var, q_mean, Q, R, xhat, pvar, innov,
               innov_var):
    """Run the EKF over y (T+1,); fill the posterior mean xhat and variance pvar (T+1,), the
    innovation y_t - h(m_t|t-1) and its predicted variance S_t (innov, innov_var (T+1,); NaN at
    t = 0).

    The process noise is taken as Gaussian with mean q_mean and variance Q, the measurement noise as
    N(0, R). Returns the number of steps whose variance came out non-positive (floored at 1e-300).
    """
    m = prior_mean
    P = prior_var
    xhat[0] = m
    pvar[0] = P
    innov[0] = np.nan
    innov_var[0] = np.nan
    a = np.empty(1)
    b = np.empty(1)
    events = 0
    for t in range(1, y.size):
        tt = float(t)
        a[0] = m
        f(a, tt, theta, b)
        fj(a, tt, theta, a)
        mp = b[0] + q_mean
        Pp = a[0] * a[0] * P + Q
        a[0] = mp
        h(a, tt, theta, b)
        hj(a, tt, theta, a)
        H = a[0]
        S = H * H * Pp + R
        K = Pp * H / S
        m = mp + K * (y[t] - b[0])
        innov[t] = y[t] - b[0]
        innov_var[t] = S
        P = (1.0 - K * H) * Pp
        if not (P > 0.0):
            events += 1
            P = 1e-300
        xhat[t] = m
        pvar[t] = P
    return events


def noise_moments(model, params) -> tuple[float, float, float]:
    """(process mean, process variance, measurement variance) a Gaussian filter assumes: the
    scenario's own moments unless the filter's config overrides them."""
    def pick(key, default):
        v = params.get(key)
        return float(default if v is None else v)
    return (pick("process_noise_mean", model.process_mean),
            pick("process_noise_var", model.process_var),
            pick("measurement_noise_var", model.measurement_var))


def run(model, y, params, particles, state, diag=True):
    """Run the EKF (deterministic: the particle count and generator state are unused)."""
    out = {k: np.empty(y.size) for k in ("xhat", "pvar", "innov", "innov_var")}
    q_mean, Q, R = noise_moments(model, params)
    fj, hj = model.jacobians()
    if fj is None or hj is None:    # validation refuses the pairing; a model that lied is named
        raise UserError("ekf: the scenario's model has no Jacobians (transition_jac, "
                        "observe_jac), though its PROVIDES says it has")
    out["variance_floor_steps"] = ekf_kernel(
        model.transition, model.observe, fj, hj, model.theta, y,
        model.prior_mean, model.prior_var, q_mean, Q, R, out["xhat"], out["pvar"], out["innov"],
        out["innov_var"])
    out["lik_evals_per_step"] = 1.0
    return out


EKF = FilterType("ekf", "extended Kalman filter (on scenarios that provide their model's "
                 "Jacobians)", gaussian_noise_keys("the EKF"), run, particles=False, cost="1",
                 needs=("jacobians", "gaussian_measurement"), reports=("nees", "nis"))
