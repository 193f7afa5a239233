"""Trials -> rows; seeding; executors; the results folder.

Seeding: trial k's data come from the SeedSequence child ``(seed, spawn_key=(k, 0))``; filter run
F of trial k from ``SeedSequence(int_words(seed) + int_words(k) + key_words(F.key))``
(pfbench.seeding: an integer as its count of 32-bit words and the words, the key as the eight
words of the SHA-256 digest of its UTF-8 bytes), an injective encoding, so two runs share a
stream only if their keys' digests collide. Seeds depend on (base seed, trial, filter key), never
on run order, the number of workers, or which other filters the experiment has.
"""
from __future__ import annotations

import copy
import dataclasses
import itertools
import json
import math
import os
import platform
import signal
import socket
import subprocess
import sys
import time
import types
from dataclasses import dataclass
from datetime import datetime, timezone
from functools import lru_cache, partial
from pathlib import Path
from typing import Callable, Iterable, Mapping, NamedTuple

import numpy as np

from ._cache import start_loading
from ._lazy import LazyKernel
from ._special import UFUNCS, functions
from .version import __version__
from .config import FORMAT_VERSION, Experiment, Params
from .diagnostics import NAMES as DIAGNOSTIC_NAMES
from .diagnostics import Diag
from .diagnostics import flags as diag_flags
from .diagnostics import plan as plan_diagnostics
from .diagnostics import reported_metrics
from .errors import UserError
from .fsutil import FolderLock, remove_tree, require_regular
from .filters import FILTERS, LOAD_SECONDS
from .kinds import check_outputs, kind_of
from .plugins import FILTER_GROUP, SCENARIO_GROUP
from .precompile import compile_ahead, uncompiled  # noqa: F401  (uncompiled: this module's API)
from .rng import state_from_seed
from .scenarios import SCENARIOS
from .seeding import run_seed
from .workers import WorkerDied, Workers
from .workers import in_worker as _in_process
from .workers import quiet_worker
from .store import (TIMINGS, TIMINGS_PARTIAL, atomic_write, clear_staged_traces,
                    complete_trials, csv_text, finish_traces, read_staged_traces, read_timings,
                    read_traces, read_trials, stage_trace, timings_text, trial_columns,
                    trials_digest, with_timings, write_json)

# What the last run into a folder took on its machine (never committed, like the timings file).
RUN_TIMINGS = "timings.json"



def data_seed(seed: int, trial: int) -> np.random.SeedSequence:
    return np.random.SeedSequence(seed, spawn_key=(trial, 0))


def filter_seed(seed: int, trial: int, key: str) -> np.random.SeedSequence:
    """The seed of filter run ``key`` of trial ``trial`` (pfbench.seeding.run_seed)."""
    return run_seed(seed, trial, key)


@lru_cache(maxsize=8)
def _model(scenario: str, params_json: str):
    return SCENARIOS[scenario].build(json.loads(params_json))


def build_model(exp: Experiment):
    """The scenario model of ``exp`` (built once per process)."""
    return _model(exp.scenario, json.dumps(dict(exp.scenario_params), sort_keys=True))


def trial_data(exp: Experiment, trial: int):
    """(model, truth, data): the truth and measurements of trial ``trial``, shared by every
    filter (each filter run gets its own copy: run_filter)."""
    model = build_model(exp)
    try:
        truth, data = SCENARIOS[exp.scenario].simulate(
            fresh(model), state_from_seed(data_seed(exp.seed, trial)))
    except Exception as exc:
        raise UserError(f"scenario '{exp.scenario}'{_package(SCENARIO_GROUP, exp.scenario)}, "
                        f"trial {trial}: simulate raised {_exception_text(exc)}") from None
    return model, truth, data


def fresh(value, _memo: dict | None = None):
    """A copy of ``value`` that shares no array with it: numpy arrays copied, and the lists,
    tuples, dicts, dataclasses and plain objects holding them rebuilt around the copies (an
    object met twice is copied once); functions, kernels and immutable values are shared. What a
    filter run gets, so that one that writes into its inputs (the measurements, the model's
    parameters) changes nothing another run sees."""
    if value is None or isinstance(value, (str, bytes, int, float, complex, bool, np.generic,
                                           type, set, frozenset, types.ModuleType)):
        return value
    if isinstance(value, np.ndarray):
        return value.copy()
    if callable(value):                 # a function, a kernel
        return value
    memo = {} if _memo is None else _memo
    if id(value) in memo:
        return memo[id(value)]
    if isinstance(value, list):
        memo[id(value)] = out = []
        out.extend(fresh(v, memo) for v in value)
        return out
    if isinstance(value, tuple):
        items = [fresh(v, memo) for v in value]
        if hasattr(value, "_fields"):            # a named tuple
            out = type(value)(*items)
        else:
            out = tuple(items) if type(value) is tuple else type(value)(items)
    elif isinstance(value, dict):
        memo[id(value)] = out = copy.copy(value)
        for k, v in value.items():
            out[k] = fresh(v, memo)
    elif isinstance(value, Params):
        out = Params({k: fresh(v, memo) for k, v in value.items()})
    elif dataclasses.is_dataclass(value) or hasattr(value, "__dict__"):
        try:
            memo[id(value)] = out = copy.copy(value)
            for k, v in vars(value).items():
                object.__setattr__(out, k, fresh(v, memo))
        except Exception:       # an object that will not be copied: shared as it is
            out = value
    else:
        out = value
    memo[id(value)] = out
    return out


class FilterError(UserError):
    """A filter run that failed: its error (``cause``, None for a malformed output), named in one
    line with the run, its type and its plug-in package."""

    def __init__(self, message: str, cause: BaseException | None = None):
        super().__init__(message)
        self.cause = cause

    def __reduce__(self):       # from a worker process: the message (a cause may not pickle)
        return FilterError, (str(self),)


def _package(group: str, name: str) -> str:
    """' (plug-in package PKG)' for a plug-in's filter or scenario; '' for pfbench's own."""
    from .plugins import ORIGIN
    pkg = ORIGIN.get((group, name), "pfbench")
    return "" if pkg == "pfbench" else f" (plug-in package {pkg})"


def _exception_text(exc: BaseException) -> str:
    try:
        text = " ".join(str(exc).split())
    except Exception:           # an exception that cannot say what it is
        text = "(its message cannot be shown)"
    text = text if len(text) <= 300 else text[:297] + "..."
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _who(run, trial: int) -> str:
    """How a message names filter run ``run`` of trial ``trial``."""
    return (f"filter run '{run.key}' (type {run.type}){_package(FILTER_GROUP, run.type)}, "
            f"trial {trial}")


def metrics_of(exp: Experiment, model, truth, out) -> dict:
    """A filter run's metrics for the experiment's kind of scenario (and the consistency metrics
    its trials file has, pfbench.diagnostics.reported_metrics)."""
    return kind_of(exp.scenario).row(model, truth, out, reported_metrics(exp))


