"""Kernels compiled on every core before a run's first trial.

numba compiles a kernel in the process that first calls it, one kernel after another: a run whose
kernels are not cached yet would compile them all in its first trial, on one core, and a run on
several workers would compile them in every worker at once. ``compile_ahead`` instead compiles
them by their declared signatures (pfbench._lazy), without running anything, in one worker
process per core, into the numba cache, which the run then loads them from:

1. Which kernels: a trial of each filter run with its kernels recorded, not run
   (``_lazy.recording``: the scenario's simulate kernel and the filter's kernel are named, the
   Python around them runs on arrays nobody filled, and nothing is simulated). The model
   functions the model is built with compile here (they are small, and the run's workers
   inherit them). A filter run that names none is read from its code instead (``_named``).
2. Their callees, from the kernels' code (``_lazy.callees``): every kernel the cache lacks is a
   job that waits for the kernels it calls, so that each compiles in one process only, once,
   and the others load it from the cache when a caller compiles. An inlined callee that its
   callers do not build (``LazyKernel.built_by_callers``) is no job: its body compiles in each
   caller, which waits for the kernels that body calls instead.
3. The jobs go out longest chain first (``_plan``: a kernel's own cost, estimated from its
   code, plus the longest chain of callers that wait for it), to as many processes as there are
   cores and as fit the memory (check_fits, as for as many workers).

Only pfbench's own kernels are compiled so; a plug-in's compile in its first trial as before,
and a plug-in scenario's filters are read from their code. A kernel that fails to compile is
left to the run, which reports the failure as usual; a worker that dies ends the compiling, not
the run.
"""
from __future__ import annotations

import os
import types as pytypes
import warnings
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Callable

from . import _cache
from ._lazy import LazyKernel, callees, named, recording, size
from .errors import UserError
from .filters import FILTERS
from .resources import check_fits
from .scenarios import SCENARIOS
from .version import CACHE_DIR
from .workers import WorkerDied, Workers, in_worker, quiet_worker

# a callee's code costs this fraction of its own again in each caller that links it (numba
# links a caller's callees into its module and optimises them there)
LINKED = 0.15

# numba's compiler allocates much and keeps most of it: at Python's default of a young collection
# every 700 allocations net, compiling the bootstrap PF's and MCL's kernels spent 3.3 to 4.0 of its
# 45 to 50 CPU-seconds collecting garbage; so, 1.25 of 43 (this project's 2-core machine)
COMPILER_GC = (20_000, 20, 10)


def compiler_worker(*_args) -> None:
    """A compiling worker's setup: a worker's (workers.quiet_worker), collecting its garbage less
    often (COMPILER_GC)."""
    import gc
    quiet_worker()
    gc.set_threshold(*COMPILER_GC)


def _own(obj) -> bool:
    return (getattr(obj, "__module__", "") or "").startswith("pfbench.")


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _fits(exp, processes: int) -> bool:
    """Whether ``processes`` processes fit this machine's memory as ``processes`` workers of a
    run of ``exp`` would (a compiling process holds numba and LLVM, not a trial: an upper bound)."""
    try:
        check_fits(exp, processes)
    except UserError:
        return False
    return True


# ---------------------------------------------------------------- which kernels

def _named(func, depth: int = 3) -> list[LazyKernel]:
    """The pfbench kernels a Python function ``func`` names, and those of the pfbench functions
    it names (``depth`` levels down): every kernel a filter's ``run`` may call, the settings it
    is run with unknown (more than the run calls where it picks one of several kernels)."""
    out: dict[int, LazyKernel] = {}
    seen: set[int] = set()

    def visit(f, d):
        if id(f) in seen or not _own(f):
            return
        seen.add(id(f))
        for v in named(f):
            if isinstance(v, LazyKernel):
                out.setdefault(id(v), v)
            elif d > 0 and isinstance(v, pytypes.FunctionType):
                visit(v, d - 1)
    visit(func, depth)
    return list(out.values())


