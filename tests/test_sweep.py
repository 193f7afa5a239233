"""Sweeps: expansion, the results, equality with single runs, the cell-count guard."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.store import TIMING_COLUMNS
from pfbench.schema import ConfigError
from pfbench.sweep import expand, parse_sets, split_values

from .conftest import SMALL

runner = CliRunner()


def test_values_split_on_top_level_commas_and_keep_their_types():
    assert split_values("1,2.5, [3, 4],'a,b'") == ["1", "2.5", "[3, 4]", "'a,b'"]
    sets = parse_sets(["scenario.steps=10,20", "filters.*.particles=[5, 6],7"])
    assert sets == {"scenario.steps": [10, 20], "filters.*.particles": [[5, 6], 7]}
    with pytest.raises(ConfigError):
        parse_sets(["scenario.steps"])


def test_expansion_is_the_cartesian_product(write_config):
    cfg = write_config(SMALL)
    name, cells = expand(cfg, parse_sets(["scenario.steps=10,20,30",
                                          "scenario.process_noise_var=0.5,2.0"]), {})
    assert len(cells) == 6
    assert [c.values for c in cells][:2] == [
        {"scenario.steps": 10, "scenario.process_noise_var": 0.5},
        {"scenario.steps": 10, "scenario.process_noise_var": 2.0}]
    assert cells[5].exp.scenario_params["steps"] == 30
    assert isinstance(cells[5].exp.scenario_params["process_noise_var"], float)
    assert len({c.name for c in cells}) == 6


def test_a_bad_value_names_its_cell(write_config):
    cfg = write_config(SMALL)
    with pytest.raises(ConfigError, match=r"scenario\.steps.*sweep cell scenario.steps=0"):
        expand(cfg, parse_sets(["scenario.steps=10,0"]), {})
    with pytest.raises(ConfigError, match="did you mean 'steps'"):
        expand(cfg, parse_sets(["scenario.stepz=10,20"]), {})


def test_sweep_cells_equal_single_runs(tmp_path, write_config):
    cfg = write_config(SMALL)
    out = tmp_path / "sw"
    res = runner.invoke(app, ["sweep", str(cfg), "--set", "scenario.steps=10,25", "--out",
                              str(out), "--trials", "3"])
    assert res.exit_code == 0, res.output
    trials = pd.read_csv(out / "trials.csv")
    assert sorted(trials["scenario.steps"].unique()) == [10, 25]
    assert (out / "summary.csv").exists() and (out / "figures" / "rmse.png").exists()
    single = tmp_path / "one"
    res = runner.invoke(app, ["run", str(cfg), "--set", "scenario.steps=25", "--trials", "3",
                              "--out", str(single), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert not set(TIMING_COLUMNS) & set(trials.columns)        # in timings.csv
    a = trials[trials["scenario.steps"] == 25].drop(columns=["scenario.steps"])
    b = pd.read_csv(single / "trials.csv")
    pd.testing.assert_frame_equal(a.reset_index(drop=True), b, check_exact=True)


def test_many_cells_need_yes_and_a_sweep_file_is_not_run(tmp_path, write_config):
    cfg = write_config(SMALL)
    values = ",".join(str(v) for v in range(10, 62))
    res = runner.invoke(app, ["sweep", str(cfg), "--set", f"scenario.steps={values}",
                              "--out", str(tmp_path / "x")])
    assert res.exit_code == 2 and "--yes" in res.output
    assert not (tmp_path / "x").exists()
    sweep_cfg = write_config(SMALL + "sweep:\n  scenario.steps: [10, 20]\n", "s.yaml")
    res = runner.invoke(app, ["run", str(sweep_cfg)])
    assert res.exit_code == 2 and "pfbench sweep" in res.output
    res = runner.invoke(app, ["validate", str(sweep_cfg)])
    assert res.exit_code == 0 and "2 cells" in res.output


def test_a_sweeps_summary_gives_each_mean_its_standard_error_beside_it():
    import numpy as np

    from pfbench.sweep import summary
    rng = np.random.default_rng(2)
    trials = pd.DataFrame({"scenario.steps": [10] * 6 + [20] * 6, "filter": "pf@20",
                           "label": "PF", "particles": 20, "trial": list(range(6)) * 2,
                           "rmse": rng.normal(1.0, 0.2, 12), "nees": rng.normal(1.0, 0.1, 12)})
    s = summary(trials, ["scenario.steps"])
    cols = list(s.columns)
    for m in ("rmse", "nees"):
        assert cols[cols.index(f"{m}_mean") + 1] == f"{m}_se"
        for k, (_, g) in enumerate(trials.groupby("scenario.steps")):
            assert s[f"{m}_se"].iloc[k] == pytest.approx(g[m].std(ddof=1) / np.sqrt(6))