def run_filter(exp: Experiment, trial: int, run, model, y, diag: Diag | None = None,
               **extra) -> tuple[dict, float]:
    """Run one filter of a trial on measurements ``y``; return (output traces, wall seconds).
    ``diag``: the per-step diagnostics it computes (None: those the experiment computes in every
    trial, pfbench.diagnostics.plan); the diagnostic outputs it returns beyond them are dropped.
    ``extra``: keyword arguments the filter's run takes beyond the common ones (snapshots).

    The run gets its own copy of the model, the measurements, its parameters and ``extra``
    (fresh): what it writes into them no other run sees. An error it raises (SystemExit
    included) is a UserError that names it."""
    diag = plan_diagnostics(exp).every if diag is None else diag_flags(diag)
    state = state_from_seed(filter_seed(exp.seed, trial, run.key))
    model, y, params, extra = fresh(model), fresh(y), fresh(run.params), fresh(extra)
    t0 = time.perf_counter()
    try:
        out = FILTERS[run.type].run(model, y, params, run.particles, state, diag, **extra)
    except (Exception, SystemExit) as exc:
        raise FilterError(f"{_who(run, trial)} raised {_exception_text(exc)}", exc) from None
    wall = time.perf_counter() - t0
    if isinstance(out, Mapping):        # anything else is checked_output's to name
        # a diagnostic's output that the filter type reports on its own (the Kalman family's
        # 'pvar', FilterType.reports) is its, asked or not
        own = FILTERS[run.type].reports
        unasked = {o for n, (f, o) in DIAGNOSTIC_NAMES.items() if not f & diag and n not in own}
        if any(o in out for o in unasked):
            out = {k: v for k, v in out.items() if k not in unasked}
    return out, wall


def checked_output(exp: Experiment, trial: int, run, model, truth, data, out,
                   snapshots=None) -> dict:
    """``out``, filter run ``run``'s outputs on trial ``trial``, checked against its kind's
    (pfbench.kinds.check_outputs; with ``snapshots``, the steps it was asked for, its snapshots
    too); a UserError names the run, what was expected and what came."""
    try:
        out = check_outputs(kind_of(exp.scenario), out, model, truth, data)
        if snapshots is not None:
            out["snapshots"] = _checked_snapshots(out.get("snapshots"), snapshots)
    except ValueError as exc:
        raise FilterError(f"{_who(run, trial)}: {exc}") from None
    return out


def _checked_snapshots(snap, steps) -> tuple:
    """(steps (S,), particles (S, N, 3), counts (S,)) as arrays, of the S steps asked for."""
    S = len(steps)
    want = f"snapshots (steps ({S},), particles ({S}, N, 3), counts ({S},))"
    try:
        got, parts, counts = (np.asarray(a) for a in snap)
    except (TypeError, ValueError):
        raise ValueError(f"'snapshots' is {type(snap).__name__}, expected {want}") from None
    if (got.shape != (S,) or parts.ndim != 3 or parts.shape[0] != S or parts.shape[2] != 3
            or counts.shape != (S,) or any(a.dtype.kind not in "biuf"
                                           for a in (got, parts, counts))):
        raise ValueError(f"'snapshots' has shapes {got.shape}, {parts.shape}, {counts.shape}, "
                         f"expected {want}")
    if list(got) != list(steps):
        raise ValueError(f"snapshots at steps {list(got)}, asked for {list(steps)}")
    if ((counts < 0) | (counts > parts.shape[1])).any():
        raise ValueError(f"snapshot counts {list(counts)} outside 0..{parts.shape[1]}")
    return got, parts, counts


class Trial(NamedTuple):
    """A finished trial: its rows (one per filter run) and, when its kind keeps one for the
    figures, its trace (pfbench.traces)."""
    rows: list[dict]
    trace: dict | None = None

    @property
    def index(self) -> int:
        return self.rows[0]["trial"]


def run_trial(exp: Experiment, trial: int) -> list[dict]:
    """One trial: simulate once, run every filter on the same data, one row of metrics each."""
    return trial_result(exp, trial).rows


def trial_result(exp: Experiment, trial: int, traces: bool = False) -> Trial:
    """One trial's rows (run_trial) and, with ``traces``, the trace its kind keeps of it for the
    figures."""
    _mark(trial, -1)
    model, truth, data = trial_data(exp, trial)
    tracer = kind_of(exp.scenario).tracer if traces else None
    keep = tracer is not None and tracer.keeps(exp, trial)
    extras = tracer.extras(exp, model, data, trial) if keep else {}
    diag = plan_diagnostics(exp).for_trial(keep)
    rows, outs = [], {}
    for i, run in enumerate(exp.filters):
        _mark(trial, i)
        extra = extras.get(run.key, {})
        out, wall = run_filter(exp, trial, run, model, data, diag, **extra)
        out = checked_output(exp, trial, run, model, truth, data, out, extra.get("snapshots"))
        row = {"trial": trial, "filter": run.key, "label": run.label, "particles": run.particles}
        row.update(metrics_of(exp, model, truth, out))
        row["wall_s"] = wall
        rows.append(row)
        if keep:
            outs[run.key] = out
    trace = tracer.keep(exp, trial, model, truth, data, outs) if keep else None
    _mark(-1, -1)
    return Trial(rows, trace)


def _run_chunk(exp: Experiment, trials: list[int], traces: bool = False) -> list[Trial]:
    return [trial_result(exp, k, traces) for k in trials]


def _unpicklable_text(exp: Experiment, exc: BaseException) -> str | None:
    """None when ``exc`` (with its chained exceptions, which tblib pickles too) can be sent back
    from a worker; else its one line, naming what ran."""
    import pickle
    try:
        pickle.loads(pickle.dumps(exc))
        for chained in (exc.__cause__, exc.__context__):
            if chained is not None:
                pickle.loads(pickle.dumps(chained))
    except Exception:
        if isinstance(exc, UserError):
            return str(exc)
        what = _running_text(exp, [_now()]) or f"a trial of {exp.name}"
        return f"{what} raised {_exception_text(exc)}"
    return None


def _guarded_chunk(exp: Experiment, trials: list[int], traces: bool = False
                   ) -> tuple[list[Trial], float]:
    """_timed_chunk in a worker (a local one or Dask's), whose errors must come back to this
    process as one line naming what ran: a KeyboardInterrupt or SystemExit is a filter's own
    (Ctrl-C goes to the parent), and would end the worker and leave its trials to wait for ever;
    an exception that cannot be pickled goes as its text."""
    text = None
    try:
        return _timed_chunk(exp, trials, traces)
    except (KeyboardInterrupt, SystemExit) as exc:
        what = _running_text(exp, [_now()]) or f"a trial of {exp.name}"
        raise UserError(f"{what} raised {_exception_text(exc)}") from None
    except Exception as exc:
        text = _unpicklable_text(exp, exc)
        if text is None:
            raise
    raise UserError(text)           # raised outside the handler: no context to pickle (tblib,
                                    # which Dask installs, pickles an exception's context too)


def _run_chunk_in_worker(exp: Experiment, trials: list[int], traces: bool = False
                         ) -> tuple[list[Trial], frozenset | None, float]:
    """_guarded_chunk in a local worker process, with the kernels the worker has built when they
    are more than it last said (else None; see _preload) and the seconds the trials took (what
    sizes the next units: Units)."""
    global _SAID
    done, seconds = _guarded_chunk(exp, trials, traces)
    built = frozenset(key for key, k in _kernels() if k.built)
    news = built if built != _SAID else None
    _SAID = built
    return done, news, seconds


