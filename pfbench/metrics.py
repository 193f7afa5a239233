"""Per-trial metrics of a filter run, and summaries over trials with 95% intervals."""
from __future__ import annotations

import math

import numpy as np

from ._special import functions

# Per-trial metric columns, in the order trials.csv shows them.
METRICS = {
    "rmse": "root mean squared error of the estimate over t = 1..T (a robot: of its position, m)",
    "mse": "mean squared error over t = 1..T (rmse squared)",
    "nees": "normalised estimation error squared (xhat_t - x_t)^2 / P_t, averaged over t = 1..T, "
            "P_t the filter's own posterior variance (filters that carry one: kf, ekf, ukf); 1 "
            "for a consistent filter, above its chi-square bound for an overconfident one",
    "nis": "normalised innovation squared nu_t^2 / S_t, averaged over t = 1..T: the innovation "
           "nu_t = y_t - yhat_t over the variance S_t the filter predicts for it (filters that "
           "predict the measurement: kf, ekf, ukf); 1 for a consistent filter",
    "heading_rmse": "root mean squared heading error over t = 1..T (wrapped, rad)",
    "position_error": "mean distance between the estimated and the true position over t = 1..T "
                      "(m)",
    "heading_error": "mean absolute heading error over t = 1..T (wrapped, rad)",
    "x_error": "mean absolute x error over t = 1..T (m; from the scenario's score_from)",
    "y_error": "mean absolute y error over t = 1..T (m; likewise)",
    "final_error": "position error at the last step (m; SLAM and localization)",
    "error_at_step": "localization: position error at the scenario's report_step (m)",
    "converged": "localization: 1 when the filter converged before the first kidnapping (or the "
                 "end): its position error stays below the bound for at least the last "
                 "converge_hold_steps steps (10 unless the scenario says) before it, else 0; its "
                 "mean over trials is the success rate",
    "converge_step": "localization: first step after which the position error stays below the "
                     "bound, in a trial that converged (NaN: it did not)",
    "recovery_steps": "localization with kidnapping: mean over the kidnappings the filter recovers "
                      "from (its error below the bound again for at least converge_hold_steps "
                      "steps before the next kidnapping or the end) of the steps until it stays "
                      "below",
    "recovery_failures": "localization with kidnapping: kidnappings it never recovers from (one "
                         "followed by fewer than converge_hold_steps steps counts neither way)",
    "mean_particles": "mean particle count over the steps (KLD-sampling adapts it)",
    "landmark_error": "SLAM: mean distance between each landmark the filter has mapped and the "
                      "true one, at the end of the trial (m)",
    "association_errors": "SLAM with nearest-neighbour association: fraction of associations "
                          "that joined an observation to a landmark started from another one",
    "dropped_frac": "SLAM with nearest-neighbour association: fraction of observations dropped "
                    "between the two gates (or because the map was full), over particles",
    "map_duplicates": "SLAM with nearest-neighbour association: landmarks of the final map "
                      "started from a true landmark the map already had",
    "mean_ess": "mean effective sample size 1 / sum W^2 over t = 1..T (particle filters)",
    "resample_count": "number of steps that resampled",
    "diversity_l1": "mean pairwise |x_i - x_j| of the particles right after resampling, averaged "
                    "over the steps that resampled (SLAM: L1 on poses, |dx| + |dy| + |dtheta|)",
    "distinct_frac": "fraction of distinct particles right after resampling, averaged likewise",
    "underflow_steps": "steps where every log-weight was -inf or NaN (that measurement ignored)",
    "diverged_steps": "steps whose estimate or its error is not a finite number, or (localization) "
                      "whose estimate lies outside the world",
    "lik_evals_per_step": "measurement-model evaluations per step (N for a PF, sigma points for "
                          "a UKF)",
}


NAN_ROW = {m: math.nan for m in METRICS}


def _nanmean(a) -> float:
    a = np.asarray(a, dtype=float)
    a = a[~np.isnan(a)]
    return float(a.mean()) if a.size else math.nan


