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


def missing_kernels(exp) -> list[str]:
    """The cached kernels of the experiment's filter and scenario modules that the numba cache
    holds no entry for (``runner.uncompiled`` looks at modules: a module with one kernel cached
    counts as compiled, though a config may need another of its kernels, as afsa_fastslam needs
    the FastSLAM kernel with the afsa2014 branches that ifa_fastslam's run does not build)."""
    import importlib

    from numba.core.caching import FunctionCache

    from pfbench import _cache
    from pfbench._lazy import LazyKernel
    from pfbench.filters import FILTERS
    from pfbench.scenarios import SCENARIOS
    if not _cache.ENABLED:
        return []
    modules = {getattr(FILTERS[f.type].run, "__module__", "") for f in exp.filters}
    modules.add(getattr(getattr(SCENARIOS[exp.scenario], "simulate", None), "__module__", ""))
    out = []
    for name in sorted(m for m in modules if m.startswith("pfbench.")):
        for k in vars(importlib.import_module(name)).values():
            if (isinstance(k, LazyKernel) and k._options.get("cache") and not k.built
                    and k.__module__ == name):
                index = _index(FunctionCache, k.__wrapped__)
                if index is not None and not os.path.exists(index):
                    out.append(f"{name}.{k.__name__}")
    return out


def _index(cache, func) -> str | None:
    """The path of the numba cache index of ``func``, or None where numba cannot cache it."""
    try:
        return cache(func)._cache_file._index_path
    except RuntimeError:        # "cannot cache function": nothing the warm-up can do
        return None


def _stamp(path: Path) -> Path:
    """The file that says the warm-up ran ``path`` (its name and text) under this kernel cache."""
    import hashlib

    from pfbench.version import CACHE_DIR
    digest = hashlib.sha256(path.name.encode() + b"\0" + path.read_bytes()).hexdigest()[:16]
    return Path(CACHE_DIR) / "suite-warmed" / f"{path.stem}-{digest}"


def warm_jobs(extra: Path | None = None) -> list[str]:
    """The committed configs, and the suite's own small config (conftest.SMALL, written into the
    folder ``extra``), whose filters' or scenario's kernels the numba cache lacks: a module none
    of whose kernels is cached (``runner.uncompiled``), or, once per kernel cache, a kernel of
    their modules that is not (``missing_kernels``)."""
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
        if uncompiled(exp) or (not _stamp(path).exists() and missing_kernels(exp)):
            jobs.append(str(path))
    return jobs


def warm_groups(paths: list[str]) -> list[tuple[str, tuple[str, ...], frozenset]]:
    """Each config's filter runs grouped by the module of their filter type (what one module's
    kernels compile: ``precompile.groups``), as (config, filter keys, modules), first the groups
    of a module the cache lacks kernels of."""
    from pfbench.config import load
    from pfbench.filters import FILTERS
    from pfbench.precompile import groups
    from pfbench.runner import uncompiled
    first, then = [], []
    for path in paths:
        exp = load(path, {"trials": 1})
        missing = set(uncompiled(exp))
        lacking = {k.rsplit(".", 1)[0] for k in missing_kernels(exp)}
        for keys in groups(exp):
            runs = [f for f in exp.filters if f.key in keys]
            modules = frozenset(getattr(FILTERS[f.type].run, "__module__", f.type) for f in runs)
            (first if any(f.type in missing for f in runs) or modules & lacking else then).append(
                (path, keys, modules))
    return first + then


_QUEUE = None


def _init(queue) -> None:
    """A pool process: its numba compilations are told to the parent through ``queue``."""
    global _QUEUE
    _QUEUE = queue
    from numba.core import event
    event.register("numba:compile", CompileReporter(
        lambda text: queue.put((os.getpid(), _CONFIG, text))).listener())


_CONFIG = ""


def _warm(path: str, keys: tuple[str, ...] | None = None) -> tuple[str, float, str]:
    """One trial of the config at ``path`` (of its filter runs ``keys``; default all) in this
    (pool) process: its kernels compile into the numba cache; returns (path, seconds, error or
    '')."""
    global _CONFIG
    _CONFIG = Path(path).name
    t0 = time.perf_counter()
    try:
        from dataclasses import replace

        from pfbench.config import load
        from pfbench.runner import trial_result
        exp = load(path, {"trials": 1})
        if keys is not None:
            exp = replace(exp, filters=tuple(f for f in exp.filters if f.key in keys))
        trial_result(exp, 0)
        err = ""
    except Exception as exc:     # the tests that use the config will say what is wrong
        err = f"{type(exc).__name__}: {exc}"
    return path, time.perf_counter() - t0, err


