"""Computing a comparison: per-trial ratios and the factors' intervals (pfbench.compare; the
verdicts themselves: test_verdicts)."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from .conftest import ROOT
from .test_tables import _afsa_cfg, _afsa_rows


def test_time_ratio_is_per_trial_against_the_baseline():
    import pandas as pd

    from pfbench.compare import _metric_values
    g = pd.DataFrame({"trial": [0, 1, 2], "wall_s": [2.0, 3.0, 4.0]})
    base = pd.DataFrame({"trial": [2, 0, 1], "wall_s": [2.0, 1.0, 1.0]})
    assert list(_metric_values("time_ratio", g, base)) == [2.0, 3.0, 2.0]
    assert list(np.isnan(_metric_values("time_ratio", g, None))) == [True] * 3


@pytest.mark.slow
def test_factor_interval_covers_the_true_ratio_about_95_percent(write_config):
    # paired trials with correlated noise; the paired BCa interval on the ratio of the means
    from pfbench.config import load
    from pfbench import papers
    from pfbench.compare import factor_claims
    exp = load(_afsa_cfg(write_config, 60))
    table = papers.find("afsa2014", ROOT / "configs" / "x.yaml").tables["table1"]
    rng = np.random.default_rng(6)
    hits, reps = 0, 400
    for _ in range(reps):
        common = rng.normal(0.0, 0.05, exp.trials)
        a = 0.4 + common + rng.normal(0.0, 0.05, exp.trials)
        b = 0.2 + 0.5 * common + rng.normal(0.0, 0.03, exp.trials)
        df = _afsa_rows(exp, {"pso": {"position_error": a}, "afsa": {"position_error": b},
                              "afsa_std": {}})
        by_key = {f.key: df[df["filter"] == f.key] for f in exp.filters}
        est = next(c.est for (x, c) in factor_claims(exp, table, by_key)
                   if x["quantity"].startswith("position"))
        assert est.method == "bca"
        lo, hi = est.interval(0.95)
        hits += lo <= 0.5 <= hi
    # 3 binomial standard errors of 400 draws (0.033)
    assert abs(hits / reps - 0.95) < 3 * np.sqrt(0.95 * 0.05 / reps)


def test_a_cost_claim_is_judged_on_evaluations_not_on_the_machines_time(write_config):
    import dataclasses

    import pandas as pd

    from pfbench.compare import compare
    from pfbench.config import load
    cfg = write_config("paper: ifa2021\ntable: table1\ntrials: 10\nscenario: {name: ungm}\n"
                       "filters:\n  pf: {label: PF, particles: 100}\n"
                       "  ifa: {label: IFA-PF, particles: 100}\ncompare: {baseline: pf}\n")
    exp = load(cfg)
    rows = [{"trial": k, "filter": f.key, "label": f.label, "particles": 100, "rmse": 3.0,
             "mse": 9.0, "diversity_l1": 0.0, "distinct_frac": 1.0, "mean_ess": 50.0,
             "resample_count": 100.0, "underflow_steps": 0.0, "diverged_steps": 0.0,
             # IFA: twice the evaluations, and 5 to 7 times the time on this machine
             "lik_evals_per_step": 100.0 * (2 if f.name == "ifa" else 1),
             "wall_s": 1e-3 * ((5 + k % 3) if f.name == "ifa" else 1)}
            for f in exp.filters for k in range(10)]
    tab = compare(exp, pd.DataFrame(rows)).table.set_index("filter")
    assert tab.loc["ifa@100", "ours_time_ratio"] == pytest.approx(5.9)    # shown as measured
    verdict = tab.loc["ifa@100", "verdict_time_ratio"]
    assert verdict.startswith("reproduced") and verdict.endswith("judged on evals ratio 2")
    # without the deterministic measure a run-time ratio is shown, never judged
    q = next(q for q in exp.reported.quantities if q.key == "time_ratio")
    plain = dataclasses.replace(exp.reported, quantities=(dataclasses.replace(q, judged_by=None),))
    paper = dataclasses.replace(exp.reference, tables={"table1": plain})
    exp2 = dataclasses.replace(exp, reference=paper)
    tab = compare(exp2, pd.DataFrame(rows)).table.set_index("filter")
    assert tab.loc["ifa@100", "verdict_time_ratio"].startswith("shown, not judged")


def test_bootstrap_of_a_metric_no_trial_defined_is_nan_not_an_error():
    """A skewed metric that no trial defines (every convergence step NaN: no run converged) or
    that one or two trials define keeps an undefined interval; regression: the spread was taken
    of an empty sample ('zero-size array to reduction operation maximum')."""
    import math

    import numpy as np

    from pfbench.compare import _bootstrap

    def mean(x, axis=-1):
        return np.mean(x, axis=axis)

    for values in ([math.nan] * 5, [math.nan, 2.0, math.nan], [1.0, math.nan, 3.0]):
        est = _bootstrap((np.array(values),), mean, math.nan, 0, "run:q")
        assert est.n == sum(v == v for v in values)
        assert math.isnan(est.se) or est.se == 0.0


def test_two_trials_that_differ_give_a_bootstrapped_statistic_no_interval():
    """A variance (or a gain, a ratio) of two trials has no interval: its bootstrap has nothing
    to resample, and a standard error of 0 (Student's t on the two equal terms of a variance, as
    before) would judge 'differs' on an interval of width 0. Three trials bootstrap; two equal
    values are exact (width 0)."""
    import math

    import numpy as np

    from pfbench.compare import _bootstrap

    def var(x, axis=-1):
        return np.var(x, axis=axis, ddof=1)

    two = _bootstrap((np.array([4.1, 4.3]),), var, 0.02, 0, "run:q")
    assert two.n == 2 and math.isnan(two.se) and two.method == "bca"
    lo, hi = two.interval(0.95)
    assert math.isnan(lo) and math.isnan(hi)
    three = _bootstrap((np.array([4.1, 4.3, 3.9]),), var, 0.04, 0, "run:q")
    assert three.method == "bca" and three.se > 0
    same = _bootstrap((np.array([2.0, 2.0]),), var, 0.0, 0, "run:q")
    assert same.se == 0.0 and same.interval(0.95) == (0.0, 0.0)


def test_a_two_trial_table_judges_no_variance_and_says_why(tmp_path):
    """The command line, end to end: two trials of sspf_ungm judge the means (Student's t with
    one degree of freedom) and leave every variance 'inconclusive', saying that two trials give
    no interval; the cells without an interval leave Holm's family (4 means, not 8 cells)."""
    from pathlib import Path

    import pandas as pd
    from typer.testing import CliRunner

    from pfbench.cli import app

    config = Path(__file__).resolve().parents[1] / "configs" / "sspf_ungm.yaml"
    res = CliRunner().invoke(app, ["run", str(config), "--trials", "2", "--out",
                                   str(tmp_path / "out"), "--no-figures"])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(tmp_path / "out" / "table.csv")
    judged = table.dropna(subset=["kind_mse_var"])
    assert len(judged) == 4
    assert (judged["kind_mse_var"] == "inconclusive").all()
    assert judged["verdict_mse_var"].str.startswith(
        "inconclusive: 2 trials give no interval (a bootstrap needs at least 3)").all()
    means = table.dropna(subset=["kind_mse_mean"])
    assert (means["kind_mse_mean"] == "differs").all()
    assert means["verdict_mse_mean"].str.contains("Holm over 4").all()


