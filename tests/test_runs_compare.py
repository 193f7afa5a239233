"""Two results compared (pfbench.runs_compare, ``pfbench compare``): a planted drift flagged, noise
not, paired by trial with the same seed and unpaired otherwise, the exit statuses."""
import json

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.runs_compare import compare_frames, compare_runs

from .conftest import SMALL, one_line_exit_2

runner = CliRunner()


def _frame(rmse: dict, trials: range) -> pd.DataFrame:
    """A trials frame of runs ``rmse[key]`` (an array over trials), its mse the square."""
    rows = []
    for key, v in rmse.items():
        for t in trials:
            rows.append({"trial": t, "filter": key, "label": key.split("@")[0].upper(),
                         "particles": int(key.split("@")[1]), "rmse": v[t - trials.start],
                         "mse": v[t - trials.start] ** 2, "lik_evals_per_step": 50.0})
    return pd.DataFrame(rows)


@pytest.mark.parametrize("paired", [True, False])
def test_a_planted_20_percent_drift_is_flagged_and_noise_is_not(paired):
    rng = np.random.default_rng(11)
    n = 200
    base = {k: rng.gamma(9.0, 0.4, n) for k in ("pf@50", "ba@50", "fa@50")}
    a = _frame(base, range(n))
    # B: pf@50's RMSE 20% up; the others the same data with 1% multiplicative noise (paired:
    # common random numbers) or fresh draws of the same law (unpaired: another seed)
    if paired:
        other = {k: v * (1 + 0.01 * rng.normal(size=n)) for k, v in base.items()}
    else:
        other = {k: rng.gamma(9.0, 0.4, n) for k in base}
    other["pf@50"] = base["pf@50"] * 1.2 if paired else other["pf@50"] * 1.2
    cmp = compare_frames(a, _frame(other, range(n)), paired)
    flagged = {(c.run, c.metric) for c in cmp.flagged}
    # the drift shows in RMSE and MSE (1.44x); nothing else passes the 1.05 factor with its test
    assert flagged == {("pf@50", "rmse"), ("pf@50", "mse")}
    pf = next(c for c in cmp.changes if (c.run, c.metric) == ("pf@50", "rmse"))
    assert pf.paired is paired and pf.lo > 0 and pf.ratio == pytest.approx(1.2, abs=0.1)
    # the constant metric is compared exactly: the same in both, never significant
    evals = [c for c in cmp.changes if c.metric == "lik_evals_per_step"]
    assert len(evals) == 3 and not any(c.significant for c in evals)
    # the Holm family is every metric x run compared
    assert len(cmp.changes) == 9 and all(c.level <= 0.05 for c in cmp.changes)


def test_a_significant_change_inside_the_factor_is_not_flagged():
    rng = np.random.default_rng(2)
    v = rng.gamma(9.0, 0.4, 300)
    cmp = compare_frames(_frame({"pf@50": v}, range(300)), _frame({"pf@50": v * 1.03},
                                                                    range(300)), True,
                         metrics=["rmse"])
    (c,) = cmp.changes
    assert c.significant and not c.flagged              # 3% < 5%
    assert compare_frames(_frame({"pf@50": v}, range(300)),
                          _frame({"pf@50": v * 1.03}, range(300)), True, metrics=["rmse"],
                          threshold=1.02).flagged


def test_paired_uses_the_trials_both_hold():
    v = np.arange(1.0, 41.0)
    a, b = _frame({"pf@50": v[:20]}, range(20)), _frame({"pf@50": v * 2}, range(40))
    (c,) = compare_frames(a, b, True, metrics=["rmse"]).changes
    assert (c.n_a, c.n_b) == (20, 20) and c.diff == pytest.approx(v[:20].mean())
    (c,) = compare_frames(a, b, False, metrics=["rmse"]).changes
    assert (c.n_a, c.n_b) == (20, 40) and c.diff == pytest.approx(2 * v.mean() - v[:20].mean())


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Three small runs: a, the same seed with more trials, another seed, and another noise."""
    root = tmp_path_factory.mktemp("runs")
    text = SMALL.replace("trials: 6", "trials: 20")
    (root / "a.yaml").write_text(text)
    (root / "noisy.yaml").write_text(text.replace("process_noise_var: 1.0",
                                                  "process_noise_var: 100.0"))
    made = {}
    for name, cfg, extra in (("a", "a.yaml", []), ("more", "a.yaml", ["--trials", "30"]),
                             ("seed", "a.yaml", ["--seed", "9"]),
                             ("noisy", "noisy.yaml", [])):
        out = root / name
        res = runner.invoke(app, ["run", str(root / cfg), "--out", str(out), "--no-figures",
                                  *extra])
        assert res.exit_code == 0, res.output
        made[name] = out
    return made


def test_pairing_follows_the_seed_and_the_exit_status_the_flags(runs):
    assert compare_runs(runs["a"], runs["more"]).paired
    assert not compare_runs(runs["a"], runs["seed"]).paired
    same = runner.invoke(app, ["compare", str(runs["a"]), str(runs["more"]), "--json"])
    assert same.exit_code == 0, same.output
    d = json.loads(same.output)
    assert d["paired"] and d["flagged"] == 0 and d["compared"] > 0
    # the same seed on its first 20 trials: every paired difference is 0
    assert all(c["diff"] == 0 for c in d["changes"])
    drift = runner.invoke(app, ["compare", str(runs["a"]), str(runs["noisy"]), "--metric",
                                "rmse"])
    assert drift.exit_code == 1, drift.output
    assert "FLAGGED" in drift.output


def test_compare_refuses_bad_input_with_exit_status_2(runs, tmp_path):
    a = str(runs["a"])
    for args in (["compare", a, str(tmp_path / "none")],
                 ["compare", a, a, "--threshold", "0.9"],
                 ["compare", a, a, "--metric", "nope"]):
        one_line_exit_2(runner.invoke(app, args))
