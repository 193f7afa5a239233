"""Hostile input and faults: every class answers with one line on stderr and exit status 2,
writes nothing, loses nothing, and touches nothing outside the folders the user named.

One test (or a parametrised family) per class of issue 13; each fails on the code before it."""
from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import fsutil
from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.runner import row_crc, run_experiment

from .conftest import SMALL

runner = CliRunner()

TINY = SMALL.replace("trials: 6", "trials: 4").replace("steps: 30", "steps: 10")


def _one_line_exit_2(res) -> str:
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = [l for l in res.output.strip().splitlines() if l.strip()]
    assert len(lines) == 1, res.output
    assert lines[0].startswith("pfbench: error: ")
    return lines[0]


def _tree(folder: Path) -> dict:
    """Every file under folder with its bytes (to show nothing changed)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


# ---------------------------------------------------------------- 1. names that escape


@pytest.mark.parametrize("name", ["../../escaped", "/tmp/pfbench-abs-escape", "a/b", "..", ".",
                                  ".hidden", "x\\y", "x\x00y", " spaced "])
def test_a_name_must_be_one_plain_folder_name(tmp_path, write_config, name, monkeypatch):
    monkeypatch.chdir(tmp_path)
    cfg = write_config(f"name: {json.dumps(name)}\n" + TINY)
    before = sorted(p.name for p in tmp_path.parent.iterdir())
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg)]))
    assert "name" in line
    assert not (tmp_path / "results").exists()
    assert sorted(p.name for p in tmp_path.parent.iterdir()) == before
    assert not Path("/tmp/pfbench-abs-escape").exists()
    # the same through --set, and in validate
    cfg = write_config(TINY, "plain.yaml")
    _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--set", f"name={json.dumps(name)}"]))
    _one_line_exit_2(runner.invoke(app, ["validate", str(cfg), "--set",
                                         f"name={json.dumps(name)}"]))


def test_tables_never_removes_a_folder_outside_results(tmp_path):
    configs = tmp_path / "configs"
    configs.mkdir()
    outside = tmp_path / "precious"
    outside.mkdir()
    (outside / "keep.txt").write_text("mine")
    (configs / "evil.yaml").write_text("name: ../precious\n" + TINY)
    res = runner.invoke(app, ["tables", "--configs", str(configs), "--results",
                              str(tmp_path / "results")])
    line = _one_line_exit_2(res)
    assert "evil.yaml" in line and "name" in line
    assert (outside / "keep.txt").read_text() == "mine"


def test_remove_and_replace_refuse_paths_outside_their_owner_and_links(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "f").write_text("x")
    (results / "link").symlink_to(outside)
    for bad in (outside, results / "link", results / ".." / "outside", results):
        with pytest.raises(UserError, match="does not lie inside"):
            fsutil.remove_tree(bad, results)
    stage = results / "stage"
    stage.mkdir()
    with pytest.raises(UserError):
        fsutil.replace_tree(stage, results / "link", results)
    assert (outside / "f").read_text() == "x"
    # inside, it works
    (results / "old").mkdir()
    (results / "old" / "a").write_text("old")
    (stage / "a").write_text("new")
    fsutil.replace_tree(stage, results / "old", results)
    assert (results / "old" / "a").read_text() == "new" and not stage.exists()


def test_sweep_cell_names_stay_plain_folder_names():
    from pfbench.sweep import _cell_name
    for values in ({"name": "../../x"}, {"a.b": "/etc"}, {"k": "." * 300}, {"k": ".."}):
        name = _cell_name(values)
        assert fsutil.name_problem(name) is None, name


# ---------------------------------------------------------------- 2. two runs, one folder


def _hold_lock(folder: Path) -> subprocess.Popen:
    code = ("import sys, time\nfrom pfbench.fsutil import FolderLock\n"
            f"FolderLock({str(folder)!r}).acquire()\nprint('locked', flush=True)\ntime.sleep(120)\n")
    proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == "locked"
    return proc


def test_a_second_run_into_a_locked_folder_exits_2_naming_the_holder(tmp_path, write_config):
    out = tmp_path / "res"
    cfg = write_config(TINY)
    holder = _hold_lock(out)
    try:
        line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out)]))
        assert f"pid {holder.pid}" in line and "in use" in line
        assert sorted(p.name for p in out.iterdir()) == [fsutil.LOCK_NAME]   # nothing written
        # a sweep into it, and a sweep whose cell is locked
        line = _one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--set", "seed=1,2",
                                                    "--out", str(out)]))
        assert f"pid {holder.pid}" in line
    finally:
        holder.send_signal(signal.SIGKILL)      # the kernel releases the lock of a dead process
        holder.wait()
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert not (out / fsutil.LOCK_NAME).exists()     # released and removed


def test_a_locked_sweep_cell_and_a_locked_results_folder_are_refused(tmp_path, write_config):
    cfg = write_config(TINY)
    sweep_out = tmp_path / "sw"
    holder = _hold_lock(sweep_out / "cells" / "seed=2")
    try:
        line = _one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--set", "seed=1,2",
                                                    "--out", str(sweep_out)]))
        assert f"pid {holder.pid}" in line and "seed=2" in line
    finally:
        holder.kill()
        holder.wait()
    configs = tmp_path / "configs"
    configs.mkdir()
    (configs / "a.yaml").write_text(TINY)
    results = tmp_path / "results"
    holder = _hold_lock(results)
    try:
        for extra in ([], ["--check"]):
            line = _one_line_exit_2(runner.invoke(app, ["tables", "--configs", str(configs),
                                                        "--results", str(results), *extra]))
            assert f"pid {holder.pid}" in line
        assert not (results / "a").exists()
    finally:
        holder.kill()
        holder.wait()


def test_run_experiment_itself_takes_the_lock(tmp_path, write_config):
    exp = load(write_config(TINY))
    holder = _hold_lock(tmp_path / "x")
    try:
        with pytest.raises(UserError, match=f"pid {holder.pid}"):
            run_experiment(exp, tmp_path / "x")
    finally:
        holder.kill()
        holder.wait()


def test_nested_locks_of_one_process_and_release():
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        a = fsutil.FolderLock(Path(d) / "f")
        with a:
            with fsutil.FolderLock(Path(d) / "f"):
                pass
            assert (Path(d) / "f" / fsutil.LOCK_NAME).exists()    # still held by the outer one
        assert not (Path(d) / "f").exists()       # made by the lock, left empty: removed


# ---------------------------------------------------------------- 3. YAML bombs and depth


BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{c}: &{c} [*{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}, *{p}]\n"
    for p, c in zip("abcdefgh", "bcdefghi"))


@pytest.mark.parametrize("text,words", [
    (BOMB + TINY, ["aliases", "expand"]),
    ("x: &r [1, *r]\n" + TINY, ["refers to a node that contains it"]),
    ("x: " + "[" * 5000 + "]" * 5000 + "\n" + TINY, ["nested deeper"]),
    ("x: " + "{a: " * 3000 + "1" + "}" * 3000 + "\n" + TINY, ["nested deeper"]),
    ("- " * 3000 + "1\n", ["nested deeper"]),
], ids=["alias bomb", "recursive alias", "deep list", "deep mapping", "deep block"])
def test_yaml_that_would_explode_is_refused_at_once(tmp_path, write_config, text, words):
    cfg = write_config(text)
    for cmd in (["run", str(cfg), "--out", str(tmp_path / "o")], ["validate", str(cfg)]):
        t0 = time.perf_counter()
        line = _one_line_exit_2(runner.invoke(app, cmd))
        assert time.perf_counter() - t0 < 60
        for w in words:
            assert w in line, line
    assert not (tmp_path / "o").exists()


def test_a_few_aliases_and_merge_keys_still_work(write_config):
    exp = load(write_config(TINY.replace("  pf:\n    label: PF\n",
                                         "  pf: &base\n    label: PF\n")
                            + "  pf2:\n    <<: *base\n    type: pf\n    label: PF2\n"
                            "    particles: 10\n"))
    assert [f.key for f in exp.filters][-1] == "pf2@10"


def test_numbers_in_exponent_form_are_numbers(write_config):
    exp = load(write_config(TINY.replace("trials: 4", "trials: 1e1").replace(
        "process_noise_var: 1.0", "process_noise_var: 2e-1")))
    assert exp.trials == 10 and exp.scenario_params["process_noise_var"] == 0.2


# ---------------------------------------------------------------- 4. every filter survives


def _scalar_filters():
    from pfbench.filters import FILTERS
    return [n for n, f in FILTERS.items() if f.kind == "scalar" and f.scenarios is None]


@pytest.mark.parametrize("particles,noise", [(2, 1.0), (2, 1e-9), (50, 1e-4), (3, 1e6)])
def test_every_scalar_filter_survives_extreme_valid_settings(tmp_path, write_config, particles,
                                                              noise):
    from pfbench.filters import FILTERS
    lines = []
    for name in _scalar_filters():
        n = f"    particles: {particles}\n" if FILTERS[name].particles else ""
        lines.append(f"  {name}:\n    type: {name}\n{n}")
    cfg = write_config("seed: 3\ntrials: 3\nscenario:\n  name: ungm\n  steps: 40\n"
                       f"  measurement_noise_var: {noise!r}\nfilters:\n" + "".join(lines))
    res = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o"), "--no-figures"])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "o/trials.csv")
    assert set(df["filter"].str.split("@").str[0]) == set(_scalar_filters())
    # an estimate that is not a number is counted, never silent
    bad = df[~df["rmse"].map(lambda v: v == v and abs(v) != float("inf"))]
    assert (bad["diverged_steps"] > 0).all(), bad


FIELD_TINY = """\
seed: 1
trials: 3
scenario:
  name: beacon_field
  steps: 30
  range_noise_m: 1.0e-9
