"""Sizes without bounds: runs that cannot fit in memory, trial counts and sweeps too large are
refused before anything is written."""
from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from pfbench.cli import app

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


@pytest.mark.parametrize("old,new,words", [
    ("particles: [20, 40]", "particles: 10000000000", ["memory", "particles"]),
    ("steps: 10", "steps: 100000000000", ["memory", "steps"]),
    ("trials: 4", "trials: 1000000000", ["memory", "trials"]),
])
def test_runs_that_cannot_fit_are_refused_before_anything_is_written(tmp_path, write_config,
                                                                     old, new, words):
    cfg = write_config(TINY.replace(old, new))
    out = tmp_path / "o"
    for cmd in (["run", str(cfg), "--out", str(out)], ["validate", str(cfg)]):
        line = one_line_exit_2(runner.invoke(app, cmd))
        for w in words:
            assert w in line, line
    assert not out.exists()


def test_trials_on_the_command_line_and_workers_are_bounded(tmp_path, write_config):
    cfg = write_config(TINY)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--trials", "2000000000",
                                                "--out", str(tmp_path / "o")]))
    assert "memory" in line
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--trials", "100000",
                                                "--workers", "1000", "--out",
                                                str(tmp_path / "o")]))
    assert "1,000 worker" in line
    assert not (tmp_path / "o").exists()
    # more workers than trials: capped at the trials, with a word about the cores
    res = runner.invoke(app, ["run", str(cfg), "--workers", "64", "--out", str(tmp_path / "w"),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "more than the" in res.output and "cores" in res.output
    assert json.loads((tmp_path / "w/timings.json").read_text())["workers"] == 4


def test_a_huge_sweep_is_counted_before_its_cells_are_built(tmp_path, write_config, monkeypatch):
    from pfbench import sweep as sw
    built = []
    real = sw.validate
    monkeypatch.setattr(sw, "validate", lambda *a, **k: built.append(1) or real(*a, **k))
    cfg = write_config(TINY)
    values = ",".join(str(i) for i in range(1000))
    res = runner.invoke(app, ["sweep", str(cfg), "--set", f"seed={values}", "--set",
                              f"trials={values}", "--out", str(tmp_path / "s")])
    line = one_line_exit_2(res)
    assert "1000000 cells" in line and "--yes" in line
    line = one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--yes", "--set",
                                                f"seed={values}", "--set", f"trials={values}",
                                                "--out", str(tmp_path / "s")]))
    assert "1,000,000 sweep cells" in line
    assert not built and not (tmp_path / "s").exists()