def test_consistency_checks_a_mean_against_its_chi_square_bounds():
    from pfbench.compare import consistency
    from pfbench.metrics import chi2_mean_bounds
    lo, hi = chi2_mean_bounds(4 * 50)
    got = consistency([1.0, 0.9, 1.1, 1.0], 50)
    assert got["nees_mean"] == 1.0 and (got["nees_bound_lo"], got["nees_bound_hi"]) == (lo, hi)
    assert got["nees_se"] == pytest.approx(np.std([1.0, 0.9, 1.1, 1.0], ddof=1) / 2)
    assert got["nees_check"] == "consistent"
    assert consistency([4.0] * 4, 50)["nees_check"] == "overconfident"
    assert consistency([0.25] * 4, 50, "nis")["nis_check"] == "underconfident"
    # a trial with no value is left out of the count; one that diverged makes the mean so
    assert consistency([1.0, np.nan, 1.0], 50)["nees_bound_lo"] == chi2_mean_bounds(100)[0]
    assert consistency([1.0, np.inf], 50)["nees_check"] == "overconfident"
    # no value (a filter that reports none) or no step count: no bounds, no check
    for got in (consistency([np.nan, np.nan], 50), consistency([1.0, 1.0], None)):
        assert got["nees_check"] == "" and np.isnan(got["nees_bound_hi"])


