"""Metrics: per-trial scores of each scenario kind, and the summaries over trials (means, their
intervals, paired differences)."""
import math

import numpy as np
import pytest

from pfbench.metrics import (chi2_mean_bounds, localization_metrics, paired, settle_step,
                             summarize, t975, trial_metrics)


def test_t_quantiles_against_scipy():
    stats = pytest.importorskip("scipy.stats")
    for df in (1, 2, 5, 10, 29, 30, 31, 40, 60, 100, 499, 10_000):
        assert math.isclose(t975(df), stats.t.ppf(0.975, df), rel_tol=2e-3), df


def test_summary_interval_covers_the_true_mean_about_95_percent():
    rng = np.random.default_rng(0)
    hits = 0
    reps = 2000
    for _ in range(reps):
        s = summarize(rng.exponential(2.0, size=40))
        hits += s["ci_lo"] <= 2.0 <= s["ci_hi"]
    # coverage of the t interval for skewed data at n = 40 is close to 95%: within 2.5 points
    assert abs(hits / reps - 0.95) < 0.025


def test_variance_interval_covers_the_true_variance():
    rng = np.random.default_rng(1)
    hits = sum(
        (lambda s: s["var_ci_lo"] <= 4.0 <= s["var_ci_hi"])(summarize(rng.normal(0, 2, 500)))
        for _ in range(1000))
    assert abs(hits / 1000 - 0.95) < 0.03


def test_summary_drops_nan_and_handles_tiny_samples():
    s = summarize([1.0, float("nan"), 3.0])
    assert s["n"] == 2 and s["mean"] == 2.0
    assert math.isnan(summarize([])["mean"])
    assert math.isnan(summarize([1.0])["ci_lo"])


def test_the_variance_has_no_distribution_free_interval_under_four_trials():
    """sqrt((m4 - s^4 (n-3)/(n-1)) / n) of two values is fixed by their variance alone (an
    interval that looks like one); three: a fourth moment of three values. Four or more: one."""
    for values in ([4.1, 4.3], [4.1, 4.3, 3.9]):
        s = summarize(values)
        assert s["var"] > 0 and math.isnan(s["var_se"]) and math.isnan(s["var_ci_lo"])
    s = summarize([4.1, 4.3, 3.9, 4.6])
    assert s["var_se"] > 0 and s["var_ci_lo"] <= s["var"] <= s["var_ci_hi"]


def test_paired_difference_and_win_rate():
    a = np.array([1.0, 2.0, 3.0, 4.0])
    b = np.array([2.0, 2.0, 1.0, 5.0])
    p = paired(a, b)
    assert p["diff_mean"] == pytest.approx(np.mean(a - b))
    assert p["win_rate"] == pytest.approx((1 + 0.5 + 0 + 1) / 4)
    assert p["diff_ci_lo"] < p["diff_mean"] < p["diff_ci_hi"]


def _poses(errs):
    """True poses at the origin and estimates displaced by errs along x: (truth, out)."""
    T = len(errs)
    truth = np.zeros((T + 1, 3))
    est = np.zeros((T + 1, 3))
    est[1:, 0] = errs
    return truth, {"pose": est, "ess": np.ones(T), "resampled": np.ones(T),
                   "lik_evals_per_step": 10.0}


def test_settle_step():
    assert settle_step(np.array([3.0, 0.1, 0.2]), 0.5) == 1
    assert settle_step(np.array([0.1, 0.9, 0.2, 0.1]), 0.5) == 2
    assert settle_step(np.array([0.1, 0.9]), 0.5) == 2          # not settled at the end
    assert settle_step(np.array([0.1, 0.2]), 0.5) == 0


def test_convergence_and_recovery_steps():
    # steps 1..10; kidnapped at step 5 (error jumps) and at step 9 (never recovers)
    errs = [5.0, 2.0, 0.3, 0.2, 8.0, 6.0, 0.4, 0.1, 7.0, 9.0]
    truth, out = _poses(errs)
    m = localization_metrics(truth, out, 0.5, np.array([5, 9]), hold=2)
    assert m["converge_step"] == 3
    assert m["recovery_steps"] == 2          # kidnapped at 5, below the bound from step 7 on
    assert m["recovery_failures"] == 1
    assert m["final_error"] == 9.0
    assert m["x_error"] == pytest.approx(np.mean(errs)) and m["y_error"] == 0.0
    assert m["rmse"] == pytest.approx(math.sqrt(np.mean(np.square(errs))))
    none = localization_metrics(truth, out, 0.5, np.array([], dtype=np.int64), hold=2)
    assert math.isnan(none["converge_step"]) and math.isnan(none["recovery_failures"])


