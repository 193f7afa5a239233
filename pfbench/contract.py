"""The contract every registered filter and scenario keeps, plug-ins included.

``pfbench list --check`` runs it (``--executor dask``: under Dask too); the test suite runs it
over pfbench's own. For each filter type, a small experiment on the first registered scenario of
its kind; for each scenario, one with the first registered filter that runs on it. Each probe:

- schema: every key documented, and the defaults pass the schema;
- deterministic from the seed: the same trial run twice gives the same numbers, bit for bit;
- finite on its kind: the kind's headline metrics (``pfbench.kinds``) are finite numbers;
- the scenario's truth and data are the same for the same seed;
- what its kind keeps of a trial for the figures (pfbench.traces) is kept without an error;
- under an executor (Dask): the rows are the in-process rows, bit for bit;
- in time: a probe that has not finished after ``timeout`` seconds (PROBE_SECONDS by default,
  ``pfbench list --check --probe-timeout``) is stopped and reported, and the check goes on. Each
  probe runs in a child process for that (where this platform can fork one), so a filter that never
  returns, or crashes the interpreter, is named like any other problem.
"""
from __future__ import annotations

import math
import pickle
from dataclasses import dataclass, field
from pathlib import Path

from .errors import UserError
from .schema import REQUIRED, ConfigError, check_section

TRIALS = (0, 1)
SEED = 20261201
STEPS = 30            # steps of a probe, where the scenario has a 'steps' key
PARTICLES = 64
# Seconds a probe may take, its kernels' first compilation included (minutes for the largest
# with an empty kernel cache), before it counts as a filter that never finishes.
PROBE_SECONDS = 600.0


@dataclass
class Probe:
    """One small experiment: ``filter`` on ``scenario``, vouching for ``subjects``."""

    filter: str
    scenario: str
    subjects: list[str] = field(default_factory=list)   # 'filter pf', 'scenario ungm'


def _schema_problems(what: str, schema: dict) -> list[str]:
    out = [f"{what}: key '{k}' has no doc line" for k, key in schema.items() if not key.doc]
    try:   # the defaults of the keys that have one
        # as a YAML file would give them (a tuple default is a list there)
        given = {k: list(key.default) if isinstance(key.default, tuple) else key.default
                 for k, key in schema.items() if key.default is not REQUIRED}
        check_section(given, {k: schema[k] for k in given}, what)
    except ConfigError as exc:
        out.append(f"{what}: its defaults do not pass its own schema: {exc}")
    return out


def probes() -> tuple[list[Probe], list[str]]:
    """The probe experiments that cover every registered filter and scenario, and the problems
    found before running anything (schemas, a filter with no scenario of its kind)."""
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    problems: list[str] = []
    found: dict[tuple[str, str], Probe] = {}

    def add(f: str, s: str, subject: str) -> None:
        found.setdefault((f, s), Probe(f, s)).subjects.append(subject)

    for name, ft in FILTERS.items():
        problems += _schema_problems(f"filter {name}", ft.schema)
        fits = [s for s, mod in SCENARIOS.items() if ft.runs_on(s, mod.KIND)]
        if not fits:
            problems.append(f"filter {name}: no registered scenario of kind '{ft.kind}' it runs on")
            continue
        add(name, fits[0], f"filter {name}")
    for name, mod in SCENARIOS.items():
        problems += _schema_problems(f"scenario {name}", mod.SCHEMA)
        fits = [f for f, ft in FILTERS.items() if ft.runs_on(name, mod.KIND)]
        if not fits:
            problems.append(f"scenario {name}: no registered filter runs on it")
            continue
        add(fits[0], name, f"scenario {name}")
    return list(found.values()), problems


def experiment(probe: Probe, configs: Path):
    """The probe as a validated experiment (files a scenario names resolve from ``configs``)."""
    from .config import validate
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    scen = {"name": probe.scenario}
    steps = SCENARIOS[probe.scenario].SCHEMA.get("steps")
    if steps is not None and steps.kind == "int" and isinstance(steps.default, int):
        scen["steps"] = min(steps.default, STEPS)
    spec = {"type": probe.filter}
    if FILTERS[probe.filter].particles:
        spec["particles"] = PARTICLES
    raw = {"name": f"contract-{probe.filter}-{probe.scenario}", "seed": SEED,
           "trials": len(TRIALS), "scenario": scen, "filters": {"probe": spec}}
    return validate(raw, str(Path(configs) / "contract.yaml"))


def _numbers(rows: list[dict]) -> list[dict]:
    from .store import TIMING_COLUMNS
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def _equal(x, y) -> bool:
    if isinstance(x, float) or isinstance(y, float):
        try:
            return (math.isnan(x) and math.isnan(y)) or x == y
        except TypeError:
            return False
    return x == y


def _same(a: list[dict], b: list[dict]) -> bool:
    """The same rows, number for number (NaN equals NaN)."""
    return len(a) == len(b) and all(
        r.keys() == s.keys() and all(_equal(r[k], s[k]) for k in r) for r, s in zip(a, b))


