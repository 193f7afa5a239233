"""Per-step diagnostics only where something reads them (pfbench.diagnostics), computed without a
sort per step where they are needed (issue 31, item 1)."""
import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from pfbench import runner as runner_mod
from pfbench.cli import app
from pfbench.config import load
from pfbench.diagnostics import ALL, Diag, flags, plan
from pfbench.filters import FILTERS
from pfbench.papers import search_folders

from .conftest import ROOT, one_line_exit_2

cli = CliRunner()

CONFIG = """\
seed: 3
trials: 2
{extra}
scenario:
  name: ungm
  steps: 20
filters:
  pf:
    label: PF
    particles: 40
    resample: always
  pfmh:
    label: PF+MH
    particles: 40
  ukf:
    label: UKF
"""

PAPER = """\
paper: tiny2024
citation: Tiny and Small, 2024
tables:
  t1:
    caption: UNGM, RMSE and particle diversity
    quantities:
      rmse_mean: {title: RMSE, metric: rmse, stat: mean}
      div_mean: {title: diversity, metric: diversity_l1, stat: mean}
    values:
      - {label: PF, particles: 40, rmse_mean: 4.9, div_mean: 2.0}
"""


@pytest.fixture(autouse=True)
def _no_search_folders():
    yield
    search_folders([])


def _config(tmp_path, extra: str = "", paper: bool = False):
    if paper:
        (tmp_path / "papers").mkdir(exist_ok=True)
        (tmp_path / "papers" / "tiny2024.yaml").write_text(PAPER)
        extra = "paper: tiny2024\ntable: t1\n" + extra
    path = tmp_path / "exp.yaml"
    path.write_text(CONFIG.format(extra=extra))
    return path


@pytest.fixture
def spy(monkeypatch):
    """Every filter type's run, recording the diag each call was given (by run type)."""
    seen = []
    for name, ft in list(FILTERS.items()):
        def run(*args, _ft=ft, _name=name, **kw):
            seen.append((_name, args[5]))
            return _ft.run(*args, **kw)
        monkeypatch.setitem(FILTERS, name, dataclasses.replace(ft, run=run))
    return seen


def test_a_config_whose_tables_read_no_diversity_computes_none(tmp_path, spy):
    """No paper file reads diversity_l1: every filter run is asked for the distinct fraction
    only (the tables print it), never the sort; the rows hold the one, not the other."""
    exp = load(_config(tmp_path))
    rows = runner_mod.trial_result(exp, 0).rows
    assert spy and all(int(d) == int(Diag.DISTINCT) for _, d in spy)
    for r in rows:
        assert math.isnan(r["diversity_l1"])
        if r["filter"] != "ukf":
            assert 0 < r["distinct_frac"] <= 1
    assert plan(exp).names == ("distinct_frac",)


def test_a_paper_that_reads_diversity_computes_it(tmp_path, spy):
    exp = load(_config(tmp_path, paper=True))
    p = plan(exp)
    assert p.names == ("distinct_frac", "diversity_l1")
    assert any("quantity div_mean" in w for w in p.why["diversity_l1"])
    rows = runner_mod.trial_result(exp, 0).rows
    assert all(int(d) == int(Diag.DISTINCT | Diag.DIVERSITY) for _, d in spy)
    pf = next(r for r in rows if r["filter"] == "pf@40")
    assert pf["diversity_l1"] > 0


def test_the_key_adds_diagnostics_and_is_checked(tmp_path):
    assert plan(load(_config(tmp_path, "diagnostics: [diversity_l1]"))).names == (
        "distinct_frac", "diversity_l1")
    assert plan(load(_config(tmp_path, "diagnostics: all"))).names == (
        "distinct_frac", "diversity_l1", "nees")
    assert plan(load(_config(tmp_path, "diagnostics: []"))).names == ("distinct_frac",)
    for bad, says in (("diagnostics: [lm_trace]", "no diagnostic 'lm_trace'"),
                      ("diagnostics: every", "'auto' or 'all' or a list"),
                      ("diagnostics: [diversity]", "did you mean"),
                      ("diagnostics: [distinct_frac, distinct_frac]", "distinct names"),
                      ("diagnostics: 3", "got 3"),
                      ("diagnostics:", "got nothing"),
                      ("diagnostics: {a: 1}", "got a mapping")):
        line = one_line_exit_2(cli.invoke(app, ["validate", str(_config(tmp_path, bad))]))
        assert "diagnostics" in line and says in line, (bad, line)