def _timed_chunk(exp: Experiment, trials: list[int], traces: bool = False
                 ) -> tuple[list[Trial], float]:
    """_run_chunk and the seconds it took (what sizes the next units: Units)."""
    t0 = time.perf_counter()
    done = _run_chunk(exp, trials, traces)
    return done, time.perf_counter() - t0


# ---------------------------------------------------------------- kernels the children built

# The kernels (module, name) a pool worker of this process built (compiled or loaded from the
# disk cache): this process builds them before it forks the next pool, whose workers then start
# with them. A run's workers never hand their kernels back to the process that forked them, so
# without this every run of a sweep, of `tables` or of the API in one process would load its
# kernels again.
_CHILD_KERNELS: set[tuple[str, str]] = set()
_SAID: frozenset = frozenset()
_KERNELS: list | None = None


def _kernels() -> list:
    """[((module, name), kernel)] of the numba kernels (pfbench._lazy) of pfbench's modules
    imported in this process (found once)."""
    global _KERNELS
    if _KERNELS is None:
        _KERNELS = [((name, attr), v) for name, mod in list(sys.modules.items())
                    if mod is not None and (name == "pfbench" or name.startswith("pfbench."))
                    for attr, v in list(vars(mod).items()) if isinstance(v, LazyKernel)]
    return _KERNELS


def _preload() -> None:
    """Build here the kernels the workers of earlier runs built (_CHILD_KERNELS): loaded from
    the disk cache they were saved to."""
    for module, name in sorted(_CHILD_KERNELS):
        kernel = getattr(sys.modules.get(module), name, None)
        if kernel is not None and not kernel.built:
            try:
                kernel.dispatcher
            except Exception:       # a worker's failure stays the worker's
                pass


# ---------------------------------------------------------------- what runs now

# This process's [trial, index of the filter run (-1: simulating its data)] while it runs a trial
# (trial -1: none): a list, or in a pool worker its two slots of an array the parent shares, so
# that an interrupted run can say which filter runs of which trials were running.
_NOW: tuple = ([-1, -1], 0)


def _mark(trial: int, index: int) -> None:
    now, at = _NOW
    now[at], now[at + 1] = trial, index


def _now() -> tuple[int, int]:
    """What this process runs now: (trial, filter run index), see _NOW."""
    now, at = _NOW
    return now[at], now[at + 1]


def _running_text(exp: Experiment, marks) -> str:
    """'filter run KEY (type ...), trial K' (or 'the simulation of trial K') for each [trial, index]
    of ``marks`` that runs something, '; '-joined."""
    out = []
    for trial, index in marks:
        if trial < 0:
            continue
        if 0 <= index < len(exp.filters):
            out.append(_who(exp.filters[index], int(trial)))
        else:
            out.append(f"the simulation of trial {int(trial)} (scenario '{exp.scenario}'"
                       f"{_package(SCENARIO_GROUP, exp.scenario)})")
    return "; ".join(out)


# ---------------------------------------------------------------- executors

def _worker_init(now, slot: int):
    """A worker process's setup (workers.quiet_worker), then where it says what it runs: ``now``
    holds two entries per slot (_NOW), which the parent reads to say what was running; ``slot``:
    this worker's."""
    global _NOW
    quiet_worker()
    _NOW = (now, 2 * slot)
    _mark(-1, -1)


def _signal_name(code: int | None) -> str:
    if code is not None and code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


# How trials are handed out: in units of about UNIT_SECONDS of work each, so that the progress
# bar moves within a fraction of a second of the first trials (after the kernels load), a run of
# seconds-long trials (FastSLAM, MCL) hands them out one at a time, and trials of milliseconds
# still go by the hundred, so that sending them to a worker and back costs little beside them.
# Before a trial has finished the size comes from the work of a trial (trial_seconds), taken as
# GUESS_DOUBT times what it says: particles x steps miss what a step does besides (FastSLAM's
# landmarks, a swarm's iterations: afsa_fastslam's trials take 55 times the guess), so the first
# units are small and only trials of well under a millisecond go several at a time. After, the
# size comes from the seconds the latest units took (their median: a first unit that loaded the
# kernels does not count for long). No unit holds more than a fourth of a worker's share of the
# trials not yet handed out, so that the workers finish together. The results do not depend on
# it: every trial is seeded on its own.
UNIT_SECONDS = 0.25
MAX_UNIT = 500
STEP_SECONDS = 2e-7         # a particle-step of a filter run
RUN_SECONDS = 5e-4          # a filter run's cost besides its particle-steps (copies, metrics)
GUESS_DOUBT = 50


def trial_seconds(exp: Experiment) -> float:
    """The seconds a trial of ``exp`` takes, guessed from its work before one has run: its filter
    runs' particles x the scenario's steps (the steps as pfbench.resources counts them)."""
    steps = int(dict(exp.scenario_params).get("steps", 1000))
    return sum((run.particles or 1) * steps * STEP_SECONDS + RUN_SECONDS
               for run in exp.filters)


