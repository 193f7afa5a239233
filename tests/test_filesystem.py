"""Filesystem faults: a file where a folder should be, an empty path, a full disk, a read-only
folder: one line each, and the old results kept."""
from __future__ import annotations

import errno
import os

import pytest
from typer.testing import CliRunner

from pfbench import fsutil
from pfbench.cli import app

from .conftest import TINY, one_line_exit_2, tree

runner = CliRunner()


def test_out_that_is_a_file_or_below_a_file(tmp_path, write_config):
    cfg = write_config(TINY)
    f = tmp_path / "afile"
    f.write_text("keep")
    for out in (f, f / "below"):
        line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out)]))
        assert str(f) in line and "not a folder" in line
    assert f.read_text() == "keep"


@pytest.mark.parametrize("cmd", [["run", "CFG", "--out", ""], ["sweep", "CFG", "--set", "seed=1,2",
                                                                "--out", " "],
                                 ["tables", "--results", ""], ["report", "--out", ""]])
def test_an_empty_path_is_not_the_current_folder(tmp_path, write_config, monkeypatch, cmd):
    monkeypatch.chdir(tmp_path)
    cfg = write_config(TINY)
    before = sorted(p.name for p in tmp_path.iterdir())
    line = one_line_exit_2(runner.invoke(app, [str(cfg) if c == "CFG" else c for c in cmd]))
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
    before = tree(out)
    monkeypatch.setattr(os, "fsync", _fail_with(errno.ENOSPC))
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out),
                                                "--no-figures", "--force"]))
    assert "No space left" in line
    monkeypatch.undo()
    assert tree(out) == before              # no temporary file left, nothing lost


def test_a_read_only_folder_is_one_line(tmp_path, write_config, monkeypatch):
    cfg = write_config(TINY)
    real_open = os.open

    def ro_open(path, flags, *a, **k):
        if flags & (os.O_WRONLY | os.O_RDWR | os.O_CREAT):
            raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(path))
        return real_open(path, flags, *a, **k)

    (tmp_path / "ro").mkdir()
    monkeypatch.setattr(os, "open", ro_open)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "ro")]))
    assert "Read-only" in line


def test_a_failed_atomic_write_removes_its_temporary_file(tmp_path, monkeypatch):
    target = tmp_path / "t.txt"
    target.write_text("old")
    monkeypatch.setattr(os, "fsync", _fail_with(errno.ENOSPC))
    with pytest.raises(OSError):
        fsutil.atomic_write(target, "new")
    assert [p.name for p in tmp_path.iterdir()] == ["t.txt"] and target.read_text() == "old"