def test_the_key_from_the_command_line(tmp_path):
    res = cli.invoke(app, ["validate", str(_config(tmp_path)), "--set", "diagnostics=all"])
    assert res.exit_code == 0, res.output
    assert "diversity_l1 (the config's diagnostics key)" in res.output
    line = one_line_exit_2(cli.invoke(app, ["validate", str(_config(tmp_path)), "--set",
                                            "diagnostics=[bogus]"]))
    assert "--set diagnostics=[bogus]" in line


def test_slam_figures_get_the_map_trace_in_the_trials_they_draw(monkeypatch):
    """afsa_fastslam: its paper file reads diversity_l1 and distinct_frac in every trial; the
    SLAM figures the map-error trace of the trials they draw (the first FIGURE_TRIALS), and only
    those. The trace is a side output: a traced trial's rows are those of the same trial run
    without it, number for number."""
    monkeypatch.chdir(ROOT)
    exp = load("configs/afsa_fastslam.yaml", sets=["scenario.steps=40", "trials=2"])
    p = plan(exp)
    assert p.every == Diag.DISTINCT | Diag.DIVERSITY and p.traced == Diag.MAP_TRACE
    assert p.for_trial(True) == Diag.DISTINCT | Diag.DIVERSITY | Diag.MAP_TRACE
    assert p.for_trial(False) == p.every
    assert any("per-run table" in w for w in p.why["distinct_frac"])
    for k in (0, 1):
        traced = runner_mod.trial_result(exp, k, traces=True)
        assert any(name.endswith("/map_error") for name in traced.trace)
        assert any(name.endswith("/lm_trace") for name in traced.trace) == (k == 0)
        plain = runner_mod.run_trial(exp, k)
        assert [{c: v for c, v in row.items() if c != "wall_s"} for row in traced.rows] == [
            {c: v for c, v in row.items() if c != "wall_s"} for row in plain]
    out, _ = runner_mod.run_filter(exp, 1, exp.filters[0], *runner_mod.trial_data(exp, 1)[::2])
    assert "lm_trace" not in out and "div_l1" in out and "distinct" in out


def test_validate_says_which_diagnostics_and_why(monkeypatch):
    monkeypatch.chdir(ROOT)
    res = cli.invoke(app, ["validate", "configs/ifa_pf_ungm.yaml"])
    assert res.exit_code == 0, res.output
    line = next(l for l in res.output.splitlines() if "per-step diagnostics" in l)
    assert "distinct_frac (the tables' Distinct column)" in line
    assert "not computed: diversity_l1, nees (blank" in line     # no filter of its own NEES
    res = cli.invoke(app, ["validate", "configs/afsa_fastslam.yaml"])
    line = next(l for l in res.output.splitlines() if "per-step diagnostics" in l)
    assert "diversity_l1 (paper afsa2014 table1: quantity diversity_mean" in line
    assert "lm_trace in the trials kept for the figures (the slam figures)" in line
    res = cli.invoke(app, ["validate", "configs/sspf_upf_gamma.yaml"])    # EKF and UKF
    line = next(l for l in res.output.splitlines() if "per-step diagnostics" in l)
    assert "nees (the filters that report their own nees give it)" in line
    res = cli.invoke(app, ["validate", "configs/kidnap.yaml"])
    line = next(l for l in res.output.splitlines() if "per-step diagnostics" in l)
    assert "none (its kind has none)" in line