class Units:
    """The units (lists of trial indices) in which ``trials`` go to ``workers`` workers, drawn
    lazily (a to-do list of a billion trials is never built), each sized as the notes above
    UNIT_SECONDS say; ``measured`` tells it what a unit took. ``count``: how many trials there
    are (-1: unknown)."""

    def __init__(self, exp: Experiment, trials: Iterable[int], count: int, workers: int):
        self._it = iter(trials)
        self.left, self.workers = count, max(1, workers)
        self.guess = trial_seconds(exp)
        self.seen: list[float] = []             # seconds a trial, of the latest units

    def _per_trial(self) -> float:
        """Seconds a trial takes: the median of the latest units', else the doubted guess."""
        return sorted(self.seen)[len(self.seen) // 2] if self.seen else self.guess * GUESS_DOUBT

    def size(self) -> int:
        """Trials in the next unit."""
        per = self._per_trial()
        n = int(UNIT_SECONDS / per) if per > 0 else MAX_UNIT
        if self.left >= 0:
            n = min(n, math.ceil(self.left / (4 * self.workers)))
        return max(1, min(MAX_UNIT, n))

    def next(self) -> list[int]:
        """The next unit ([] when every trial is handed out)."""
        unit = list(itertools.islice(self._it, self.size()))
        if self.left >= 0:
            self.left = max(0, self.left - len(unit))
        return unit

    def ahead(self) -> int:
        """How many units a worker holds at once: two while a unit takes well under a second (the
        next is there when one ends, whatever this process is doing), else one (a worker never
        waits behind another's unit at the end of a run while one of the others is idle)."""
        return 2 if self.size() * self._per_trial() < 1.0 else 1

    def measured(self, trials: int, seconds: float) -> None:
        """A unit of ``trials`` trials took ``seconds`` on its worker."""
        if trials > 0 and seconds >= 0:
            self.seen = (self.seen + [seconds / trials])[-5:]


def _count(trials) -> int:
    return len(trials) if hasattr(trials, "__len__") else -1


def import_ahead(stats: bool = False) -> None:
    """Import, in a thread of this process, the modules the table of a run needs (scipy's special
    functions for its intervals, pfbench._special; the comparison and the tables; with
    ``stats``, scipy.stats for the ranking of its filters, pfbench.rank) and what writes the
    results folder (pyarrow's parquet), and hash the package's sources for the table cache's
    key, while this process waits for the trials of its worker processes: a short run's table
    then starts at once. Call it only after those workers are forked, and ``settle`` before
    forking others (a fork while a thread imports could copy a held import lock into the child:
    tablecache.settle)."""
    import threading

    from .tablecache import code_digest, hold, settle
    wanted = (UFUNCS, "pfbench.compare", "pfbench.tables") + (
        ("scipy.stats",) if stats else ())
    if all(m in sys.modules for m in wanted):
        return

    def ahead():
        try:
            functions()

            from . import compare, tables  # noqa: F401
            if stats:
                import scipy.stats  # noqa: F401
            code_digest()       # the table cache's key reads every source file (7 ms)
            # what writing the results folder imports: trials.parquet (pyarrow's parquet, 12
            # ms), table.csv, the replay record
            import pandas.io.formats.csvs  # noqa: F401
            import pyarrow.pandas_compat  # noqa: F401
            import pyarrow.parquet  # noqa: F401

            from . import dataset, replay  # noqa: F401
        except Exception:       # imported again where needed, and failing there if it must
            pass
    settle()
    thread = threading.Thread(target=ahead, name="pfbench-import-ahead", daemon=True)
    thread.start()
    hold(thread)


def execute(exp: Experiment, trials: Iterable[int], workers: int, count: int | None = None,
            traces: bool = False, running: list | None = None) -> Iterable[list[Trial]]:
    """Yield chunks of ``trials`` as they finish, each a list of Trial (with its trace where
    ``traces`` and the kind keeps one): the units they were handed out in (Units), so that a
    chunk arrives every fraction of a second once the kernels are loaded, or with each trial
    where one takes longer.

    The trials run in a pool of ``workers`` child processes, one worker included, so that this
    process sees Ctrl-C at once even while a kernel holds a child's interpreter (in this process
    only where it may start none: a pool worker itself). ``count``: how many trials there are
    (when ``trials`` is an iterator). Never more workers than trials. Workers ignore SIGINT; on
    Ctrl-C the parent terminates them, keeping what already arrived. ``running``: a list this
    function fills with a callable that returns, at any moment, what the workers run (for the
    message of an interrupted run: _running_text).
    """
    count = _count(trials) if count is None else count
    if count == 0:
        return
    workers = max(1, min(workers, count) if count >= 0 else workers)
    if _in_process():
        if running is not None:
            running.append(lambda: [_now()])
        for k in trials:
            yield _run_chunk(exp, [k], traces)
        return
    units = Units(exp, trials, count, workers)
    compile_ahead(exp, trial_result)
    _preload()
    pool, now, send = _pool(exp, workers, traces)
    if running is not None:
        running.append(lambda: [tuple(now[i:i + 2]) for i in range(0, len(now), 2)])
    with pool:
        sizes: list[list[int]] = [[] for _ in range(workers)]   # units each worker holds

        def hand_out(slot: int) -> None:
            while len(sizes[slot]) < units.ahead():
                unit = units.next()
                if not unit:
                    return
                send(slot, unit)
                sizes[slot].append(len(unit))

        try:
            for slot in range(workers):
                hand_out(slot)
            # the table's modules, while the workers run the trials (their first units are
            # theirs already: the thread's start would hold them back)
            from .rank import ranks_filters
            import_ahead(stats=ranks_filters(exp))
            while any(sizes):
                for slot, ok, got in pool.results(timeout=0.25):
                    n = sizes[slot].pop(0)
                    if not ok:
                        raise got
                    chunk, built, seconds = got
                    units.measured(n, seconds)
                    if built:
                        _CHILD_KERNELS.update(built)
                    hand_out(slot)  # before this process writes what arrived
                    yield chunk
        except WorkerDied as dead:
            raise _died(exp, dead, now) from None
        pool.close()


def _pool(exp: Experiment, workers: int, traces: bool):
    """(the pool of ``workers`` worker processes that runs the trials of ``exp``, the array of
    what each runs (_NOW), ``send(slot, unit)``): the worker the command line started early
    (prestart) when it fits, else a pool forked now, which inherits ``exp``."""
    early = _claim(exp, workers)
    if early is not None:
        pool, now = early
        first = set(range(workers))
        token = id(exp)

        def send(slot: int, unit: list[int]) -> None:
            pool.send(slot, (token, exp if slot in first else None, traces, unit))
            first.discard(slot)
        return pool, now, send
    import multiprocessing as mp

    from .tablecache import settle
    settle()                        # no fork while a thread of this process imports
    now = mp.RawArray("q", [-1] * (2 * workers))
    pool = Workers(workers, partial(_run_chunk_in_worker, exp, traces=traces),
                   setup=_worker_init, setup_args=(now,))
    return pool, now, pool.send


# ---------------------------------------------------------------- a worker started early

# The worker `prestart` started, with its array of what it runs, until a run claims it.
_EARLY: list = []
# In that worker: the experiment its units run, and whether they keep traces, by token.
_SENT: dict = {}


def prestart() -> None:
    """Start now the worker process a run's trials will need (one, as a run has by default),
    and have it start what loading kernels from the cache needs (_cache.start_loading: a
    tenth of a second on a small machine) while this process reads its command line and its
    config: the run then hands it the experiment (pickled, with its first unit of trials)
    instead of forking a worker once the config is read. For the command line, first thing; a
    run of another worker count, or none, leaves it to ``discard_prestarted``. Never an error:
    a worker that cannot start is one the run forks later, as without this."""
    if _EARLY or _in_process():
        return
    import multiprocessing as mp
    now = mp.RawArray("q", [-1, -1])
    try:
        # right after the imports the collector finds next to nothing (about 20 objects) in a
        # full collection that would take 17 ms before the fork: none
        pool = Workers(1, _run_sent_chunk, setup=_early_worker_init, setup_args=(now,),
                       collect=False)
    except Exception:
        return
    _EARLY.append((pool, now))


def discard_prestarted() -> None:
    """Stop the worker ``prestart`` started, when no run claimed it."""
    while _EARLY:
        _EARLY.pop()[0].stop()


def _claim(exp: Experiment, workers: int):
    """(pool, now) of the worker ``prestart`` started, for a run of ``workers`` workers, when it
    is alive, one is what the run needs, and ``exp`` can be sent to it; None otherwise (and the
    early worker, if any, is stopped)."""
    if not _EARLY:
        return None
    pool, now = _EARLY.pop()
    if workers == 1 and all(p.exitcode is None for p in pool.procs):
        import pickle
        try:
            pickle.dumps(exp)
            return pool, now
        except Exception:           # an experiment only a fork can hand over
            pass
    pool.stop()
    return None


def _early_worker_init(now, slot: int) -> None:
    """The early worker's setup: a worker's (_worker_init), then what loading the first kernel
    from the cache needs (_cache.start_loading)."""
    _worker_init(now, slot)
    try:
        start_loading()
    except Exception:               # the first kernel meets it, and the run reports it
        pass


def _run_sent_chunk(item) -> tuple:
    """The early worker's handle: ``(token, experiment or None, traces, trials)``, the
    experiment sent with a run's first unit and kept for the next ones (_run_chunk_in_worker)."""
    token, exp, traces, trials = item
    if exp is not None:
        _SENT.clear()
        _SENT[token] = (exp, traces)
    exp, traces = _SENT[token]
    return _run_chunk_in_worker(exp, trials, traces)


def _died(exp: Experiment, dead, now) -> UserError:
    """The error of a worker process that died (a crash in a kernel, a filter that ended its
    process), naming what it was running (``dead``: workers.WorkerDied)."""
    slot = dead.slot
    what = _running_text(exp, [tuple(now[2 * slot:2 * slot + 2])])
    return UserError(f"a worker process ended ({_signal_name(dead.exitcode)}) while running "
                     f"{what or 'a trial'}; the trials finished before it are kept (--resume "
                     "continues)")


class LocalExecutor:
    """Trials in a local process pool (of one worker by default; see execute)."""

    def __init__(self, workers: int = 1):
        self.workers = workers
        self._running: list = []
        self._exp = None

    def describe(self) -> str:
        return f"{self.workers} worker(s)"

    def run(self, exp: Experiment, trials: Iterable[int], count: int | None = None,
            traces: bool = False) -> Iterable[list[Trial]]:
        """Yield the finished trials in chunks, as they arrive (see execute)."""
        self._running, self._exp = [], exp
        yield from execute(exp, trials, self.workers, count, traces, self._running)

    def running(self) -> str:
        """What the trials of the latest ``run`` run now ('' when nothing, or unknown): which
        filter runs of which trials."""
        if not getattr(self, "_running", None) or getattr(self, "_exp", None) is None:
            return ""
        try:
            return _running_text(self._exp, self._running[-1]())
        except Exception:       # a pool torn down meanwhile
            return ""

    def underway(self) -> float:
        """How much of the trials its workers run now is done, in trials: each trial under way
        counts the fraction of its filter runs that have finished (0.0 when nothing runs, or
        unknown). What a progress bar adds to the trials finished, so that it moves while trials
        of seconds run (they are handed out one at a time: Units)."""
        exp = getattr(self, "_exp", None)
        if not getattr(self, "_running", None) or exp is None or not exp.filters:
            return 0.0
        try:
            marks = self._running[-1]()
        except Exception:       # a pool torn down meanwhile
            return 0.0
        n = len(exp.filters)
        return sum(min(max(0, int(i)), n - 1) / n for t, i in marks if t >= 0)

    def close(self) -> None:
        pass

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


DASK_HINT = ("--executor dask needs Dask distributed: pip install 'pfbench[dask]' (or pip install "
             "'dask[distributed]')")


class DaskExecutor(LocalExecutor):
    """Trials on a Dask distributed cluster: the scheduler at ``scheduler`` (tcp://HOST:PORT), or,
    without one, a local cluster of ``workers`` single-threaded worker processes.

    The same trial function runs on the workers, seeded as everywhere else, so the rows are the
    in-process executor's bit for bit. A worker that dies takes its unfinished chunks with it; the
    scheduler runs them again elsewhere, and the runner keeps one row set per trial, so nothing is
    counted twice. Workers must run the same pfbench, numpy and numba versions as this process
    (checked when connecting): otherwise their rows could differ.
    """

    def __init__(self, workers: int = 1, scheduler: str | None = None, timeout: float = 10.0):
        try:
            import distributed
        except ImportError:
            raise UserError(DASK_HINT) from None
        self.workers, self.scheduler, self.cluster = workers, scheduler, None
        if scheduler:
            check_scheduler(scheduler)
        try:
            if scheduler:
                self.client = distributed.Client(scheduler, timeout=timeout)
            else:
                # no dashboard; the scheduler's own HTTP routes (health, metrics) on a free
                # port rather than 8787, which another cluster may hold (a warning on stderr)
                self.cluster = distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True,
                    dashboard_address=None, silence_logs=40,
                    scheduler_kwargs={"dashboard_address": ":0"})
                self.client = distributed.Client(self.cluster)
        except (OSError, TimeoutError, ValueError) as exc:  # refused, unreachable, no answer
            raise UserError(f"--scheduler {scheduler}: cannot connect ({exc}); start one with "
                            "'dask scheduler' and workers with 'dask worker SCHEDULER'") from None
        self._check_versions()

    def _check_versions(self) -> None:
        ours = versions()
        ours.pop("python")
        theirs = self.client.run(_worker_versions)
        if not theirs:
            self.close()
            raise UserError(f"--scheduler {self.scheduler}: the cluster has no workers; start "
                            "them with 'dask worker SCHEDULER'")
        for addr, v in theirs.items():
            if v != ours:
                bad = ", ".join(f"{k} {v.get(k)} (here {ours[k]})" for k in ours
                                if v.get(k) != ours[k])
                self.close()
                raise UserError(f"worker {addr} runs {bad}: install the same versions on every "
                                "worker, or its trials could differ")

    def describe(self) -> str:
        n = len(self.client.scheduler_info().get("workers", {}))
        where = self.scheduler or "a local Dask cluster"
        return f"{n} Dask worker(s) at {where}"

    def run(self, exp: Experiment, trials: Iterable[int], count: int | None = None,
            traces: bool = False) -> Iterable[list[Trial]]:
        import distributed
        n = max(1, len(self.client.scheduler_info().get("workers", {})))
        units = Units(exp, trials, _count(trials) if count is None else count, n)
        futures, sizes = [], {}

        def hand_out():
            unit = units.next()
            if not unit:
                return None
            fut = self.client.submit(_guarded_chunk, exp, unit, traces, pure=False)
            futures.append(fut)
            sizes[fut.key] = len(unit)
            return fut

        try:        # units sized as the local pool's (Units), two a worker under way
            pending = distributed.as_completed([f for f in (hand_out() for _ in range(2 * n))
                                                if f is not None])
            for fut in pending:
                chunk, seconds = fut.result()
                units.measured(sizes[fut.key], seconds)
                more = hand_out()
                if more is not None:
                    pending.add(more)
                yield chunk
        finally:
            self.client.cancel(futures)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def check_scheduler(address: str) -> None:
    """A UserError unless ``address`` reads as SCHEME://HOST:PORT (a Dask scheduler)."""
    from urllib.parse import urlsplit
    hint = f"--scheduler {address}: expected tcp://HOST:PORT"
    try:
        parts = urlsplit(address)
        port = parts.port
    except ValueError as exc:
        raise UserError(f"{hint} ({exc})") from None
    if parts.scheme not in SCHEDULER_SCHEMES:
        raise UserError(f"{hint} (the scheme is one of {', '.join(SCHEDULER_SCHEMES)})")
    if not parts.hostname or port is None or not 0 < port < 65536:
        raise UserError(f"{hint} (a host and a port from 1 to 65535)")
    if parts.path not in ("", "/") or parts.query or parts.fragment:
        raise UserError(f"{hint} (nothing after the port)")


