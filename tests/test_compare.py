"""Computing a comparison: per-trial ratios and the factors' intervals (pfbench.compare; the
verdicts themselves: test_verdicts)."""
import numpy as np

from .conftest import ROOT
from .test_tables import _afsa_cfg, _afsa_rows


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