# the longest the warm-up stays silent: a kernel compiling longer is named again, with its time
QUIET_S = 5.0


def warm(say, workers: int | None = None) -> None:
    """Compile the kernels of ``warm_jobs`` in ``workers`` processes (default: the cores), one
    group of filter runs of a config at a time (``warm_groups``), never two groups of one module
    at once (they would compile its kernels twice), saying each kernel as it compiles, each
    group as it is done, and every few seconds what is still compiling; then stamps each config
    done without an error (``_stamp``)."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        paths = warm_jobs(Path(tmp))
        if not paths:
            return
        failed = _warm_all(say, warm_groups(paths), workers, configs=len(paths))
        for path in paths:
            if Path(path).parent == ROOT / "configs" and path not in failed:
                stamp = _stamp(Path(path))
                stamp.parent.mkdir(parents=True, exist_ok=True)
                stamp.touch()


def _warm_all(say, jobs: list, workers: int | None, run=None, configs: int | None = None
              ) -> set[str]:
    """Run ``jobs`` ((config, filter keys, modules), or config paths) in a pool of ``workers``
    processes, no two with a module in common at once; returns the configs that failed."""
    if not jobs:
        return set()
    jobs = [j if isinstance(j, tuple) else (j, None, frozenset()) for j in jobs]
    workers = max(1, min(len(jobs), workers or os.cpu_count() or 1))
    say(f"numba: compiling the kernels of {configs or len(jobs)} config(s) the cache lacks "
        f"({len(jobs)} groups of filters), in {workers} process(es) (first run only) ...")
    t0 = time.perf_counter()
    ctx = mp.get_context("spawn")       # a fresh interpreter: no state of the test session
    queue = ctx.Queue()
    busy: dict[int, tuple[str, float]] = {}     # pid -> (what it compiles, since)
    last = time.perf_counter()
    failed: set[str] = set()

    def drain(wait: float) -> None:
        nonlocal last
        import queue as q
        end = time.perf_counter() + wait
        while True:
            try:
                pid, config, text = queue.get(timeout=max(0.0, end - time.perf_counter()))
            except q.Empty:
                break
            if text.startswith("numba: compiling "):
                busy[pid] = (f"{text[len('numba: compiling '):-4]} ({config})",
                             time.perf_counter())
            else:
                busy.pop(pid, None)
            say(f"numba: [{config}] {text[len('numba: '):]}")
            last = time.perf_counter()
        if time.perf_counter() - last >= QUIET_S:
            now = time.perf_counter()
            say("numba: still compiling " + "; ".join(
                f"{what}: {now - since:.0f} s" for what, since in busy.values())
                if busy else f"numba: still compiling ({now - t0:.0f} s)")
            last = now

    with ctx.Pool(workers, initializer=_init, initargs=(queue,)) as pool:
        pending, running, done = list(jobs), {}, 0
        while pending or running:
            while len(running) < workers:
                taken = frozenset().union(*(j[2] for j in running.values()))
                job = next((j for j in pending if not j[2] & taken), None)
                if job is None:
                    break
                pending.remove(job)
                args = (job[0],) if job[1] is None else (job[0], job[1])
                running[pool.apply_async(run or _warm, args)] = job
            finished = [r for r in running if r.ready()]
            if not finished:
                drain(0.25)
                continue
            drain(0.0)
            for r in finished:
                path, keys, _ = running.pop(r)
                _, dt, err = r.get()
                done += 1
                if err:
                    failed.add(path)
                what = Path(path).name + (f" ({', '.join(keys)})" if keys else "")
                say(f"numba: [{done}/{len(jobs)}] {what}: {dt:.0f} s"
                    + (f" ({err[:120]})" if err else ""))
                last = time.perf_counter()
    say(f"numba: kernels compiled in {time.perf_counter() - t0:.0f} s")
    return failed