def _worker_versions() -> dict:
    v = versions()
    v.pop("python")
    return v


def make_executor(kind: str, workers: int = 1, scheduler: str | None = None) -> LocalExecutor:
    """The executor a command asked for: 'local' (in-process or a process pool) or 'dask'."""
    if kind == "dask":
        return DaskExecutor(workers, scheduler)
    if scheduler:
        raise UserError("--scheduler needs --executor dask")
    return LocalExecutor(workers)


def git_commit(cwd: Path | None = None) -> str | None:
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=cwd, capture_output=True,
                             text=True, timeout=5)
        # the code and configs, not the results folder the run is writing into
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--",
                                ":(top)pfbench", ":(top)configs", ":(top)pyproject.toml"],
                               cwd=cwd, capture_output=True, text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def versions() -> dict:
    import numba
    import pandas
    return {"pfbench": __version__, "python": platform.python_version(), "numpy": np.__version__,
            "numba": numba.__version__, "pandas": pandas.__version__}


class Interrupted(Exception):
    """Ctrl-C during a run; the finished trials are saved. ``running``: what was running then
    (which filter runs of which trials), '' when nothing or unknown."""

    def __init__(self, done: int, total: int, path: Path, running: str = ""):
        self.done, self.total, self.path, self.running = done, total, path, running
        what = f" (it was running: {running})" if running else ""
        if done:
            super().__init__(f"interrupted: {done} of {total} trials saved in {path}; "
                             f"run again with --resume to continue{what}")
        else:       # the run's folder keeps nothing of it (fsutil.FolderLock.release)
            super().__init__(f"interrupted before any of the {total} trials finished: nothing "
                             f"was saved{what}")


