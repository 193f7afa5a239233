"""Kernels compiled on every core before a run's first trial.

numba compiles a kernel in the process that first calls it, one kernel after another: a run whose
filters' kernels are not cached yet would compile them all in its first trial, on one core, and a
run on several workers would compile them in every worker at once. ``compile_ahead`` instead
splits the experiment's filter runs into groups that compile different kernels (one per module
of filter types), and runs one trial of each group, on the experiment's own first trial's data,
in one worker process per core (at most one per group): each kernel compiles once, into the
numba cache, while the others compile beside it. The run then loads them all from the cache.

Only pfbench's own kernels are compiled so (``uncompiled``); a plug-in's compile in its
first trial as before. Nothing of these trials is kept: what they compute is the first trial's,
which the run computes again, bit for bit (numba's code does not depend on which process
compiled it). A group that fails is left to the run, which reports the failure as usual; a
worker that dies ends the compiling, not the run.
"""
from __future__ import annotations

import os
from dataclasses import replace
from functools import partial
from pathlib import Path
from typing import Callable

from . import _cache
from .errors import UserError
from .filters import FILTERS
from .resources import check_fits
from .scenarios import SCENARIOS
from .version import CACHE_DIR
from .workers import WorkerDied, Workers, in_worker, quiet_worker


def groups(exp) -> list[tuple[str, ...]]:
    """The keys of the experiment's filter runs grouped by the module of their filter type: the
    runs of one module share its kernels (pf and pfmh one kernel, the swarm filters another),
    which would compile in every group that ran them."""
    by: dict[str, list[str]] = {}
    for f in exp.filters:
        by.setdefault(getattr(FILTERS[f.type].run, "__module__", f.type), []).append(f.key)
    return [tuple(keys) for keys in by.values()]


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


def _fits(exp, processes: int) -> bool:
    """Whether ``processes`` trials of ``exp`` at once fit this machine's memory (each group runs
    a part of a trial, so that many whole trials bound it)."""
    try:
        check_fits(exp, processes)
    except UserError:
        return False
    return True


def _compile(exp, keys: tuple[str, ...], trial: Callable) -> None:
    """One trial of the filter runs ``keys`` of ``exp`` (their kernels build): ``trial(exp, 0)``
    (the runner's trial_result); errors are the run's to report."""
    try:
        trial(replace(exp, filters=tuple(f for f in exp.filters if f.key in keys)), 0)
    except Exception:
        pass


def _group(exp, trial: Callable, keys: tuple[str, ...]) -> None:
    """What a pool worker runs: _compile, looked up in the worker (which the tests replace)."""
    _compile(exp, keys, trial)


def compile_ahead(exp, trial: Callable, processes: int | None = None) -> int:
    """Compile the kernels the numba cache lacks for ``exp`` in ``processes`` processes (default:
    the cores this process may use), one group of filter runs each (see the module), each
    running ``trial(experiment, 0)`` (the runner's trial_result, handed down: the runner calls
    this module); returns the groups compiled (0: nothing to do, or too little to split)."""
    if not uncompiled(exp) or in_worker():
        return 0
    todo = groups(exp)
    processes = min(len(todo), processes or _cores())
    while processes >= 2 and not _fits(exp, processes):
        processes -= 1          # never more trials at once than the memory holds
    if processes < 2:
        return 0
    from .tablecache import settle
    settle()                    # no fork while a thread of this process imports
    with Workers(processes, partial(_group, exp, trial), setup=quiet_worker) as pool:
        left = list(todo)
        held = [0] * processes          # groups a worker holds (one at a time)

        def give(slot: int) -> None:
            if left:
                pool.send(slot, left.pop(0))
                held[slot] += 1

        try:
            for slot in range(processes):
                give(slot)
            while any(held):
                for slot, _, _ in pool.results(timeout=0.25):
                    held[slot] -= 1
                    give(slot)
        except WorkerDied:
            return 0            # the run meets (and names) what killed it
        pool.close()
    return len(todo)


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
