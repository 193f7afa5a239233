"""pfbench bench: the run-path rows, what `pfbench run` runs beside the bare kernel (issue 31,
item 2). No timing is asserted: only that the rows appear, with their ratio and target."""
import json

import pytest
from typer.testing import CliRunner

from pfbench.benchmarks import run_path, suite
from pfbench.cli import app

from .conftest import ROOT, one_line_exit_2

cli = CliRunner()


@pytest.fixture
def small(monkeypatch):
    """The run-path workloads at a few hundred particles and steps (the same configs)."""
    monkeypatch.chdir(ROOT)
    monkeypatch.setattr(run_path, "RUN_PATH", (
        ("ungm", "configs/ifa_pf_ungm.yaml", "pf", 200, None, 1.3),
        ("mcl", "configs/sspf_global.yaml", "mcl", 200, None, 1.3),
        ("fastslam", "configs/afsa_fastslam.yaml", None, None, (30, 30), 1.5)))


def test_run_path_rows_beside_the_kernel_with_ratio_and_target(small):
    recs = suite.run_bench(quick=True, only=("run",))
    rows = [r for r in recs if r["workload"] == "run-path"]
    assert [(r["filter"], r["impl"]) for r in rows] == [
        (f, i) for f in ("ungm", "mcl", "fastslam") for i in ("kernel", "run")]
    for r in rows:
        assert r["ns_per_particle_step"] > 0 and r["particle_steps_per_s"] > 0
    runs = {r["filter"]: r for r in rows if r["impl"] == "run"}
    assert {f: r["target"] for f, r in runs.items()} == {"ungm": 1.3, "mcl": 1.3, "fastslam": 1.5}
    for r in runs.values():
        assert r["run_over_kernel"] > 0 and isinstance(r["meets_target"], bool)
    # what each computes, as its config has it: afsa_fastslam's diversity, the others' not
    assert "diversity_l1" in runs["fastslam"]["diagnostics"]
    assert "diversity_l1" not in runs["ungm"]["diagnostics"]
    assert runs["mcl"]["diagnostics"] == []


def test_one_family_alone_and_the_json(small, tmp_path):
    path = tmp_path / "b.json"
    res = cli.invoke(app, ["bench", "--quick", "--only", "run-mcl", "--json", str(path)])
    assert res.exit_code == 0, res.output
    recs = json.loads(path.read_text())
    assert {r["filter"] for r in recs if r["workload"] == "run-path"} == {"mcl"}
    assert "run / kernel" in res.output
    line = one_line_exit_2(cli.invoke(app, ["bench", "--only", "run-nothing"]))
    assert "run-ungm" in line
