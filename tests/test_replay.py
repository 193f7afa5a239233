"""An up-to-date ``pfbench run`` prints its table from pfbench.replay: the very text the
comparison gives, without pandas, and never for a folder that no longer holds what the run that
recorded it left there."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest
from typer.testing import CliRunner

import pfbench.cli as cli
import pfbench.replay as rp
from pfbench.cli import app

from .conftest import TINY, one_line_exit_2, tree

runner = CliRunner()


def _own_cache(tmp_path, monkeypatch, module, name: str):
    """A replay cache of the test's own (its folder), and the list that grows by one at each
    call of ``module.name`` (the ordinary path)."""
    where = tmp_path / "cache"
    monkeypatch.setattr(rp, "_where", lambda: where)
    ran = []
    original = getattr(module, name)

    def counted(*a, **k):
        ran.append(1)
        return original(*a, **k)
    monkeypatch.setattr(module, name, counted)
    return where, ran


@pytest.fixture
def entries(tmp_path, monkeypatch):
    """A replay cache of the test's own; returns its folder. Counts the runs that took the
    ordinary path (cli._run_trials) in ``entries.ran``."""
    where, ran = _own_cache(tmp_path, monkeypatch, cli, "_run_trials")

    class Entries:
        folder = where

        @property
        def ran(self):
            return len(ran)
    return Entries()


def _run(cfg, out, *more):
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), *more])
    assert res.exit_code == 0, res.output
    return res


@pytest.mark.parametrize("wide", [(), ("--wide",)])
def test_the_replayed_table_is_the_computed_one(tmp_path, write_config, entries, wide):
    cfg, out = write_config(TINY), tmp_path / "o"
    _run(cfg, out, "--no-figures")
    assert entries.ran == 1 and len(list(entries.folder.glob("*.replay.json"))) == 1
    before = tree(out)
    replayed = _run(cfg, out, "--no-figures", *wide)
    assert entries.ran == 1                             # nothing computed
    assert "is up to date" in replayed.stderr
    for p in entries.folder.glob("*.replay.json"):
        p.unlink()
    computed = _run(cfg, out, "--no-figures", *wide)    # the ordinary path, recording again
    assert entries.ran == 2 and "is up to date" in computed.stderr
    assert replayed.stdout == computed.stdout and "Intervals: 95%" in computed.stdout
    assert tree(out) == before                          # neither wrote a byte
    _run(cfg, out, "--no-figures")
    assert entries.ran == 2                             # replayed again


@pytest.mark.parametrize("change", ["table.md", "table.csv", "trials.parquet", "timings.csv",
                                    "meta.json", "entry"])
def test_a_changed_folder_or_entry_takes_the_ordinary_path(tmp_path, write_config, entries,
                                                           change):
    """Whatever no longer matches what the entry recorded (a file the run writes, one its table
    is computed from, the entry itself) is computed and written again, then recorded again."""
    cfg, out = write_config(TINY), tmp_path / "o"
    first = _run(cfg, out, "--no-figures")
    written = tree(out)
    if change == "entry":
        for p in entries.folder.glob("*.replay.json"):
            p.write_text("{not json")
    elif change == "trials.parquet":
        (out / change).unlink()
    elif change == "meta.json":
        meta = json.loads((out / change).read_text())
        meta["note"] = "edited"
        (out / change).write_text(json.dumps(meta, indent=2))
    else:
        with open(out / change, "a") as fh:
            fh.write("\n" if change != "timings.csv" else "")
        if change == "timings.csv":     # a run time edited: the console's run times change
            text = (out / change).read_text().splitlines()
            head, row = text[0], text[1].split(",")
            row[-1] = "9.5"
            (out / change).write_text("\n".join([head, ",".join(row)] + text[2:]) + "\n")
    res = _run(cfg, out, "--no-figures")
    assert entries.ran == 2, change                     # computed again
    assert "is up to date" in res.stderr
    if change in ("table.md", "table.csv", "trials.parquet"):
        assert tree(out) == written                     # written again, the same bytes
        assert res.stdout == first.stdout
    _run(cfg, out, "--no-figures")
    assert entries.ran == 2                             # and recorded again


def test_figures_the_entry_names_must_be_there_in_the_format_asked(tmp_path, write_config,
                                                                   entries):
    cfg, out = write_config(TINY), tmp_path / "o"
    _run(cfg, out)
    figs = sorted(p.name for p in (out / "figures").iterdir())
    assert figs and entries.ran == 1
    _run(cfg, out)
    assert entries.ran == 1
    (out / "figures" / figs[0]).unlink()
    _run(cfg, out)                                      # drawn again
    assert entries.ran == 2 and (out / "figures" / figs[0]).is_file()
    (out / "figures" / ".rmse.png.tmp").write_bytes(b"half")  # a killed drawing's leftover
    _run(cfg, out)
    assert entries.ran == 3 and not (out / "figures" / ".rmse.png.tmp").exists()
    _run(cfg, out, "--figure-format", "svg")            # another format: drawn
    assert entries.ran == 4 and any(p.suffix == ".svg" for p in (out / "figures").iterdir())
    _run(cfg, out, "--no-figures")                      # none asked: any entry of the folder
    assert entries.ran == 4


def test_refusals_are_the_runs(tmp_path, write_config, entries):
    """A folder of another experiment, or of more trials, is refused as the ordinary path
    refuses it, untouched, with or without an entry."""
    cfg, out = write_config(TINY), tmp_path / "o"
    _run(cfg, out, "--no-figures")
    before = tree(out)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out),
                                               "--no-figures", "--seed", "3"]))
    assert "another experiment" in line and "seed 0 -> 3" in line
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out),
                                               "--no-figures", "--trials", "2"]))
    assert "holds 4 trials" in line
    assert tree(out) == before


def test_a_cache_that_cannot_be_written_records_nothing(tmp_path, write_config, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("")
    monkeypatch.setattr(rp, "_where", lambda: blocker / "cache")
    cfg, out = write_config(TINY), tmp_path / "o"
    first = _run(cfg, out, "--no-figures")
    again = _run(cfg, out, "--no-figures")
    assert first.stdout == again.stdout and "is up to date" in again.stderr


def _modules_of_two_commands(tmp_path, args: list[str]) -> list[str]:
    """Run ``pfbench ARGS`` twice, each in a process of its own; per run, the last line it
    printed: the table libraries it imported (pandas, scipy's statistics and special functions,
    matplotlib, pyarrow; numba itself imports scipy's top package) and its exit status."""
    code = ("import sys\nfrom pfbench.cli import main\n"
            f"sys.argv = ['pfbench'] + {list(args)!r}\n"
            "try:\n    main()\nexcept SystemExit as e:\n    code = e.code\n"
            "print(sorted(m for m in ('pandas', 'scipy.special', 'scipy.stats', 'matplotlib', "
            "'pyarrow') if m in sys.modules), code)\n")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           cwd=tmp_path, timeout=600) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs
    return [r.stdout.splitlines()[-1] for r in runs]


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_an_up_to_date_run_imports_no_table_library(tmp_path, write_config):
    """The whole command, in a process of its own: the second run replays, without pandas,
    scipy's statistics, matplotlib or pyarrow."""
    cfg, out = write_config(TINY), tmp_path / "o"
    first, second = _modules_of_two_commands(
        tmp_path, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert "'pandas'" in first                          # the first run computes
    assert second == "[] 0", second


# ---- an up-to-date sweep (pfbench sweep): its tables and curves replayed the same way

def _sweep_args(out, *more):
    from .conftest import ROOT
    return ["sweep", str(ROOT / "configs" / "ifa_pf_particles.yaml"), "--trials", "2",
            "--set", "filters.pf.particles=50,100", "--out", str(out), *more]


@pytest.fixture
def swept(tmp_path, monkeypatch):
    """A replay cache of the test's own, and a counter of the sweeps that took the ordinary
    path (pfbench.sweep.run_sweep)."""
    import pfbench.sweep as sw
    return _own_cache(tmp_path, monkeypatch, sw, "run_sweep")


def _sweep(out, *more):
    res = runner.invoke(app, _sweep_args(out, *more))
    assert res.exit_code == 0, res.output
    return res


def _written(folder):
    """Every file under folder with the time it was last written."""
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in sorted(folder.rglob("*"))
            if p.is_file()}


