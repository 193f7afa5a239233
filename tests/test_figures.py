"""Figures: one style, labels from names and units, the paper's values marked, a sweep's lines,
a snapshot of each outcome, and the formats, byte for byte (issue 18, parts 2, 3 and 5)."""
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import figstyle as fs
from pfbench import plots
from pfbench.cli import app
from pfbench.config import load
from pfbench.runner import run_experiment

from .conftest import ROOT, TINY, one_line_exit_2

runner = CliRunner()


def test_axis_labels_come_from_names_and_units_never_raw_keys():
    assert fs.label("scenario.speed_mps") == "robot speed (m/s)"
    assert fs.label("filters.*.particles") == "particles N"
    assert fs.label("rmse", "m") == "RMSE (m)" and fs.label("rmse") == "RMSE"
    assert fs.label("scenario.wheel_gap_deg") == "wheel gap (deg)"       # not in the table
    assert fs.label("scenario.some_thing") == "some thing"
    for key in ("scenario.steps", "filters.pf.neff_ratio", "scenario.bearing_noise_deg"):
        assert "." not in fs.label(key) and "_" not in fs.label(key)


@pytest.mark.parametrize("fmt", fs.FORMATS)
def test_every_format_gives_the_same_bytes_twice_and_replaces_the_other(tmp_path, write_config,
                                                                        fmt):
    exp = load(write_config(TINY))
    res = run_experiment(exp, tmp_path / "r", traces=False)
    a = plots.write_figures(exp, res.rows, tmp_path / "r", fmt)
    first = {p.name: p.read_bytes() for p in a}
    b = plots.write_figures(exp, res.rows, tmp_path / "r", fmt)
    assert {p.name: p.read_bytes() for p in b} == first and all(p.suffix == f".{fmt}" for p in a)
    other = "svg" if fmt != "svg" else "pdf"
    plots.write_figures(exp, res.rows, tmp_path / "r", other)
    assert {p.suffix for p in (tmp_path / "r/figures").iterdir()} == {f".{other}"}


def test_a_bad_figure_format_is_one_line(write_config):
    line = one_line_exit_2(runner.invoke(app, ["run", str(write_config(TINY)),
                                               "--figure-format", "jpg"]))
    assert "--figure-format jpg" in line and "png, svg, pdf" in line


def test_the_distributions_are_the_tables_quantities_in_the_papers_unit(monkeypatch):
    monkeypatch.chdir(ROOT)
    exp = load(ROOT / "configs/asrl_vs_srl.yaml")
    got = {m: (scale, label, q) for m, scale, label, q in plots._distribution_quantities(exp)}
    assert set(got) >= {"rmse", "x_error", "y_error"}
    assert got["x_error"][0] == 1000.0 and got["x_error"][1] == "x error (mm)"
    assert got["x_error"][2].metric == "x_error"


def _figures_saved(monkeypatch) -> list:
    saved = []
    monkeypatch.setattr(plots, "save_figure", lambda fig, path: saved.append((fig, path)))
    return saved


def test_the_distribution_marks_the_paper_and_our_mean_with_its_interval(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    exp = load(ROOT / "configs/ifa_pf_ungm.yaml", {"trials": 3})
    res = run_experiment(exp, tmp_path / "u", traces=False)
    from pfbench.compare import compare
    table = compare(exp, res.rows).table
    saved = _figures_saved(monkeypatch)
    plots.write_figures(exp, res.rows, tmp_path / "u", "png", table)
    fig, path = next((f, p) for f, p in saved if p.stem == "rmse")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "the paper's value" in labels and "mean and its 95% interval" in labels
    paper = next(line for line in ax.get_lines() if line.get_label() == "the paper's value")
    assert paper.get_ydata()[0] == pytest.approx(4.2216)      # PF at N = 50, the first given


def test_a_sweep_over_particles_draws_a_line_per_filter(tmp_path, write_config, monkeypatch):
    saved = _figures_saved(monkeypatch)
    cfg = write_config(TINY)
    res = runner.invoke(app, ["sweep", str(cfg), "--set", "filters.pf.particles=10,30,90",
                              "--out", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    fig = next(f for f, p in saved if p.stem == "rmse")
    ax = fig.axes[0]
    assert ax.get_xlabel() == "particles N"
    pf = [line for line in ax.get_lines() if line.get_label().startswith("PF")]
    assert len(pf) == 1 and list(pf[0].get_xdata()) == [10, 30, 90]
    assert ax.collections, "the 95% bands"


def test_a_snapshot_shows_a_converged_and_a_failed_trial():
    class Run:
        key = "mcl@100"

    class T:
        trials = {k: {"mcl@100/snap_xy": 1} for k in range(4)}
    rows = pd.DataFrame({"trial": range(4), "filter": ["mcl@100"] * 4,
                         "converged": [0.0, 0.0, 1.0, 0.0]})
    assert plots._snapshot_trials(None, T, rows, Run) == [(2, 1.0), (0, 0.0)]
    rows["converged"] = 0.0
    assert plots._snapshot_trials(None, T, rows, Run) == [(0, 0.0)]


def test_with_kidnappings_the_outcome_is_recovering_from_every_one():
    class Run:
        key = "srl@100"

    class T:
        trials = {k: {"srl@100/snap_xy": 1} for k in range(3)}
    rows = pd.DataFrame({"trial": range(3), "filter": ["srl@100"] * 3,
                         "converged": [1.0, 1.0, 1.0], "recovery_failures": [1.0, 0.0, 2.0]})
    assert plots._snapshot_trials(None, T, rows, Run, kidnapped=True) == [(1, 1.0), (0, 0.0)]
    assert plots._snapshot_trials(None, T, rows, Run) == [(0, 1.0)]
