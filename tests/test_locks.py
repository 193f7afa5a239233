"""Folder locks: two runs never write into one folder; a lock dies with its holder."""
from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pfbench import fsutil
from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.runner import run_experiment

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


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
        line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out)]))
        assert f"pid {holder.pid}" in line and "in use" in line
        assert sorted(p.name for p in out.iterdir()) == [fsutil.LOCK_NAME]   # nothing written
        # a sweep into it, and a sweep whose cell is locked
        line = one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--set", "seed=1,2",
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
        line = one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--set", "seed=1,2",
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
            line = one_line_exit_2(runner.invoke(app, ["tables", "--configs", str(configs),
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
