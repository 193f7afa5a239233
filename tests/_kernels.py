"""What the suite compiles, on screen: each numba compilation a test starts is named as it
starts and timed as it ends, and before the first test the kernels of every committed config
that the numba cache does not hold yet compile by their signatures, on every core, a line per
kernel (the first run of the suite after ``pfbench run configs/ifa_fastslam.yaml`` compiles the
other filters' kernels there, instead of silently inside the tests that first use them). The
plan is pfbench's own compiling ahead (pfbench.precompile) over every config at once: each
kernel the cache lacks is one job, after the jobs of the kernels it calls, longest chain first,
so that no kernel compiles twice and every core stays busy."""
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


def _paths(extra: Path | None) -> list[Path]:
    """The committed configs (not the sweeps, whose cells are configs of the same filters), and
    the suite's own small config (conftest.SMALL, written into the folder ``extra``)."""
    from pfbench.regen import is_sweep
    paths = [p for p in sorted((ROOT / "configs").glob("*.yaml")) if not is_sweep(p)]
    if extra is not None:
        from .conftest import SMALL
        (extra / "small.yaml").write_text(SMALL)
        paths.append(extra / "small.yaml")
    return paths


def _names() -> dict[int, tuple[str, str]]:
    """id of each kernel of pfbench's imported modules -> (module, attribute): how a fresh
    process finds it."""
    import sys

    from pfbench._lazy import LazyKernel
    out: dict[int, tuple[str, str]] = {}
    for name, mod in sorted(sys.modules.items()):
        if mod is None or not name.startswith("pfbench."):
            continue
        for attr, value in list(vars(mod).items()):
            if isinstance(value, LazyKernel) and value.__module__ == name:
                out.setdefault(id(value), (name, attr))
    return out


def warm_plan(extra: Path | None = None) -> list[tuple[str, str, frozenset, float]]:
    """The kernels the configs (``_paths``) call that the numba cache lacks, as (module,
    attribute, the indices of the entries it waits for, rank), ranked first to last
    (pfbench.precompile's plan over every config at once). A kernel no module names (none of
    pfbench's today) is left to the tests; what waits for it compiles it inline."""
    from pfbench import precompile, runner
    from pfbench.config import load
    exps = [load(path, {"trials": 1}) for path in _paths(extra)]
    jobs = precompile.kernel_jobs(exps, runner.trial_result)
    names = _names()
    keep = [i for i, job in enumerate(jobs) if id(job.kernel) in names]
    keep.sort(key=lambda i: (-jobs[i].rank, i))
    new = {old: n for n, old in enumerate(keep)}
    return [(*names[id(jobs[i].kernel)], frozenset(new[j] for j in jobs[i].needs if j in new),
             jobs[i].rank) for i in keep]


_QUEUE = None


def _init(queue) -> None:
    """A pool process: its numba compilations are told to the parent through ``queue``."""
    global _QUEUE
    _QUEUE = queue
    import gc

    from pfbench.precompile import COMPILER_GC
    gc.set_threshold(*COMPILER_GC)      # as pfbench's own compiling workers
    from numba.core import event
    event.register("numba:compile", CompileReporter(
        lambda text: queue.put((os.getpid(), _LABEL, text))).listener())


_LABEL = ""


def _build(module: str, attr: str) -> tuple[float, str]:
    """Build the kernel ``module.attr`` in this (pool) process: its declared signatures compile
    into the numba cache, its callees load from it; returns (seconds, error or '')."""
    global _LABEL
    _LABEL = f"{module.removeprefix('pfbench.')}.{attr}"
    t0 = time.perf_counter()
    try:
        import importlib

        import pfbench  # noqa: F401  (the kernel cache's folder, before any kernel builds)
        getattr(importlib.import_module(module), attr).dispatcher
        err = ""
    except Exception as exc:     # the tests that use the kernel will say what is wrong
        err = f"{type(exc).__name__}: {exc}"
    return time.perf_counter() - t0, err


