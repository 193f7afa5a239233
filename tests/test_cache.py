"""A kernel cache folder that cannot be written is never an error (pfbench._cache): one warning
line, and the kernels still run."""
from __future__ import annotations

import os
import subprocess
import sys

import pytest

from .conftest import ROOT

PROGRAM = """
import numpy as np, pfbench
from pfbench import _cache
from pfbench.filters._common import mean_abs_pairwise
print("result", mean_abs_pairwise(np.arange(5.0)), "cache", pfbench.CACHE_DIR, _cache.ENABLED)
"""


def _run(tmp_path, **env):
    full = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    full.update(PYTHONPATH=str(ROOT), TMPDIR=str(tmp_path / "tmp"), **env)
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True,
                          env=full, cwd=tmp_path, timeout=600)


def _warnings(res) -> list[str]:
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr
    assert "result 2.0" in res.stdout
    return [l for l in res.stderr.splitlines() if l.strip()]


@pytest.mark.parametrize("where", ["home", pytest.param("xdg", marks=pytest.mark.slow),
                                   pytest.param("numba", marks=pytest.mark.slow)])
def test_an_unwritable_cache_folder_falls_back_to_a_private_temporary_one(tmp_path, where):
    blocker = tmp_path / "a-file"
    blocker.write_text("in the way")
    env = {"home": {"HOME": str(blocker)},
           "xdg": {"XDG_CACHE_HOME": str(blocker / "cache")},
           "numba": {"NUMBA_CACHE_DIR": str(blocker / "numba")}}[where]
    res = _run(tmp_path, **env)
    lines = _warnings(res)
    assert len(lines) == 1 and lines[0].startswith("pfbench: warning: "), res.stderr
    assert str(tmp_path / "tmp") in lines[0]
    assert f"cache {tmp_path / 'tmp'}" in res.stdout and "True" in res.stdout
    assert list((tmp_path / "tmp").rglob("*.nbi"))        # the kernel was cached there
    assert blocker.read_text() == "in the way"


def test_with_no_writable_folder_at_all_the_kernels_compile_uncached(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("")
    (tmp_path / "tmp").mkdir()
    # the private temporary folder is taken by a file: nowhere to cache
    (tmp_path / "tmp" / f"pfbench-{os.getuid()}").write_text("")
    res = _run(tmp_path, HOME=str(blocker), NUMBA_CACHE_DIR=str(blocker / "n"))
    lines = _warnings(res)
    assert len(lines) == 1 and "without a disk cache" in lines[0], res.stderr
    assert "False" in res.stdout


def test_a_writable_numba_cache_dir_is_used_without_a_word(tmp_path):
    res = _run(tmp_path, NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    assert _warnings(res) == []
    assert f"cache {tmp_path / 'mine'}" in res.stdout