def roots(exp, trial: Callable) -> list[LazyKernel]:
    """The pfbench kernels a trial of ``exp`` calls from Python (its scenario's and its filter
    runs'), found without running one: each filter run's trial, ``trial(experiment, 0)`` (the
    runner's trial_result), with its kernels recorded instead of run (see the module). A
    plug-in's filter runs are left out, and with a plug-in scenario (whose simulation would run)
    the filter runs' kernels are read from their code."""
    found: dict[int, LazyKernel] = {}
    own_scenario = _own(getattr(SCENARIOS[exp.scenario], "simulate", None))
    for f in exp.filters:
        run = FILTERS[f.type].run
        if not _own(run):
            continue
        calls: list = []
        if own_scenario:
            with recording() as calls, warnings.catch_warnings():
                warnings.simplefilter("ignore")
                import numpy as np
                with np.errstate(all="ignore"):
                    try:
                        trial(replace(exp, filters=(f,)), 0)
                    except Exception:   # what ran on unfilled arrays: the kernels came before
                        pass
        mine = [k for k in calls if _own(k)]
        if not any(k in _named(run) for k in mine):     # the run named none of its own
            mine += _named(run)
        for k in mine:
            found.setdefault(id(k), k)
    return list(found.values())


def _cached(kern: LazyKernel) -> bool:
    """Whether ``kern`` is built in this process or has an entry in the numba cache."""
    if kern.built:
        return True
    try:
        from numba.core.caching import FunctionCache
        return os.path.exists(FunctionCache(kern._func)._cache_file._index_path)
    except Exception:
        return False


@dataclass
class Job:
    """A kernel to compile: the jobs of the kernels it calls (``needs``, indices) come first."""
    kernel: LazyKernel
    cost: float
    needs: set[int] = field(default_factory=set)
    callers: set[int] = field(default_factory=set)
    rank: float = 0.0           # its cost plus the longest chain of callers waiting for it


def _below(kern: LazyKernel) -> list[LazyKernel]:
    """Every pfbench kernel ``kern`` calls, its callees' callees included (what numba links into
    its module)."""
    out: dict[int, LazyKernel] = {}
    todo = [kern]
    while todo:
        for c in callees(todo.pop()):
            if _own(c) and id(c) not in out and c is not kern:
                out[id(c)] = c
                todo.append(c)
    return list(out.values())


def _compiled_callees(kern: LazyKernel) -> list[LazyKernel]:
    """The pfbench kernels numba builds when it compiles ``kern``: those it calls, and in place
    of an inlined callee that compiling a caller does not build (``LazyKernel.built_by_callers``)
    those its body calls, for its body is compiled into ``kern``."""
    out: dict[int, LazyKernel] = {}
    seen: set[int] = set()
    todo = callees(kern)
    while todo:
        c = todo.pop()
        if id(c) in seen or c is kern or not _own(c):
            continue
        seen.add(id(c))
        if not c.built_by_callers:
            todo.extend(callees(c))
        else:
            out[id(c)] = c
    return list(out.values())


def _plan(kernels: list[LazyKernel]) -> list[Job]:
    """The jobs of ``kernels`` and of every kernel they call that is not cached yet (a cached
    kernel's callees are in its cache entry), ranked (see Job)."""
    jobs: list[Job] = []
    index: dict[int, int] = {}
    todo = [k for k in kernels if not _cached(k)]
    for k in todo:
        index.setdefault(id(k), len(index))
    links = {}
    while len(jobs) < len(index):
        k = todo[len(jobs)]
        below = _compiled_callees(k)
        for c in below:
            if not _cached(c) and id(c) not in index:
                index[id(c)] = len(index)
                todo.append(c)
        links[id(k)] = [index[id(c)] for c in below if id(c) in index]
        jobs.append(Job(k, size(k) + LINKED * sum(size(c) for c in _below(k))))
    for i, job in enumerate(jobs):
        job.needs = {j for j in links[id(job.kernel)] if j != i}
        for j in job.needs:
            jobs[j].callers.add(i)
    # rank: from the callers down (a caller's rank is known before its callees'), cycles cut
    done: dict[int, float] = {}

    def rank(i: int, path: frozenset) -> float:
        if i in done:
            return done[i]
        up = [rank(c, path | {i}) for c in jobs[i].callers if c not in path]
        done[i] = jobs[i].cost + max(up, default=0.0)
        return done[i]
    for i, job in enumerate(jobs):
        job.rank = rank(i, frozenset())
    return jobs