def test_an_up_to_date_sweep_prints_its_tables_and_curves_again(tmp_path, swept):
    """The second sweep into the same folder prints the table and the curves' verdicts the first
    printed, from the entry, writing nothing; without the entry the ordinary path computes the
    same text (and records it again)."""
    where, ran = swept
    out = tmp_path / "s"
    first = _sweep(out)
    assert len(ran) == 1 and len(list(where.glob("*.sweep.json"))) == 1
    assert "curve table1_pf" in first.stdout and "RMSE [95% CI]" in first.stdout
    files, times = tree(out), _written(out)
    replayed = _sweep(out)
    assert len(ran) == 1 and "is up to date" in replayed.stderr
    assert replayed.stdout == first.stdout and _written(out) == times     # not a byte written
    for p in where.glob("*.sweep.json"):
        p.unlink()
    computed = _sweep(out)
    assert len(ran) == 2 and computed.stdout == first.stdout and tree(out) == files
    _sweep(out)
    assert len(ran) == 2                                # recorded again, replayed


# a sweep runs its cells and draws its figures two or three times a case: the cases a run's folder
# shares (test_a_changed_folder_or_entry_takes_the_ordinary_path) are slow tests here
_SLOW = pytest.mark.slow


@pytest.mark.parametrize("change", [
    pytest.param("summary.csv", marks=_SLOW), "cell table.md", "curves.md", "figure",
    pytest.param("half-written figure", marks=_SLOW), "entry", pytest.param("--force", marks=_SLOW),
    "another --set"])