filters:
  mcl:
    particles: 2
  sspf:
    particles: 2
"""


def test_localization_filters_with_two_particles_and_no_sensor_noise(tmp_path):
    import shutil
    root = Path(__file__).resolve().parents[1]
    shutil.copytree(root / "configs" / "worlds", tmp_path / "worlds")
    (tmp_path / "exp.yaml").write_text(FIELD_TINY)
    res = runner.invoke(app, ["run", str(tmp_path / "exp.yaml"), "--out", str(tmp_path / "o"),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    df = pd.read_csv(tmp_path / "o/trials.csv")
    # an estimate far outside the 40 m field is a divergence event, not a silent error
    far = df[df["final_error"] > 100]
    assert (far["diverged_steps"] > 0).all(), far
    # two particles lose the robot: the steps outside the world are counted and named
    assert df["diverged_steps"].sum() > 0
    note = next(l for l in (tmp_path / "o/table.md").read_text().splitlines()
                if "left the world" in l)
    assert "trial" in note


def test_an_estimate_outside_the_world_is_counted_as_diverged():
    import numpy as np

    from pfbench.metrics import localization_metrics
    T = 5
    pose = np.zeros((T + 1, 3)) + [10.0, 10.0, 0.0]
    est = pose.copy()
    est[2, 0] = 6.6e5
    est[4, 1] = -1.0
    est[5, 0] = np.nan
    out = {"pose": est, "ess": np.ones(T), "resampled": np.zeros(T), "lik_evals_per_step": 1.0}
    row = localization_metrics(pose, out, 0.5, np.array([], dtype=np.int64), area=[40.0, 40.0])
    assert row["diverged_steps"] == 3.0
    out["pose"] = pose.copy()
    assert localization_metrics(pose, out, 0.5, np.array([], dtype=np.int64),
                                area=[40.0, 40.0])["diverged_steps"] == 0.0


# ---------------------------------------------------------------- 5. sizes without bounds


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
        line = _one_line_exit_2(runner.invoke(app, cmd))
        for w in words:
            assert w in line, line
    assert not out.exists()


def test_trials_on_the_command_line_and_workers_are_bounded(tmp_path, write_config):
    cfg = write_config(TINY)
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--trials", "2000000000",
                                                "--out", str(tmp_path / "o")]))
    assert "memory" in line
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--trials", "100000",
                                                "--workers", "1000", "--out",
                                                str(tmp_path / "o")]))
    assert "1,000 worker" in line
    assert not (tmp_path / "o").exists()
    # more workers than trials: capped at the trials, with a word about the cores
    res = runner.invoke(app, ["run", str(cfg), "--workers", "64", "--out", str(tmp_path / "w"),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "more than the" in res.output and "cores" in res.output
    assert json.loads((tmp_path / "w/meta.json").read_text())["workers"] == 4


def test_a_huge_sweep_is_counted_before_its_cells_are_built(tmp_path, write_config, monkeypatch):
    from pfbench import sweep as sw
    built = []
    real = sw.validate
    monkeypatch.setattr(sw, "validate", lambda *a, **k: built.append(1) or real(*a, **k))
    cfg = write_config(TINY)
    values = ",".join(str(i) for i in range(1000))
    res = runner.invoke(app, ["sweep", str(cfg), "--set", f"seed={values}", "--set",
                              f"trials={values}", "--out", str(tmp_path / "s")])
    line = _one_line_exit_2(res)
    assert "1000000 cells" in line and "--yes" in line
    line = _one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--yes", "--set",
                                                f"seed={values}", "--set", f"trials={values}",
                                                "--out", str(tmp_path / "s")]))
    assert "1,000,000 sweep cells" in line
    assert not built and not (tmp_path / "s").exists()


# ---------------------------------------------------------------- 6. filesystem errors


def test_out_that_is_a_file_or_below_a_file(tmp_path, write_config):
    cfg = write_config(TINY)
    f = tmp_path / "afile"
    f.write_text("keep")
    for out in (f, f / "below"):
        line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out)]))
        assert str(f) in line and "not a folder" in line
    assert f.read_text() == "keep"


@pytest.mark.parametrize("cmd", [["run", "CFG", "--out", ""], ["sweep", "CFG", "--set", "seed=1,2",
                                                                "--out", " "],
                                 ["tables", "--results", ""], ["report", "--out", ""]])
def test_an_empty_path_is_not_the_current_folder(tmp_path, write_config, monkeypatch, cmd):
    monkeypatch.chdir(tmp_path)
    cfg = write_config(TINY)
    before = sorted(p.name for p in tmp_path.iterdir())
    line = _one_line_exit_2(runner.invoke(app, [str(cfg) if c == "CFG" else c for c in cmd]))
    assert "empty" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == before


def _fail_with(err_no):
    def fail(*a, **k):
        raise OSError(err_no, os.strerror(err_no))
    return fail


def test_a_full_disk_is_one_line_and_keeps_the_old_results(tmp_path, write_config, monkeypatch):
    cfg = write_config(TINY)
    out = tmp_path / "o"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"]).exit_code == 0
    before = _tree(out)
    monkeypatch.setattr(os, "fsync", _fail_with(errno.ENOSPC))
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out),
                                                "--no-figures"]))
    assert "No space left" in line
    monkeypatch.undo()
    assert _tree(out) == before              # no temporary file left, nothing lost


def test_a_read_only_folder_is_one_line(tmp_path, write_config, monkeypatch):
    cfg = write_config(TINY)
    real_open = os.open

    def ro_open(path, flags, *a, **k):
        if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real_open(path, flags, *a, **k)

    (tmp_path / "ro").mkdir()
    monkeypatch.setattr(os, "open", ro_open)
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "ro")]))
    assert "Read-only" in line


def test_a_failed_atomic_write_removes_its_temporary_file(tmp_path, monkeypatch):
    target = tmp_path / "t.txt"
    target.write_text("old")
    monkeypatch.setattr(os, "fsync", _fail_with(errno.ENOSPC))
    with pytest.raises(OSError):
        fsutil.atomic_write(target, "new")
    assert [p.name for p in tmp_path.iterdir()] == ["t.txt"] and target.read_text() == "old"


# ---------------------------------------------------------------- 7. more tracebacks


WORLD = """\
area: [40.0, 40.0]
start: [5.0, 5.0, 0.0]
waypoints: [[5, 5], [35, 5], [35, 35], [5, 35]]
beacons: [[0, 0], [40, 0], [40, 40], [0, 40], [20, 20], [20, 0]]
"""
FIELD = """\
trials: 2
scenario:
  name: beacon_field
  world: world.yaml
  steps: 10