def _mean_or_nan(a) -> float:
    """The mean of ``a``; NaN when it is None (an optional output not given) or empty."""
    if a is None:
        return math.nan
    a = np.asarray(a, dtype=float)
    return float(np.mean(a)) if a.size else math.nan


def trial_metrics(x: np.ndarray, out: dict) -> dict:
    """Metrics of one filter run: truth ``x`` (T+1,), filter output ``out`` (traces (T+1,)): 'xhat'
    and 'lik_evals_per_step'; 'underflow_steps', 'ess', 'resampled', 'div_l1', 'distinct',
    'pvar' (the NEES) and 'innov' with 'innov_var' (the NIS) each optional (a metric without its
    output is NaN; underflow_steps 0)."""
    err = out["xhat"][1:] - x[1:]
    with np.errstate(over="ignore", invalid="ignore"):
        sq = err * err
    mse = float(np.mean(sq))
    row = {**NAN_ROW, "rmse": math.sqrt(mse), "mse": mse,
           "underflow_steps": float(out.get("underflow_steps", 0)),
           "diverged_steps": float(np.sum(~np.isfinite(out["xhat"][1:]) | ~np.isfinite(sq))),
           "lik_evals_per_step": float(out["lik_evals_per_step"])}
    # each optional output on its own: a metric whose output is missing stays NaN
    if "ess" in out:
        row["mean_ess"] = float(np.mean(out["ess"][1:]))
    if "resampled" in out:
        row["resample_count"] = float(np.sum(out["resampled"][1:]))
    if "div_l1" in out:
        row["diversity_l1"] = _nanmean(out["div_l1"][1:])
    if "distinct" in out:
        row["distinct_frac"] = _nanmean(out["distinct"][1:])
    if "pvar" in out:
        row["nees"] = normalised_squares(err, out["pvar"][1:])
    if "innov" in out and "innov_var" in out:
        row["nis"] = normalised_squares(out["innov"][1:], out["innov_var"][1:])
    return row


def normalised_squares(e: np.ndarray, var: np.ndarray) -> float:
    """The mean over steps of e^2 / var: a filter's NEES (e its errors, var its variances) or
    NIS (its innovations and their predicted variances). Not finite when a step's is not (a
    diverged estimate, a variance of zero)."""
    e = np.asarray(e, dtype=float)
    with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
        return float(np.mean(e * e / np.asarray(var, dtype=float)))


def _pose_metrics(pose: np.ndarray, out: dict, score_from: int = 1,
                  area: np.ndarray | None = None) -> tuple[dict, np.ndarray, np.ndarray]:
    """The pose-error and filter-diagnostic metrics shared by SLAM and localization runs (true
    poses (T+1, 3), the filter's 'pose' (T+1, 3), optionally 'ess', 'resampled'), with the
    position error vectors d (T, 2) and distances err (T,) over t = 1..T. The error averages
    count the steps from ``score_from`` on. A step diverged when its estimate or error is not
    finite, or (with ``area``, the world [0, area[0]] x [0, area[1]]) when its estimate lies
    outside the world."""
    est = out["pose"]
    d = est[1:, :2] - pose[1:, :2]
    err = np.hypot(d[:, 0], d[:, 1])
    k = score_from - 1
    mse = float(np.mean(np.sum(d[k:] * d[k:], axis=1)))
    dth = (est[score_from:, 2] - pose[score_from:, 2] + math.pi) % (2 * math.pi) - math.pi
    row = {**NAN_ROW, "rmse": math.sqrt(mse), "mse": mse,
           "heading_rmse": float(np.sqrt(np.mean(dth * dth))),
           "position_error": float(np.mean(err[k:])),
           "heading_error": float(np.mean(np.abs(dth))),
           "final_error": float(err[-1]),
           "mean_ess": _mean_or_nan(out.get("ess")),
           "resample_count": (float(np.sum(out["resampled"])) if "resampled" in out
                              else math.nan),
           "underflow_steps": float(out.get("underflow_steps", 0)),
           "diverged_steps": float(np.sum(_diverged(est[1:], err, area))),
           "lik_evals_per_step": float(out["lik_evals_per_step"])}
    return row, d, err


