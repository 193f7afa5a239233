import ast
import contextlib
import functools
import gc
import math
import os
import sys
import types
from pathlib import Path

import numpy as np
import pytest

from pfbench.config import Params

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COLUMNS", "200")


@pytest.fixture
def write_config(tmp_path):
    """Write YAML text to a file under tmp_path and return its path."""
    def _write(text: str, name: str = "exp.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


SMALL = """\
seed: 0
trials: 6
scenario:
  name: ungm
  steps: 30
  process_noise_var: 1.0
filters:
  pf:
    label: PF
    particles: [20, 40]
  ukf:
    label: UKF
"""


def default_params(schema: dict, **over) -> Params:
    """A schema's defaults with some keys overridden, as validated parameters."""
    p = {k: key.default for k, key in schema.items()}
    p.update(over)
    return Params(p)


TINY = SMALL.replace("trials: 6", "trials: 4").replace("steps: 30", "steps: 10")


def one_line_exit_2(res) -> str:
    """The one line a CLI run gave for bad input (exit status 2, no traceback)."""
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = res.output.splitlines()
    assert len(lines) == 1, res.output          # no empty line before it either
    assert lines[0].startswith("pfbench: error: ")
    return lines[0]


def tree(folder: Path) -> dict:
    """Every file under folder with its bytes (to show nothing changed)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


@functools.cache
def parsed(text: str) -> ast.Module:
    """``ast.parse(text)``, once per text in a test process: the tests that read the whole of
    pfbench's source (its layers, function sizes, one owner per concept, codes) share the trees.
    Read them; never change one."""
    return ast.parse(text)


def njit_when_used(sig, **options):
    """A decorator: ``numba.njit(sig, cache=True, **options)`` applied the first time a test
    calls ``kern()`` for the kernel (the call returns the numba function). A module-level
    ``@njit(sig)`` compiles when its module is imported, that is at collection, and in every
    pytest-xdist worker, whether the worker runs a test of it or not."""
    def wrap(func):
        @functools.cache
        def kern():
            import numba
            return numba.njit(sig, cache=True, **options)(func)
        return functools.update_wrapper(kern, func)
    return wrap


def _say(config):
    """A function that writes a line to the terminal even while a test's output is captured."""
    worker = getattr(config, "workerinput", {}).get("workerid")

    def write(text: str) -> None:
        if worker:      # a pytest-xdist worker: its stderr is the terminal of the controller
            os.write(2, f"[{worker}] {text}\n".encode())
        else:
            config.pluginmanager.getplugin("terminalreporter").write_line(text)

    def say(text: str) -> None:
        tr = config.pluginmanager.getplugin("terminalreporter")
        cap = config.pluginmanager.getplugin("capturemanager")
        if tr is None and not worker:
            return
        if cap is None:
            write(text)
            return
        # pytest's capture, suspended and resumed, sets sys.stdout and sys.stderr to its own:
        # a test that swapped them (typer's CliRunner) gets its own back
        out, err = sys.stdout, sys.stderr
        try:
            with cap.global_and_fixture_disabled():
                write(text)
        finally:
            sys.stdout, sys.stderr = out, err
    return say


def _one_click_command_per_app() -> None:
    """typer's CliRunner builds the click command of the app it invokes at every invoke (10 ms
    for pfbench's, read from its functions' signatures and type hints); the suite's tests invoke
    it some 570 times. Each Typer app's command is built once and kept while the app lives."""
    import weakref

    import typer.main
    import typer.testing
    built: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()

    def get_command(app):
        command = built.get(app)
        if command is None:
            command = built[app] = typer.main.get_command(app)
        return command
    typer.testing._get_command = get_command


class _PipeHere:
    """The two ends of a worker's pipe in one process, for ``workers._serve``: it receives
    ``item``, then the end, and what it sends is kept in ``sent``; both cross a pickle, as they
    would the pipe (a result that cannot be pickled fails ``send`` as it would there)."""

    def __init__(self, item):
        self._items, self.sent = [item, None], []

    def recv(self):
        import pickle
        return pickle.loads(pickle.dumps(self._items.pop(0)))

    def send(self, obj) -> None:
        import pickle
        self.sent.append(pickle.loads(pickle.dumps(obj)))


class WorkerHere:
    """pfbench.workers.Workers with its one worker in the test's process: what a test's run of
    one worker gets unless the test is marked ``worker_processes`` (see ``_one_worker_here``).
    An item sent is handled at once by a worker's own loop (``workers._serve``, on a _PipeHere):
    its result or its exception, through a pickle, as the pipe would carry it; nothing forks.
    A fork of a test's process, grown large by the time, and a worker's first writes to the
    pages it shares with it cost about as much as a small run's trials: 0.065 CPU-seconds of a
    run of SMALL's 0.13."""

    def __init__(self, count: int, handle, setup=None, setup_args: tuple = (),
                 collect: bool = True):
        assert count == 1, count
        self._handle, self._done = handle, []
        self.procs = [types.SimpleNamespace(exitcode=None, pid=os.getpid())]   # runner._claim's

    def send(self, slot: int, item) -> None:
        from pfbench import workers
        assert slot == 0 and self._handle is not None, (slot, "sent after close")
        pipe = _PipeHere(item)
        workers._serve(pipe, slot, self._handle, None, ())
        self._done += pipe.sent

    def results(self, timeout: float | None = None) -> list:
        done, self._done = self._done, []
        return [(0, ok, got) for ok, got in done]

    def close(self, timeout: float = 5.0) -> None:
        self.stop()

    def stop(self) -> None:
        self._handle = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


@pytest.fixture(autouse=True)
def _one_worker_here(request, monkeypatch):
    """A run of one worker runs its trials in the test's process (WorkerHere): the runner's
    code is the same, its pool of one worker is not forked. A run of more workers forks them as
    a user's would, and so does every run of a test marked ``worker_processes`` (what the
    worker processes themselves do: their start, their end, Ctrl-C, a crash, the progress they
    report). The models such a run built are forgotten after the test, as its worker would
    have taken them with it: a test's plug-in scenario is another test's under the same name."""
    if request.node.get_closest_marker("worker_processes"):
        yield
        return
    from pfbench import runner, workers
    real = workers.Workers

    def pool(count: int, *args, **kwargs):
        return (WorkerHere if count == 1 else real)(count, *args, **kwargs)
    monkeypatch.setattr(runner, "Workers", pool)
    yield
    runner._model.cache_clear()


# The file whose byte-range locks the pytest-xdist workers of a run take while they build a
# kernel (one byte per kernel, at an offset its name hashes to): _one_build_per_kernel.
_BUILD_LOCKS = "PFBENCH_TESTS_BUILD_LOCKS"


def _one_build_per_kernel() -> None:
    """In a pytest-xdist worker: a kernel of pfbench that this process builds (compiles, or
    loads from the numba cache) is built under a lock the other workers of the run share, so
    that two workers that come to the same kernel at once (two tests calling an inlined kernel
    from Python: swarm_move, 6 CPU-seconds) do not both compile it: the second waits, then
    loads what the first wrote to the cache. A kernel's callees are built inside it, later in
    its call graph's order, so that two workers never wait on each other (the kernel returns
    unlocked where the system says they would)."""
    path = os.environ.get(_BUILD_LOCKS)
    if not path:
        return
    import fcntl
    import hashlib

    from pfbench._lazy import LazyKernel
    built = LazyKernel.dispatcher.fget
    fd = os.open(path, os.O_RDWR)       # one descriptor: closing one drops all of them

    def dispatcher(self):
        if self._disp is not None:
            return self._disp
        name = f"{self._func.__module__}.{self._func.__qualname__}".encode()
        at = int.from_bytes(hashlib.blake2b(name, digest_size=5).digest(), "big")
        try:
            fcntl.lockf(fd, fcntl.LOCK_EX, 1, at)
        except OSError:                 # EDEADLK: build it unlocked
            return built(self)
        try:
            return built(self)
        finally:
            fcntl.lockf(fd, fcntl.LOCK_UN, 1, at)
    LazyKernel.dispatcher = property(dispatcher, doc=LazyKernel.dispatcher.__doc__)


def pytest_configure(config):
    # A test process allocates much and keeps most of it (kernels, modules, the tests' own
    # objects), as numba's compiler does: at Python's default of a young collection every 700
    # allocations net, its collections took 12 CPU-seconds of a run of the suite on 2 cores, 4
    # at the compiling workers' thresholds.
    from pfbench.precompile import COMPILER_GC
    gc.set_threshold(*COMPILER_GC)
    from numba.core import event

    from ._kernels import CompileReporter
    event.register("numba:compile", CompileReporter(_say(config)).listener())
    _one_click_command_per_app()
    if hasattr(config, "workerinput"):
        _one_build_per_kernel()
    elif config.getoption("numprocesses", None) and not os.environ.get(_BUILD_LOCKS):
        import tempfile
        fd, path = tempfile.mkstemp(prefix="pfbench-tests-", suffix=".locks")
        os.close(fd)
        os.environ[_BUILD_LOCKS] = config._pfbench_build_locks = path


def pytest_unconfigure(config):
    path = getattr(config, "_pfbench_build_locks", None)
    if path:
        os.environ.pop(_BUILD_LOCKS, None)
        with contextlib.suppress(OSError):
            os.unlink(path)


def _suite_files(config) -> int:
    """How many test files the command line names (its folders' test_*.py counted; the
    testpaths when it names none)."""
    files = set()
    for arg in config.args or [str(ROOT / "tests")]:
        path = Path(config.invocation_params.dir, arg.split("::", 1)[0])
        if path.is_dir():
            files.update(path.rglob("test_*.py"))
        else:
            files.add(path)
    return len(files)


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config):
    """``-n auto`` (pyproject's addopts): one worker process per core for a run of the suite (the
    default selection, more than ten files); a run of a few files, or of another selection
    (``-m slow``: the long end-to-end runs, one at a time as before), runs in this process."""
    if config.option.markexpr != "not slow" or _suite_files(config) <= 10:
        return 0
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _warm_first(config, files: int) -> None:
    """The kernels of the committed configs the numba cache lacks compile on every core, visibly
    (tests/_kernels.py), before the first test of a run of the suite (tests from more than ten
    files; a run of a few files compiles only what its tests use)."""
    if config.option.collectonly or files <= 10 or getattr(config, "_pfbench_warmed", False):
        return
    config._pfbench_warmed = True
    from ._kernels import warm
    tr = config.pluginmanager.getplugin("terminalreporter")
    if tr is not None:
        tr.write_line("")
    warm(_say(config))