filters:
  mcl:
    particles: 50
"""


@pytest.mark.parametrize("world,words", [
    (b"area: [40.0, 40.0]\nname: \xff\xfe\n", ["world", "not UTF-8"]),
    (WORLD.replace("[40.0, 40.0]", "[forty, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "[.inf, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "[.nan, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "{w: 1}").encode(), ["area"]),
    (BOMB.encode() + WORLD.encode(), ["world", "aliases"]),
])
def test_bad_world_files(tmp_path, world, words):
    (tmp_path / "world.yaml").write_bytes(world)
    (tmp_path / "exp.yaml").write_text(FIELD)
    for cmd in (["run", str(tmp_path / "exp.yaml"), "--out", str(tmp_path / "o")],
                ["validate", str(tmp_path / "exp.yaml")]):
        line = _one_line_exit_2(runner.invoke(app, cmd))
        for w in words:
            assert w in line, line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("content", [bytes(range(256)) * 8, b"\x00" * 100,
                                     "trial,filter\n1,2\n".encode(), b""])
def test_a_broken_trials_file_on_resume_is_one_line(tmp_path, write_config, content):
    cfg = write_config(TINY)
    out = tmp_path / "o"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"]).exit_code == 0
    (out / "trials.csv").write_bytes(content)
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out), "--resume"]))
    assert "trials.csv" in line
    assert (out / "trials.csv").read_bytes() == content        # nothing lost


@pytest.mark.parametrize("url", ["not a url", "tcp://", "http://[::1", "tcp://256.1.1.1:99999"])
def test_a_scheduler_that_is_not_an_address(tmp_path, write_config, url):
    pytest.importorskip("distributed")
    cfg = write_config(TINY)
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--executor", "dask",
                                                "--scheduler", url, "--out",
                                                str(tmp_path / "o")]))
    assert "--scheduler" in line
    assert not (tmp_path / "o").exists()


# ---------------------------------------------------------------- 8. resume checks its rows


def _numbers(path):
    return pd.read_csv(path).drop(columns=["wall_s", "crc"]).sort_values(
        ["trial", "filter"]).reset_index(drop=True)


def test_resume_re_runs_trials_whose_rows_were_edited_or_duplicated(tmp_path, write_config):
    cfg = write_config(TINY)
    fresh, out = tmp_path / "fresh", tmp_path / "o"
    for folder in (fresh, out):
        res = runner.invoke(app, ["run", str(cfg), "--out", str(folder), "--no-figures"])
        assert res.exit_code == 0, res.output
    lines = (out / "trials.csv").read_text().splitlines(keepends=True)
    header = lines[0].split(",")
    col = header.index("rmse")
    # trial 1: a value edited; trial 2: a second row for the same filter run with another value
    edited = lines[1 + 3].split(",")
    assert edited[0] == "1"
    edited[col] = "0.001"
    lines[1 + 3] = ",".join(edited)
    dup = lines[1 + 6].rstrip("\n").split(",")
    assert dup[0] == "2"
    dup[col] = "0.002"
    dup[-1] = str(row_crc(dup[:-1]))           # a valid row, but not the one the trial gave
    lines.append(",".join(dup) + "\n")
    (out / "trials.csv").write_text("".join(lines))
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--resume", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "trial 1:" in res.output and "checksum" in res.output
    assert "trial 2:" in res.output and "different values" in res.output
    assert "2 trials in" in res.output and "(2 resumed)" in res.output
    pd.testing.assert_frame_equal(_numbers(out / "trials.csv"), _numbers(fresh / "trials.csv"),
                                  check_exact=True)


def test_rows_carry_a_checksum_and_an_identical_repeat_is_kept_once(tmp_path, write_config):
    from pfbench.runner import read_trials
    cfg = write_config(TINY)
    out = tmp_path / "o"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"]).exit_code == 0
    text = (out / "trials.csv").read_text()
    (out / "trials.csv").write_text(text + text.splitlines(keepends=True)[1])
    got = read_trials(out / "trials.csv")
    assert not got.rejected and len(got.rows) == 4 * 3


# ---------------------------------------------------------------- 9. smaller


@pytest.mark.parametrize("args,words", [
    (["--trials", "0"], ["--trials", ">= 1", "pfbench run --help"]),
    (["--workers", "0"], ["--workers"]),
    (["--seed", "-1"], ["--seed"]),
    (["--trials", "1e9"], ["--trials"]),
    (["--no-such-flag"], ["--no-such-flag"]),
])
def test_usage_errors_are_one_line(tmp_path, write_config, args, words):
    cfg = write_config(TINY)
    line = _one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o"),
                                                *args]))
    for w in words:
        assert w in line, line
    assert not (tmp_path / "o").exists()


def test_usage_errors_are_one_line_from_the_console_script(tmp_path):
    res = subprocess.run([sys.executable, "-m", "pfbench.cli", "run", "x.yaml", "--trials", "0"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.strip().count("\n") == 0 and res.stderr.startswith("pfbench: error: ")


@pytest.mark.parametrize("z", ["inf", "nan", "-1", "0"])
def test_tables_check_needs_a_finite_positive_z(tmp_path, z):
    line = _one_line_exit_2(runner.invoke(app, ["tables", "--check", "--z", z, "--results",
                                                str(tmp_path)]))
    assert "--z" in line


def test_validate_of_a_sweep_applies_set(write_config):
    cfg = write_config(TINY + "sweep:\n  seed: [1, 2]\n")
    res = runner.invoke(app, ["validate", str(cfg), "--set", "trials=3,4,5"])
    assert res.exit_code == 0, res.output
    assert "6 cells" in res.output and "3 trials each" in res.output
    _one_line_exit_2(runner.invoke(app, ["validate", str(cfg), "--set", "trials=0"]))
