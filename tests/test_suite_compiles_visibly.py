"""The suite says what it compiles (tests/_kernels.py): a compilation a test starts is named when
it starts and timed when it ends; the warm-up picks the configs whose kernels are not cached."""
from pathlib import Path

import numba
from numba.core import event

from . import _kernels
from ._kernels import CompileReporter, warm_plan


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


def test_the_warm_up_plans_only_the_kernels_the_cache_lacks_callees_first(monkeypatch):
    """Every kernel the configs call that the cache lacks, and no other: a module with one
    kernel cached is not all of it (afsa_fastslam needs the FastSLAM kernel with the afsa2014
    branches, which ifa_fastslam's run, the main job, does not build); each entry waits only
    for entries before it."""
    from pfbench import precompile
    from pfbench.filters import fastslam
    monkeypatch.setattr(precompile, "_cached", lambda k: True)
    assert warm_plan() == []
    lacking = {id(fastslam.fastslam_kernel), id(fastslam.update_maps)}
    monkeypatch.setattr(precompile, "_cached", lambda k: id(k) not in lacking)
    plan = warm_plan()
    names = [(m, a) for m, a, _, _ in plan]
    assert sorted(names) == [("pfbench.filters.fastslam", "fastslam_kernel"),
                             ("pfbench.filters.fastslam", "update_maps")]
    assert all(j < i for i, (_, _, needs, _) in enumerate(plan) for j in needs)
    calls = dict(zip(names, plan))
    assert calls["pfbench.filters.fastslam", "fastslam_kernel"][2] == {
        names.index(("pfbench.filters.fastslam", "update_maps"))}


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


def _slow_job(module, attr):
    """A warm-up job that compiles for a while (a pool process's; see the test below)."""
    import time
    _kernels._QUEUE.put((__import__("os").getpid(), "m.k", "numba: compiling pfbench.m.k ..."))
    time.sleep(1.0)
    return 1.0, ""


def test_the_warm_up_is_never_silent_while_a_kernel_compiles(monkeypatch):
    """What compiles in the warm-up's processes is named as it starts, and every few seconds
    (QUIET_S) while it goes on."""
    said = []
    monkeypatch.setattr(_kernels, "QUIET_S", 0.25)
    _kernels._warm_all(said.append, [("pfbench.m", "k", frozenset(), 1.0)], 1, run=_slow_job)
    assert said[0].startswith("numba: compiling 1 kernel(s) the cache lacks")
    start = said.index("numba: [m.k] compiling pfbench.m.k ...")
    still = [s for s in said[start:] if s.startswith("numba: still compiling pfbench.m.k: ")]
    assert len(still) >= 2, said
    assert said[-2] == "numba: [1/1] m.k: 1 s" and said[-1].startswith("numba: kernels compiled")


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


def _timed_job(module, attr):
    """A warm-up job that notes when it ran (a pool process's; see the test below)."""
    import time
    t0 = time.time()
    time.sleep(0.6)
    Path(module).write_text(f"{t0} {time.time()}")
    return 0.6, ""


def test_a_kernel_compiles_after_the_kernels_it_calls_and_beside_the_others(tmp_path):
    """A job starts once every job it waits for has ended (its callees then load from the
    cache, never compile twice), while a job that waits for nothing runs beside them."""
    a, b, c = (str(tmp_path / n) for n in "abc")
    said = []
    failed = _kernels._warm_all(said.append, [(a, "k", frozenset(), 3.0),
                                              (b, "k", frozenset({0}), 2.0),
                                              (c, "k", frozenset(), 1.0)], 2, run=_timed_job)
    assert failed == set()
    (a0, a1), (b0, b1), (c0, c1) = (map(float, Path(p).read_text().split()) for p in (a, b, c))
    assert b0 >= a1                         # b after a, which it calls
    assert c0 < a1 and a0 < c1              # c beside a
    assert any(s.endswith(f"{a}.k: 1 s") for s in said), said
