"""Trials -> rows; seeding; executors; the results folder.

Seeding (DESIGN.md section 3): trial k's randomness is the SeedSequence child ``(seed, spawn_key=(k,))``
(what ``SeedSequence(seed).spawn(n)[k]`` gives); inside it the data come from child ``(k, 0)`` and
filter run F from child ``(k, 1, crc32(F.key))``. Seeds depend on (base seed, trial, filter key), never
on run order, the number of workers, or which other filters the experiment has.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
import platform
import signal
import socket
import subprocess
import sys
import time
import zlib
from dataclasses import dataclass
from datetime import datetime, timezone
from functools import lru_cache, partial
from pathlib import Path
from typing import Callable, Iterable

import numpy as np

from . import __version__
from .config import FORMAT_VERSION, Experiment
from .errors import UserError
from .filters import FILTERS, LOAD_SECONDS
from .metrics import METRICS, localization_metrics, slam_metrics, trial_metrics
from .rng import state_from_seed
from .scenarios import SCENARIOS

TRIAL_COLUMNS = ("trial", "filter", "label", "particles", *METRICS, "wall_s")
# Columns that may differ between two runs of the same experiment (timings).
TIMING_COLUMNS = ("wall_s",)


def data_seed(seed: int, trial: int) -> np.random.SeedSequence:
    return np.random.SeedSequence(seed, spawn_key=(trial, 0))


def filter_seed(seed: int, trial: int, key: str) -> np.random.SeedSequence:
    return np.random.SeedSequence(seed, spawn_key=(trial, 1, zlib.crc32(key.encode())))


@lru_cache(maxsize=8)
def _model(scenario: str, params_json: str):
    return SCENARIOS[scenario].build(json.loads(params_json))


def build_model(exp: Experiment):
    """The scenario model of ``exp`` (built once per process)."""
    return _model(exp.scenario, json.dumps(dict(exp.scenario_params), sort_keys=True))


def trial_data(exp: Experiment, trial: int):
    """(model, truth, data): the truth and measurements of trial ``trial``, shared by every
    filter."""
    model = build_model(exp)
    truth, data = SCENARIOS[exp.scenario].simulate(model, state_from_seed(data_seed(exp.seed, trial)))
    return model, truth, data


def metrics_of(exp: Experiment, model, truth, out) -> dict:
    """A filter run's metrics for the experiment's kind of scenario."""
    kind = getattr(SCENARIOS[exp.scenario], "KIND", "scalar")
    if kind == "slam":
        return slam_metrics(truth.pose, model.landmarks, out)
    if kind == "localization":
        return localization_metrics(truth.pose, out, model.bound, model.kidnaps,
                                    model.score_from, model.report_step)
    return trial_metrics(truth, out)


def run_filter(exp: Experiment, trial: int, run, model, y, diag: bool = True,
               **extra) -> tuple[dict, float]:
    """Run one filter of a trial on measurements ``y``; return (output traces, wall seconds).
    ``extra``: keyword arguments the filter's run takes beyond the common ones (snapshots)."""
    state = state_from_seed(filter_seed(exp.seed, trial, run.key))
    t0 = time.perf_counter()
    out = FILTERS[run.type].run(model, y, run.params, run.particles, state, diag, **extra)
    return out, time.perf_counter() - t0


def run_trial(exp: Experiment, trial: int) -> list[dict]:
    """One trial: simulate once, run every filter on the same data, one row of metrics each."""
    model, truth, data = trial_data(exp, trial)
    rows = []
    for run in exp.filters:
        out, wall = run_filter(exp, trial, run, model, data)
        row = {"trial": trial, "filter": run.key, "label": run.label, "particles": run.particles}
        row.update(metrics_of(exp, model, truth, out))
        row["wall_s"] = wall
        rows.append(row)
    return rows


def _run_chunk(exp: Experiment, trials: list[int]) -> list[list[dict]]:
    return [run_trial(exp, k) for k in trials]


# ---------------------------------------------------------------- executors

def _ignore_sigint():  # workers leave Ctrl-C to the parent, which stops them
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def _chunks(trials: list[int], size: int) -> list[list[int]]:
    return [trials[i:i + size] for i in range(0, len(trials), size)]