def _overconfident_kf(model, y, params, particles, state, diag=True):
    """The Kalman filter with its variances scaled by 0.25: the same estimates, overconfident."""
    from pfbench.filters import FILTERS
    out = FILTERS["kf"].run(model, y, params, particles, state, diag)
    out["pvar"] = 0.25 * out["pvar"]
    out["innov_var"] = 0.25 * out["innov_var"]
    return out


def test_the_kalman_filter_is_consistent_and_an_overconfident_one_is_flagged(monkeypatch):
    """A statistical check on linear_gaussian (the truth starts at the prior mean, so a prior
    variance near zero is the exact one): the KF's NEES and NIS averaged over 1000 trials of 50
    steps lie within the 95% chi-square bounds of the mean of K = 50 000 squares, and within 4
    Monte Carlo standard errors of 1 (a tolerance that holds whatever the errors' correlation in
    time); the same filter with its variances scaled by 0.25 averages 4 and is flagged
    overconfident. Fixed seed: the test's outcome is the same on every run."""
    from pfbench.api import run_experiment
    from pfbench.filters import FILTERS
    from pfbench.filters.types import FilterType
    monkeypatch.setitem(FILTERS, "kf_overconfident", FilterType(
        "kf_overconfident", "the KF with its variances scaled by 0.25", {}, _overconfident_kf,
        particles=False, scenarios=("linear_gaussian",), cost="1", reports=("nees", "nis")))
    cfg = {"seed": 33, "trials": 1000,
           "scenario": {"name": "linear_gaussian", "steps": 50, "prior_var": 1e-12},
           "filters": {"kf": {}, "kf_overconfident": {}, "pf": {"particles": 20}}}
    res = run_experiment(cfg)
    assert {"nees", "nis"} <= set(res.trials.columns)
    tab = res.table.set_index("filter")
    for m in ("nees", "nis"):
        kf, over = tab.loc["kf"], tab.loc["kf_overconfident"]
        assert kf[f"{m}_check"] == "consistent", kf
        assert kf[f"{m}_bound_lo"] <= kf[f"{m}_mean"] <= kf[f"{m}_bound_hi"]
        assert abs(kf[f"{m}_mean"] - 1.0) <= 4 * kf[f"{m}_se"]
        assert over[f"{m}_check"] == "overconfident"
        assert over[f"{m}_mean"] == pytest.approx(4 * kf[f"{m}_mean"], rel=1e-12)
        assert over[f"{m}_mean"] > over[f"{m}_bound_hi"]
        assert tab.loc["pf@20", f"{m}_check"] == "" and np.isnan(tab.loc["pf@20", f"{m}_mean"])


def test_every_mean_in_the_table_carries_its_standard_error_beside_it(write_config):
    from pfbench.compare import MEAN_COLUMNS, compare
    from pfbench.config import load
    exp = load(_afsa_cfg(write_config))
    rng = np.random.default_rng(3)
    vals = {"pso": {"position_error": rng.normal(0.4, 0.05, exp.trials),
                    "mean_ess": rng.normal(30.0, 2.0, exp.trials)},
            "afsa": {"position_error": rng.normal(0.2, 0.05, exp.trials)}, "afsa_std": {}}
    df = _afsa_rows(exp, vals)
    tab = compare(exp, df).table
    cols = list(tab.columns)
    per_cell = {c for c in cols for q in exp.reported.quantities if c.endswith(f"_{q.key}")}
    means = [c for c in cols if c.endswith("_mean") and c not in per_cell]
    assert {"rmse_mean", "mse_mean", "rmse_diff_mean"} <= set(means)
    for c in means:
        se = c[:-len("_mean")] + "_se"
        assert cols[cols.index(c) + 1] == se, c
    for c in MEAN_COLUMNS + ("wall_ms_per_trial",):
        assert cols[cols.index(c) + 1] == f"{c}_se", c
    for q in exp.reported.quantities:
        assert cols[cols.index(f"ours_{q.key}") + 1] == f"ours_se_{q.key}"
    # the standard errors are sd / sqrt(trials) of the per-trial values
    keys = {f.name: f.key for f in exp.filters}
    for name, metric in (("pso", "mean_ess"), ("pso", "position_error"), ("afsa", "rmse")):
        key = keys[name]
        g = df[df["filter"] == key][metric]
        row = tab[tab["filter"] == key].iloc[0]
        q = next((q for q in exp.reported.quantities if q.metric == metric and q.stat == "mean"
                  and q.scale == 1.0), None)
        col = f"ours_se_{q.key}" if metric == "position_error" else f"{metric}_se"
        assert row[col] == pytest.approx(g.std(ddof=1) / np.sqrt(len(g)), rel=1e-12, abs=1e-15)
    # the table's file leaves the machine's times out, their standard error too
    cmp = compare(exp, df)
    assert cmp.table["wall_ms_per_trial_se"].notna().all()
    assert cmp.without_timings().table["wall_ms_per_trial_se"].isna().all()


