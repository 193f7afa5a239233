"""What the suite compiles, on screen: each numba compilation a test starts is named as it
starts and timed as it ends, and before the first test the kernels of every committed config
that the numba cache does not hold yet compile in parallel, one line per config (the first run
of the suite after ``pfbench run configs/ifa_fastslam.yaml`` compiles the other filters' kernels
there, on every core, instead of silently inside the tests that first use them)."""
from __future__ import annotations

import multiprocessing as mp
import os
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


class CompileReporter:
    """A numba event listener that says, on the terminal, which kernel compiles and how long it
    took (only the outermost compilation of this process: a kernel's callees compile inside it)."""

    def __init__(self, say):
        self.say, self.depth, self.t0, self.pid = say, 0, 0.0, os.getpid()

    def listener(self):
        from numba.core import event

        reporter = self

        class Listener(event.Listener):
            def on_start(self, ev):
                reporter.start(ev)

            def on_end(self, ev):
                reporter.end(ev)
        return Listener()

    @staticmethod
    def _name(ev) -> str:
        disp = (ev.data or {}).get("dispatcher")
        func = getattr(disp, "py_func", None)
        return (f"{getattr(func, '__module__', '?')}.{getattr(func, '__qualname__', '?')}"
                if func is not None else "a kernel")

    def start(self, ev):
        if os.getpid() != self.pid:
            return
        if self.depth == 0:
            self.t0 = time.perf_counter()
            self.say(f"numba: compiling {self._name(ev)} ...")
        self.depth += 1

    def end(self, ev):
        if os.getpid() != self.pid:
            return
        self.depth -= 1
        if self.depth == 0:
            self.say(f"numba: compiled {self._name(ev)} in {time.perf_counter() - self.t0:.1f} s")


def warm_jobs(extra: Path | None = None) -> list[str]:
    """The committed configs, and the suite's own small config (conftest.SMALL, written into the
    folder ``extra``), whose filters' or scenario's kernels the numba cache lacks."""
    from pfbench.config import load
    from pfbench.runner import uncompiled
    jobs = []
    paths = sorted((ROOT / "configs").glob("*.yaml"))
    if extra is not None:
        from .conftest import SMALL
        (extra / "small.yaml").write_text(SMALL)
        paths.append(extra / "small.yaml")
    from pfbench.regen import is_sweep
    for path in paths:
        if is_sweep(path):
            continue
        exp = load(path, {"trials": 1})
        if uncompiled(exp):
            jobs.append(str(path))
    return jobs


def _warm(path: str) -> tuple[str, float, str]:
    """One trial of the config at ``path`` in this (pool) process: its kernels compile into the
    numba cache; returns (path, seconds, error or '')."""
    t0 = time.perf_counter()
    try:
        from pfbench.config import load
        from pfbench.runner import trial_result
        trial_result(load(path, {"trials": 1}), 0)
        err = ""
    except Exception as exc:     # the tests that use the config will say what is wrong
        err = f"{type(exc).__name__}: {exc}"
    return path, time.perf_counter() - t0, err


def warm(say, workers: int | None = None) -> None:
    """Compile the kernels of ``warm_jobs`` in ``workers`` processes (default: the cores),
    saying each config as it is done."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        _warm_all(say, warm_jobs(Path(tmp)), workers)


def _warm_all(say, jobs: list[str], workers: int | None) -> None:
    if not jobs:
        return
    workers = max(1, min(len(jobs), workers or os.cpu_count() or 1))
    say(f"numba: compiling the kernels of {len(jobs)} config(s) the cache lacks, in "
        f"{workers} process(es) (first run only) ...")
    t0 = time.perf_counter()
    ctx = mp.get_context("spawn")       # a fresh interpreter: no state of the test session
    with ctx.Pool(workers) as pool:
        for k, (path, dt, err) in enumerate(pool.imap_unordered(_warm, jobs), 1):
            say(f"numba: [{k}/{len(jobs)}] {Path(path).name}: {dt:.0f} s"
                + (f" ({err[:120]})" if err else ""))
    say(f"numba: kernels compiled in {time.perf_counter() - t0:.0f} s")