def execute(exp: Experiment, trials: list[int], workers: int) -> Iterable[list[list[dict]]]:
    """Yield the rows of chunks of ``trials`` as they finish (in-process or a process pool).

    Workers ignore SIGINT; on Ctrl-C the parent terminates them, keeping what already arrived.
    """
    if workers <= 1 or len(trials) <= 1:
        for chunk in _chunks(trials, 1):
            yield _run_chunk(exp, chunk)
        return
    import multiprocessing as mp
    ctx = mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")
    size = max(1, min(25, math.ceil(len(trials) / (workers * 6))))
    pool = ctx.Pool(workers, initializer=_ignore_sigint)
    try:
        yield from pool.imap_unordered(partial(_run_chunk, exp), _chunks(trials, size))
        pool.close()
    finally:
        pool.terminate()
        pool.join()


class LocalExecutor:
    """Trials in this process (workers = 1) or a local process pool."""

    def __init__(self, workers: int = 1):
        self.workers = workers

    def describe(self) -> str:
        return f"{self.workers} worker(s)"

    def run(self, exp: Experiment, trials: list[int]) -> Iterable[list[list[dict]]]:
        yield from execute(exp, trials, self.workers)

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
        try:
            if scheduler:
                self.client = distributed.Client(scheduler, timeout=timeout)
            else:
                self.cluster = distributed.LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True,
                    dashboard_address=None, silence_logs=40)
                self.client = distributed.Client(self.cluster)
        except (OSError, TimeoutError) as exc:  # refused, unreachable, or no answer in time
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

    def run(self, exp: Experiment, trials: list[int]) -> Iterable[list[list[dict]]]:
        import distributed
        n = max(1, len(self.client.scheduler_info().get("workers", {})))
        size = max(1, min(25, math.ceil(len(trials) / (n * 6))))
        futures = [self.client.submit(_run_chunk, exp, chunk, pure=False)
                   for chunk in _chunks(trials, size)]
        try:
            for fut in distributed.as_completed(futures):
                yield fut.result()
        finally:
            self.client.cancel(futures)

    def close(self) -> None:
        self.client.close()
        if self.cluster is not None:
            self.cluster.close()


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


# ---------------------------------------------------------------- files

