"""The suite says what it compiles (tests/_kernels.py): a compilation a test starts is named when
it starts and timed when it ends; the warm-up picks the configs whose kernels are not cached."""
import numba
from numba.core import event

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
