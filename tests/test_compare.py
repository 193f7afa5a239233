"""Computing a comparison: verdicts, intervals widened by the paper's runs, per-trial ratios and
the factors' intervals (pfbench.compare)."""
import math

import numpy as np

from pfbench.compare import verdict
from pfbench.metrics import summarize

from .conftest import ROOT
from .test_tables import _afsa_cfg, _afsa_rows


def test_verdicts():
    assert verdict(None, 1.0, 0.9, 1.1) == ""
    assert verdict(1.0, 1.05, 0.95, 1.15) == "reproduced"
    assert verdict(2.0, 1.0, 0.9, 1.1) == "differs (x0.50)"
    assert verdict(1.05, 1.0, 0.98, 1.02, rel_tol=0.1).startswith("reproduced (within 10%)")
    assert "floor" in verdict(2.0, 3.0, 2.9, 3.1, floor=2.5)
    assert "floor" not in verdict(2.0, 3.0, 2.9, 3.1, floor=1.5)
    assert verdict(1.0, 1.0, 0.9, 1.1, not_comparable="units").startswith("not comparable")


def test_paper_runs_widen_the_interval_by_the_batch_error():
    from pfbench.papers import Quantity
    from pfbench.compare import _stat
    rng = np.random.default_rng(2)
    s = summarize(rng.normal(1.0, 0.3, 1000))
    q = Quantity("m", "m", "rmse", "mean")
    v, lo, hi = _stat(s, q)
    assert (lo, hi) == (s["ci_lo"], s["ci_hi"])
    v, lo, hi = _stat(s, q, paper_runs=100)
    # a 100-run batch has sqrt(1000 / 100) times our standard error: half-width 1.96 se sqrt(11)
    assert math.isclose(hi - v, 1.959963984540054 * s["se"] * math.sqrt(11), rel_tol=1e-12)
    qv = Quantity("v", "v", "rmse", "var")
    v, lo, hi = _stat(s, qv, paper_runs=100)
    assert math.isclose(hi - v, 1.959963984540054 * s["var_se"] * math.sqrt(11), rel_tol=1e-12)


def test_a_paper_range_is_reproduced_when_our_interval_meets_it():
    from pfbench.compare import verdict
    assert verdict((10.0, 20.0), 22.0, 19.0, 25.0).startswith("reproduced")
    assert verdict((10.0, 20.0), 5.0, 4.0, 6.0) == "differs (x0.33 the range's middle)"


def test_time_ratio_is_per_trial_against_the_baseline():
    import pandas as pd

    from pfbench.compare import _metric_values
    g = pd.DataFrame({"trial": [0, 1, 2], "wall_s": [2.0, 3.0, 4.0]})
    base = pd.DataFrame({"trial": [2, 0, 1], "wall_s": [2.0, 1.0, 1.0]})
    assert list(_metric_values("time_ratio", g, base)) == [2.0, 3.0, 2.0]
    assert list(_metric_values("time_ratio", g, None).isna()) == [True] * 3


def test_factor_interval_covers_the_true_ratio_about_95_percent(write_config):
    # paired trials with correlated noise; the delta-method interval on the ratio of the means
    from pfbench.config import load
    from pfbench import papers
    from pfbench.compare import factors
    exp = load(_afsa_cfg(write_config, 60))
    table = papers.find("afsa2014", ROOT / "configs" / "x.yaml").tables["table1"]
    rng = np.random.default_rng(6)
    hits, reps = 0, 1000
    for _ in range(reps):
        common = rng.normal(0.0, 0.05, exp.trials)
        a = 0.4 + common + rng.normal(0.0, 0.05, exp.trials)
        b = 0.2 + 0.5 * common + rng.normal(0.0, 0.03, exp.trials)
        df = _afsa_rows(exp, {"pso": {"position_error": a}, "afsa": {"position_error": b},
                              "afsa_std": {}})
        by_key = {f.key: df[df["filter"] == f.key] for f in exp.filters}
        pos = next(x for x in factors(exp, table, by_key) if x["quantity"].startswith("position"))
        hits += pos["lo"] <= 0.5 <= pos["hi"]
    assert abs(hits / reps - 0.95) < 0.025