def test_a_filter_of_the_older_signature_still_runs_and_what_it_was_not_asked_is_dropped(
        tmp_path, monkeypatch):
    """A plug-in's run(model, y, params, particles, state, diag) that treats diag as a bool and
    returns every diagnostic: it runs, bool(diag) and int(diag) work, and the runner drops the
    outputs the experiment does not compute."""
    got = []
    pf = FILTERS["pf"]

    def old_run(model, y, params, particles, state, diag=True):
        got.append((bool(diag), int(diag)))
        out = pf.run(model, y, params, particles, state, True)
        assert "div_l1" in out and "distinct" in out
        return out

    monkeypatch.setitem(FILTERS, "pf", dataclasses.replace(pf, run=old_run))
    exp = load(_config(tmp_path))
    rows = runner_mod.trial_result(exp, 0).rows
    assert got == [(True, 1)]
    row = next(r for r in rows if r["filter"] == "pf@40")
    assert math.isnan(row["diversity_l1"]) and row["distinct_frac"] > 0


def test_flags_of_the_older_boolean():
    assert flags(True) == ALL and flags(False) == Diag.NONE and flags(None) == Diag.NONE
    assert flags(Diag.DIVERSITY) == Diag.DIVERSITY and flags(3) == Diag.DISTINCT | Diag.DIVERSITY


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 300), seed=st.integers(0, 2**32 - 1),
       scheme=st.sampled_from(["multinomial", "systematic", "stratified", "residual"]),
       moved=st.floats(0.0, 1.0), spread=st.floats(1e-6, 1e6), nan=st.booleans())
def test_the_distinct_count_from_the_ancestors_is_the_sorted_count(n, seed, scheme, moved,
                                                                   spread, nan):
    """On continuous particles (pairwise distinct before resampling), some of them then moved
    to new values (MH moves, mutations): the count from the ancestors equals the number of
    distinct values the sort finds, a NaN particle counting once per copy as it does there."""
    from pfbench.filters._common import distinct_count, diversity
    from pfbench.resampling import ancestors
    from pfbench.rng import state_from_seed
    rng = np.random.default_rng(seed)
    xn = spread * rng.standard_normal(n)
    assert np.unique(xn).size == n          # continuous: pairwise distinct
    if nan:
        xn[rng.integers(n)] = np.nan
    w = rng.random(n) ** 8                  # uneven: many copies
    idx = ancestors(w, scheme, state_from_seed(np.random.SeedSequence(seed)))
    x = xn[idx]
    move = rng.random(n) < moved
    x[move] = x[move] + spread * (1.0 + rng.random(move.sum()))
    sorted_count = diversity(x)[1] * n
    assert distinct_count(x, xn, idx, np.empty(n, dtype=np.int8)) == round(sorted_count)


def test_every_scalar_pf_computes_what_it_is_asked_and_the_filter_stays_the_same():
    """Every scalar PF (the swarm PFs' moves, stepwise EWA's mutants, PF+MH's and SSPF's moves
    included): the distinct fraction alone, all diagnostics or none give the same filter (its
    random stream untouched), and only the outputs asked for."""
    from pfbench.config import Params
    from pfbench.rng import state_from_seed
    from pfbench.scenarios import SCENARIOS
    mod = SCENARIOS["ungm"]
    model = mod.build({k: key.default for k, key in mod.SCHEMA.items()} | {"steps": 15})
    _, y = mod.simulate(model, state_from_seed(np.random.SeedSequence(1)))
    for name in ("pf", "pfmh", "upf", "sspf", "fa", "ifa", "ba", "pso", "afsa"):
        ft = FILTERS[name]
        p = {k: key.default for k, key in ft.schema.items()} | {"resample": "always"}
        if name == "ifa":
            p["resampling"] = "stepwise_ewa"
        runs = [ft.run(model, y, Params(p), 30, state_from_seed(np.random.SeedSequence(2)), d)
                for d in (Diag.DISTINCT, Diag.NONE)]
        on, off = runs
        assert "div_l1" not in on and "distinct" not in off and "div_l1" not in off
        np.testing.assert_array_equal(on["xhat"], off["xhat"])    # the filter's stream: same
        assert np.isfinite(on["distinct"][1:]).all(), name
        full = ft.run(model, y, Params(p), 30, state_from_seed(np.random.SeedSequence(2)), ALL)
        np.testing.assert_array_equal(full["distinct"], on["distinct"])
        assert np.isfinite(full["div_l1"][1:]).all()
        assert "pvar" not in on and np.isfinite(full["pvar"]).all()
        np.testing.assert_array_equal(full["xhat"], off["xhat"])
