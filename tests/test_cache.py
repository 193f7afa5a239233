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
from pfbench.resampling import scaled_weights       # a small kernel: compiles in a fraction of a s
print("result", scaled_weights(np.arange(5.0))[1], "cache", pfbench.CACHE_DIR, _cache.ENABLED)
"""


def _environment(**env) -> dict:
    """This process's environment without the user's cache folders, the checkout importable,
    and ``env``."""
    full = {k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "XDG_CACHE_HOME")}
    full.update(PYTHONPATH=str(ROOT))
    full.update(env)
    return full


def _run(tmp_path, **env):
    full = _environment(TMPDIR=str(tmp_path / "tmp"), **env)
    (tmp_path / "tmp").mkdir(exist_ok=True)
    return subprocess.run([sys.executable, "-c", PROGRAM], capture_output=True, text=True,
                          env=full, cwd=tmp_path, timeout=600)


def _warnings(res) -> list[str]:
    assert res.returncode == 0, res.stderr
    assert "Traceback" not in res.stderr
    assert "result 1.25" in res.stdout
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
from summed import total        # its environment names numba's array functions (a sum)
value = mean_abs_pairwise(np.arange(5.0))
hits = sum(mean_abs_pairwise.stats.cache_hits.values())
summed = total(np.arange(5.0))
hits += sum(total.stats.cache_hits.values())
refreshed = "numba.typed.typeddict" in sys.modules     # what numba's refresh imports
linalg = "scipy.linalg" in sys.modules

@numba.njit
def fresh(n):                   # compiles after the load: the compiler refreshes on its own
    d = {}                      # (a typed dict: numba.typed's lowering, which the refresh imports)
    for i in range(n):
        d[i] = i * 0.5
    total = 0.0
    for v in d.values():
        total += v
    return total
print("result", value, summed, "hits", hits, "refreshed", refreshed, "linalg", linalg,
      "fresh", fresh(4))
"""


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
def test_a_kernel_loads_from_the_cache_without_numbas_compiler_refresh(tmp_path):
    """A kernel found in the cache loads with numba's runtime alone (no import of every lowering
    module, nor of scipy.linalg), gives what it gave when compiled, and a kernel compiled
    afterwards in the same process still compiles and runs; a kernel the cache lacks compiles
    as numba does."""
    env = _environment(PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path)]),
                       NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    (tmp_path / "summed.py").write_text("import numba\n\n\n@numba.njit(cache=True)\n"
                                        "def total(a):\n    return a.sum()\n")

    def once():
        res = subprocess.run([sys.executable, "-c", LOADS], capture_output=True, text=True,
                             env=env, cwd=tmp_path, timeout=600)
        assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
        return res.stdout.split()

    first, second = once(), once()
    assert first[:5] == ["result", "2.0", "10.0", "hits", "0"]   # compiled: nothing to load
    assert first[6] == "True"
    assert second[:9] == ["result", "2.0", "10.0", "hits", "2", "refreshed", "False", "linalg",
                          "False"], second
    assert second[9:] == first[9:] == ["fresh", "3.0"]