def test_a_changed_sweep_folder_or_entry_takes_the_ordinary_path(tmp_path, swept, change):
    """Whatever no longer matches the entry (a file the sweep writes, a figure, a leftover of a
    killed drawing, the entry itself), or a sweep asked to run again or of other cells, computes
    and writes again: the files come back as the sweep writes them."""
    where, ran = swept
    out = tmp_path / "s"
    first = _sweep(out)
    files = tree(out)
    cell = sorted((out / "cells").iterdir())[0]
    figure = sorted((out / "figures").iterdir())[0]
    more = ()
    if change == "summary.csv" or change == "curves.md":
        with open(out / change, "a") as fh:
            fh.write("\n")
    elif change == "cell table.md":
        (cell / "table.md").write_text("edited\n")
    elif change == "figure":
        figure.unlink()
    elif change == "half-written figure":
        (out / "figures" / f".{figure.name}.tmp").write_bytes(b"half")
    elif change == "entry":
        for p in where.glob("*.sweep.json"):
            p.write_text("{not json")
    elif change == "--force":
        more = ("--force",)
    res = runner.invoke(app, _sweep_args(out, *more) if change != "another --set" else
                        [a if a != "filters.pf.particles=50,100" else "filters.pf.particles=50"
                         for a in _sweep_args(out)])
    assert res.exit_code == 0, res.output
    assert len(ran) == 2, change                        # the ordinary path
    if change == "another --set":
        return
    if change == "--force":                             # run again: their own run times
        return
    assert tree(out) == files, change                   # the same trials: the same bytes
    assert res.stdout == first.stdout


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_an_up_to_date_sweep_imports_no_table_library(tmp_path):
    """The whole command, in a process of its own: the second sweep replays without pandas,
    scipy's statistics or special functions, matplotlib or pyarrow."""
    first, second = _modules_of_two_commands(tmp_path, _sweep_args(tmp_path / "s"))
    assert "'pandas'" in first                          # the first sweep computes
    assert second == "[] 0", second


# ---- the folder's own entry (console.json): a fresh clone, without the run times

def _clone_like(out):
    """The folder as a fresh clone of committed results has it: no timings file (the machine's,
    ignored) and no trials.parquet (ignored)."""
    for name in ("timings.csv", "timings.json", "trials.parquet"):
        (out / name).unlink(missing_ok=True)


def test_a_folder_without_run_times_replays_its_own_entry(tmp_path, write_config, entries):
    """A run writes console.json; in the folder as a fresh clone has it, with no entry in the
    user's cache, an up-to-date run prints from it the very text the comparison gives there,
    writing nothing; the ordinary path's console.json has the same bytes."""
    cfg, out = write_config(TINY), tmp_path / "o"
    ran = _run(cfg, out, "--no-figures")
    assert "console.json" in ran.stderr and (out / rp.FOLDER_RECORD).is_file()
    _clone_like(out)
    for p in entries.folder.glob("*"):
        p.unlink()
    before = tree(out)
    replayed = _run(cfg, out, "--no-figures")
    assert entries.ran == 1 and "is up to date" in replayed.stderr      # nothing computed
    assert tree(out) == before                                          # nothing written
    kept = (out / rp.FOLDER_RECORD).read_bytes()
    (out / rp.FOLDER_RECORD).unlink()
    for p in entries.folder.glob("*"):
        p.unlink()
    computed = _run(cfg, out, "--no-figures")       # the ordinary path, without run times
    assert entries.ran == 2 and replayed.stdout == computed.stdout
    assert (out / rp.FOLDER_RECORD).read_bytes() == kept     # written again where it had none


def _one_more_line(path):
    """The same content in other bytes: a line more at the end."""
    path.write_text(path.read_text() + "\n")


def _other_key(record):
    """A folder entry under a key no inputs give."""
    entry = json.loads(record.read_text())
    entry["key"] = "0" * 64
    record.write_text(json.dumps(entry))