def _diverged(est: np.ndarray, err: np.ndarray, area) -> np.ndarray:
    """(T,) bool: the steps whose estimate est (T, 3) or error err (T,) is not finite, or whose
    position lies outside [0, area[0]] x [0, area[1]] (when ``area`` is given)."""
    bad = ~np.isfinite(est).all(axis=1) | ~np.isfinite(err)
    if area is not None:
        with np.errstate(invalid="ignore"):
            bad |= ~((est[:, :2] >= 0.0) & (est[:, :2] <= np.asarray(area, float))).all(axis=1)
    return bad


def slam_metrics(pose: np.ndarray, landmarks: np.ndarray, out: dict) -> dict:
    """Metrics of one SLAM run: true poses (T+1, 3), true landmarks (M, 2), filter output with
    'pose' (T+1, 3), 'lm_est' (M, 2), 'lm_seen' (M,), 'ess' and 'resampled' per observation."""
    row, _, _ = _pose_metrics(pose, out)
    seen = out["lm_seen"].astype(bool)
    lm_err = (float(np.mean(np.hypot(*(out["lm_est"][seen] - landmarks[seen]).T)))
              if seen.any() else math.nan)
    row.update({"landmark_error": lm_err,
                "association_errors": float(out.get("association_errors", math.nan)),
                "dropped_frac": float(out.get("dropped_frac", math.nan)),
                "map_duplicates": float(out.get("map_duplicates", math.nan)),
                "diversity_l1": _nanmean(out["div_l1"]) if "div_l1" in out else math.nan,
                "distinct_frac": _nanmean(out["distinct"]) if "distinct" in out else math.nan})
    return row


Z975 = 1.959963984540054


def t975(df: int) -> float:
    """0.975 quantile of Student's t with ``df`` degrees of freedom."""
    if df < 1:
        return math.nan
    return float(functions().stdtrit(df, 0.975))     # scipy.stats.t.ppf, without scipy.stats


def chi2_mean_bounds(k: int, level: float = 0.95) -> tuple[float, float]:
    """The two-sided ``level`` bounds of the mean of ``k`` squares of independent standard
    normals: the chi-square quantiles with k degrees of freedom at (1 -+ level) / 2, over k (the
    bounds of a consistent filter's NEES or NIS averaged over k steps and trials)."""
    if k < 1:
        return math.nan, math.nan
    chdtri = functions().chdtri        # scipy.stats.chi2.isf, without importing scipy.stats
    tail = (1.0 - level) / 2.0
    return float(chdtri(k, 1.0 - tail)) / k, float(chdtri(k, tail)) / k


VAR_SE_MIN = 4      # the fewest trials the variance's standard error is given for


def summarize(values) -> dict:
    """Mean, variance, standard error and 95% intervals over trials (NaN values are dropped).

    The mean's interval uses Student's t; the variance's uses the distribution-free standard error
    sqrt((m4 - s^4 (n-3)/(n-1)) / n) with a normal quantile (values over 30 trials or so), and
    none under VAR_SE_MIN trials: a fourth moment of fewer values says nothing (of two, the
    formula's terms are fixed by the variance alone).
    """
    v = np.asarray(values, dtype=float)
    v = v[~np.isnan(v)]
    n = v.size
    out = {"n": n, "mean": math.nan, "var": math.nan, "se": math.nan, "ci_lo": math.nan,
           "ci_hi": math.nan, "var_se": math.nan, "var_ci_lo": math.nan, "var_ci_hi": math.nan}
    if n == 0:
        return out
    mean = float(v.mean())
    out["mean"] = mean
    if n < 2:
        return out
    with np.errstate(invalid="ignore", over="ignore"):  # an infinite value (a diverged trial)
        var = float(v.var(ddof=1))                      # gives an infinite or NaN spread
        sq = (v - mean) * (v - mean)    # products, not a power: the same bits on every CPU
        m4 = float(np.mean(sq * sq))    # (numpy's vectorised pow differs in the last bit)
    se = math.sqrt(var / n)
    half = t975(n - 1) * se
    out.update(var=var, se=se, ci_lo=mean - half, ci_hi=mean + half)
    if n >= VAR_SE_MIN:
        var_se = math.sqrt(max(m4 - var * var * (n - 3) / (n - 1), 0.0) / n)
        out.update(var_se=var_se, var_ci_lo=max(var - Z975 * var_se, 0.0),
                   var_ci_hi=var + Z975 * var_se)
    return out