@dataclass
class RunResult:
    rows: list[dict]
    out_dir: Path
    wall_s: float
    ran: int           # trials run now (the rest came from --resume)
    meta: dict         # meta.json: what the seed and config determine, and the provenance
    up_to_date: bool = False    # the folder held every trial already: nothing ran or was written
    run: dict | None = None     # timings.json: this run's wall time, workers, start and end


def difference(old: dict, exp: Experiment) -> str:
    """What tells the experiment of a folder's stamp ``old`` (meta.json or run.json) from
    ``exp``, in a few words ('seed 2021 -> 5; scenario.steps 100 -> 60')."""
    ident = old.get("identity")
    if isinstance(ident, dict):
        try:
            return _identity_difference(ident, old, exp)
        except (TypeError, KeyError, IndexError, AttributeError):
            pass                    # a stamp edited by hand: say what the hashes say
    name = old.get("experiment")
    return (f"experiment {name!r}, hash {old.get('experiment_hash')}; this config's "
            f"{exp.name!r}, hash {exp.hash}")


def _identity_difference(ident: dict, old: dict, exp: Experiment) -> str:
    new = exp.identity
    out = []
    if ident.get("streams") != new["streams"]:
        out.append("random streams drawn by another pfbench (its trials cannot be this "
                   "one's)")
    for key in ("seed", "scenario"):
        if ident.get(key) != new[key]:
            out.append(f"{key} {ident.get(key)} -> {new[key]}")
    a, b = ident.get("scenario_params") or {}, new["scenario_params"]
    if ident.get("scenario") == new["scenario"]:
        out += [f"scenario.{k} {_short(a.get(k))} -> {_short(b.get(k))}"
                for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)]
    fa = {f[0]: f for f in ident.get("filters") or []}
    fb = {f[0]: f for f in new["filters"]}
    gone, added = sorted(set(fa) - set(fb)), sorted(set(fb) - set(fa))
    if gone:
        out.append(f"filter runs {', '.join(gone)} not in this config")
    if added:
        out.append(f"filter runs {', '.join(added)} new in this config")
    changed = [k for k in fa if k in fb and fa[k] != fb[k]]
    if changed:
        out.append(f"filter runs {', '.join(changed)} set otherwise")
    if not out:
        return f"hash {old.get('experiment_hash')}, this config's {exp.hash}"
    more = f" and {len(out) - 3} more" if len(out) > 3 else ""
    return "; ".join(out[:3]) + more


def _short(v) -> str:
    text = json.dumps(v) if not isinstance(v, str) else v
    return text if len(text) <= 40 else text[:37] + "..."


def _holds_sweep(out_dir: Path) -> bool:
    """Whether ``out_dir`` holds a sweep's results (its cells and summary)."""
    return (out_dir / "cells").is_dir() or (out_dir / "summary.csv").exists()


def _stamp(out_dir: Path) -> tuple[str, dict] | None:
    """('finished', meta.json) or ('unfinished', run.json) of an earlier run in out_dir, or
    None; a stamp that cannot be read is refused (the folder is not left to be overwritten)."""
    for name in ("run.json", "meta.json", "trials.partial.csv", "trials.csv"):
        require_regular(out_dir / name)     # a FIFO or a device would hang or never end
    if _holds_sweep(out_dir):
        raise UserError(f"{out_dir} holds a sweep's results: --force replaces them, or --out "
                        "names another folder")
    for what, name, trials in (("unfinished", "run.json", "trials.partial.csv"),
                               ("finished", "meta.json", "trials.csv")):
        path = out_dir / name
        if path.exists() and (out_dir / trials).exists():
            try:
                data = json.loads(path.read_text(encoding="utf-8"))
                if (not isinstance(data, dict) or not isinstance(data.get("experiment_hash"), str)
                        or type(data.get("trials", 0)) is not int or data.get("trials", 0) < 0):
                    raise ValueError
            except (OSError, ValueError):
                raise UserError(f"{path}: unreadable, so {out_dir} may hold another "
                                "experiment's trials; --force replaces them") from None
            if what == "finished":
                from .store import check_meta
                check_meta(data, path)
            return what, data
    if (out_dir / "trials.csv").exists() or (out_dir / "trials.partial.csv").exists():
        raise UserError(f"{out_dir} holds trials that no meta.json or run.json describes: "
                        "--force replaces them, or --out names another folder")
    return None


def _check_folder(exp: Experiment, out_dir: Path, resume: bool, force: bool,
                  traces: bool) -> tuple[bool, RunResult | None]:
    """Whether the run keeps the trials ``out_dir`` holds (True for the same experiment: its
    trials are deterministic, so they are the trials this run would make), and the result when
    they are every trial already ('up to date'). Refuses, without ``force``, a folder that holds
    another experiment, or more trials of this one than asked for (they would be lost)."""
    if force:
        if _holds_sweep(out_dir):
            # a sweep's results give way to this run's: its cells and summary go
            remove_tree(out_dir / "cells", out_dir)
            (out_dir / "summary.csv").unlink(missing_ok=True)
        return resume, None
    stamp = _stamp(out_dir)
    if stamp is None:
        return resume, None
    what, old = stamp
    if old["experiment_hash"] != exp.hash:
        if resume:
            return resume, None             # _resumed says why it cannot
        raise UserError(f"{out_dir} holds the {what} trials of another experiment "
                        f"({difference(old, exp)}): --force replaces them, or --out names "
                        "another folder")
    had = int(old.get("trials") or 0)
    if what == "finished" and had > exp.trials:
        raise UserError(f"{out_dir} holds {had} trials of this experiment; {exp.trials} would "
                        f"replace them with fewer: --trials {had} keeps them, --force replaces "
                        "them, or --out names another folder")
    if what == "finished" and had == exp.trials:
        done = _resumed(exp, out_dir, None)     # the trials that check (the run warns of the rest)
        has_traces = (not traces or kind_of(exp.scenario).tracer is None
                      or (out_dir / "traces.npz").exists())
        if len(done) == exp.trials and has_traces:
            rows = [r for k in sorted(done) for r in done[k]]
            with_timings(rows, read_timings(out_dir))
            return True, RunResult(rows, out_dir, 0.0, 0, old, up_to_date=True,
                                   run={"trials_run_now": 0, "wall_s": 0.0})
    return True, None


