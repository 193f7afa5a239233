"""The Python API: pfbench.run_experiment and pfbench.load_results."""
import numpy as np
import pandas as pd
import pytest

import pfbench
from pfbench.errors import UserError
from pfbench.store import TIMING_COLUMNS

from .conftest import ROOT, SMALL, tree


def _numbers(df):
    return df.drop(columns=[c for c in TIMING_COLUMNS if c in df]).reset_index(drop=True)


def test_a_run_in_memory_writes_nothing_and_matches_the_cli_files(tmp_path, write_config,
                                                                  monkeypatch):
    cfg = write_config(SMALL)
    monkeypatch.chdir(tmp_path)
    before = tree(tmp_path)
    res = pfbench.run_experiment(cfg)
    assert tree(tmp_path) == before and res.folder is None
    assert list(res.trials.columns[:4]) == ["trial", "filter", "label", "particles"]
    assert len(res.trials) == 6 * 3 and "crc" not in res.trials
    assert set(res.table["filter"]) == {"pf@20", "pf@40", "ukf"}
    assert res.meta["trials"] == 6 and res.meta["experiment_hash"] == res.experiment.hash
    # the same numbers as a run into a folder, read back
    out = tmp_path / "out"
    written = pfbench.run_experiment(cfg, out=out, workers=2, figures=False)
    assert (out / "trials.csv").exists() and (out / "table.csv").exists()
    back = pfbench.load_results(out)
    for other in (written, back):
        pd.testing.assert_frame_equal(_numbers(res.trials), _numbers(other.trials),
                                      check_exact=True, check_dtype=False)
    cols = [c for c in res.table.columns if not c.startswith("wall")]
    pd.testing.assert_frame_equal(res.table[cols], back.table[cols], check_exact=True)
    assert back.experiment is not None and back.meta["trials"] == 6


def test_a_mapping_with_overrides_trials_and_seed(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    config = {"name": "mine", "scenario": {"name": "ungm", "steps": 20},
              "filters": {"pf": {"particles": 50}, "ukf": {}}}
    a = pfbench.run_experiment(config, trials=4, seed=7,
                               overrides=["filters.pf.particles=80"])
    assert a.meta["trials"] == 4 and a.meta["seed"] == 7
    assert set(a.trials["filter"]) == {"pf@80", "ukf"}
    b = pfbench.run_experiment(config, trials=4, seed=7, overrides=["filters.pf.particles=80"])
    pd.testing.assert_frame_equal(_numbers(a.trials), _numbers(b.trials), check_exact=True)
    c = pfbench.run_experiment(config, trials=4, seed=8, overrides=["filters.pf.particles=80"])
    assert not np.array_equal(a.trials["rmse"], c.trials["rmse"])
    assert config["filters"]["pf"] == {"particles": 50}        # the caller's mapping untouched
    # comparing two filters, as the README's example does
    pivot = a.trials.pivot(index="trial", columns="label", values="rmse")
    assert list(pivot.columns) == ["PF", "UKF"] or set(pivot.columns) == {"pf", "ukf"}


def test_a_paper_table_comes_with_its_verdicts():
    res = pfbench.run_experiment(ROOT / "configs" / "sspf_upf_gamma.yaml", trials=30)
    assert {"paper_mse_mean", "ours_mse_mean", "verdict_mse_mean"} <= set(res.table.columns)
    assert res.comparison.reported.caption.startswith("UKF, PF, PFMH and SSPF")


@pytest.mark.parametrize("config, message", [
    (42, "expected a path or a mapping"),
    ({"scenario": {"name": "ungm"}, "filters": {"pf": {"particels": 5}}},
     "config \\(a mapping\\): filters.pf.particels: unknown key"),
    ("nope.yaml", "nope.yaml: no such file"),
])
def test_bad_input_is_a_user_error(config, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(UserError, match=message):
        pfbench.run_experiment(config)


def test_load_results_reads_the_committed_results_and_refuses_other_folders(tmp_path):
    res = pfbench.load_results(ROOT / "results" / "ifa_pf_ungm")
    assert res.experiment is not None and res.experiment.name == "ifa_pf_ungm"
    committed = pd.read_csv(ROOT / "results" / "ifa_pf_ungm" / "table.csv")
    assert np.array_equal(res.table["rmse_mean"], committed["rmse_mean"])
    assert len(res.trials) == res.meta["trials"] * len(res.experiment.filters)
    sweep = pfbench.load_results(ROOT / "results" / "ifa_fastslam_speed")
    assert "rmse_mean" in sweep.table and "scenario.speed_mps" in sweep.trials
    with pytest.raises(UserError, match="no such results folder"):
        pfbench.load_results(tmp_path / "none")
    with pytest.raises(UserError, match="no trials.csv"):
        pfbench.load_results(tmp_path)


@pytest.mark.slow
def test_the_docs_python_api_example_runs(monkeypatch):
    import re

    import matplotlib
    matplotlib.use("Agg")
    text = (ROOT / "docs/how-to/python-api.md").read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    monkeypatch.chdir(ROOT)
    scope: dict = {}
    exec(compile(code, "docs/how-to/python-api.md", "exec"), scope)
    res, old = scope["res"], scope["old"]
    assert set(res.table["filter"]) >= {"pf@50", "pf@100", "fa@100"}
    assert "verdict_rmse_mean" in res.table and old.experiment.name == "ifa_pf_ungm"