def paired(values, baseline) -> dict:
    """Paired comparison over trials (the same truth per trial): the mean difference
    values - baseline with its 95% interval, and the win rate (fraction of trials where the value
    is smaller, ties counting half)."""
    a = np.asarray(values, dtype=float)
    b = np.asarray(baseline, dtype=float)
    ok = ~(np.isnan(a) | np.isnan(b))
    d = a[ok] - b[ok]
    s = summarize(d)
    wins = float(np.mean((d < 0) + 0.5 * (d == 0))) if d.size else math.nan
    return {"diff_mean": s["mean"], "diff_se": s["se"], "diff_ci_lo": s["ci_lo"],
            "diff_ci_hi": s["ci_hi"], "win_rate": wins}


def settle_step(err: np.ndarray, bound: float) -> int:
    """Index of the first entry after which ``err`` stays below ``bound`` to its end (len(err)
    when its last entry is not below)."""
    above = np.flatnonzero(~(err < bound))
    return int(above[-1]) + 1 if above.size else 0


# Steps a filter's error must stay below the bound at the end of a stretch (before the first
# kidnapping, between two, or before the end) to count as converged or recovered.
CONVERGE_HOLD_STEPS = 10


def localization_metrics(pose: np.ndarray, out: dict, bound: float, kidnaps: np.ndarray,
                         score_from: int = 1, report_step: int = 0,
                         area: np.ndarray | None = None,
                         hold: int = CONVERGE_HOLD_STEPS) -> dict:
    """Metrics of one localization run: true poses (T+1, 3), the filter's 'pose' (T+1, 3), 'ess'
    (T,), 'resampled' (T,), optionally 'n' (T,) particle counts; ``bound`` the convergence bound
    (m); ``kidnaps`` the steps t at which the robot was moved (the pose at t is the new one).
    Convergence: the first step after which the error stays below the bound until the first
    kidnapping (or the end), for at least ``hold`` steps (a filter whose error dips under the
    bound only in the last few steps has not converged); recovery: likewise from each
    kidnapping to the next (a stretch shorter than ``hold`` steps counts neither way). The error
    averages count the steps from ``score_from``; error_at_step is the error at ``report_step``
    (NaN for 0). ``area`` (2,): the world is [0, area[0]] x [0, area[1]]; an estimate outside it
    is a divergence (diverged_steps), never a silent error of any size."""
    row, d, err = _pose_metrics(pose, out, score_from, area)  # err[t - 1]: the error at step t
    T = err.size
    cuts = [int(k) for k in sorted(kidnaps) if 1 <= k <= T] + [T + 1]
    first = err[: cuts[0] - 1]
    s = settle_step(first, bound)
    converge = float(s + 1) if first.size - s >= hold else math.nan
    recover, failures = [], 0
    for k, nxt in zip(cuts[:-1], cuts[1:]):
        seg = err[k - 1: nxt - 1]
        if seg.size < hold:             # too short to tell
            continue
        s = settle_step(seg, bound)
        if seg.size - s >= hold:
            recover.append(float(s))
        else:
            failures += 1
    k = score_from - 1
    row.update({"x_error": float(np.mean(np.abs(d[k:, 0]))),
                "y_error": float(np.mean(np.abs(d[k:, 1]))),
                "error_at_step": float(err[report_step - 1]) if report_step else math.nan,
                "converged": float(not math.isnan(converge)),
                "converge_step": converge,
                "recovery_steps": float(np.mean(recover)) if recover else math.nan,
                "recovery_failures": float(failures) if len(cuts) > 1 else math.nan,
                "mean_particles": float(np.mean(out["n"])) if "n" in out else math.nan})
    return row
