"""pfbench tables: regeneration of a folder of configs, and --check against committed results."""
import json

import numpy as np
import pandas as pd

import pytest
from typer.testing import CliRunner

from pfbench import regen
from pfbench.cli import app
from pfbench.store import csv_text, read_trials, trials_digest

from .conftest import SMALL

runner = CliRunner()

EXPERIMENT = SMALL.replace("trials: 6", "name: small\ntrials: 12\ncheck:\n  trials: 5")
SWEEP = SMALL.replace("trials: 6", "name: swept\ntrials: 4\ncheck:\n  trials: 3") + """\
sweep:
  scenario.steps: [10, 20]
"""


@pytest.fixture
def folders(tmp_path):
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    (configs / "small.yaml").write_text(EXPERIMENT)
    (configs / "swept.yaml").write_text(SWEEP)
    (configs / "worlds").mkdir()          # subfolders are not configs
    return configs, results


def tables(*args):
    return runner.invoke(app, ["tables", *map(str, args)])


def test_tables_regenerates_every_config_then_check_passes(folders):
    configs, results = folders
    r = tables("--configs", configs, "--results", results, "--no-figures")
    assert r.exit_code == 0, r.output
    trials = pd.read_csv(results / "small" / "trials.csv")
    assert trials["trial"].nunique() == 12
    assert (results / "small" / "table.md").exists()
    assert (results / "swept" / "summary.csv").exists()
    assert len(list((results / "swept" / "cells").iterdir())) == 2
    assert not list(results.glob(".*"))                       # no staging folder left
    # what an up-to-date run or sweep in a fresh clone prints (pfbench.replay), for the folder
    from pfbench import replay as rp
    from pfbench.config import load
    record = json.loads((results / "small" / rp.FOLDER_RECORD).read_text())
    assert record["key"] == rp.untimed_key(load(configs / "small.yaml"), results / "small")
    assert (results / "swept" / rp.FOLDER_RECORD).is_file()

    r = tables("--check", "--configs", configs, "--results", results)
    assert r.exit_code == 0, r.output
    assert "moved" not in r.output
    row = next(line for line in r.output.splitlines() if "small.yaml" in line)
    assert "5" in row and "yes" in row and "ok" in row       # 5 trials re-run, bit for bit
    assert "pooled standard deviation" in r.output            # the rule is stated


def test_check_fails_on_a_perturbed_table_and_names_the_metric(folders):
    configs, results = folders
    assert tables("--configs", configs, "--results", results, "--no-figures",
                  "--only", "small").exit_code == 0
    path = results / "small" / "trials.csv"
    df = pd.read_csv(path)
    pf = df["filter"] == "pf@20"
    # a change that moves the filter's error by 3 standard deviations of a trial: with 5 trials
    # re-run against 12 the tolerance is 4 sqrt(1/5 + 1/12) = 2.1 of them (written as a run
    # would write it, checksums and meta.json's included: a file edited by hand is refused)
    shift = 3 * df.loc[pf, "rmse"].std()
    rows = read_trials(path).rows
    for r in rows:
        if r["filter"] == "pf@20":
            r["rmse"] += shift
    text = csv_text(rows, True, tuple(df.columns))
    path.write_text(text)
    meta = json.loads((path.parent / "meta.json").read_text())
    meta["trials_sha256"] = trials_digest(text)
    (path.parent / "meta.json").write_text(json.dumps(meta))
    r = tables("--check", "--configs", configs, "--results", results, "--only", "small.yaml")
    assert r.exit_code == 1, r.output
    moved = [line for line in r.output.splitlines() if line.startswith("moved:")]
    assert any("pf@20 rmse:" in line for line in moved), r.output
    assert not any("ukf" in line for line in moved)           # the others did not move
    assert "no" in next(line for line in r.output.splitlines() if "small.yaml" in line)


def test_check_flags_a_changed_constant_metric():
    rows = [{"trial": t, "filter": "pf@20", "lik_evals_per_step": 20.0, "rmse": 1.0 + 0.1 * t}
            for t in range(6)]
    committed = pd.DataFrame(rows)
    now = committed.head(3).copy()
    assert regen.check_against_committed(now, committed, "x").ok
    now["lik_evals_per_step"] = 21.0
    found = regen.check_against_committed(now, committed, "x").findings
    assert [f.metric for f in found] == ["lik_evals_per_step"]