# ---- the per-run view a comparison reads (compare.RunTrials): pandas' own results, bit for bit

_finite = st.floats(-1e6, 1e6, allow_nan=False, allow_infinity=False)


@settings(max_examples=200, deadline=None)
@given(mine=st.dictionaries(st.integers(0, 40), st.one_of(_finite, st.just(math.nan)),
                            max_size=25),
       wanted=st.lists(st.integers(0, 45), unique=True, max_size=25))
def test_a_run_read_at_another_runs_trials_is_pandas_reindex(mine, wanted):
    """A baseline run's values at a run's trials (NaN where it lacks one) equal pandas'
    set_index('trial').reindex, whatever the order and overlap of the two runs' trials."""
    import pandas as pd

    from pfbench.compare import RunTrials
    base = pd.DataFrame({"trial": list(mine), "rmse": [mine[k] for k in mine]})
    run = pd.DataFrame({"trial": wanted, "rmse": [0.0] * len(wanted)})
    got = RunTrials.of(base).at_trials_of(RunTrials.of(run), "rmse")
    want = base.set_index("trial")["rmse"].reindex(pd.Index(wanted)).to_numpy(float)
    assert got.dtype == np.float64 and got.shape == want.shape
    assert np.array_equal(got, want, equal_nan=True)


@settings(max_examples=200, deadline=None)
@given(values=st.lists(st.one_of(_finite, st.just(math.nan)), max_size=300))
def test_sums_and_means_without_nan_are_pandas_bit_for_bit(values):
    """The sum and mean a run's row takes over its trials, NaN left out, are pandas' Series.sum
    and Series.mean to the last bit (numpy's pairwise sum over as many values in the same
    order)."""
    import pandas as pd

    from pfbench.compare import _skipna_mean, _skipna_sum
    s = pd.Series(values, dtype=float)
    assert float(_skipna_sum(s.to_numpy())) == float(s.sum())
    mean = _skipna_mean(s.to_numpy())
    assert (math.isnan(mean) and math.isnan(s.mean())) or mean == float(s.mean())


def test_the_comparison_reads_a_run_by_its_own_rows_in_a_frame_of_many():
    """Rows of many runs interleaved by trial, with a baseline missing a trial: each run's
    statistics are its own rows' (the paired difference where both have the trial)."""
    import pandas as pd

    from pfbench.compare import RunTrials, _Columns
    df = pd.DataFrame({"trial": [0, 0, 1, 1, 2], "filter": ["a", "b", "a", "b", "a"],
                       "rmse": [1.0, 10.0, 2.0, 20.0, 3.0]})
    cols = _Columns(df)
    a = RunTrials(cols, np.flatnonzero(cols["filter"] == "a"))
    b = RunTrials(cols, np.flatnonzero(cols["filter"] == "b"))
    assert len(a) == 3 and list(a["rmse"]) == [1.0, 2.0, 3.0]
    assert np.array_equal(b.at_trials_of(a, "rmse"), [10.0, 20.0, math.nan], equal_nan=True)
    assert list(a.at_trials_of(b, "rmse")) == [1.0, 2.0]
