"""The contract every registered filter and scenario keeps, plug-ins included.

``pfbench check`` (alias ``pfbench list --check``) runs it from any folder, a pip install with no
repository included: every registered filter on every registered scenario it can run on
(``FilterType.cannot_run_on``), each pair a small generated experiment (``experiment``: a few
steps and particles, a generated world for a scenario that reads a world file). Then the trap
suite (pfbench.traps) on every filter. Each probe:

- schema: every key documented, and the defaults pass the schema;
- deterministic from the seed: the same trial run twice gives the same numbers, bit for bit;
- finite on its kind: the kind's headline metrics (``pfbench.kinds``) are finite numbers;
- the scenario's truth and data are the same for the same seed;
- what its kind keeps of a trial for the figures (pfbench.traces) is kept without an error;
- across worker counts (a pool of 2 worker processes, ``WORKERS``) and under an executor (Dask,
  ``--executor dask``): the rows are the in-process rows, bit for bit;
- in time: a probe that has not finished after ``timeout`` seconds (PROBE_SECONDS by default,
  ``pfbench check --probe-timeout``) is stopped and reported, and the check goes on. Each
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
    """The probe experiments: every registered filter on every registered scenario it can run on
    (``FilterType.cannot_run_on``), plug-ins and pfbench's own alike; and the problems found
    before running anything (schemas, a filter or scenario that no pair covers)."""
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    problems: list[str] = []
    found: list[Probe] = []
    for name, mod in SCENARIOS.items():
        problems += _schema_problems(f"scenario {name}", mod.SCHEMA)
    # a scenario of recorded data that are not on this machine is not probed (its module's
    # ``unavailable``, pfbench.scenarios.plaza); the simulated ones always are
    here = {name: mod for name, mod in SCENARIOS.items()
            if getattr(mod, "unavailable", None) is None or mod.unavailable({}) is None}
    for name, ft in FILTERS.items():
        problems += _schema_problems(f"filter {name}", ft.schema)
        fits = [s for s, mod in here.items()
                if ft.cannot_run_on(s, mod.KIND, mod) is None]
        if not fits:
            problems.append(f"filter {name}: no registered scenario of kind '{ft.kind}' it runs on")
        found += [Probe(name, s, [f"filter {name} on scenario {s}"]) for s in fits]
    covered = {p.scenario for p in found}
    problems += [f"scenario {name}: no registered filter runs on it" for name in here
                 if name not in covered]
    return found, problems


# The world a probe gives a scenario with a 'world' key (a world file: pfbench.scenarios.worlds),
# so that the contract needs no file of pfbench's repository: a 30 m x 30 m square path around
# the area's centre, a ring of point features around it (landmarks or beacons: the file has both
# keys), in an area of 40 m x 40 m; 'centre' (the area centred on the origin) or 'corner'
# ([0, 40] x [0, 40]), whichever the scenario reads.
WORLD_AREA = 40.0


def world(origin: str = "centre", rotated: bool = False) -> dict:
    """The generated world (see WORLD_AREA); ``rotated``: the same world turned by pi about the
    area's centre (every point mirrored through it, the start heading plus 180 degrees)."""
    import numpy as np
    ring = [[13.0 * math.cos(a), 13.0 * math.sin(a)]
            for a in np.linspace(0.0, 2 * math.pi, 12, endpoint=False)]
    points = ring + [[0.0, 0.0], [4.0, -3.0]]
    path = [[-8.0, -8.0], [8.0, -8.0], [8.0, 8.0], [-8.0, 8.0]]
    start = [-8.0, -8.0, 0.0]
    sign, shift = (-1.0 if rotated else 1.0), (WORLD_AREA / 2 if origin == "corner" else 0.0)

    def place(pts):
        return [[sign * x + shift, sign * y + shift] for x, y in pts]
    return {"area": [WORLD_AREA, WORLD_AREA], "start": place([start[:2]])[0]
            + [180.0 if rotated else 0.0], "waypoints": place(path),
            "landmarks": place(points), "beacons": place(points)}