def up_to_date(exp: Experiment, out_dir: Path, traces: bool = True) -> RunResult | None:
    """The result of a run of ``exp`` into ``out_dir`` when the folder holds every trial of it
    (run_experiment's 'up to date': nothing would run), else None; refuses what run_experiment
    refuses (a folder of another experiment, or of more trials). ``traces``: as run_experiment's
    (a run that keeps them needs the folder's traces file too; a sweep's cells keep none). Call
    it holding the folder's lock."""
    return _check_folder(exp, Path(out_dir), False, False, traces)[1]


def run_experiment(exp: Experiment, out_dir: Path, *, workers: int = 1, resume: bool = False,
                   progress: Callable[[int, int], None] | None = None,
                   executor: LocalExecutor | None = None,
                   warn: Callable[[str], None] | None = None, traces: bool = True,
                   force: bool = False) -> RunResult:
    """Run every trial of ``exp`` into ``out_dir`` (docs/guide/results.md lists the files).

    Trials go to ``trials.partial.csv`` as they finish; at the end the sorted ``trials.csv``
    replaces it. ``resume`` keeps the finished trials of a partial (or a complete) earlier run of
    the same experiment (same hash) and runs the rest; rows that fail their checksum or disagree
    with another row of the same trial are not kept: their trials run again, and ``warn`` is told
    which. ``executor``: where the trials run (default: a LocalExecutor of ``workers``); a trial
    that arrives twice (a re-run chunk) is kept once. The folder is locked (:class:`FolderLock`)
    for the whole run: a second run into it is refused.

    A folder that holds this experiment's trials keeps them (they are the trials this run would
    make), and when it holds every one the result is ``up_to_date`` and nothing runs or is
    written. Without ``force`` a folder that holds another experiment, or more trials of this
    one, is refused with what differs (``force``: replace it).

    ``traces``: keep what the figures draw of the trials the scenario's kind names
    (``traces.npz``, pfbench.traces); a resumed trial that should have a trace and has none
    runs again.
    """
    executor = executor or LocalExecutor(workers)
    out_dir = Path(out_dir)
    with FolderLock(out_dir):
        resume, ready = _check_folder(exp, out_dir, resume, force, traces)
        if ready is not None:
            return ready
        _require_data(exp)
        return _run_locked(exp, out_dir, workers, resume, progress, executor, warn, traces)


def _require_data(exp: Experiment) -> None:
    """Refuse, in one line and before any trial, an experiment whose recorded data are absent
    (a folder that is up to date needs none: its table prints without them)."""
    why = missing_data(exp)
    if why is not None:
        raise UserError(why)


def missing_data(exp: Experiment) -> str | None:
    """Why the recorded data experiment ``exp``'s scenario reads are not on this machine (its
    module's ``unavailable(params)``, one line), or None: a simulated scenario, or the data
    present."""
    hook = getattr(SCENARIOS[exp.scenario], "unavailable", None)
    return hook(dict(exp.scenario_params)) if hook is not None else None


def _resumed(exp: Experiment, out_dir: Path, warn) -> dict[int, list[dict]]:
    """The finished trials an earlier run of ``exp`` left in ``out_dir`` (see run_experiment)."""
    partial, final = out_dir / "trials.partial.csv", out_dir / "trials.csv"
    source = partial if partial.exists() else final if final.exists() else None
    if source is None:
        return {}
    stamp = out_dir / "run.json" if source == partial else out_dir / "meta.json"
    try:
        old = json.loads(stamp.read_text(encoding="utf-8"))
        old_hash = old["experiment_hash"]
    except (OSError, ValueError, KeyError, TypeError):
        raise UserError(f"{out_dir}: cannot resume: {stamp.name} is missing or unreadable") \
            from None
    if old_hash != exp.hash:
        raise UserError(f"{out_dir}: cannot resume: those trials come from a different "
                        f"experiment (hash {old_hash}, this config {exp.hash}); run without "
                        "--resume or choose another --out")
    try:                            # a file that is no trials file: refused
        got = read_trials(source, trial_columns(exp))
    except UserError as exc:        # (an older pfbench's, of other columns: say what to do)
        raise UserError(f"{exc}; --force runs its trials again, or --out names another "
                        "folder") from None
    digest = old.get("trials_sha256") if source == final else None
    if (isinstance(digest, str) and not got.rejected
            and trials_digest(source.read_bytes()) != digest):
        # every row sound, but not the trials file its meta.json describes (another run's):
        # none of its rows can be vouched for. (Rows edited or damaged are named one by one
        # below, and only their trials run again.)
        if warn:
            warn(f"{source}: not the trials file {stamp.name} describes (its checksum differs); "
                 "every trial runs again")
        return {}
    bad = {k: why for k, why in got.rejected.items() if 0 <= k < exp.trials}
    if bad and warn:
        shown = "; ".join(f"trial {k}: {why}" for k, why in sorted(bad.items())[:5])
        more = f" and {len(bad) - 5} more" if len(bad) > 5 else ""
        warn(f"{source}: {len(bad)} trial(s) not kept, they run again: {shown}{more}")
    return {k: v for k, v in complete_trials(got.rows, exp).items() if k < exp.trials}


def _resumed_traces(exp: Experiment, out_dir: Path, done: dict[int, list[dict]]) -> dict:
    """The traces of the resumed trials ``done`` (from the unfinished run's staged traces, or a
    finished run's traces.npz); a trial that should have one and has none leaves ``done``."""
    tracer = kind_of(exp.scenario).tracer
    if (out_dir / "trials.partial.csv").exists():
        found = read_staged_traces(out_dir)
    else:
        old = read_traces(out_dir)
        found = old.trials if old is not None else {}
    for k in [k for k in done if tracer.keeps(exp, k) and k not in found]:
        del done[k]
    return {k: found[k] for k in done if tracer.keeps(exp, k)}


# What a folder's meta.json says of the machine and code that made its trials; a run that makes the
# same trials file again keeps what the earlier run wrote (the trials are still those it made).
PROVENANCE = ("host", "platform", "cpus", "git_commit", "versions")


def _machine() -> dict:
    """Where trials run now: this machine's name, platform and cores, and the git commit of the
    code (pfbench's checkout, '-dirty' with changes)."""
    return {"host": socket.gethostname(), "platform": platform.platform(),
            "cpus": os.cpu_count(), "git_commit": git_commit()}


def provenance() -> dict:
    """The provenance of trials that run now (PROVENANCE): _machine() and the versions."""
    return {**_machine(), "versions": versions()}


