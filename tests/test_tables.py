import math


import numpy as np
import pytest

from pfbench.metrics import summarize
from pfbench.papers import PAPERS
from pfbench.tables import verdict

from .conftest import ROOT


def test_verdicts():
    assert verdict(None, 1.0, 0.9, 1.1) == ""
    assert verdict(1.0, 1.05, 0.95, 1.15) == "reproduced"
    assert verdict(2.0, 1.0, 0.9, 1.1) == "differs (x0.50)"
    assert verdict(1.05, 1.0, 0.98, 1.02, rel_tol=0.1).startswith("reproduced (within 10%)")
    assert "floor" in verdict(2.0, 3.0, 2.9, 3.1, floor=2.5)
    assert "floor" not in verdict(2.0, 3.0, 2.9, 3.1, floor=1.5)
    assert verdict(1.0, 1.0, 0.9, 1.1, not_comparable="units").startswith("not comparable")


def test_paper_tables_are_well_formed():
    for paper in PAPERS.values():
        for table in paper.tables.values():
            keys = {q.key for q in table.quantities}
            for (label, n), values in table.values.items():
                assert isinstance(label, str) and (n is None or n >= 2)
                assert set(values) <= keys


def test_paper_runs_widen_the_interval_by_the_batch_error():
    from pfbench.papers import Quantity
    from pfbench.tables import _stat
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


def test_ranking_lines_compare_orders(write_config):
    import pandas as pd

    from pfbench.config import load
    from pfbench.tables import rankings
    cfg = write_config("paper: ifa2021\ntable: table1\nscenario: {name: ungm}\nfilters:\n"
                       "  pf: {label: PF, particles: 50}\n  fa: {label: FA-PF, particles: 50}\n")
    exp = load(cfg)
    tab = pd.DataFrame({"label": ["PF", "FA-PF"], "particles": [50, 50],
                        "ours_rmse_mean": [4.0, 3.0]})
    assert rankings(exp, tab) == ["Ranking by RMSE at N = 50: paper FA-PF < PF; ours FA-PF < PF: "
                                  "same order."]
    tab["ours_rmse_mean"] = [3.0, 4.0]
    assert rankings(exp, tab)[0].endswith("ours PF < FA-PF: differs.")


def test_rankings_over_several_quantities_count_the_agreements(write_config):
    import pandas as pd

    from pfbench.config import load
    from pfbench.tables import rankings
    world = ROOT / "configs/worlds/beacon_field.yaml"
    cfg = write_config(f"paper: asrl2008\ntable: table1\nscenario: {{name: beacon_field, world: "
                       f"{world}}}\nfilters:\n  srl: {{type: mcl, label: SRL, particles: [100, 200], "
                       "reset: srl}\n  asrl: {type: mcl, label: ASRL, particles: [100, 200], "
                       "reset: asrl}\n")
    exp = load(cfg)
    # paper: ASRL below SRL in x, y and heading at 100 and 200 particles
    tab = pd.DataFrame({"label": ["SRL", "SRL", "ASRL", "ASRL"], "particles": [100, 200, 100, 200],
                        "ours_x_mm": [50.0, 50.0, 40.0, 60.0], "ours_y_mm": [1.0, 1.0, 2.0, 2.0],
                        "ours_th_deg": [3.0, 3.0, 2.0, 2.0]})
    lines = rankings(exp, tab)
    assert len(lines) == 7
    assert lines[1] == ("Ranking by x error (mm) at N = 200: paper ASRL < SRL; ours SRL < ASRL: "
                        "differs.")
    assert lines[-1] == "Rankings: the same order in 3 of 6 comparisons."


def test_a_paper_range_is_reproduced_when_our_interval_meets_it():
    from pfbench.tables import verdict
    assert verdict((10.0, 20.0), 22.0, 19.0, 25.0).startswith("reproduced")
    assert verdict((10.0, 20.0), 5.0, 4.0, 6.0) == "differs (x0.33 the range's middle)"