def atomic_write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` through a temporary file and a rename (never half-written)."""
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "w", encoding="utf-8", newline="") as fh:
        fh.write(text)
        fh.flush()
        os.fsync(fh.fileno())
    os.replace(tmp, path)


def _csv_text(rows: Iterable[dict], header: bool) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    if header:
        w.writerow(TRIAL_COLUMNS)
    for r in rows:
        w.writerow(["" if r[c] is None else r[c] for c in TRIAL_COLUMNS])
    return buf.getvalue()


def _parse_row(fields: list[str]) -> dict:
    row = dict(zip(TRIAL_COLUMNS, fields))
    row["trial"] = int(row["trial"])
    row["particles"] = int(row["particles"]) if row["particles"] else None
    for c in (*METRICS, "wall_s"):
        row[c] = float(row[c])
    return row


def read_trials(path: Path) -> list[dict]:
    """Rows of a trials file; a torn last line (an interrupted write) is dropped."""
    text = path.read_text(encoding="utf-8")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    lines = list(csv.reader(io.StringIO(text)))
    if not lines or tuple(lines[0]) != TRIAL_COLUMNS:
        raise UserError(f"{path}: not a pfbench trials file of this version (columns differ)")
    rows = []
    for fields in lines[1:]:
        if len(fields) != len(TRIAL_COLUMNS):
            continue
        try:
            rows.append(_parse_row(fields))
        except ValueError:
            continue
    return rows


def complete_trials(rows: list[dict], exp: Experiment) -> dict[int, list[dict]]:
    """Rows grouped by trial, keeping only trials with a row for every filter run of ``exp``."""
    order = {f.key: i for i, f in enumerate(exp.filters)}
    by_trial: dict[int, dict[str, dict]] = {}
    for r in rows:
        if r["filter"] in order and 0 <= r["trial"]:
            by_trial.setdefault(r["trial"], {})[r["filter"]] = r
    return {k: sorted(v.values(), key=lambda r: order[r["filter"]])
            for k, v in by_trial.items() if len(v) == len(order)}


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
    """Ctrl-C during a run; the finished trials are saved."""

    def __init__(self, done: int, total: int, path: Path):
        self.done, self.total, self.path = done, total, path
        super().__init__(f"interrupted: {done} of {total} trials saved in {path}; "
                         "run again with --resume to continue")


@dataclass
class RunResult:
    rows: list[dict]
    out_dir: Path
    wall_s: float
    ran: int           # trials run now (the rest came from --resume)
    meta: dict


def run_experiment(exp: Experiment, out_dir: Path, *, workers: int = 1, resume: bool = False,
                   progress: Callable[[int, int], None] | None = None,
                   executor: LocalExecutor | None = None) -> RunResult:
    """Run every trial of ``exp`` into ``out_dir`` (see DESIGN.md section 3 for the files).

    Trials go to ``trials.partial.csv`` as they finish; at the end the sorted ``trials.csv``
    replaces it. ``resume`` keeps the finished trials of a partial (or a complete) earlier run of
    the same experiment (same hash) and runs the rest. ``executor``: where the trials run (default:
    a LocalExecutor of ``workers``); a trial that arrives twice (a re-run chunk) is kept once.
    """
    executor = executor or LocalExecutor(workers)
    out_dir = Path(out_dir)
    partial = out_dir / "trials.partial.csv"
    final = out_dir / "trials.csv"
    marker = out_dir / "run.json"
    done: dict[int, list[dict]] = {}
    if resume:
        source = partial if partial.exists() else final if final.exists() else None
        if source is not None:
            stamp = marker if source == partial else out_dir / "meta.json"
            try:
                old_hash = json.loads(stamp.read_text())["experiment_hash"]
            except (OSError, ValueError, KeyError):
                raise UserError(f"{out_dir}: cannot resume: {stamp.name} is missing or unreadable")
            if old_hash != exp.hash:
                raise UserError(f"{out_dir}: cannot resume: those trials come from a different "
                                f"experiment (hash {old_hash}, this config {exp.hash}); run without "
                                "--resume or choose another --out")
            done = {k: v for k, v in complete_trials(read_trials(source), exp).items()
                    if k < exp.trials}
    out_dir.mkdir(parents=True, exist_ok=True)
    started = datetime.now(timezone.utc)
    atomic_write(marker, json.dumps({"format": FORMAT_VERSION, "experiment": exp.name,
                                     "experiment_hash": exp.hash, "seed": exp.seed,
                                     "trials": exp.trials, "started": started.isoformat()}) + "\n")
    atomic_write(partial, _csv_text((r for k in sorted(done) for r in done[k]), header=True))
    todo = [k for k in range(exp.trials) if k not in done]
    total = exp.trials
    if progress:
        progress(len(done), total)
    t0 = time.perf_counter()
    with open(partial, "a", encoding="utf-8", newline="") as fh:
        try:
            for chunk in executor.run(exp, todo):
                chunk = [rows for rows in chunk if rows[0]["trial"] not in done]
                fh.write(_csv_text((r for rows in chunk for r in rows), header=False))
                fh.flush()
                for rows in chunk:
                    done[rows[0]["trial"]] = rows
                if progress:
                    progress(len(done), total)
        except KeyboardInterrupt:
            raise Interrupted(len(done), total, partial) from None
    wall = time.perf_counter() - t0
    rows = [r for k in sorted(done) for r in done[k]]
    atomic_write(final, _csv_text(rows, header=True))
    meta = {
        "format": FORMAT_VERSION, "experiment": exp.name, "config": exp.source,
        "experiment_hash": exp.hash, "paper": exp.paper, "table": exp.table, "seed": exp.seed,
        "trials": exp.trials, "trials_run_now": len(todo), "workers": workers,
        "executor": executor.describe(),
        "wall_s": round(wall, 3), "kernel_load_s": round(LOAD_SECONDS, 3),
        "started": started.isoformat(), "finished": datetime.now(timezone.utc).isoformat(),
        "host": socket.gethostname(), "platform": platform.platform(), "cpus": os.cpu_count(),
        "git_commit": git_commit(), "versions": versions(), "argv": sys.argv[1:],
    }
    atomic_write(out_dir / "meta.json", json.dumps(meta, indent=2) + "\n")
    partial.unlink(missing_ok=True)
    marker.unlink(missing_ok=True)
    return RunResult(rows, out_dir, wall, len(todo), meta)