# ---------------------------------------------------------------- compiling them

def _build(kernels: list[LazyKernel], i: int) -> bool:
    """What a pool worker runs: build kernel ``i`` (compile its declared signatures, its callees
    loaded from the cache); False when it fails (the run reports it)."""
    try:
        kernels[i].dispatcher
    except Exception:
        return False
    return True


def kernel_jobs(exps, trial: Callable) -> list[Job]:
    """The jobs (see Job) of compiling ahead the kernels that trials of any of the experiments
    ``exps`` call and the numba cache does not hold yet: one plan for all of them, so that a
    kernel several of them call is one job (what the test suite's warm-up compiles)."""
    found: dict[int, LazyKernel] = {}
    for exp in exps:
        for k in roots(exp, trial):
            found.setdefault(id(k), k)
    return _plan(list(found.values()))


def uncompiled_kernels(exp, trial: Callable) -> list[Job]:
    """The jobs (see Job) of compiling ahead the kernels a trial of ``exp`` calls that the
    numba cache does not hold yet."""
    return kernel_jobs([exp], trial)


def compile_ahead(exp, trial: Callable, processes: int | None = None) -> int:
    """Compile the kernels the numba cache lacks for ``exp`` (see the module) in ``processes``
    processes (default: the cores this process may use); ``trial`` is the runner's trial_result,
    handed down (the runner calls this module), which finds them. Returns the kernels compiled
    (0: nothing to do, or too little to split)."""
    if not _cache.ENABLED or not uncompiled(exp) or in_worker():
        return 0
    processes = processes or _cores()
    while processes >= 2 and not _fits(exp, processes):
        processes -= 1          # never more processes than as many workers would fit
    if processes < 2:
        return 0
    jobs = uncompiled_kernels(exp, trial)
    processes = min(processes, len(jobs))
    if processes < 2:
        return 0
    from .tablecache import settle
    settle()                    # no fork while a thread of this process imports
    kernels = [job.kernel for job in jobs]
    with Workers(processes, partial(_build, kernels), setup=compiler_worker) as pool:
        waiting = set(range(len(jobs)))
        finished: set[int] = set()
        held: list[int | None] = [None] * processes     # the job a worker compiles

        def give(slot: int) -> None:
            ready = [i for i in waiting if jobs[i].needs <= finished]
            if not ready and not any(h is not None for h in held):
                ready = list(waiting)       # a cycle among the rest: one compiles its callees
            if ready:
                i = max(ready, key=lambda i: (jobs[i].rank, -i))
                waiting.discard(i)
                pool.send(slot, i)
                held[slot] = i

        try:
            for slot in range(processes):
                give(slot)
            while any(h is not None for h in held):
                for slot, _, _ in pool.results(timeout=0.25):
                    finished.add(held[slot])
                    held[slot] = None
                    for other in [slot] + [s for s in range(processes) if held[s] is None]:
                        if held[other] is None:
                            give(other)
        except WorkerDied:
            return 0            # the run meets (and names) what killed it
        pool.close()
    return len(jobs)


def uncompiled(exp) -> list[str]:
    """The names of the experiment's filter types (and its scenario) whose kernels the numba
    cache does not hold yet: they compile when the first trial uses them (pfbench._lazy)."""
    index = Path(CACHE_DIR) / "pfbench"
    have = ({p.name.split(".")[0] for p in index.rglob("*.nbi")}
            if _cache.ENABLED and index.is_dir() else set())
    out = []
    for what, obj in ([(f.type, FILTERS[f.type].run) for f in exp.filters]
                      + [(exp.scenario, getattr(SCENARIOS[exp.scenario], "simulate", None))]):
        module = getattr(obj, "__module__", "") or ""
        if module.startswith("pfbench.") and module.rsplit(".", 1)[-1] not in have:
            out.append(what)
    return list(dict.fromkeys(out))
