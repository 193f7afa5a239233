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


LOADS = """
import sys
import numpy as np, numba, pfbench
from pfbench.filters._common import mean_abs_pairwise
value = mean_abs_pairwise(np.arange(5.0))
hits = sum(mean_abs_pairwise.stats.cache_hits.values())
refreshed = "numba.typed.typeddict" in sys.modules     # what numba's refresh imports

@numba.njit
def fresh(n):                   # compiles after the load: the compiler refreshes on its own
    d = {}
    for i in range(n):
        d[str(i)] = i * 0.5
    total = 0.0
    for v in d.values():
        total += v
    return total
print("result", value, "hits", hits, "refreshed", refreshed, "fresh", fresh(4))
"""


def test_a_kernel_loads_from_the_cache_without_numbas_compiler_refresh(tmp_path):
    """A kernel found in the cache loads with numba's runtime alone (no import of every lowering
    module), gives what it gave when compiled, and a kernel compiled afterwards in the same
    process still compiles and runs; a kernel the cache lacks compiles as numba does."""
    env = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    env.update(PYTHONPATH=str(ROOT), NUMBA_CACHE_DIR=str(tmp_path / "mine"))

    def once():
        res = subprocess.run([sys.executable, "-c", LOADS], capture_output=True, text=True,
                             env=env, cwd=tmp_path, timeout=600)
        assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
        return res.stdout.split()

    first, second = once(), once()
    assert first[:4] == ["result", "2.0", "hits", "0"]            # compiled: nothing to load
    assert first[5] == "True"
    assert second[:6] == ["result", "2.0", "hits", "1", "refreshed", "False"], second
    assert second[6:] == first[6:] == ["fresh", "3.0"]