_SCRATCH: list = []


def scratch() -> Path:
    """A folder of this process for the generated world files (removed at exit)."""
    if not _SCRATCH:
        import tempfile
        _SCRATCH.append(tempfile.TemporaryDirectory(prefix="pfbench-contract-"))
    return Path(_SCRATCH[0].name)


def world_file(origin: str = "centre", rotated: bool = False) -> Path:
    """The generated world (``world``) as a file in ``scratch()``."""
    import json
    path = scratch() / f"world-{origin}{'-rotated' if rotated else ''}.yaml"
    if not path.exists():
        path.write_text(json.dumps(world(origin, rotated)))   # JSON is YAML
    return path


_ORIGINS: dict = {}


def world_origin(scenario: str) -> str | None:
    """Which generated world scenario ``scenario`` takes ('centre' or 'corner', see ``world``):
    the first its ``resolve`` accepts with its other keys at their defaults; None when it reads
    no world file or takes neither."""
    from .scenarios import SCENARIOS
    if scenario in _ORIGINS:
        return _ORIGINS[scenario]
    mod = SCENARIOS[scenario]
    key = mod.SCHEMA.get("world")
    found = None
    if key is not None and key.kind == "str" and hasattr(mod, "resolve"):
        params = {k: list(v.default) if isinstance(v.default, tuple) else v.default
                  for k, v in mod.SCHEMA.items() if v.default is not REQUIRED}
        for origin in ("centre", "corner"):
            try:
                mod.resolve({**params, "world": str(world_file(origin))}, scratch())
            except Exception:       # noqa: BLE001 (any refusal: not this origin)
                continue
            found = origin
            break
    _ORIGINS[scenario] = found
    return found


def experiment(probe: Probe, configs: Path | None = None, scenario: dict | None = None,
               spec: dict | None = None, trials: int | None = None,
               others: dict | None = None):
    """The probe as a validated experiment: ``STEPS`` steps, ``PARTICLES`` particles, a generated
    world (``world``) for a scenario that reads one; ``scenario`` and ``spec``: keys of the
    scenario and the filter that replace those; ``others``: more filter runs (key -> keys, the
    key its type by default). Files a scenario names resolve from ``configs``
    (default: a folder of generated files)."""
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    scen = {"name": probe.scenario}
    schema = SCENARIOS[probe.scenario].SCHEMA
    steps = schema.get("steps")
    if steps is not None and steps.kind == "int" and isinstance(steps.default, int):
        scen["steps"] = min(steps.default, STEPS)
    origin = world_origin(probe.scenario)
    if origin is not None:
        scen["world"] = str(world_file(origin))
    scen.update(scenario or {})
    run = {"type": probe.filter}
    if FILTERS[probe.filter].particles:
        run["particles"] = PARTICLES
    run.update(spec or {})
    raw = {"name": f"contract-{probe.filter}-{probe.scenario}", "seed": SEED,
           "trials": len(TRIALS) if trials is None else trials, "scenario": scen,
           "filters": {"probe": run, **{k: {"type": k, **v} for k, v in (others or {}).items()}}}
    from .config import validate
    return validate(raw, str(Path(scratch() if configs is None else configs) / "contract.yaml"))


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


def check_probe(probe: Probe, configs: Path | None = None) -> tuple[list[str], object, list[dict]]:
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


def _probe_child(conn, probe: Probe, configs: Path | None) -> None:
    """check_probe in a child process: its problems and rows go back through ``conn``."""
    try:
        problems, _, rows = check_probe(probe, configs)
        conn.send((problems, rows, _built()))
    except BaseException as exc:    # noqa: BLE001 (a plug-in's exit or interrupt is a problem too)
        conn.send(([f"{' and '.join(probe.subjects)}: {probe.filter} on {probe.scenario} raised "
                    f"{type(exc).__name__}: {' '.join(str(exc).split())}"], [], set()))
    finally:
        conn.close()


def _built() -> set:
    """The kernels of pfbench's modules built (compiled or loaded) in this process."""
    from .runner import _kernels
    return {name for name, k in _kernels() if k.built}