# the longest the warm-up stays silent: a kernel compiling longer is named again, with its time
QUIET_S = 5.0
# how often the warm-up looks whether a job ended, while it waits for what the pool says
POLL_S = 0.01


def warm(say, workers: int | None = None) -> None:
    """Compile the kernels of ``warm_plan`` in ``workers`` processes (default: the cores), each
    after the kernels it calls, saying each kernel as it compiles and every few seconds what is
    still compiling."""
    import tempfile
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        plan = warm_plan(Path(tmp))
    if time.perf_counter() - t0 > 2.0:
        say(f"numba: the committed configs' kernels found in {time.perf_counter() - t0:.0f} s")
    if plan:
        _warm_all(say, plan, workers)


def _warm_all(say, plan: list, workers: int | None, run=None) -> set[str]:
    """Run the jobs of ``plan`` ((module, attribute, needs, rank), first to last) in a pool of
    ``workers`` fresh processes, a job once every job it needs has ended; ``run(module, attr)``
    (default _build) -> (seconds, error). Returns the jobs that failed, as module.attribute."""
    workers = max(1, min(len(plan), workers or os.cpu_count() or 1))
    say(f"numba: compiling {len(plan)} kernel(s) the cache lacks, for the committed configs, in "
        f"{workers} process(es) (first run only) ...")
    t0 = time.perf_counter()
    ctx = mp.get_context("spawn")       # a fresh interpreter: no state of the test session
    queue = ctx.Queue()
    busy: dict[int, tuple[str, float]] = {}     # pid -> (what it compiles, since)
    last = time.perf_counter()
    failed: set[str] = set()

    def drain(wait: float, done=lambda: False) -> None:
        """Say what the pool processes said, for up to ``wait`` seconds, or until ``done()``
        (a job ended: the next one starts at once, not at the end of the wait)."""
        nonlocal last
        import queue as q
        end = time.perf_counter() + wait
        while not done():
            try:
                pid, label, text = queue.get(timeout=min(POLL_S, max(0.0,
                                                                      end - time.perf_counter())))
            except q.Empty:
                if time.perf_counter() >= end:
                    break
                continue
            if text.startswith("numba: compiling "):
                busy[pid] = (text[len("numba: compiling "):-4], time.perf_counter())
            else:
                busy.pop(pid, None)
            say(f"numba: [{label}] {text[len('numba: '):]}")
            last = time.perf_counter()
        if time.perf_counter() - last >= QUIET_S:
            now = time.perf_counter()
            say("numba: still compiling " + "; ".join(
                f"{what}: {now - since:.0f} s" for what, since in busy.values())
                if busy else f"numba: still compiling ({now - t0:.0f} s)")
            last = now

    with ctx.Pool(workers, initializer=_init, initargs=(queue,)) as pool:
        waiting, running, ended = list(range(len(plan))), {}, set()
        while waiting or running:
            while len(running) < workers:
                i = next((i for i in waiting if plan[i][2] <= ended), None)
                if i is None and not running and waiting:
                    i = waiting[0]              # what it waits for never ended: go on anyway
                if i is None:
                    break
                waiting.remove(i)
                running[pool.apply_async(run or _build, plan[i][:2])] = i
            finished = [r for r in running if r.ready()]
            if not finished:
                drain(0.25, lambda: any(r.ready() for r in running))
                continue
            drain(0.0)
            for r in finished:
                i = running.pop(r)
                dt, err = r.get()
                ended.add(i)
                what = f"{plan[i][0]}.{plan[i][1]}"
                if err:
                    failed.add(what)
                say(f"numba: [{len(ended)}/{len(plan)}] {what.removeprefix('pfbench.')}: "
                    f"{dt:.0f} s" + (f" ({err[:120]})" if err else ""))
                last = time.perf_counter()
    say(f"numba: kernels compiled in {time.perf_counter() - t0:.0f} s")
    return failed