@pytest.mark.parametrize("change", ["trials.csv", "table.md", "parquet", "timings", "entry"])
def test_the_folder_entry_is_read_only_where_it_still_holds(tmp_path, write_config, entries,
                                                            change):
    """Other trials (a key of other inputs), a table of other bytes, a trials.parquet of other
    bytes, a timings file (the folder is not a clone's: the user's cache speaks for it), an
    entry of another key: the ordinary path, which never replaces the folder's entry."""
    cfg, out = write_config(TINY), tmp_path / "o"
    _run(cfg, out, "--no-figures")
    _clone_like(out)
    record = out / rp.FOLDER_RECORD
    if change == "trials.csv":      # the same trials, written otherwise: other bytes, same rows
        _one_more_line(out / "trials.csv")
    elif change == "table.md":
        _one_more_line(out / "table.md")
    elif change == "parquet":
        (out / "trials.parquet").write_bytes(b"not the parquet it was")
    elif change == "timings":
        (out / "timings.csv").write_text("trial,filter,wall_s\n")
    else:
        _other_key(record)
    kept = record.read_bytes()
    for p in entries.folder.glob("*"):
        p.unlink()
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert res.exit_code == 0 and entries.ran == 2, res.output     # computed
    assert record.read_bytes() == kept                      # an up-to-date run never replaces it


def _sweep_clone_like(out):
    """A sweep folder as a fresh clone of committed results has it: no timings files and no
    trials.parquet, in the folder or any cell."""
    for p in list(out.rglob("timings.*")) + list(out.rglob("trials.parquet")):
        p.unlink()


def test_a_sweep_folder_without_run_times_replays_its_own_entry(tmp_path, swept):
    """A sweep writes console.json; in the folder as a fresh clone has it, with no entry in the
    user's cache, an up-to-date sweep prints from it the text the ordinary path prints there
    (the time column empty), writing nothing; the ordinary path's console.json has the same
    bytes."""
    where, ran = swept
    out = tmp_path / "s"
    _sweep(out)
    assert (out / rp.FOLDER_RECORD).is_file() and len(ran) == 1
    _sweep_clone_like(out)
    for p in where.glob("*"):
        p.unlink()
    times = _written(out)
    replayed = _sweep(out)
    assert len(ran) == 1 and "is up to date" in replayed.stderr
    assert _written(out) == times                                   # not a byte written
    kept = (out / rp.FOLDER_RECORD).read_bytes()
    (out / rp.FOLDER_RECORD).unlink()
    for p in where.glob("*"):
        p.unlink()
    computed = _sweep(out)
    assert len(ran) == 2 and computed.stdout == replayed.stdout
    assert "curve table1_pf" in computed.stdout
    # the ordinary path of an up-to-date sweep says so too, and writes no timings file of none
    assert computed.stderr == replayed.stderr and "is up to date" in computed.stderr
    assert not (out / "timings.csv").exists()
    assert (out / rp.FOLDER_RECORD).read_bytes() == kept


@pytest.mark.parametrize("change", ["summary.csv", pytest.param("cell table.md", marks=_SLOW),
                                    "figure", "cell timings", pytest.param("entry", marks=_SLOW)])
def test_a_sweep_folder_entry_is_read_only_where_it_still_holds(tmp_path, swept, change):
    """A file or figure of other bytes, a cell's timings file, an entry of another key: the
    ordinary path, which never replaces the folder's entry."""
    where, ran = swept
    out = tmp_path / "s"
    _sweep(out)
    _sweep_clone_like(out)
    record = out / rp.FOLDER_RECORD
    cell = next(p for p in (out / "cells").iterdir() if p.is_dir())
    if change == "summary.csv":
        _one_more_line(out / "summary.csv")
    elif change == "cell table.md":
        _one_more_line(cell / "table.md")
    elif change == "figure":
        fig = next((out / "figures").iterdir())
        fig.write_bytes(fig.read_bytes() + b"\0")
    elif change == "cell timings":
        (cell / "timings.csv").write_text("trial,filter,wall_s\n")
    else:
        _other_key(record)
    kept = record.read_bytes()
    for p in where.glob("*"):
        p.unlink()
    _sweep(out)
    assert len(ran) == 2 and record.read_bytes() == kept


def test_a_sweep_of_a_kind_with_traces_replays_too(tmp_path, swept):
    """A sweep's cells keep no traces (the sweep runs them without): an up-to-date sweep of
    FastSLAM, whose runs keep traces, replays as any other (it never did: each cell was taken
    for out of date for want of a traces file, so the sweep computed every time)."""
    from .conftest import ROOT
    where, ran = swept
    args = ["sweep", str(ROOT / "configs" / "ifa_fastslam_speed.yaml"), "--trials", "1",
            "--set", "scenario.speed_mps=1.0,2.0", "--out", str(tmp_path / "s"), "--no-figures"]
    first = runner.invoke(app, args)
    assert first.exit_code == 0 and len(ran) == 1, first.output
    again = runner.invoke(app, args)
    assert again.exit_code == 0 and len(ran) == 1, again.output
    assert "is up to date" in again.stderr and again.stdout == first.stdout