def _load(built: set) -> None:
    """Load here, from the disk cache a probe's process saved them to, the kernels it built: the
    probes forked after it, and the worker pools, start with them (as the runner's workers)."""
    from . import runner
    runner._CHILD_KERNELS.update(built)
    runner._preload()


def run_probe(probe: Probe, configs: Path | None = None, timeout: float | None = PROBE_SECONDS
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
    who, where = " and ".join(probe.subjects), f"{probe.filter} on {probe.scenario}"
    how, got = in_child(_probe_child, (probe, configs), timeout)
    if how == "ok":
        problems, rows, built = got
        _load(built)
        return problems, exp, rows
    if how == "ended":
        return [f"{who}: {where} ended the process that ran it (exit code {got})"], exp, []
    return [f"{who}: {where} did not finish within {timeout:g} s (--probe-timeout); "
            "stopped"], exp, []


def in_child(target, args: tuple, timeout: float) -> tuple[str, object]:
    """``target(conn, *args)`` in a forked child process that sends its one result through
    ``conn``: ("ok", the result); ("ended", its exit code) when it ended without sending one;
    ("late", None) when none came within ``timeout`` seconds. The child is stopped either way
    (SIGTERM, then SIGKILL five seconds later): a filter that never returns, or ends the
    interpreter, is a finding, never a hung or crashed check."""
    import multiprocessing as mp
    ctx = mp.get_context("fork")
    mine, theirs = ctx.Pipe(duplex=False)
    child = ctx.Process(target=target, args=(theirs, *args), daemon=True)
    child.start()
    theirs.close()
    try:
        if not mine.poll(timeout):
            return "late", None
        try:
            return "ok", mine.recv()
        except (EOFError, OSError):     # its end of the pipe closed: the child ended
            child.join(5)
            return "ended", child.exitcode
    finally:
        mine.close()
        if child.is_alive():
            child.terminate()
            child.join(5)
            if child.is_alive():
                child.kill()
                child.join()


def _compare_under(executor, done: list, problems: list[str]) -> None:
    """Run the probes ``done`` ((probe, experiment, rows) each) on ``executor`` and add a problem
    for each whose rows are not the in-process rows, number for number."""
    for probe, exp, rows in done:
        who = " and ".join(probe.subjects)
        try:
            chunks = [t for chunk in executor.run(exp, list(TRIALS)) for t in chunk]
            theirs = sorted((row for trial in chunks for row in trial.rows),
                            key=lambda r: r["trial"])
        except Exception as exc:
            problems.append(f"{who}: under {executor.describe()}: {type(exc).__name__}: "
                            f"{' '.join(str(exc).split())}")
            continue
        if not _same(_numbers(theirs), rows):
            problems.append(f"{who}: {probe.filter} on {probe.scenario} gave other numbers under "
                            f"{executor.describe()} than in this process")


# The worker counts the contract compares with the in-process run (pfbench.runner's pool).
WORKERS = (2,)


def check_all(configs: Path | None = None, executor=None, progress=None,
              timeout: float | None = PROBE_SECONDS, workers=WORKERS,
              only: str | None = None) -> tuple[int, list[str]]:
    """Run the contract over every registered filter on every scenario it runs on: (probes run,
    problems). Each probe's trials are also run in a pool of each of ``workers`` worker processes
    and, with ``executor`` (a runner executor, such as Dask's), there too, and compared with this
    process's rows. ``timeout``: seconds each probe may take (run_probe). ``configs``: where the
    files a scenario names resolve (default: generated ones). ``only``: the probes of this filter
    or scenario alone."""
    from .runner import LocalExecutor
    scratch()       # made here, before a probe forks, so that this process removes it
    found, problems = probes()
    if only is not None:
        found = [p for p in found if only in (p.filter, p.scenario)]
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
    for n in workers:
        with LocalExecutor(n) as ex:
            _compare_under(ex, done, problems)
    if executor is not None:
        _compare_under(executor, done, problems)
    return len(found), problems