def provenance_ahead() -> Callable[[], dict]:
    """Start ``_machine()`` in a thread of this process, to run beside the trials (git's two
    commands take 5 to 10 ms that would otherwise follow the last trial); returns the function
    that gives ``provenance()``, waiting for the thread (computing it then if the thread failed).
    The thread imports nothing and is noted (tablecache.hold): a fork of this process waits for
    it."""
    import threading

    from .tablecache import hold
    got: dict = {}

    def work():
        try:
            got["machine"] = _machine()
        except Exception:       # computed again where needed, and failing there if it must
            pass
    thread = threading.Thread(target=work, name="pfbench-provenance", daemon=True)
    thread.start()
    hold(thread)

    def result() -> dict:
        thread.join()
        return {**(got["machine"] if "machine" in got else _machine()), "versions": versions()}
    return result


def stamp_meta(exp: Experiment, out_dir: Path, trials_text: str | None = None,
               where: dict | None = None) -> dict:
    """The meta.json of a folder that holds every trial of ``exp``: what the seed and the config
    determine, and the provenance of its trials (``where``, default provenance() now; kept from
    the folder's earlier meta.json when ``trials_text`` is the trials file it already held)."""
    where = provenance() if where is None else where
    meta = {
        "format": FORMAT_VERSION, "experiment": exp.name, "config": exp.source,
        "experiment_hash": exp.hash, "paper": exp.paper, "table": exp.table, "seed": exp.seed,
        "trials": exp.trials, **{k: where[k] for k in PROVENANCE}, "identity": exp.identity,
    }
    if trials_text is not None:
        meta.update(_earlier_provenance(out_dir, trials_text.encode("utf-8"), exp.hash))
        # ties meta.json to the trials file it describes (pfbench.store.check_trials)
        meta["trials_sha256"] = trials_digest(trials_text)
        meta["trials_rows"] = trials_text.count("\n") - 1
    return meta


def _earlier_provenance(folder: Path, trials: bytes, experiment_hash: str) -> dict:
    """The provenance (PROVENANCE) of ``folder``'s meta.json when the folder holds the trials file
    ``trials`` of the same experiment: the trials are still those that run made. {} otherwise."""
    try:
        if (folder / "trials.csv").read_bytes() != trials:
            return {}
        old = json.loads((folder / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    if not isinstance(old, dict) or old.get("experiment_hash") != experiment_hash:
        return {}
    return {k: old[k] for k in PROVENANCE if k in old}


def keep_provenance(new: Path, old: Path) -> None:
    """Where a staged results folder ``new`` (and each of its cells) holds the same trials file as
    ``old``, the folder it replaces, its meta.json keeps ``old``'s provenance (PROVENANCE): the
    trials are still those that run made, and the committed files stay as they were."""
    for path in Path(new).rglob("meta.json"):
        try:
            meta = json.loads(path.read_text(encoding="utf-8"))
            trials = (path.parent / "trials.csv").read_bytes()
        except (OSError, ValueError):
            continue
        if isinstance(meta, dict):
            kept = _earlier_provenance(Path(old) / path.parent.relative_to(new), trials,
                                       meta.get("experiment_hash"))
            if kept:
                write_json(path, {**meta, **kept})


def _resumed_timings(out_dir: Path, done: dict[int, list[dict]]) -> None:
    """Give the resumed trials' rows the wall times the folder's timings file holds."""
    partial = (out_dir / "trials.partial.csv").exists()
    timings = read_timings(out_dir, partial=partial)
    for rows in done.values():
        with_timings(rows, timings)


def _run_locked(exp, out_dir, workers, resume, progress, executor, warn, traces) -> RunResult:
    partial = out_dir / "trials.partial.csv"
    final = out_dir / "trials.csv"
    marker = out_dir / "run.json"
    done = _resumed(exp, out_dir, warn) if resume else {}
    if done:
        _resumed_timings(out_dir, done)
    traces = traces and kind_of(exp.scenario).tracer is not None
    kept = _resumed_traces(exp, out_dir, done) if traces and resume else {}
    clear_staged_traces(out_dir)
    for k, trace in kept.items():
        stage_trace(out_dir, k, trace)
    started = datetime.now(timezone.utc)
    write_json(marker, {"format": FORMAT_VERSION, "experiment": exp.name,
                        "experiment_hash": exp.hash, "seed": exp.seed, "trials": exp.trials,
                        "started": started.isoformat(), "identity": exp.identity}, indent=None)
    columns = trial_columns(exp)
    old_rows = [r for k in sorted(done) for r in done[k]]
    atomic_write(partial, csv_text(old_rows, True, columns))
    atomic_write(out_dir / TIMINGS_PARTIAL, timings_text(old_rows, True))
    resumed = set(done)
    todo = (k for k in range(exp.trials) if k not in resumed)    # lazy: no list of all trials
    n_todo = exp.trials - len(resumed)
    total = exp.trials
    if progress:
        progress(len(done), total)
    t0 = time.perf_counter()
    where = provenance_ahead()
    with open(partial, "a", encoding="utf-8", newline="") as fh, \
            open(out_dir / TIMINGS_PARTIAL, "a", encoding="utf-8", newline="") as th:
        chunks = executor.run(exp, todo, n_todo, traces)
        try:
            for chunk in chunks:
                chunk = [t for t in chunk if t.index not in done]
                for t in chunk:       # the trace first: a trial with rows but no trace reruns
                    if t.trace is not None:
                        kept[t.index] = t.trace
                        stage_trace(out_dir, t.index, t.trace)
                fh.write(csv_text((r for t in chunk for r in t.rows), False, columns))
                fh.flush()
                th.write(timings_text((r for t in chunk for r in t.rows), False))
                th.flush()
                for t in chunk:
                    done[t.index] = t.rows
                if progress:
                    progress(len(done), total)
        except KeyboardInterrupt:
            running = executor.running() if hasattr(executor, "running") else ""
            chunks.close()          # the workers stop now
            raise Interrupted(len(done), total, partial, running) from None
    wall = time.perf_counter() - t0
    rows = [r for k in sorted(done) for r in done[k]]
    text = csv_text(rows, True, columns)
    meta = stamp_meta(exp, out_dir, text, where())
    # the folder never pairs these trials with another run's meta.json: the old one goes first
    # (a kill before the new one leaves trials.csv that no meta.json describes, which readers
    # refuse), and the new one records the trials file's checksum
    (out_dir / "meta.json").unlink(missing_ok=True)
    atomic_write(final, text)
    atomic_write(out_dir / TIMINGS, timings_text(rows, True))
    if traces:
        finish_traces(out_dir, kind_of(exp.scenario).tracer.world(exp, build_model(exp)), kept)
    else:
        finish_traces(out_dir, {}, {})
    write_json(out_dir / "meta.json", meta)
    run_info = {
        "experiment": exp.name, "experiment_hash": exp.hash, "trials": exp.trials,
        "trials_run_now": n_todo, "workers": workers, "executor": executor.describe(),
        "wall_s": round(wall, 3), "kernel_load_s": round(LOAD_SECONDS, 3),
        "started": started.isoformat(), "finished": datetime.now(timezone.utc).isoformat(),
        "host": socket.gethostname(), "argv": sys.argv[1:],
    }
    write_json(out_dir / RUN_TIMINGS, run_info)
    partial.unlink(missing_ok=True)
    (out_dir / TIMINGS_PARTIAL).unlink(missing_ok=True)
    marker.unlink(missing_ok=True)
    return RunResult(rows, out_dir, wall, n_todo, meta, run=run_info)
