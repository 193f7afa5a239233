"""Filters and scenarios through entry points: pfbench's own register as plug-ins do, and a
plug-in package (tests/plugin_example) runs from YAML without a line of pfbench changed; a
broken plug-in is named in one line and leaves the others working.

The plug-in is installed for these tests as pip would lay it out (the package and its
``.dist-info`` with the entry points) in a folder put on PYTHONPATH of a pfbench subprocess."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import pandas as pd
import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "tests" / "plugin_example"


def _dist(site: Path, name: str, entry_points: str, files: dict[str, str] | None = None) -> None:
    info = site / f"{name.replace('-', '_')}-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {name}\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(entry_points)
    for rel, text in (files or {}).items():
        (site / rel).parent.mkdir(parents=True, exist_ok=True)
        (site / rel).write_text(text)


@pytest.fixture
def site(tmp_path):
    """A folder holding the example plug-in as installed, and three broken ones."""
    site = tmp_path / "site"
    site.mkdir()
    shutil.copytree(EXAMPLE / "pfbench_example", site / "pfbench_example")
    eps = tomllib.loads((EXAMPLE / "pyproject.toml").read_text())["project"]["entry-points"]
    text = "".join(f"[{group}]\n" + "".join(f"{k} = {v}\n" for k, v in items.items())
                   for group, items in eps.items())
    _dist(site, "pfbench-example", text)
    _dist(site, "broken-import", "[pfbench.filters]\nbroken = broken_import_mod:F\n",
          {"broken_import_mod.py": "raise ImportError('a dependency is missing')\n"})
    _dist(site, "not-a-filter", "[pfbench.filters]\nnotafilter = not_a_filter_mod:F\n"
          "[pfbench.scenarios]\nbadworld = not_a_filter_mod\n",
          {"not_a_filter_mod.py": "F = 42\nNAME = 'badworld'\n"})
    _dist(site, "name-thief", "[pfbench.filters]\npf = pfbench_example.filters:METROPOLIS_PF\n")
    return site


def _pfbench(site: Path, *args, cwd: Path):
    env = dict(os.environ, PYTHONPATH=str(site), COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "pfbench.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


CONFIG = """\
seed: 5
trials: 6
scenario:
  name: ungm
  steps: 30
filters:
  pf:
    particles: 200
  mpf:
    type: metropolis_pf
    label: Metropolis PF
    particles: 200
    iterations: 30
