"""``pfbench bench``: the parts, checked before anything is timed, run in order, their records
written as JSON and set beside an earlier run's."""
from __future__ import annotations

import json
import os
import platform
from pathlib import Path

import numba
import numpy as np

from ..errors import UserError
from ..fsutil import atomic_write, os_error_line
from .afsa_world import afsa_bench
from .common import BATCH_TRIALS, bench_data
from .fastslam_course import fastslam_bench
from .filter_costs import costs_bench
from .limits import limit_bench
from .mcl_field import mcl_bench
from .peers import peer_modules, peers_bench
from .records import compare_records, print_comparison, read_records
from .run_path import RUN_FAMILIES, families_of, run_path_bench
from .ungm_pf import ungm_bench

PARTS = ("ungm", "costs", "fastslam", "afsa", "mcl", "run") + RUN_FAMILIES + ("limit",)
# the limit runs when asked for (--limit or --only limit); 'run' is every run-path family
DEFAULT_PARTS = ("ungm", "costs", "fastslam", "afsa", "mcl", "run")
C_BUILD = "gcc -O3 -march=native -fopenmp -o ungm_ref bench/ungm_ref.c -lm"


def bench_command(quick=False, c_ref=None, threads=0, only=(), limit=False,
                  peers=False) -> str:
    """The command line of a bench run with these options, as its JSON's run record keeps it."""
    return " ".join(["pfbench bench"] + (["--quick"] if quick else [])
                    + ([f"--c-ref {Path(c_ref).name}"] if c_ref else [])
                    + ([f"--threads {threads}"] if threads else [])
                    + [f"--only {o}" for o in only]
                    + (["--limit"] if limit else [])
                    + (["--peers"] if peers else []))


def _c_reference(c_ref) -> Path:
    """``--c-ref`` as an absolute path to a program this user can run (a bare name would be
    looked up on PATH, not in the current folder); a UserError otherwise."""
    path = Path(c_ref)
    if not path.exists():
        raise UserError(f"--c-ref {c_ref}: no such file (build it: {C_BUILD})")
    if not path.is_file():
        raise UserError(f"--c-ref {c_ref}: not a file (build it: {C_BUILD})")
    if not os.access(path, os.X_OK):
        raise UserError(f"--c-ref {c_ref}: not an executable program (build it: {C_BUILD})")
    return path.resolve()


def _parts(only, limit: bool, c_ref) -> set[str]:
    """The parts to run; a UserError for a part that is not one, or --c-ref without ungm."""
    unknown = sorted(set(only) - set(PARTS))
    if unknown:
        raise UserError(f"--only {unknown[0]}: no such part of the bench; parts: "
                        f"{', '.join(PARTS)}")
    parts = set(only) or set(DEFAULT_PARTS)
    if limit:
        parts.add("limit")
    if c_ref is not None and "ungm" not in parts:
        raise UserError("--c-ref times the UNGM rows: add --only ungm")
    return parts


def run_bench(json_path=None, quick=False, c_ref=None, threads=0, console=None, only=(),
              compare=None, limit=False, peers=False, command=None):
    """Time every implementation (or the parts named in ``only``: PARTS), print tables of
    throughputs and ratios, optionally write JSON; ``compare``: an earlier run's JSON, each
    record's ratio to it printed at the end; ``limit``: also the practical limits
    (``limit_bench``); ``peers``: also the peers (``peers_bench``, the 'peers' extra);
    ``command``: the command that ran, for the JSON's run record (None: bench_command's).
    Every option is checked before anything is timed."""
    if json_path is not None:       # a file it can write, known before minutes of timing
        json_path = Path(json_path)
        if json_path.is_dir() or not json_path.parent.is_dir():
            raise UserError(f"--json {json_path}: expected a file in an existing folder")
        if not os.access(json_path.parent, os.W_OK | os.X_OK):
            raise UserError(f"--json {json_path}: its folder is not writable")
    old = read_records(compare) if compare is not None else None
    parts = _parts(only, limit, c_ref)
    if peers:
        peer_modules()          # installed? (before anything is timed)
    if c_ref is not None:
        c_ref = _c_reference(c_ref)
    if command is None:
        command = bench_command(quick, c_ref, threads, only, limit, peers)
    threads = threads or os.cpu_count() or 1
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    min_time, reps = (0.05, 1) if quick else (0.3, 3)
    K = 100 if quick else BATCH_TRIALS
    records = []
    say = console.print if console else print
    if "ungm" in parts:
        records += ungm_bench(quick, c_ref, K, min_time, reps, threads, say, console)
    if "costs" in parts:
        records += costs_bench(bench_data(K)[1], min_time, reps, say, console)
    if "fastslam" in parts:
        records += fastslam_bench(quick, min_time, reps, say)
    if "afsa" in parts:
        records += afsa_bench(quick, min_time, reps, say, console)
    if "mcl" in parts:
        records += mcl_bench(quick, min_time, reps, say)
    if peers:
        records += peers_bench(quick, min_time, reps, say, console)
    families = families_of(parts)
    if families:
        records += run_path_bench(quick, min_time, reps, say, console, families)
    if "limit" in parts:
        records += limit_bench(quick, min_time, reps, say, console)
    records.append({"workload": "run", "impl": "pfbench", "command": command,
                    "cores": os.cpu_count(), "numba": numba.__version__,
                    "numpy": np.__version__, "python": platform.python_version()})
    if json_path is not None:
        try:
            atomic_write(json_path, json.dumps(records, indent=2) + "\n")
        except OSError as exc:
            raise UserError(f"--json {json_path}: {os_error_line(exc)}") from None
        say(f"wrote {json_path}")
    if old is not None and console is not None:
        print_comparison(compare_records(records, old), Path(compare), console)
    return records
