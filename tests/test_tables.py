"""Rendering a comparison: ranking lines, the per-run table, table.md."""

import numpy as np
import pytest


from .conftest import ROOT


def test_ranking_lines_compare_orders(write_config):
    import pandas as pd

    from pfbench.compare import rankings
    from pfbench.config import load
    from pfbench.tables import ranking_lines
    cfg = write_config("paper: ifa2021\ntable: table1\nscenario: {name: ungm}\nfilters:\n"
                       "  pf: {label: PF, particles: 50}\n  fa: {label: FA-PF, particles: 50}\n")
    exp = load(cfg)
    tab = pd.DataFrame({"label": ["PF", "FA-PF"], "particles": [50, 50],
                        "ours_rmse_mean": [4.0, 3.0]})
    assert ranking_lines(rankings(exp, tab)) == [
        "Ranking by RMSE at N = 50: paper FA-PF < PF; ours FA-PF < PF: same order."]
    tab["ours_rmse_mean"] = [3.0, 4.0]
    assert ranking_lines(rankings(exp, tab))[0].endswith("ours PF < FA-PF: differs.")


def test_rankings_over_several_quantities_count_the_agreements(write_config):
    import pandas as pd

    from pfbench.compare import rankings
    from pfbench.config import load
    from pfbench.tables import ranking_lines
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
    lines = ranking_lines(rankings(exp, tab))
    assert len(lines) == 7
    assert lines[1] == ("Ranking by x error (mm) at N = 200: paper ASRL < SRL; ours SRL < ASRL: "
                        "differs.")
    assert lines[-1] == "Rankings: the same order in 3 of 6 comparisons."


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
    from pfbench.compare import compare
    from pfbench.config import load
    from pfbench.tables import markdown, per_trial_cells
    exp = load(_afsa_cfg(write_config))
    rng = np.random.default_rng(5)
    pso = rng.uniform(0.3, 0.5, exp.trials)
    div = rng.uniform(0.01, 0.02, exp.trials)
    cmp = compare(exp, _afsa_rows(exp, {
        "pso": {"position_error": pso},
        "afsa": {"position_error": 0.2 * pso, "diversity_l1": 3 * div},
        "afsa_std": {"diversity_l1": div, "mean_ess": np.full(exp.trials, 1.5)}}))
    tab = cmp.table
    f = {x["quantity"]: x for x in cmp.factors}
    pos = f["position error (m)"]
    assert pos["ours"] == pytest.approx(0.2) and pos["hi"] - pos["lo"] == pytest.approx(0, abs=1e-9)
    assert pos["paper"] == pytest.approx(0.034 / 0.41)
    assert pos["verdict"].startswith("differs")
    assert f["diversity"]["ours"] == pytest.approx(3.0)
    # the impossible Neff is shown, never judged
    std = tab[tab["label"] == "AFSA-FastSLAM (standard resampling)"].iloc[0]
    assert std["paper_neff_mean"] == 0.336 and std["verdict_neff_mean"].startswith("not comparable")
    title, head, cells = per_trial_cells(cmp.per_trial)
    assert head[1:11] == [str(i) for i in range(1, 11)]
    ours = next(c for c in cells if c[0] == "ours: AFSA-FastSLAM")
    assert ours[1:11] == [f"{v:.3g}" for v in 3 * div[:10]]
    assert ours[11].startswith(f"{np.mean(3 * div):.3g} [")
    paper = next(c for c in cells if c[0] == "paper: directional")
    assert paper[-1] == "0.978"
    md = markdown(cmp)
    assert "paper: traditional | 0.42 | 0.29" in md and "AFSA-FastSLAM / PSO-FastSLAM" in md

