"""A results folder never keeps figures of trials it no longer holds: a run or sweep that writes
new trials with --no-figures takes away the figures of the earlier ones, and the next up-to-date
run or sweep asked for figures draws them from the trials there. A sweep skips its figures with
--no-figures as a run does."""
import os

from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.figstyle import FORMATS

from .conftest import ROOT, TINY

runner = CliRunner()


def _ok(*args):
    res = runner.invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output
    return res


def _figures(folder):
    return {p.name: p.read_bytes() for p in sorted((folder / "figures").iterdir())}


def test_a_run_without_figures_takes_away_those_of_the_trials_it_replaced(tmp_path,
                                                                         write_config):
    cfg = write_config(TINY)
    out, fresh = tmp_path / "o", tmp_path / "fresh"
    _ok("run", cfg, "--out", out)
    old = _figures(out)
    assert old
    (out / "timings.png").write_bytes(b"mine")         # a run draws nothing there: not its own
    _ok("run", cfg, "--out", out, "--force", "--seed", 5, "--no-figures")
    assert _figures(out) == {}                          # none of the seed-0 trials' figures
    assert (out / "timings.png").read_bytes() == b"mine"
    _ok("run", cfg, "--out", out, "--seed", 5, "--no-figures")       # up to date: as it was
    assert _figures(out) == {}
    _ok("run", cfg, "--out", out, "--seed", 5)          # up to date, figures asked: drawn
    _ok("run", cfg, "--out", fresh, "--seed", 5)
    assert _figures(out) == _figures(fresh) and _figures(out) != old


def _sweep(out, *more):
    return _ok("sweep", ROOT / "configs" / "ifa_pf_particles.yaml", "--trials", 2,
               "--set", "filters.pf.particles=50,100", "--out", out, *more)


def test_a_sweep_without_figures_draws_none_and_replays_without_them(tmp_path):
    out = tmp_path / "s"
    first = _sweep(out, "--no-figures")
    assert not (out / "figures").exists() or _figures(out) == {}
    assert (out / "timings.csv").is_file()              # the run times, but not their figure
    assert not [f for f in FORMATS if (out / f"timings.{f}").exists()]
    assert (out / "summary.csv").is_file() and "and the figures" not in first.stderr
    times = {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()}
    again = _sweep(out, "--no-figures")
    assert "is up to date" in again.stderr and again.stdout == first.stdout
    assert {p: p.stat().st_mtime_ns for p in out.rglob("*") if p.is_file()} == times
    drawn = _sweep(out)                                 # up to date, figures asked: drawn
    assert "is up to date" in drawn.stderr and _figures(out)
    assert (out / "timings.png").is_file()


def test_a_sweep_without_figures_takes_away_those_of_the_trials_it_replaced(tmp_path):
    out, fresh = tmp_path / "s", tmp_path / "fresh"
    _sweep(out)
    old = _figures(out)
    _sweep(out, "--seed", 3, "--force", "--no-figures")
    assert _figures(out) == {} and not [f for f in FORMATS if (out / f"timings.{f}").exists()]
    _sweep(out, "--seed", 3)
    _sweep(fresh, "--seed", 3)
    assert _figures(out) == _figures(fresh) and _figures(out) != old


def test_a_figures_folder_that_is_a_link_is_left_alone(tmp_path, write_config):
    cfg = write_config(TINY)
    out, elsewhere = tmp_path / "o", tmp_path / "elsewhere"
    elsewhere.mkdir()
    (elsewhere / "mine.png").write_bytes(b"not pfbench's")
    out.mkdir()
    os.symlink(elsewhere, out / "figures")
    _ok("run", cfg, "--out", out, "--no-figures")
    assert (elsewhere / "mine.png").read_bytes() == b"not pfbench's"