def check_probe(probe: Probe, configs: Path) -> tuple[list[str], object, list[dict]]:
    """Run one probe in this process: (problems, experiment, its rows)."""
    from .kinds import kind_of
    from .rng import state_from_seed
    from .runner import FilterError, data_seed, run_trial, trial_data, trial_result
    from .scenarios import SCENARIOS
    who = " and ".join(probe.subjects)
    where = f"{probe.filter} on {probe.scenario}"
    try:
        exp = experiment(probe, configs)
    except UserError as exc:
        return [f"{who}: the probe {where} does not validate: {exc}"], None, []
    problems: list[str] = []
    rows: list[dict] = []
    kind = kind_of(probe.scenario)
    try:
        for k in TRIALS:
            model, truth, data = trial_data(exp, k)
            again = SCENARIOS[probe.scenario].simulate(
                model, state_from_seed(data_seed(exp.seed, k)))
            if pickle.dumps((truth, data)) != pickle.dumps(again):
                problems.append(f"scenario {probe.scenario}: the same seed simulated trial {k} "
                                "twice differently")
            # the first run also keeps what the figures draw, as a results folder's run does
            first = _numbers(trial_result(exp, k, traces=True).rows)
            second = _numbers(run_trial(exp, k))
            if not _same(first, second):
                problems.append(f"{who}: {where}, trial {k}: the same seed gave different "
                                "numbers on a second run")
            for m in kind.headline:
                v = first[0].get(m)
                if not isinstance(v, (int, float)) or not math.isfinite(v):
                    problems.append(f"{who}: {where}, trial {k}: {m} is {v!r}, expected a "
                                    f"finite number on a {kind.name} scenario")
            rows += first
    except FilterError as exc:  # the filter's own error, or a malformed output
        if exc.cause is not None:
            problems.append(f"{who}: {where} raised {type(exc.cause).__name__}: "
                            f"{' '.join(str(exc.cause).split())}")
        else:
            problems.append(f"{who}: {where}: {exc}")
    except Exception as exc:    # a plug-in's error is reported, not raised
        problems.append(f"{who}: {where} raised {type(exc).__name__}: "
                        f"{' '.join(str(exc).split())}")
    return problems, exp, rows


class ProbeInterrupted(Exception):
    """Ctrl-C during the contract: which probe was running."""


def _probe_child(conn, probe: Probe, configs: Path) -> None:
    """check_probe in a child process: its problems and rows go back through ``conn``."""
    try:
        problems, _, rows = check_probe(probe, configs)
        conn.send((problems, rows))
    except BaseException as exc:    # noqa: BLE001 (a plug-in's exit or interrupt is a problem too)
        conn.send(([f"{' and '.join(probe.subjects)}: {probe.filter} on {probe.scenario} raised "
                    f"{type(exc).__name__}: {' '.join(str(exc).split())}"], []))
    finally:
        conn.close()


def run_probe(probe: Probe, configs: Path, timeout: float | None = PROBE_SECONDS
              ) -> tuple[list[str], object, list[dict]]:
    """check_probe with a time limit: in a child process stopped after ``timeout`` seconds (a
    problem naming the probe's filter and scenario). ``timeout`` None, or a platform that cannot
    fork: in this process, without a limit."""
    import multiprocessing as mp
    if timeout is None or "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
        return check_probe(probe, configs)
    try:
        exp = experiment(probe, configs)
    except UserError as exc:
        return [f"{' and '.join(probe.subjects)}: the probe {probe.filter} on {probe.scenario} "
                f"does not validate: {exc}"], None, []
    ctx = mp.get_context("fork")
    mine, theirs = ctx.Pipe(duplex=False)
    child = ctx.Process(target=_probe_child, args=(theirs, probe, configs), daemon=True)
    child.start()
    theirs.close()
    who, where = " and ".join(probe.subjects), f"{probe.filter} on {probe.scenario}"
    try:
        if mine.poll(timeout):
            try:
                problems, rows = mine.recv()
                return problems, exp, rows
            except (EOFError, OSError):
                pass
            child.join(5)
            return [f"{who}: {where} ended the process that ran it (exit code "
                    f"{child.exitcode})"], exp, []
        return [f"{who}: {where} did not finish within {timeout:g} s (--probe-timeout); "
                "stopped"], exp, []
    finally:
        mine.close()
        if child.is_alive():
            child.terminate()
            child.join(5)
            if child.is_alive():
                child.kill()
                child.join()


def check_all(configs: Path = Path("configs"), executor=None, progress=None,
              timeout: float | None = PROBE_SECONDS) -> tuple[int, list[str]]:
    """Run the contract over every registered filter and scenario: (probes run, problems).
    ``executor`` (a runner executor, such as Dask's): the probes' trials are run there too and
    compared with this process's rows. ``timeout``: seconds each probe may take (run_probe)."""
    found, problems = probes()
    done: list[tuple[Probe, object, list[dict]]] = []
    for i, probe in enumerate(found):
        try:
            p, exp, rows = run_probe(probe, configs, timeout)
        except KeyboardInterrupt:
            raise ProbeInterrupted(f"interrupted in the probe {probe.filter} on "
                                   f"{probe.scenario} ({' and '.join(probe.subjects)}); {i} of "
                                   f"{len(found)} probes done") from None
        problems += p
        if exp is not None and not p:
            done.append((probe, exp, rows))
        if progress:
            progress(i + 1, len(found))
    if executor is not None:
        for probe, exp, rows in done:
            try:
                chunks = [t for chunk in executor.run(exp, list(TRIALS)) for t in chunk]
                theirs = sorted((row for trial in chunks for row in trial.rows),
                                key=lambda r: r["trial"])
            except Exception as exc:
                problems.append(f"{' and '.join(probe.subjects)}: under {executor.describe()}: "
                                f"{type(exc).__name__}: {' '.join(str(exc).split())}")
                continue
            if not _same(_numbers(theirs), rows):
                problems.append(f"{' and '.join(probe.subjects)}: {probe.filter} on "
                                f"{probe.scenario} gave other numbers under "
                                f"{executor.describe()} than in this process")
    return len(found), problems
