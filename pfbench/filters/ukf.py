"""Unscented Kalman filter on a scalar model (scaled unscented transform).

Sigma points use lambda = alpha^2 (L + kappa) - L. With ``augmented`` the state is augmented with the
process and measurement noise (L = 3, 7 points, van der Merwe's form); otherwise (L = 1) the noise
variances are added to the predicted covariances and the measurement sigma points are redrawn from
the predicted mean and variance.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from .._lazy import kernel

from ..schema import Key
from ..models.scalar import ModelFn
from .ekf import noise_moments
from .keys import gaussian_noise_keys, sigma_check, sigma_keys
from .types import FilterType

_F = types.float64[::1]

@kernel(types.UniTuple(types.float64, 2)(ModelFn, _F, types.float64, _F, _F, types.int64, _F, _F,
                                       _F), cache=True)
def _transform(fn, pts, t, theta, offset, add_offset, Wm, Wc, out):
    """out = fn(pts) (+ offset when add_offset); return the weighted mean and variance of out."""
    fn(pts, t, theta, out)
    if add_offset:
        for i in range(out.size):
            out[i] += offset[i]
    mean = 0.0
    for i in range(out.size):
        mean += Wm[i] * out[i]
    var = 0.0
    for i in range(out.size):
        var += Wc[i] * (out[i] - mean) ** 2
    return mean, var


@kernel(types.float64(types.int64, types.float64, types.float64, types.float64, _F, _F),
      cache=True)
def ut_weights(L, alpha, beta, kappa, Wm, Wc):
    """The scaled unscented transform's weights for an L-dimensional state into Wm, Wc (2 L + 1,)
    (lambda = alpha^2 (L + kappa) - L); returns sqrt(L + lambda), the sigma points' scale."""
    lam = alpha * alpha * (L + kappa) - L
    c = L + lam
    Wm[:] = 0.5 / c
    Wc[:] = 0.5 / c
    Wm[0] = lam / c
    Wc[0] = lam / c + 1.0 - alpha * alpha + beta
    return math.sqrt(c)


UKF_SIG = types.int64(ModelFn, ModelFn, _F, _F, _F, types.float64, types.float64, types.float64,
                      types.float64, types.float64, types.float64, types.float64, types.float64,
                      types.int64, _F, _F, _F, _F)


@kernel(UKF_SIG, cache=True)
def ukf_kernel(f, h, theta, noise, y, prior_mean, prior_var, q_mean, Q, R, alpha, beta, kappa,
               augmented, xhat, pvar, innov, innov_var):
    """Run the UKF over y (T+1,), filling the posterior mean xhat and variance pvar (T+1,), the
    innovation y_t - zm_t (zm_t the predicted measurement) and its predicted variance S_t (innov,
    innov_var (T+1,); NaN at t = 0).

    q_mean, Q, R : the Gaussian process noise (mean, variance) and measurement noise variance the
    filter assumes.
    Returns the number of steps whose posterior variance came out non-positive (then floored at
    1e-300 so the filter goes on; a well-posed model never does this).
    """
    T = y.size - 1
    L = 3 if augmented else 1
    n = 2 * L + 1
    Wm = np.empty(n)
    Wc = np.empty(n)
    sq = ut_weights(L, alpha, beta, kappa, Wm, Wc)
    chi = np.empty(n)
    fx = np.empty(n)
    hz = np.empty(n)
    wn = np.zeros(n)
    vn = np.zeros(n)
    m = prior_mean
    P = prior_var
    xhat[0] = m
    pvar[0] = P
    innov[0] = np.nan
    innov_var[0] = np.nan
    events = 0
    wn[:] = q_mean
    if augmented:
        wn[2] += sq * math.sqrt(Q)
        wn[5] -= sq * math.sqrt(Q)
        vn[3] = sq * math.sqrt(R)
        vn[6] = -vn[3]
    for t in range(1, T + 1):
        tt = float(t)
        d = sq * math.sqrt(P)
        chi[:] = m
        chi[1] = m + d
        chi[1 + L] = m - d
        mp, Pp = _transform(f, chi, tt, theta, wn, 1, Wm, Wc, fx)
        if augmented:
            xs = fx
        else:
            Pp += Q
            dp = sq * math.sqrt(Pp)
            chi[0] = mp
            chi[1] = mp + dp
            chi[2] = mp - dp
            xs = chi
        zm, S = _transform(h, xs, tt, theta, vn, augmented, Wm, Wc, hz)
        C = 0.0
        for i in range(n):
            C += Wc[i] * (xs[i] - mp) * (hz[i] - zm)
        if not augmented:
            S += R
        K = C / S
        m = mp + K * (y[t] - zm)
        innov[t] = y[t] - zm
        innov_var[t] = S
        P = Pp - K * K * S
        if not (P > 0.0):
            events += 1
            P = 1e-300
        xhat[t] = m
        pvar[t] = P
    return events


def run(model, y, params, particles, state, diag=True):
    """Run the UKF; the particle count and generator state are unused (it is deterministic)."""
    T1 = y.size
    out = {k: np.empty(T1) for k in ("xhat", "pvar", "innov", "innov_var")}
    aug = bool(params["augmented"])
    q_mean, Q, R = noise_moments(model, params)
    out["variance_floor_steps"] = ukf_kernel(
        model.transition, model.observe, model.theta, model.noise, y, model.prior_mean,
        model.prior_var, q_mean, Q, R, params["alpha"], params["beta"], params["kappa"], int(aug),
        out["xhat"], out["pvar"], out["innov"], out["innov_var"])
    out["lik_evals_per_step"] = 7.0 if aug else 3.0
    return out


UKF = FilterType(
    "ukf", "unscented Kalman filter (scaled sigma points, optional noise augmentation)",
    {**sigma_keys(),
     "augmented": Key("bool", True, "augment the state with the process and measurement noise"),
     **gaussian_noise_keys("the UKF")},
    run, particles=False, cost="1", check=sigma_check, needs=("gaussian_measurement",),
    reports=("nees", "nis"))
