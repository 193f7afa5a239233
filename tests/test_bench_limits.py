"""pfbench bench --limit: each kernel's irreducible passes timed alone, their sum, the kernel
beside it (issue 19, part 1). Only the records' structure and arithmetic are tested; the times
themselves belong to the bench, never to a test."""
import pytest
from typer.testing import CliRunner

from pfbench.benchmarks import limits
from pfbench.cli import app

from .conftest import ROOT

runner = CliRunner()


def _check(recs, passes):
    kinds = [r["impl"] for r in recs]
    assert kinds == ["pass"] * passes + ["limit", "pfbench"]
    N = recs[0]["particles"]
    total = sum(r["seconds_per_step"] for r in recs[:passes])
    limit, kernel = recs[-2], recs[-1]
    assert limit["seconds_per_step"] == pytest.approx(total)
    assert sum(r["share_of_limit"] for r in recs[:passes]) == pytest.approx(1.0)
    assert kernel["kernel_over_limit"] == pytest.approx(kernel["seconds_per_step"] / total)
    for r in recs:
        assert r["particles"] == N and r["seconds_per_step"] > 0
        assert r["ns_per_particle_step"] == pytest.approx(1e9 * r["seconds_per_step"] / N)
        assert r["seconds"] == pytest.approx(r["seconds_per_step"] * r["steps"])
    assert len({r["filter"] for r in recs}) == len(recs)       # each names its own work


def test_ungm_limit_records():
    recs = limits.ungm_limit(64, 0.001, 1)
    _check(recs, 5)
    assert [r["filter"] for r in recs[:5]] == ["normal draws", "move", "likelihood and max",
                                               "exponentials and sums",
                                               "resampling and gather"]


@pytest.mark.slow
def test_limit_cli_writes_every_workload(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    out = tmp_path / "limit.json"
    res = runner.invoke(app, ["bench", "--only", "limit", "--quick", "--json", str(out)])
    assert res.exit_code == 0, res.output
    import json
    recs = json.loads(out.read_text())
    for workload, passes in (("ungm-limit", 5), ("mcl-limit", 6), ("fastslam-limit", 6)):
        _check([r for r in recs if r["workload"] == workload], passes)
    assert "practical limit" in res.output and "x the limit" in res.output