def test_time_ratio_is_per_trial_against_the_baseline():
    import pandas as pd

    from pfbench.tables import _metric_values
    g = pd.DataFrame({"trial": [0, 1, 2], "wall_s": [2.0, 3.0, 4.0]})
    base = pd.DataFrame({"trial": [2, 0, 1], "wall_s": [2.0, 1.0, 1.0]})
    assert list(_metric_values("time_ratio", g, base)) == [2.0, 3.0, 2.0]
    assert list(_metric_values("time_ratio", g, None).isna()) == [True] * 3


AFSA_CFG = """\
paper: afsa2014
table: table1
trials: 12
scenario: {name: landmark_world, steps: 50, world: WORLD}
filters:
  pso: {type: fastslam, label: PSO-FastSLAM, particles: 10, refine: pso}
  afsa_std: {type: fastslam, label: AFSA-FastSLAM (standard resampling), particles: 10}
  afsa: {type: fastslam, label: AFSA-FastSLAM, particles: 10}
"""


def _afsa_cfg(write_config, trials=12):
    world = ROOT / "configs" / "worlds" / "afsa_world.yaml"
    return write_config(AFSA_CFG.replace("WORLD", str(world)).replace("trials: 12",
                                                                      f"trials: {trials}"))


def _afsa_rows(exp, values):
    """Trials rows for the filter runs of exp: values[key] -> {metric: per-trial array}."""
    import pandas as pd

    from pfbench.kinds import kind_of
    rows = []
    for f in exp.filters:
        for k in range(exp.trials):
            r = {"trial": k, "filter": f.key, "label": f.label, "particles": f.particles,
                 "wall_s": 1.0}
            r.update({m: float(values[f.name].get(m, np.full(exp.trials, 0.5))[k])
                      for m in kind_of(exp.scenario).metrics})
            rows.append(r)
    return pd.DataFrame(rows)


def test_paper_factors_and_the_per_trial_table(write_config):
    from pfbench.config import load
    from pfbench.tables import markdown, summary
    exp = load(_afsa_cfg(write_config))
    rng = np.random.default_rng(5)
    pso = rng.uniform(0.3, 0.5, exp.trials)
    div = rng.uniform(0.01, 0.02, exp.trials)
    tab = summary(exp, _afsa_rows(exp, {
        "pso": {"position_error": pso},
        "afsa": {"position_error": 0.1 * pso, "diversity_l1": 3 * div},
        "afsa_std": {"diversity_l1": div, "mean_ess": np.full(exp.trials, 1.5)}}))
    f = {x["quantity"]: x for x in tab.attrs["factors"]}
    pos = f["position error (m)"]
    assert pos["ours"] == pytest.approx(0.1) and pos["hi"] - pos["lo"] == pytest.approx(0, abs=1e-9)
    assert pos["paper"] == pytest.approx(0.034 / 0.41)
    assert pos["verdict"].startswith("differs")
    assert f["diversity"]["ours"] == pytest.approx(3.0)
    # the impossible Neff is shown, never judged
    std = tab[tab["label"] == "AFSA-FastSLAM (standard resampling)"].iloc[0]
    assert std["paper_neff_mean"] == 0.336 and std["verdict_neff_mean"].startswith("not comparable")
    title, head, cells = tab.attrs["per_trial"]
    assert head[1:11] == [str(i) for i in range(1, 11)]
    ours = next(c for c in cells if c[0] == "ours: AFSA-FastSLAM")
    assert ours[1:11] == [f"{v:.3g}" for v in 3 * div[:10]]
    assert ours[11].startswith(f"{np.mean(3 * div):.3g} [")
    paper = next(c for c in cells if c[0] == "paper: directional")
    assert paper[-1] == "0.978"
    md = markdown(exp, tab)
    assert "paper: traditional | 0.42 | 0.29" in md and "AFSA-FastSLAM / PSO-FastSLAM" in md


def test_factor_interval_covers_the_true_ratio_about_95_percent(write_config):
    # paired trials with correlated noise; the delta-method interval on the ratio of the means
    from pfbench.config import load
    from pfbench.papers import PAPERS
    from pfbench.tables import factors
    exp = load(_afsa_cfg(write_config, 60))
    table = PAPERS["afsa2014"].tables["table1"]
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