LINKS = """
import numpy as np, numba, pfbench
from pfbench.models.scalar import ModelFunction
from scaled import scale, step
a = np.arange(4.0)
first = scale(a, 3.0)
lib = scale.overloads[scale.signatures[0]].library
lazy = type(lib).__name__ == "LinkOnDemand"
waits = "_pfbench_bitcode" in lib.__dict__      # its linking module not read yet

@numba.njit
def apply(f, x, out):           # a first-class function: its address is looked up
    f(x, 1.0, x, out)
out = np.empty(4)
apply(ModelFunction(step), a, out)
still = "_pfbench_bitcode" in lib.__dict__      # that lookup read the model function's alone

@numba.njit
def twice(a):                   # compiled now: links the loaded kernel's module in
    return scale(a, 2.0)
linked = twice(a).tolist()
read = "_pfbench_bitcode" not in lib.__dict__
print("lazy", lazy, "waits", waits, still, "first", first.tolist(), "applied", out.tolist(),
      "linked", linked, "read", read)
"""


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
def test_a_kernel_loaded_from_the_cache_reads_its_linking_module_only_when_needed(tmp_path):
    """A kernel loaded from the cache runs without its linking module being parsed
    (_cache._link_on_demand); a cached model function handed to a kernel as a first-class
    function is found, its own module read and not the other's; a kernel compiled later that
    calls the first links it in (its module is parsed then): the same values as when they were
    compiled."""
    env = _environment(PYTHONPATH=os.pathsep.join([str(ROOT), str(tmp_path)]),
                       NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    (tmp_path / "scaled.py").write_text(
        "import numba\nfrom pfbench.models.scalar import MODEL_SIG\n\n\n"
        "@numba.njit(cache=True)\ndef scale(a, k):\n    return a * k\n\n\n"
        "@numba.njit(MODEL_SIG, cache=True)\ndef step(x, t, theta, out):\n"
        "    for i in range(x.size):\n        out[i] = x[i] * t + theta[i]\n")

    def once():
        res = subprocess.run([sys.executable, "-c", LINKS], capture_output=True, text=True,
                             env=env, cwd=tmp_path, timeout=600)
        assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
        return res.stdout.split(" first ")

    compiled, loaded = once(), once()
    assert compiled[0] == "lazy False waits False False"     # compiled: nothing was loaded
    assert loaded[0] == "lazy True waits True True", loaded
    assert loaded[1] == compiled[1] == ("[0.0, 3.0, 6.0, 9.0] applied [0.0, 2.0, 4.0, 6.0] "
                                        "linked [0.0, 2.0, 4.0, 6.0] read True\n")


def _on_demand_library(parse):
    """A library of the class _link_on_demand makes, on a stand-in for numba's code library and
    engine, waiting with bitcode b"bitcode"; (library, engine, waiting list)."""
    from pfbench import _cache

    class Engine:
        def __init__(self):
            self.listed = []

        def _load_defined_symbols(self, module):
            self.listed.append(module)

    class Codegen:
        _engine = Engine()

    class Library:
        def __init__(self, codegen):
            self._codegen = codegen

    lib = _cache._on_demand_class(Library, parse)(Codegen())
    lib.__dict__["_pfbench_bitcode"] = b"bitcode"
    waiting = _cache._waiting(Codegen._engine)
    waiting.append(lib)
    return lib, Codegen._engine, waiting


def test_a_waiting_linking_module_is_parsed_once_and_its_symbols_listed_once():
    """The first look parses the bitcode, lists its symbols and takes the library off the
    waiting list; a second look returns the same module."""
    parsed = []
    lib, engine, waiting = _on_demand_library(lambda b: parsed.append(b) or "module")
    assert lib._shared_module == "module" and lib._shared_module == "module"
    assert parsed == [b"bitcode"] and engine.listed == ["module"] and waiting == []


def test_a_linking_module_that_fails_to_parse_leaves_nothing_waiting():
    """Bitcode that does not parse raises where it is first needed, as numba's load would have,
    and the library leaves the waiting list all the same: a later look over it cannot loop."""
    def parse(bitcode):
        raise ValueError("not bitcode")
    lib, engine, waiting = _on_demand_library(parse)
    with pytest.raises(ValueError):
        lib._shared_module
    assert waiting == [] and lib._shared_module is None and engine.listed == []


BLAS = """
import sys
import numpy as np, numba
from pfbench import _cache
if sys.argv[1] == "linalg-first":
    import scipy.linalg  # noqa: F401
_cache.start_loading()
after = ["scipy.linalg" in sys.modules, "scipy.linalg.cython_blas" in sys.modules,
         "numba.np.arraymath" in sys.modules]

@numba.njit
def product(a, b):              # numpy's dot of two matrices: numba calls scipy's BLAS
    return np.dot(a, b)
a = np.arange(6.0).reshape(2, 3)
b = np.arange(12.0).reshape(3, 4) / 7.0
print("after", *after, "same", bool(np.array_equal(product(a, b), a @ b)),
      "blas", "scipy.linalg.cython_blas" in sys.modules)
"""


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
@pytest.mark.parametrize("how", ["alone", "linalg-first"])
def test_a_worker_gets_numbas_array_functions_without_importing_scipy_linalg(tmp_path, how):
    """start_loading checks for a BLAS with scipy's BLAS module alone: the scipy.linalg package
    (a tenth of a second) is not imported, the module is not left half-registered, and a kernel
    that calls the BLAS later imports it the usual way and computes numpy's product. Where
    scipy.linalg is imported already, nothing changes."""
    env = _environment(NUMBA_CACHE_DIR=str(tmp_path / "mine"))
    res = subprocess.run([sys.executable, "-c", BLAS, how], capture_output=True, text=True,
                         env=env, cwd=tmp_path, timeout=600)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    linalg = "True" if how == "linalg-first" else "False"
    assert res.stdout.split() == ["after", linalg, linalg, "True", "same", "True",
                                  "blas", "True"], res.stdout
