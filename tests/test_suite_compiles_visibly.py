"""The suite says what it compiles (tests/_kernels.py): a compilation a test starts is named when
it starts and timed when it ends; the warm-up picks the configs whose kernels are not cached."""
from pathlib import Path

import numba
from numba.core import event

from . import _kernels
from ._kernels import CompileReporter, warm_jobs


def test_a_compilation_is_named_as_it_starts_and_timed_as_it_ends():
    said = []
    listener = CompileReporter(said.append).listener()
    event.register("numba:compile", listener)
    try:
        def outer(x):
            return inner(x) + 1.0

        def inner(x):
            return 2.0 * x
        inner = numba.njit("float64(float64)")(inner)      # compiled here: one start, one end
        outer = numba.njit("float64(float64)")(outer)      # inner is already built
        assert outer(1.0) == 3.0
    finally:
        event.unregister("numba:compile", listener)
    assert len(said) == 4, said
    assert said[0].startswith("numba: compiling ") and said[0].endswith("inner ...")
    assert said[1].startswith("numba: compiled ") and "inner in " in said[1]
    assert said[2].endswith("outer ...") and said[3].endswith(" s")


def test_the_warm_up_names_only_configs_whose_kernels_are_missing(monkeypatch):
    import pfbench.runner as runner
    monkeypatch.setattr(runner, "uncompiled", lambda exp: [])
    monkeypatch.setattr(_kernels, "missing_kernels", lambda exp: [])
    assert warm_jobs() == []
    monkeypatch.setattr(runner, "uncompiled",
                        lambda exp: ["mcl"] if any(f.type == "mcl" for f in exp.filters) else [])
    jobs = warm_jobs()
    assert jobs and all("mcl" in open(p).read() for p in jobs)


def test_asking_a_kernel_for_what_no_dispatcher_has_builds_nothing():
    """pytest's collection asks every object of a test module for its fixture and mark
    attributes: a kernel imported into a test module must not compile for that."""
    import pytest

    from pfbench._lazy import kernel
    k = kernel("float64(float64)", cache=False)(lambda x: x + 1.0)
    for name in ("pytestmark", "_pytestfixturefunction", "_fixture_function_marker", "nope"):
        with pytest.raises(AttributeError):
            getattr(k, name)
    assert not k.built
    assert k.signatures == [] or k.built           # a dispatcher's own attribute builds it
    assert k(1.0) == 2.0 and k.built


def test_a_compilation_inside_a_cli_runner_keeps_its_output():
    """The suite's compile lines go to the terminal without taking sys.stdout from a test that
    swapped it (typer's CliRunner, whose output was lost, then read from a closed file)."""
    import typer
    from typer.testing import CliRunner
    app = typer.Typer()

    @app.command()
    def go():
        f = numba.njit("float64(float64)")(lambda x: 3.0 * x)     # compiles here
        print(f"result {f(2.0)}")
    res = CliRunner().invoke(app, [])
    assert res.exit_code == 0, res.output
    assert "result 6.0" in res.output


def test_a_config_needing_a_kernel_its_modules_lack_is_warmed(monkeypatch, tmp_path):
    """A module with one kernel cached is not all of it: afsa_fastslam needs the FastSLAM kernel
    with the afsa2014 branches, which ifa_fastslam's run (the main job) does not build."""
    import subprocess
    import sys

    from .conftest import ROOT
    program = ("from pfbench.config import load\n"
               "from tests._kernels import missing_kernels\n"
               "print(missing_kernels(load('configs/afsa_fastslam.yaml', {'trials': 1})))\n")
    res = subprocess.run([sys.executable, "-c", program], cwd=ROOT, capture_output=True,
                         text=True, timeout=300, check=False,
                         env={**__import__("os").environ, "PYTHONPATH": str(ROOT),
                              "NUMBA_CACHE_DIR": str(tmp_path)})
    assert res.returncode == 0, res.stderr
    assert "pfbench.filters.fastslam.fastslam_kernel'" in res.stdout
    # a config warmed once under this cache is not warmed again for a kernel none of its
    # trials build
    from pfbench import runner
    monkeypatch.setattr(runner, "uncompiled", lambda exp: [])
    monkeypatch.setattr(_kernels, "missing_kernels", lambda exp: ["m.k"])
    monkeypatch.setattr(_kernels, "_stamp", lambda path: tmp_path / path.name)
    assert len(warm_jobs()) >= 8
    (tmp_path / "afsa_fastslam.yaml").touch()
    assert not any(p.endswith("afsa_fastslam.yaml") for p in warm_jobs())


