"""Nothing is written outside the folders a user named, and nothing a user had is lost: links
are never followed into, two runs of one command never share or nest their folders, a failed
run leaves no folder it made, bad options are refused before anything is written."""
import os
import shutil

import pytest
import yaml
from typer.testing import CliRunner

import pfbench
from pfbench import fsutil
from pfbench.cli import app
from pfbench.errors import UserError

from .conftest import ROOT, TINY, one_line_exit_2, tree

runner = CliRunner()
MAPPING = yaml.safe_load(TINY)


def everything(folder) -> dict:
    """Every path under ``folder`` (links not followed) with its bytes, or its link target."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            if os.path.islink(p):
                out[p] = "-> " + os.readlink(p)
            elif os.path.isfile(p):
                out[p] = open(p, "rb").read()
            else:
                out[p] = "dir"
    return out


def stat_tree(folder) -> dict:
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            st = os.lstat(os.path.join(dirpath, n))
            out[os.path.join(dirpath, n)] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


# ---------------------------------------------------------------- links

def test_a_lock_file_that_is_a_link_is_refused_and_its_target_untouched(tmp_path):
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    folder = tmp_path / "out"
    folder.mkdir()
    (folder / ".pfbench.lock").symlink_to(target)
    with pytest.raises(UserError, match="symbolic link"):
        fsutil.FolderLock(folder).acquire()
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(TINY)
    for args in (["run", str(cfg), "--out", str(folder)],
                 ["sweep", str(cfg), "--out", str(folder), "--set", "scenario.steps=10,20"]):
        assert "symbolic link" in one_line_exit_2(runner.invoke(app, args))
    configs = tmp_path / "configs"
    configs.mkdir()
    shutil.copy(cfg, configs / "exp.yaml")
    r = runner.invoke(app, ["tables", "--configs", str(configs), "--results", str(folder)])
    assert "symbolic link" in one_line_exit_2(r)
    assert target.read_text() == "keep me"


def test_an_atomic_write_never_writes_through_a_link_at_its_temporary_name(tmp_path):
    target = tmp_path / "precious.txt"
    target.write_text("keep me")
    path = tmp_path / "table.csv"
    (tmp_path / f".table.csv.tmp{os.getpid()}").symlink_to(target)
    fsutil.atomic_write(path, "a,b\n")
    assert target.read_text() == "keep me"
    assert path.read_text() == "a,b\n" and not path.is_symlink()


@pytest.mark.parametrize("link", ["cells/steps=10", "cells"])
def test_a_sweep_never_writes_into_a_linked_cell_folder(tmp_path, link):
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(TINY)
    outside = tmp_path / "outside"
    (outside / "steps=10").mkdir(parents=True)
    out = tmp_path / "sweep"
    (out / "cells").mkdir(parents=True)
    if link == "cells":
        (out / "cells").rmdir()
        (out / "cells").symlink_to(outside)
    else:
        (out / link).symlink_to(outside / "steps=10")
    before = everything(outside)
    r = runner.invoke(app, ["sweep", str(cfg), "--out", str(out), "--force", "--set",
                            "scenario.steps=10,20"])
    assert "symbolic link" in one_line_exit_2(r)
    assert everything(outside) == before


def test_tables_never_replaces_a_linked_results_folder(tmp_path):
    configs, results, outside = tmp_path / "configs", tmp_path / "results", tmp_path / "elsewhere"
    configs.mkdir()
    results.mkdir()
    outside.mkdir()
    (outside / "mine.txt").write_text("keep")
    (configs / "exp.yaml").write_text(TINY.replace("seed: 0", "name: plain\nseed: 0"))
    (results / "plain").symlink_to(outside)
    r = runner.invoke(app, ["tables", "--configs", str(configs), "--results", str(results)])
    assert "symbolic link" in one_line_exit_2(r)
    assert (outside / "mine.txt").read_text() == "keep" and (results / "plain").is_symlink()


def test_figures_never_go_into_a_linked_figures_folder(tmp_path):
    outside = tmp_path / "outside"
    outside.mkdir()
    out = tmp_path / "run"
    out.mkdir()
    (out / "figures").symlink_to(outside)
    with pytest.raises(UserError, match="symbolic link"):
        pfbench.run_experiment(MAPPING, out=out)
    assert list(outside.iterdir()) == []


# ---------------------------------------------------------------- two runs, one folder

def test_tables_refuses_two_configs_of_one_name_before_anything_runs(tmp_path):
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    for f in ("a.yaml", "b.yaml"):
        (configs / f).write_text(TINY.replace("seed: 0", "name: same\nseed: 0"))
    r = runner.invoke(app, ["tables", "--configs", str(configs), "--results", str(results)])
    line = one_line_exit_2(r)
    assert "a.yaml" in line and "b.yaml" in line and "'same'" in line
    assert not results.exists()


def test_tables_refuses_a_results_folder_inside_an_experiments(tmp_path):
    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "exp.yaml").write_text(TINY)
    done = tmp_path / "results" / "finished"
    pfbench.run_experiment(MAPPING, out=done, figures=False)
    before = tree(done)
    for results in (done, done / "inner", done / "cells"):
        r = runner.invoke(app, ["tables", "--configs", str(configs), "--results",
                                str(results)])
        assert "inside the results of a run" in one_line_exit_2(r)
        assert tree(done) == before


# ---------------------------------------------------------------- a kill between renames

def test_a_folder_left_aside_by_a_killed_replace_is_restored(tmp_path):
    out = tmp_path / "results" / "plain"
    pfbench.run_experiment(MAPPING, out=out, figures=False)
    before = tree(out)
    aside = out.with_name(".plain.old99999")
    out.rename(aside)
    warned = []
    res = pfbench.run_experiment(MAPPING, out=out, figures=False, warn=warned.append)
    assert res.up_to_date and tree(out) == before and not aside.exists()
    assert warned and "restored" in warned[0]
    # the CLI's run and sweep too (a sweep's folder is replaced by tables as a run's)
    cfg = tmp_path / "config.yaml"         # the name a mapping gets: the same experiment
    cfg.write_text(TINY)
    out.rename(aside)
    r = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert r.exit_code == 0 and "restored" in r.output and "up to date" in r.output, r.output
    assert tree(out) == before and not aside.exists()


def test_tables_restores_a_folder_left_aside_and_removes_superseded_copies(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    (results / ".plain.old1").mkdir()
    (results / ".plain.old1" / "trials.csv").write_text("old")
    assert fsutil.recover_aside(results / "plain", results) == results / ".plain.old1"
    assert (results / "plain" / "trials.csv").read_text() == "old"
    (results / ".plain.old2").mkdir()
    fsutil.recover_aside(results / "plain", results)
    assert sorted(p.name for p in results.iterdir()) == ["plain"]


# ---------------------------------------------------------------- out values of the API

@pytest.mark.parametrize("out", ["", "   ", "a\x00b"])
def test_the_api_refuses_an_out_the_cli_refuses(tmp_path, monkeypatch, out):
    monkeypatch.chdir(tmp_path)
    for fn in (pfbench.run_experiment, pfbench.run_until_decided):
        with pytest.raises(UserError, match=r"^out: "):
            fn(MAPPING, out=out)
    assert list(tmp_path.iterdir()) == []


def test_the_api_refuses_an_out_that_is_a_file(tmp_path):
    f = tmp_path / "file"
    f.write_text("mine")
    for fn in (pfbench.run_experiment, pfbench.run_until_decided):
        with pytest.raises(UserError, match="exists and is not a folder"):
            fn(MAPPING, out=f)
    assert f.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["file"]


# ---------------------------------------------------------------- bad options first

def test_a_bad_figure_format_is_refused_before_anything_is_written(tmp_path):
    from pfbench import regen
    from pfbench.runner import LocalExecutor
    out = tmp_path / "out"
    for fn in (pfbench.run_experiment, pfbench.run_until_decided):
        for fmt in ("bmp", "", None, "PNG"):
            with pytest.raises(UserError, match="figure_format"):
                fn(MAPPING, out=out, figure_format=fmt)
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(TINY)
    with pytest.raises(UserError, match="figure_format"):
        regen.regenerate(cfg, tmp_path / "results", LocalExecutor(1), figure_format="bmp")
    for args in (["run", str(cfg)], ["sweep", str(cfg), "--set", "scenario.steps=10,20"]):
        one_line_exit_2(runner.invoke(app, [*args, "--out", str(out), "--figure-format", "x"]))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp.yaml"]


# ---------------------------------------------------------------- failed runs

def test_a_run_under_a_name_too_long_leaves_no_folder(tmp_path):
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(TINY)
    long = tmp_path / "new" / "deeper" / ("ü" * 200) / "out"
    for args in (["run", str(cfg)], ["sweep", str(cfg), "--set", "scenario.steps=10,20"]):
        r = runner.invoke(app, [*args, "--out", str(long)])
        assert "cannot create it" in one_line_exit_2(r)
    with pytest.raises(UserError, match="cannot create it"):
        pfbench.run_experiment(MAPPING, out=long)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["exp.yaml"]


class _Failing:
    """An executor whose trials fail (a filter that raises)."""

    def describe(self):
        return "failing"

    def run(self, *args, **kwargs):
        raise RuntimeError("a filter failed")


def test_a_run_that_fails_before_a_trial_leaves_no_folder_it_made(tmp_path):
    out = tmp_path / "new" / "nested" / "out"
    with pytest.raises(RuntimeError):
        pfbench.run_experiment(MAPPING, out=out, executor=_Failing())
    assert list(tmp_path.iterdir()) == []
    # a folder the user had is kept, with what it held
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("mine")
    with pytest.raises(RuntimeError):
        pfbench.run_experiment(MAPPING, out=mine, executor=_Failing())
    assert mine.is_dir() and (mine / "notes.txt").read_text() == "mine"


# ---------------------------------------------------------------- up to date, figures included

def test_an_up_to_date_run_redraws_a_missing_figure(tmp_path):
    out = tmp_path / "run"
    first = pfbench.run_experiment(MAPPING, out=out)
    assert first.figures
    gone = first.figures[0]
    gone.unlink()
    (gone.parent / f".{gone.name}.tmp123{gone.suffix}").write_bytes(b"half")   # a kill mid-write
    again = pfbench.run_experiment(MAPPING, out=out)
    assert again.up_to_date and gone.is_file()
    assert sorted(p.name for p in gone.parent.iterdir()) == sorted(p.name for p in first.figures)
    # with every figure there, an up-to-date run draws none
    mtimes = {p: p.stat().st_mtime_ns for p in first.figures}
    pfbench.run_experiment(MAPPING, out=out)
    assert {p: p.stat().st_mtime_ns for p in first.figures} == mtimes


# ---------------------------------------------------------------- where each command writes

def test_every_writing_command_writes_only_where_it_was_told(tmp_path, monkeypatch):
    """run, sweep, tables, report (and validate, list: nothing) into a scratch folder: nothing
    outside the folders named changes, not the current folder, not the repository's results."""
    work, cwd = tmp_path / "work", tmp_path / "cwd"
    configs = work / "configs"
    configs.mkdir(parents=True)
    cwd.mkdir()
    (configs / "plain.yaml").write_text(TINY.replace("seed: 0", "name: plain\nseed: 0"))
    (configs / "swept.yaml").write_text(TINY.replace("seed: 0", "name: swept\nseed: 0")
                                        + "sweep:\n  scenario.steps: [10, 12]\n")
    repo = stat_tree(ROOT / "results")
    monkeypatch.chdir(cwd)
    named = {
        "run": (["run", str(configs / "plain.yaml"), "--out", str(work / "run")], "run"),
        "sweep": (["sweep", str(configs / "swept.yaml"), "--out", str(work / "sweep")],
                  "sweep"),
        "tables": (["tables", "--configs", str(configs), "--results", str(work / "results"),
                    "--no-figures"], "results"),
        "report": (["report", "--configs", str(configs), "--results", str(work / "results"),
                    "--out", str(work / "report")], "report"),
        "validate": (["validate", str(configs / "plain.yaml")], None),
        "list": (["list", "--configs", str(configs)], None),
    }
    for what, (args, folder) in named.items():
        if what == "report":        # the report 'tables' wrote into the results is gone
            shutil.rmtree(work / "results" / "report")
            (work / "results" / "REPORT.md").unlink()
        before = everything(work)
        r = runner.invoke(app, args)
        assert r.exit_code == 0, (what, r.output)
        after = everything(work)
        changed = {p for p in set(before) | set(after) if before.get(p) != after.get(p)}
        mine = str(work / folder) if folder else None
        assert all(mine and (p == mine or p.startswith(mine + os.sep)) for p in changed), \
            (what, sorted(changed))
        assert list(cwd.iterdir()) == [], what
    assert stat_tree(ROOT / "results") == repo


def test_an_experiment_named_like_the_report_is_refused_where_it_would_share_its_folder(
        tmp_path, monkeypatch):
    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "exp.yaml").write_text(TINY.replace("seed: 0", "name: report\nseed: 0"))
    r = runner.invoke(app, ["tables", "--configs", str(configs), "--results",
                            str(tmp_path / "results")])
    assert "holds the reproduction report" in one_line_exit_2(r)
    monkeypatch.chdir(tmp_path)
    r = runner.invoke(app, ["run", str(configs / "exp.yaml")])
    assert "holds the reproduction report" in one_line_exit_2(r)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["configs"]


def test_bench_json_that_cannot_be_written_is_refused_before_the_timing(tmp_path):
    for path in (tmp_path / "no" / "such.json", tmp_path):
        r = runner.invoke(app, ["bench", "--quick", "--json", str(path)])
        assert "--json" in one_line_exit_2(r)
    assert list(tmp_path.iterdir()) == []