"""


@pytest.mark.slow
def test_a_plugin_filter_runs_from_yaml_beside_the_built_ins(site, tmp_path):
    (tmp_path / "exp.yaml").write_text(CONFIG)
    res = _pfbench(site, "list", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    line = next(l for l in res.stdout.splitlines() if l.strip().startswith("metropolis_pf"))
    assert "plug-in: pfbench-example" in line
    # the broken ones: one line each on stderr, the rest listed
    warnings = [l for l in res.stderr.splitlines() if l.startswith("pfbench: warning:")]
    assert len(warnings) == 4, res.stderr
    assert any("'broken'" in w and "cannot be loaded" in w and "a dependency is missing" in w
               for w in warnings)
    assert any("'notafilter'" in w and "FilterType" in w for w in warnings)
    assert any("'badworld'" in w and "has no" in w for w in warnings)
    assert any("'pf'" in w and "taken by package pfbench" in w for w in warnings)
    assert "Traceback" not in res.stderr
    for out in ("a", "b"):
        res = _pfbench(site, "run", "exp.yaml", "--out", out, "--no-figures", cwd=tmp_path)
        assert res.returncode == 0, res.stderr
    a = pd.read_csv(tmp_path / "a/trials.csv")
    b = pd.read_csv(tmp_path / "b/trials.csv")
    assert set(a["filter"]) == {"pf@200", "mpf@200"}
    # seeded by the same contract: the same numbers again, and sound ones
    pd.testing.assert_series_equal(a["rmse"], b["rmse"])
    m = a.groupby("filter")["rmse"].mean()
    assert m["mpf@200"] < 2 * m["pf@200"]


def test_a_plugins_schema_is_checked_like_a_built_ins(site, tmp_path):
    (tmp_path / "exp.yaml").write_text(CONFIG.replace("iterations: 30", "iteratons: 30"))
    res = _pfbench(site, "validate", "exp.yaml", cwd=tmp_path)
    assert res.returncode == 2
    assert "filters.mpf.iteratons" in res.stderr and "did you mean 'iterations'" in res.stderr
    (tmp_path / "exp.yaml").write_text(CONFIG.replace("type: metropolis_pf", "type: broken"))
    res = _pfbench(site, "validate", "exp.yaml", cwd=tmp_path)
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "cannot be loaded" in res.stderr and "a dependency is missing" in res.stderr


def test_the_built_ins_are_the_entry_points_pyproject_declares():
    from pfbench.filters import BUILTIN as FILTER_BUILTIN
    from pfbench.filters import FILTERS
    from pfbench.scenarios import BUILTIN as SCENARIO_BUILTIN
    from pfbench.scenarios import SCENARIOS
    eps = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["entry-points"]
    assert list(eps["pfbench.filters"]) == list(FILTER_BUILTIN)
    assert list(eps["pfbench.scenarios"]) == list(SCENARIO_BUILTIN)
    import importlib
    for name, value in eps["pfbench.filters"].items():
        module, attr = value.split(":")
        assert getattr(importlib.import_module(module), attr) is FILTER_BUILTIN[name]
        assert FILTERS[name] is FILTER_BUILTIN[name]
    for name, value in eps["pfbench.scenarios"].items():
        assert importlib.import_module(value) is SCENARIO_BUILTIN[name] is SCENARIOS[name]


EXAMPLE_CONFIG = EXAMPLE / "configs" / "bearings_road.yaml"


@pytest.mark.slow
def test_a_plugin_scenario_runs_the_built_in_filters_and_the_plugin_filter(site, tmp_path):
    res = _pfbench(site, "list", cwd=tmp_path)
    line = next(l for l in res.stdout.splitlines() if l.strip().startswith("bearings_road"))
    assert "plug-in: pfbench-example" in line
    res = _pfbench(site, "run", str(EXAMPLE_CONFIG), "--out", "a", "--trials", "4",
                   "--set", "scenario.steps=25", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    a = pd.read_csv(tmp_path / "a/trials.csv")
    assert set(a["filter"]) == {"pf@500", "mpf@500", "ekf", "ukf"} and len(a) == 16
    assert a["rmse"].notna().all() and (a["rmse"] > 0).all()
    # a bearing of 2 degrees from 2 m away: every filter follows the target within metres
    assert (a.groupby("filter")["rmse"].mean() < 15).all()
    assert (tmp_path / "a/table.md").is_file() and (tmp_path / "a/figures/rmse.png").is_file()
    # the plug-in's scenario keys are checked like a built-in scenario's
    res = _pfbench(site, "validate", str(EXAMPLE_CONFIG), "--set", "scenario.ofset_m=3",
                   cwd=tmp_path)
    assert res.returncode == 2 and "did you mean 'offset_m'" in res.stderr


@pytest.mark.slow
def test_plugins_run_through_sweep_and_the_dask_executor(site, tmp_path):
    common = ["--trials", "3", "--set", "scenario.steps=20"]
    res = _pfbench(site, "sweep", str(EXAMPLE_CONFIG), "--out", "sw", "--trials", "3",
                   "--set", "filters.mpf.iterations=5,30", "--set", "scenario.steps=20",
                   cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    sw = pd.read_csv(tmp_path / "sw/trials.csv")
    assert sorted(sw["filters.mpf.iterations"].unique()) == [5, 30]
    assert len(sw) == 2 * 3 * 4
    res = _pfbench(site, "run", str(EXAMPLE_CONFIG), "--out", "local", *common, cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    res = _pfbench(site, "run", str(EXAMPLE_CONFIG), "--out", "dask", "--executor", "dask",
                   "--workers", "2", "--no-figures", *common, cwd=tmp_path)
    if "needs Dask distributed" in res.stderr:
        pytest.skip("Dask distributed is not installed")
    assert res.returncode == 0, res.stderr
    local, dask = ((tmp_path / f"{d}/trials.csv").read_bytes() for d in ("local", "dask"))
    assert local == dask


@pytest.mark.slow
def test_the_contract_covers_the_plugins_under_dask(site, tmp_path):
    # no configs/ needed; the plug-in filter on pfbench's scenarios, pfbench's on the plug-in's
    res = _pfbench(site, "check", "--no-traps", "--executor", "dask", "--workers", "2",
                   cwd=tmp_path)
    if "needs Dask distributed" in res.stderr:
        pytest.skip("Dask distributed is not installed")
    assert res.returncode == 0, res.stderr
    import re
    from pfbench.contract import probes
    got = re.search(r"contract: (\d+) probes cover every filter and scenario, and under 2 Dask "
                    r"worker\(s\)", " ".join(res.stderr.split()))
    # more than pfbench's own: the plug-in filter on every scalar scenario, and the scalar
    # filters on the plug-in's scenario
    assert got and int(got.group(1)) > len(probes()[0]) + 2 and "all kept" in res.stderr, \
        res.stderr


@pytest.mark.slow     # the whole contract, every configs' probes, through the installed plug-in: 20 s
def test_a_plugin_that_breaks_the_contract_is_named(site, tmp_path):
    # the example filter, its generator seeded from the clock instead of the state it is given
    path = site / "pfbench_example" / "filters.py"
    path.write_text(path.read_text().replace(
        "np.random.default_rng(np.asarray(state, dtype=np.uint64))", "np.random.default_rng()"))
    res = _pfbench(site, "list", "--check", "--configs", str(ROOT / "configs"), cwd=tmp_path)
    assert res.returncode == 1
    # the probes' lines (the trap suite's on pfbench's own filters: tests/test_traps.py)
    lines = [l for l in res.stderr.splitlines() if l.startswith("pfbench: contract:")
             and not l.startswith("pfbench: contract: trap ")]
    assert lines and all("metropolis_pf" in l for l in lines), res.stderr
    assert "the same seed gave different numbers" in lines[0]


def test_a_filter_type_reports_only_the_consistency_metrics_pfbench_knows():
    from pfbench.filters.types import FilterType
    from pfbench.plugins import check_filter

    def run(model, y, params, particles, state, diag=True):
        return {}
    assert check_filter("ok", FilterType("ok", "d", {}, run, reports=("nees",))) is None
    for bad in (("nees", "coverage"), "nees", ["nis"]):
        why = check_filter("bad", FilterType("bad", "d", {}, run, reports=bad))
        assert why is not None and "its reports" in why and "nees, nis" in why