def test_converged_means_under_the_bound_for_the_last_hold_steps():
    from pfbench.metrics import CONVERGE_HOLD_STEPS
    # under the bound only at the last two steps: not converged with hold 3, converged with 2
    errs = [5.0, 4.0, 3.0, 2.0, 0.3, 0.2]
    truth, out = _poses(errs)
    none = np.array([], dtype=np.int64)
    m = localization_metrics(truth, out, 0.5, none, hold=3)
    assert m["converged"] == 0.0 and math.isnan(m["converge_step"])
    m = localization_metrics(truth, out, 0.5, none, hold=2)
    assert m["converged"] == 1.0 and m["converge_step"] == 5
    # the default: a dip under the bound in the last steps of a long run is not convergence
    long = [3.0] * (40 - CONVERGE_HOLD_STEPS + 1) + [0.1] * (CONVERGE_HOLD_STEPS - 1)
    assert localization_metrics(*_poses(long), 0.5, none)["converged"] == 0.0
    assert localization_metrics(*_poses(long + [0.1]), 0.5, none)["converge_step"] == \
        40 - CONVERGE_HOLD_STEPS + 2
    # a recovery needs the same hold; a stretch shorter than it counts neither way
    errs = [0.1] * 5 + [9.0, 0.2, 0.2, 0.2, 9.0, 9.0]      # kidnapped at 6 and at 10
    m = localization_metrics(*_poses(errs), 0.5, np.array([6, 10]), hold=3)
    assert m["recovery_steps"] == 1 and m["recovery_failures"] == 0.0
    m = localization_metrics(*_poses(errs), 0.5, np.array([6, 10]), hold=4)
    assert math.isnan(m["recovery_steps"]) and m["recovery_failures"] == 1.0


def test_scoring_from_a_later_step_and_the_error_at_a_step():
    errs = [5.0, 2.0, 0.3, 0.2, 0.4, 0.1]
    truth, out = _poses(errs)
    out["pose"][1:, 2] = [1.0, 1.0, 0.1, 0.1, 0.1, 0.1]          # heading errors
    m = localization_metrics(truth, out, 0.5, np.array([], dtype=np.int64), score_from=3,
                             report_step=2, hold=2)
    assert m["position_error"] == pytest.approx(np.mean(errs[2:]))
    assert m["x_error"] == pytest.approx(np.mean(errs[2:]))
    assert m["rmse"] == pytest.approx(math.sqrt(np.mean(np.square(errs[2:]))))
    assert m["heading_error"] == pytest.approx(0.1)
    assert m["error_at_step"] == 2.0 and m["converge_step"] == 3 and m["converged"] == 1.0
    never = localization_metrics(*_poses([5.0, 6.0]), 0.5, np.array([], dtype=np.int64))
    assert never["converged"] == 0.0 and math.isnan(never["error_at_step"])


def test_chi_square_bounds_of_a_mean_against_scipy():
    stats = pytest.importorskip("scipy.stats")
    for k in (1, 2, 7, 50, 1000, 59_000, 1_000_000):
        lo, hi = chi2_mean_bounds(k)
        assert math.isclose(lo, stats.chi2.ppf(0.025, k) / k, rel_tol=1e-9), k
        assert math.isclose(hi, stats.chi2.ppf(0.975, k) / k, rel_tol=1e-9), k
        assert lo < 1.0 < hi
    lo99, hi99 = chi2_mean_bounds(50, 0.99)
    assert lo99 < chi2_mean_bounds(50)[0] and hi99 > chi2_mean_bounds(50)[1]
    assert all(math.isnan(v) for v in chi2_mean_bounds(0))


def _scalar_out(T, **extra):
    return {"xhat": np.zeros(T + 1), "lik_evals_per_step": 1.0, **extra}


def test_nees_and_nis_are_the_mean_normalised_squares_over_t_1_to_T():
    x = np.array([5.0, 1.0, -2.0, 3.0])       # x_0 is never scored
    pvar = np.array([1e-300, 2.0, 4.0, 1.0])
    innov = np.array([np.nan, 1.0, 2.0, -3.0])
    S = np.array([np.nan, 1.0, 8.0, 9.0])
    row = trial_metrics(x, _scalar_out(3, pvar=pvar, innov=innov, innov_var=S))
    assert row["nees"] == pytest.approx((1 / 2 + 4 / 4 + 9 / 1) / 3)
    assert row["nis"] == pytest.approx((1 + 4 / 8 + 9 / 9) / 3)
    # each optional on its own: no variance, no NEES; an innovation without its variance, no NIS
    row = trial_metrics(x, _scalar_out(3, innov=innov))
    assert math.isnan(row["nees"]) and math.isnan(row["nis"])
    # a variance of zero or a diverged estimate: not finite, never an exception
    row = trial_metrics(x, _scalar_out(3, pvar=np.array([1.0, 0.0, 1.0, 1.0])))
    assert row["nees"] == math.inf
    bad = _scalar_out(3, pvar=np.ones(4))
    bad["xhat"][2] = np.nan
    assert math.isnan(trial_metrics(x, bad)["nees"])
