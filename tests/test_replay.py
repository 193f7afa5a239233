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


@pytest.fixture
def entries(tmp_path, monkeypatch):
    """A replay cache of the test's own; returns its folder. Counts the runs that took the
    ordinary path (cli._run_trials) in ``entries.ran``."""
    where = tmp_path / "cache"
    monkeypatch.setattr(rp, "_where", lambda: where)
    ran = []
    original = cli._run_trials

    def counted(*a, **k):
        ran.append(1)
        return original(*a, **k)
    monkeypatch.setattr(cli, "_run_trials", counted)

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


def test_an_up_to_date_run_imports_no_table_library(tmp_path, write_config):
    """The whole command, in a process of its own: the second run replays, without pandas,
    scipy's statistics (numba itself imports scipy's top package), matplotlib or pyarrow."""
    cfg, out = write_config(TINY), tmp_path / "o"
    code = ("import sys\nfrom pfbench.cli import main\nsys.argv = ['pfbench', 'run', "
            f"{str(cfg)!r}, '--out', {str(out)!r}, '--no-figures']\n"
            "try:\n    main()\nexcept SystemExit as e:\n    code = e.code\n"
            "print(sorted(m for m in ('pandas', 'scipy.special', 'scipy.stats', 'matplotlib', 'pyarrow') "
            "if m in sys.modules), code)\n")
    runs = [subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                           cwd=tmp_path, timeout=600) for _ in range(2)]
    assert all(r.returncode == 0 for r in runs), runs
    assert "'pandas'" in runs[0].stdout.splitlines()[-1]      # the first run computes
    assert runs[1].stdout.splitlines()[-1] == "[] 0", runs[1].stdout
