"""What a run needs of the machine, estimated from its config before anything runs.

A trial holds its scenario's truth and measurements (steps x what a step stores), and one filter
run at a time: its particles (particle count x what a particle stores) and its traces (steps x a
few numbers). The runner keeps every finished trial's rows until it writes ``trials.csv``. Each
worker process holds a trial of its own and the loaded kernels. The estimate is an upper bound of
that order, not an exact count (KLD-sampling's histogram included: at most 4 MiB dense, a hash set
of the particles' size past that, whatever the bin sizes): it is there to refuse, in one line and
before a file is written, what cannot fit (a billion particles, 1e11 steps, a billion trials, a
thousand workers), never to refuse a run that fits.
"""
from __future__ import annotations

import os
from dataclasses import dataclass

from .errors import UserError

PROCESS_BYTES = 300 * 2**20        # python, numpy, numba and the loaded kernels, per process
ROW_BYTES = 2048                   # a trial row in memory (a dict of ~30 fields) and its CSV text
TRACE_FLOATS = 16                  # per step, the traces a filter run returns and its metrics use


@dataclass(frozen=True)
class Need:
    bytes: int
    what: str        # the term that dominates, in words


def estimate(exp, workers: int = 1) -> Need:
    """Bytes of memory a run of ``exp`` on ``workers`` local processes needs, about."""
    from .kinds import kind_of
    kind = kind_of(exp.scenario)
    scen = dict(exp.scenario_params)
    steps = int(scen.get("steps", 1000))
    terms = [(8 * steps * kind.step_floats(scen),
              f"the scenario's {steps:,} steps")]
    for run in exp.filters:
        n = run.particles or 1
        particles = 8 * n * kind.particle_floats(run.params, scen) + _extra_bytes(run, n)
        traces = 8 * steps * TRACE_FLOATS
        what = (f"filters.{run.name}: {n:,} particles" if particles >= traces
                else f"filters.{run.name}: the traces of {steps:,} steps")
        terms.append((particles + traces, what))
    trial = terms[0][0] + max(t[0] for t in terms[1:])
    biggest = max(terms[1:], key=lambda t: t[0])
    if terms[0][0] > biggest[0]:
        biggest = terms[0]
    rows = exp.trials * len(exp.filters) * ROW_BYTES
    per_worker = trial + PROCESS_BYTES
    total = PROCESS_BYTES + rows + workers * per_worker
    parts = [(workers * trial, biggest[1] + (f" in each of {workers:,} workers"
                                             if workers > 1 else "")),
             (rows, f"the rows of {exp.trials:,} trials x {len(exp.filters)} filter runs"),
             (workers * PROCESS_BYTES, f"{workers:,} worker processes")]
    return Need(total, max(parts, key=lambda p: p[0])[1])


def _extra_bytes(run, n: int) -> int:
    """What a filter run holds besides its particles: KLD-sampling's histogram of bins."""
    params = run.params or {}
    if getattr(run, "type", None) == "mcl" and params.get("sampling") == "kld":
        from .filters.mcl import kld_histogram_bytes
        return kld_histogram_bytes(n)
    return 0


def available_bytes() -> int:
    """Memory this machine can give a run now (MemAvailable; the physical memory elsewhere)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def human(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if n < 1024 or unit == "EiB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} EiB"  # pragma: no cover


def check_fits(exp, workers: int = 1, where: str | None = None) -> Need:
    """Raise a UserError when a run of ``exp`` cannot fit this machine's memory; return the
    estimate otherwise."""
    need = estimate(exp, workers)
    have = available_bytes()
    if need.bytes > have:
        raise UserError(f"{where or exp.source}: the run needs about {human(need.bytes)} of "
                        f"memory, mostly for {need.what}, and this machine has "
                        f"{human(have)} available: lower the particles, steps, trials or "
                        "workers")
    return need


def cap_workers(workers: int, trials: int) -> int:
    """Never more worker processes than trials."""
    return max(1, min(workers, trials))


def warn_above_cores(workers: int, warn) -> None:
    """Tell ``warn`` when more workers were asked for than the machine has cores."""
    cores = os.cpu_count() or 1
    if workers > cores:
        warn(f"--workers {workers} is more than the {cores} cores of this machine: the trials "
             "will not run faster")