def pytest_collection_finish(session):
    """In one process (no ``-n``): the warm-up, before the first test. Under pytest-xdist the
    workers leave it to the controller (``pytest_xdist_node_collection_finished``)."""
    if hasattr(session.config, "workerinput"):
        return
    _warm_first(session.config, len({item.path for item in session.items}))


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids):
    """Under pytest-xdist: the warm-up runs once, in the controller, when the first worker has
    collected and before any test is handed out (the workers then load every kernel from the
    cache instead of each compiling it, unseen)."""
    _warm_first(node.config, len({i.split("::", 1)[0] for i in ids}))


def holm_by_closure(pvalues, alpha: float) -> list[bool]:
    """Which hypotheses Holm's procedure rejects, computed from its definition rather than as a
    step-down: Holm's test is the closed test of Bonferroni's (Holm 1979; Marcus, Peritz and
    Gabriel 1976), so H_i is rejected when every intersection H_S with i in S is, and Bonferroni
    rejects H_S when min(p_j, j in S) <= alpha / |S|. Up to 10 hypotheses every such S is
    enumerated; beyond, for each size k the S hardest to reject is i with the k - 1 largest other
    p-values (the largest minimum), which decides all the sets of that size."""
    import itertools
    p = [float(x) for x in pvalues]
    m = len(p)

    def rejected(s) -> bool:
        return min(p[j] for j in s) <= alpha / len(s)

    out = []
    for i in range(m):
        others = [j for j in range(m) if j != i]
        if m <= 10:
            sets = ((i, *c) for k in range(m) for c in itertools.combinations(others, k))
        else:
            largest = sorted(others, key=lambda j: p[j], reverse=True)
            sets = ((i, *largest[:k]) for k in range(m))
        out.append(all(rejected(s) for s in sets))
    return out


def ewa_reference(W, beta, printed=False, copies="ceil"):
    """ifa2021 section 1.2 written plainly in numpy; ``copies``: how many copies a kept particle
    of weight W gets, n = W / delta (the key ``ewa_copies``)."""
    N = W.size
    order = np.argsort(-W, kind="stable")
    Ws = W[order]
    v, deltas = 0.0, []
    for i, wi in enumerate(Ws, start=1):
        v = beta * v + (1 - beta) * wi
        deltas.append(v / (1 - beta ** i))
        if printed:
            v = deltas[-1]
    delta = np.mean(deltas)
    kept = max(1, int(np.sum(Ws >= delta * (1 - 1e-12))))   # round-off guard, as documented
    src, mutant = [], []
    for i in range(kept):
        n = Ws[i] / delta
        c = {"ceil": math.ceil(n - 1e-12), "floor_plus_one": math.floor(n + 1e-12) + 1,
             "ceil_plus_one": math.ceil(n - 1e-12) + 1}[copies]
        for _ in range(c):
            if len(src) < N:
                src.append(order[i])
                mutant.append(0)
    j = 0
    while len(src) < N:
        src.append(order[j % kept])
        mutant.append(1)
        j += 1
    return np.array(src), np.array(mutant)
