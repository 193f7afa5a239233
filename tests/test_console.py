"""The console's tables fit 100 columns, one line per row; --wide prints every column (issue 18,
part 4)."""
import io

import pytest
from rich.console import Console
from typer.testing import CliRunner

from pfbench.api import load_results
from pfbench.cli import _rich_table, app
from pfbench.tables import table_title
from pfbench.regen import config_files, is_sweep
from pfbench.tables import headline_tables, short_verdict

from .conftest import ROOT, TINY

runner = CliRunner()
COMMITTED = [p for p in config_files(ROOT / "configs") if not is_sweep(p)]


def _render(table, width: int) -> list[str]:
    buf = io.StringIO()
    Console(file=buf, width=width, highlight=False, emoji=False).print(table)
    return buf.getvalue().splitlines()


@pytest.mark.parametrize("config", COMMITTED, ids=lambda p: p.stem)
def test_every_committed_table_fits_100_columns_one_line_a_row(config, monkeypatch):
    monkeypatch.chdir(ROOT)
    res = load_results(ROOT / "results" / config.stem)
    assert res.comparison is not None, "the committed results match their config"
    tables = headline_tables(res.comparison)
    assert tables and sum(len(cells) for _, _, cells in tables) >= len(res.table)
    for name, head, cells in tables:
        lines = _render(_rich_table(name, head, cells, edge=False), 100)
        assert max(len(line.rstrip()) for line in lines) <= 100, "\n".join(lines)
        rule = next(i for i, line in enumerate(lines) if line.startswith("━"))
        rows = [line for line in lines[rule + 1:] if line.strip()]      # below the header
        assert len(rows) == len(cells), "a row wrapped:\n" + "\n".join(lines)
    # every filter run is in the first table, every judged cell's verdict in a few words
    first = tables[0][2]
    assert [c[0] for c in first] == list(res.table["label"])
    assert all(len(c[-1]) <= 40 for _, _, cells in tables for c in cells)


def test_short_verdicts_keep_what_decides():
    class Q:
        key, judged_by = "rmse_mean", None
    row = {"kind_rmse_mean": "differs", "ratio_rmse_mean": 1.349,
           "verdict_rmse_mean": "differs (x1.35; ...); paper below the model's floor"}
    assert short_verdict(row, Q) == "differs x1.35, below floor"
    row = {"kind_rmse_mean": "inconclusive", "needed_rmse_mean": 130.0,
           "verdict_rmse_mean": "inconclusive: ..."}
    assert short_verdict(row, Q) == "inconclusive (~130 trials)"
    row = {"kind_rmse_mean": "not comparable", "verdict_rmse_mean": "shown, not judged: ..."}
    assert short_verdict(row, Q) == "not judged"
    assert short_verdict({"kind_rmse_mean": "", "verdict_rmse_mean": ""}, Q) == "-"


def test_run_prints_the_headline_and_wide_prints_every_column(tmp_path, write_config):
    cfg = write_config(TINY)
    out = tmp_path / "o"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"],
                        env={"COLUMNS": "100"})
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert max(len(line.rstrip()) for line in lines) <= 100
    # (the closing note wraps where its path is long: a worker's temporary folder)
    assert "Evals/step" not in res.stdout
    assert "--wide prints them here" in " ".join(res.stdout.split())
    wide = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--wide", "--no-figures"])
    assert wide.exit_code == 0, wide.output
    assert "Evals/step" in wide.stdout and "ms/trial" in wide.stdout      # up to date: timed


def test_a_title_never_prints_none(write_config):
    from pfbench.config import load
    exp = load(write_config(TINY))
    assert table_title(exp) == exp.name
    sweep = load(ROOT / "configs" / "ifa_pf_ungm.yaml")
    assert table_title(sweep) == "ifa_pf_ungm  (ifa2021 table1)"


def test_a_sweep_prints_the_experiments_metrics_in_100_columns(tmp_path, write_config):
    cfg = write_config(TINY)
    res = runner.invoke(app, ["sweep", str(cfg), "--set", "scenario.steps=5,8", "--out",
                              str(tmp_path / "s"), "--no-figures"], env={"COLUMNS": "100"})
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    assert max(len(line.rstrip()) for line in lines) <= 100
    rows = [line for line in lines if line.lstrip().startswith(("5", "8"))]
    assert len(rows) == 2 * 3, "one line per cell and filter run"
    assert "RMSE [95% CI]" in res.stdout and "ms/trial" in res.stdout