@pytest.mark.slow
def test_check_tolerance_holds_its_false_alarm_rate_and_sees_a_shift():
    """Under the null (the same distribution) z = 4 flags about 1e-4 of comparisons of normal
    metrics; over 2000 comparisons of 10 re-run trials against 100 committed ones we allow 3
    (expected 0.2). The tolerance is 4 sqrt(1/10 + 1/100) = 1.33 standard deviations of a trial,
    so a shift of 2 is seen with probability P(Z > (1.33 - 2) / 0.33) = 0.98; we ask for 95%."""
    rng = np.random.default_rng(7)
    false_alarms = seen = 0
    n = 2000
    for _ in range(n):
        committed = pd.DataFrame({"trial": range(100), "filter": "f",
                                  "rmse": rng.standard_normal(100)})
        now = pd.DataFrame({"trial": range(10), "filter": "f", "rmse": rng.standard_normal(10)})
        false_alarms += not regen.check_against_committed(now, committed, "x").ok
        now["rmse"] += 2.0
        seen += not regen.check_against_committed(now, committed, "x").ok
    assert false_alarms <= 3
    assert seen >= 0.95 * n


def test_pooled_se_is_the_two_sample_standard_error():
    a, b = np.array([1.0, 2.0, 4.0]), np.array([0.0, 1.0, 1.0, 3.0, 5.0])
    var = (2 * a.var(ddof=1) + 4 * b.var(ddof=1)) / 6
    assert regen.pooled_se(a, b) == pytest.approx(np.sqrt(var * (1 / 3 + 1 / 5)))


def test_tables_input_errors_are_one_line_exit_2(folders, tmp_path):
    configs, results = folders
    r = tables("--configs", configs, "--results", results, "--only", "nosuch")
    assert r.exit_code == 2 and "no such config" in r.output and "small" in r.output
    r = tables("--check", "--configs", configs, "--results", results)
    assert r.exit_code == 2 and "run 'pfbench tables' first" in r.output
    assert len(r.output.strip().splitlines()) == 1
    r = tables("--configs", tmp_path / "none", "--results", results)
    assert r.exit_code == 2 and "no such folder" in r.output
    (configs / "bad.yaml").write_text(SMALL.replace("steps: 30", "steps: -1"))
    r = tables("--configs", configs, "--results", results)
    assert r.exit_code == 2 and "steps" in r.output
    assert not results.exists()                 # a bad config stops everything before it runs


def test_a_failed_regeneration_keeps_the_committed_folder(folders, monkeypatch):
    configs, results = folders
    assert tables("--configs", configs, "--results", results, "--no-figures",
                  "--only", "small").exit_code == 0
    before = (results / "small" / "trials.csv").read_bytes()

    def broken(*args, **kwargs):
        raise RuntimeError("disk full")
    monkeypatch.setattr(regen, "write_experiment", broken)
    with pytest.raises(RuntimeError):
        regen.regenerate(configs / "small.yaml", results, regen.LocalExecutor(1), figures=False)
    assert (results / "small" / "trials.csv").read_bytes() == before


def test_tables_resume_keeps_the_staged_trials_of_an_interrupted_regeneration(folders):
    from pfbench.config import load
    from pfbench.runner import run_experiment
    configs, results = folders
    exp = load(configs / "small.yaml")
    # what an interrupted 'pfbench tables' leaves: the first trials in the staging folder
    stage = results / ".small.partial"
    run_experiment(load(configs / "small.yaml", {"trials": 5}), stage)
    r = tables("--configs", configs, "--results", results, "--no-figures", "--only", "small",
               "--resume")
    assert r.exit_code == 0, r.output
    meta = json.loads((results / "small" / "meta.json").read_text())
    took = json.loads((results / "small" / "timings.json").read_text())
    assert meta["trials"] == exp.trials == 12 and took["trials_run_now"] == 7
    assert not stage.exists()
    # the same trials as a regeneration from scratch
    resumed = pd.read_csv(results / "small" / "trials.csv")
    assert tables("--configs", configs, "--results", results, "--no-figures", "--only",
                  "small").exit_code == 0
    fresh = pd.read_csv(results / "small" / "trials.csv")
    assert resumed.equals(fresh)
    assert json.loads((results / "small" / "timings.json").read_text())["trials_run_now"] == 12