def _slow_job(path):
    """A warm-up job that compiles for a while (a pool process's; see the test below)."""
    import time
    _kernels._QUEUE.put((__import__("os").getpid(), "x.yaml",
                         "numba: compiling pfbench.slow_kernel ..."))
    time.sleep(2.0)
    return path, 2.0, ""


def test_the_warm_up_is_never_silent_while_a_kernel_compiles(monkeypatch):
    """What compiles in the warm-up's processes is named as it starts, and every few seconds
    (QUIET_S) while it goes on."""
    said = []
    monkeypatch.setattr(_kernels, "QUIET_S", 0.5)
    _kernels._warm_all(said.append, ["a.yaml"], 1, run=_slow_job)
    assert said[0].startswith("numba: compiling the kernels of 1 config(s)")
    start = said.index("numba: [x.yaml] compiling pfbench.slow_kernel ...")
    still = [s for s in said[start:]
             if s.startswith("numba: still compiling pfbench.slow_kernel (x.yaml): ")]
    assert len(still) >= 2, said
    assert said[-2] == "numba: [1/1] a.yaml: 2 s" and said[-1].startswith("numba: kernels compiled")


class _Config:
    def __init__(self, args, markexpr="not slow"):
        from types import SimpleNamespace

        from .conftest import ROOT
        self.args, self.option = args, SimpleNamespace(markexpr=markexpr, collectonly=False)
        self.invocation_params = SimpleNamespace(dir=ROOT)


def test_the_suite_runs_on_every_core_and_a_few_files_in_one_process():
    from .conftest import pytest_xdist_auto_num_workers as workers
    assert workers(_Config([])) >= 1
    assert workers(_Config(["tests"])) >= 1
    assert workers(_Config(["tests/test_cli.py", "tests/test_api.py::test_x"])) == 0
    assert workers(_Config(["tests"], markexpr="slow")) == 0


def test_the_warm_up_runs_once_per_run_of_the_suite(monkeypatch):
    """Under pytest-xdist each worker's collection reaches the controller: one warm-up."""
    from . import conftest
    calls = []
    monkeypatch.setattr(_kernels, "warm", lambda say: calls.append(1))
    config = _Config([])
    config.pluginmanager = type("PM", (), {"getplugin": staticmethod(lambda name: None)})()
    ids = [f"tests/test_{i}.py::t" for i in range(11)]
    node = type("Node", (), {"config": config})()
    conftest.pytest_xdist_node_collection_finished(node, ids)
    conftest.pytest_xdist_node_collection_finished(node, ids)
    assert calls == [1]
    few = _Config([])
    few.pluginmanager = config.pluginmanager
    conftest.pytest_xdist_node_collection_finished(type("Node", (), {"config": few})(), ids[:3])
    assert calls == [1]


def _timed_job(path, keys):
    """A warm-up job that notes when it ran (a pool process's; see the test below)."""
    import time
    t0 = time.time()
    time.sleep(0.6)
    Path(path).write_text(f"{t0} {time.time()}")
    return path, 0.6, ""


def test_two_groups_of_one_module_never_compile_at_once(tmp_path):
    """The warm-up's processes take groups of filter runs; two that share a module would compile
    its kernels twice, side by side: one waits for the other, while a group of another module
    runs beside it."""
    a, b, c = (str(tmp_path / n) for n in "abc")
    said = []
    failed = _kernels._warm_all(said.append, [(a, ("pf",), frozenset({"m.pf"})),
                                              (b, ("pfmh",), frozenset({"m.pf"})),
                                              (c, ("mcl",), frozenset({"m.mcl"}))], 2,
                                run=_timed_job)
    assert failed == set()
    (a0, a1), (b0, b1), (c0, c1) = (map(float, Path(p).read_text().split()) for p in (a, b, c))
    assert b0 >= a1 or a0 >= b1             # a and b one after the other
    assert c0 < a1 and a0 < c1              # c beside a
    assert any(s.endswith("a (pf): 1 s") for s in said), said
