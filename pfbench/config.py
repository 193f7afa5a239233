"""YAML experiment -> validated, frozen :class:`Experiment`.

Loading is strict: ``yaml.safe_load`` semantics with duplicate keys rejected; every section is checked
against the schema of its scenario or filter type (unknown keys, wrong types, out-of-range values);
errors are :class:`ConfigError` with the file, line and key path.
"""
from __future__ import annotations

import copy
import hashlib
import json
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

from .diagnostics import KEY_WORDS
from .diagnostics import NAMES as DIAGNOSTIC_NAMES
from .filters import FILTERS, KIND_TYPES
from .filters.types import FILTER_COMMON  # noqa: F401  (part of this module's API)
from .fsutil import name_problem
from .kinds import kind_of
from .papers import Paper, Table
from .papers import find as find_paper
from .plugins import FILTER_GROUP, SCENARIO_GROUP, problem_for
from .scenarios import SCENARIOS
from .schema import (ConfigError, Key, Problems, check_mapping, check_section, describe,
                     did_you_mean, gather, in_order, not_utf8, printable)
from .yamlio import parse_yaml, read_yaml  # noqa: F401  (read_yaml: part of this module's API)

FORMAT_VERSION = 7   # 7: run times in timings.csv, not in trials.csv or meta.json
# How filter runs' random streams derive from (seed, trial, key) (pfbench.seeding); part of an
# experiment's identity, so trials drawn otherwise are never taken for this experiment's.
STREAMS = "sha256-v2"


class Params(Mapping):
    """A read-only mapping of validated parameters (also readable as attributes)."""

    def __init__(self, data: dict):
        self._data = dict(data)

    def __getitem__(self, k):
        return self._data[k]

    def __iter__(self) -> Iterator:
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __getattr__(self, k):
        try:
            return self.__dict__["_data"][k]
        except KeyError:
            raise AttributeError(k) from None

    def __repr__(self) -> str:
        return f"Params({self._data!r})"

    def __eq__(self, other) -> bool:
        return isinstance(other, Mapping) and dict(self) == dict(other)

    def __hash__(self):
        return hash(json.dumps(self._data, sort_keys=True, default=str))


@dataclass(frozen=True)
class FilterRun:
    """One filter of an experiment at one particle count (``particles`` is None without particles)."""

    key: str          # unique id within the experiment: "pf@50", "ukf"
    name: str         # the config key under `filters`
    type: str
    label: str        # the paper's name for the row ("PF", "UKF")
    particles: int | None
    params: Params


@dataclass(frozen=True)
class Experiment:
    name: str
    source: str
    paper: str | None
    table: str | None
    description: str
    seed: int
    trials: int
    scenario: str
    scenario_params: Params
    filters: tuple[FilterRun, ...]
    compare: Params
    check: Params
    raw: dict = field(repr=False, compare=False, hash=False)
    reference: Paper | None = field(default=None, repr=False, compare=False, hash=False)
    # the per-step diagnostics the config asks for beyond what it reads: 'auto', 'all' or names
    # (pfbench.diagnostics decides what a run computes)
    diagnostics: tuple | str = "auto"

    @property
    def reported(self) -> Table | None:
        """The paper's table this experiment is compared with (None: it names none)."""
        if self.reference is None or self.table is None:
            return None
        return self.reference.tables[self.table]

    @property
    def identity(self) -> dict:
        """Everything a trial's rows depend on: seed, scenario, filters (not ``trials``), as
        JSON-ready values (meta.json keeps it, so that a run into the folder of another
        experiment can say what differs)."""
        payload = {"seed": self.seed, "streams": STREAMS, "scenario": self.scenario,
                   "scenario_params": dict(self.scenario_params),
                   "filters": [[f.key, f.type, f.label, f.particles, dict(f.params)]
                               for f in self.filters]}
        return json.loads(json.dumps(payload, sort_keys=True, default=str))

    @property
    def hash(self) -> str:
        """sha256 of the experiment's identity (seed, scenario, filters; not ``trials``)."""
        text = json.dumps(self.identity, sort_keys=True)
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def filter(self, key: str) -> FilterRun:
        return next(f for f in self.filters if f.key == key)


# ---------------------------------------------------------------- YAML reading

# ---------------------------------------------------------------- overrides

def apply_override(raw: dict, assignment: str) -> list[str]:
    """Apply ``KEY.PATH=VALUE`` (VALUE read as YAML; ``*`` in the path matches every key) to raw;
    return the key paths it set."""
    key, sep, text = assignment.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(f"--set {assignment}", "expected KEY=VALUE, e.g. scenario.steps=60")
    try:
        value, _ = parse_yaml(text, "--set")
    except ConfigError as err:
        raise ConfigError(f"--set {key}", f"cannot read the value {text!r}: {err.message}") \
            from None
    parts = key.split(".")

    def walk(node, i, trail):
        name = parts[i]
        here = ".".join(trail + [name])
        if not isinstance(node, dict):
            raise ConfigError(f"--set {key}", f"'{'.'.join(trail)}' is not a mapping")
        if i == len(parts) - 1:
            targets = list(node) if name == "*" else [name]
            for t in targets:
                node[t] = copy.deepcopy(value)
                done.append(".".join(trail + [str(t)]))
            return
        if name == "*":
            for k in node:
                walk(node[k], i + 1, trail + [str(k)])
            return
        if name not in node:
            if parts[i + 1] != "*" and i == 0:  # a top-level section the file leaves out
                node[name] = {}
            else:
                raise ConfigError(f"--set {key}", f"no '{here}' in the config"
                                  + did_you_mean(name, list(node)))
        walk(node[name], i + 1, trail + [name])

    done: list[str] = []
    walk(raw, 0, [])
    return done


# ---------------------------------------------------------------- validation

TOP_SCHEMA = {
    "name": Key("str", None, "experiment name, the results folder results/<name>: one plain folder "
                "name (default: the file name)", nullable=True, check=name_problem),
    "paper": Key("str", None, "the paper whose table this reproduces: the key of a paper file "
                 "(PAPER.yaml in --papers folders, papers/ beside the config, or configs/papers/)",
                 nullable=True),
    "table": Key("str", None, "the table of that paper (a key of its file's tables)",
                 nullable=True),
    "description": Key("str", None, "one line on what the experiment shows", nullable=True),
    "seed": Key("int", 0, "base seed of numpy.random.SeedSequence (0 is a valid seed)", min=0),
    "trials": Key("int", 100, "Monte Carlo trials (independent truths and filter runs)", min=1),
    "diagnostics": Key("names", "auto", "per-step diagnostics to compute beyond those the "
                       "experiment's tables, figures and paper file read (which 'pfbench "
                       "validate' lists): 'auto' none more, 'all' every one its kind has, or a "
                       "list of them", choices=tuple(DIAGNOSTIC_NAMES), words=KEY_WORDS),
}

CHECK_SCHEMA = {
    "trials": Key("int", 20, "trials 'pfbench tables --check' runs again (the first ones) to "
                  "compare with the committed results", min=2),
}

COMPARE_SCHEMA = {
    "floor": Key("str", None, "key of a filter run with many particles whose result bounds what any "
                 "filter can reach; paper values below it are marked 'below the model's floor'",
                 nullable=True),
    "baseline": Key("str", None, "filter (a key under filters) every row is compared with, trial by "
                    "trial: mean RMSE difference with its 95% interval and win rate", nullable=True),
}



SECTIONS = ("scenario", "filters", "compare", "check")


def _filter_type(name: Any, spec: dict, path: str, scenario: str | None, kind: str | None):
    """The filter type of ``filters.NAME`` (the name under FILTERS), or raise ConfigError."""
    shown = spec.get("type", name)
    ftype_name = KIND_TYPES.get((shown, kind), shown) if kind else shown
    if isinstance(ftype_name, str) and ftype_name in FILTERS:
        return ftype_name
    where = f"{path}.type" if "type" in spec else path
    if "type" in spec and not isinstance(shown, str):
        raise ConfigError(where, f"expected a filter type (text), got {describe(shown)}")
    broken = problem_for(FILTER_GROUP, str(shown))
    if broken:
        raise ConfigError(where, f"filter type '{shown}': {broken}")
    raise ConfigError(where, f"unknown filter type '{shown}'" + did_you_mean(shown, FILTERS)
                      + f"; valid types: {', '.join(FILTERS)}"
                      + ("" if "type" in spec else " (set 'type' when the key is not one)"))


def _validate_filters(raw: Any, scenario: str | None, scen_params: dict | None,
                      problems: Problems) -> tuple[FilterRun, ...]:
    """The filter runs of ``filters:`` on ``scenario`` (None: no valid scenario name; each
    filter's own keys are still checked) with its validated keys ``scen_params`` (None: they are
    broken); every problem goes to ``problems``."""
    mod = SCENARIOS.get(scenario) if scenario else None
    kind = mod.KIND if mod is not None else None
    raw = check_mapping("filters", raw)
    if not raw:
        raise ConfigError("filters", "expected at least one filter")
    runs: list[FilterRun] = []
    for name, spec in raw.items():
        path = f"filters.{name}"
        before = len(problems.found)
        with problems.attempt():
            if not isinstance(name, str) or not name.strip():
                raise ConfigError(path, f"a filter's key names its runs: expected text, got "
                                  f"{describe(name)} (quote it)")
            if not_utf8(name):
                raise ConfigError(path, "a filter's key names its runs: expected UTF-8 text, "
                                  "got an undecodable byte")
            spec = check_mapping(path, spec if spec is not None else {})
            ftype_name = _filter_type(name, spec, path, scenario, kind)
        if not problems.ok:
            continue
        ftype = FILTERS[ftype_name]
        if kind is not None:
            why = ftype.cannot_run_on(scenario, kind, mod, scen_params)
            if why:
                fits = [n for n, f in FILTERS.items()
                        if f.cannot_run_on(scenario, kind, mod, scen_params) is None]
                problems.add(ConfigError(path, f"filter type '{ftype_name}' {why}; the filters "
                                         f"that run on '{scenario}': {', '.join(fits) or 'none'}"))
        checked = check_section(spec, {**FILTER_COMMON, **ftype.schema}, path, problems=problems)
        common = {k: checked[k] for k in FILTER_COMMON}
        params = {k: checked[k] for k in ftype.schema}
        if len(problems.found) == before and ftype.check:
            broken = ftype.check(params)
            if broken:
                problems.add(ConfigError(f"{path}.{broken[0]}", broken[1]))
        if len(problems.found) == before and ftype.check_scenario and scen_params is not None:
            broken = ftype.check_scenario(params, scen_params)
            if broken:
                problems.add(ConfigError(f"{path}.{broken[0]}", broken[1]))
        counts = common["particles"]
        misspelt = any(did_you_mean(k, ["particles"]) for k in spec
                       if k not in FILTER_COMMON and k not in ftype.schema)
        if not misspelt and not any(p.path.startswith(f"{path}.particles")
                                    for p in problems.found[before:]):
            if ftype.particles and counts is None:
                problems.add(ConfigError(f"{path}.particles", "missing required key (an integer "
                                         ">= 2 or a list of them)"))
            if not ftype.particles and counts is not None:
                problems.add(ConfigError(f"{path}.particles",
                                         f"filter type '{ftype_name}' has no particles"))
        if len(problems.found) != before:
            continue
        label = common["label"] or name
        for n in counts or (None,):
            key = name if n is None else f"{name}@{n}"
            runs.append(FilterRun(key, name, ftype_name, label, n, Params(params)))
    keys: dict[str, FilterRun] = {}
    rows: dict[tuple, str] = {}
    for r in runs:
        if r.key in keys:
            o = keys[r.key]
            problems.add(ConfigError(f"filters.{r.name}", f"its run '{r.key}' has the key of a "
                                     f"run of filters.{o.name}"
                                     + (f" ({o.particles} particles)" if o.particles else "")
                                     + ": runs are named KEY@PARTICLES, so rename one filter"))
            continue
        keys[r.key] = r
        row = (r.label, r.particles)
        if row in rows:
            problems.add(ConfigError(f"filters.{r.name}.label", f"label '{r.label}' with "
                                     f"{r.particles} particles is also used by "
                                     f"filters.{rows[row]}"))
        rows.setdefault(row, r.name)
    return tuple(runs)


def refuse_incompatible(exp: "Experiment") -> None:
    """Raise a one-line ConfigError when a filter run of ``exp`` cannot run on its scenario (what
    it needs that the scenario does not provide): the check ``validate`` makes, made again on an
    Experiment handed to the API as it is (built or changed by hand), before anything runs."""
    mod = SCENARIOS.get(exp.scenario)
    if mod is None:
        raise ConfigError("scenario.name", f"unknown scenario '{exp.scenario}'; valid "
                          f"scenarios: {', '.join(SCENARIOS)}", source=exp.source)
    for run in exp.filters:
        ftype = FILTERS.get(run.type)
        path = f"filters.{run.name}"
        if ftype is None:
            raise ConfigError(path, f"unknown filter type '{run.type}'; valid types: "
                              f"{', '.join(FILTERS)}", source=exp.source)
        why = ftype.cannot_run_on(exp.scenario, mod.KIND, mod, dict(exp.scenario_params))
        if why:
            raise ConfigError(path, f"filter type '{run.type}' {why}", source=exp.source)


def validate(raw: Any, source: str = "config") -> Experiment:
    """Validate the raw mapping of a config file into an :class:`Experiment`.

    Every problem of the config is found before any is raised: one ConfigError for one, a
    :class:`pfbench.schema.ConfigErrors` listing them for several."""
    raw = check_mapping("", raw if raw is not None else {})
    if "sweep" in raw:
        raise ConfigError("sweep", "this file describes a sweep: run it with 'pfbench sweep'")
    problems = Problems()
    top = check_section(raw, TOP_SCHEMA, "", ignore=SECTIONS, problems=problems)
    scen_name, scen_params = _validate_scenario(raw, source, problems)
    filters: tuple[FilterRun, ...] = ()
    if "filters" not in raw:
        problems.add(ConfigError("filters", "missing required section (a mapping of filter "
                                 "name -> settings)"))
    else:
        with problems.attempt():
            filters = _validate_filters(raw["filters"], scen_name, scen_params, problems)
    compare = _validate_compare(raw, filters, problems)
    _check_diagnostics(top, scen_name, problems)
    check = {k: key.default for k, key in CHECK_SCHEMA.items()}
    with problems.attempt():
        check = check_section(raw.get("check") or {}, CHECK_SCHEMA, "check", problems=problems)
    name = _experiment_name(top, source, problems)
    reference = _validate_reference(top, raw, source, problems)
    problems.raise_if_any()
    return Experiment(name=name, source=printable(source), paper=top["paper"],
                      table=top["table"],
                      description=top["description"] or "", seed=top["seed"],
                      trials=top["trials"], scenario=scen_name,
                      scenario_params=Params(scen_params), filters=filters,
                      compare=Params(compare), check=Params(check), raw=copy.deepcopy(raw),
                      reference=reference, diagnostics=top["diagnostics"])


def _validate_scenario(raw: dict, source: str, problems: Problems) -> tuple:
    """The scenario section: (its name, its parameters), None for what is not valid (each
    problem added to ``problems``)."""
    scen_name = scen_params = None
    if "scenario" not in raw:
        problems.add(ConfigError("scenario", "missing required section (a mapping with 'name' "
                                 "and the scenario's keys)"))
        return scen_name, scen_params
    with problems.attempt():
        scen_raw = check_mapping("scenario", raw["scenario"])
        name = scen_raw.get("name")
        if not isinstance(name, str) or name not in SCENARIOS:
            if isinstance(name, str) and (broken := problem_for(SCENARIO_GROUP, name)):
                raise ConfigError("scenario.name", f"scenario '{name}': {broken}")
            msg = ("missing required key" if name is None
                   else f"unknown scenario {describe(name)}" + did_you_mean(name, SCENARIOS))
            raise ConfigError("scenario.name", f"{msg}; valid scenarios: "
                              f"{', '.join(SCENARIOS)}")
        scen_name = name
    if scen_name is not None:
        before = len(problems.found)
        params = check_section(scen_raw, SCENARIOS[scen_name].SCHEMA, "scenario",
                               ignore=("name",), problems=problems)
        params.pop("name", None)
        resolve = getattr(SCENARIOS[scen_name], "resolve", None)
        if len(problems.found) == before:
            with problems.attempt():
                if resolve is not None:  # files the scenario names, relative to the file
                    params = resolve(params, _folder_of(source))
                scen_params = params
    return scen_name, scen_params


def _validate_compare(raw: dict, filters: tuple, problems: Problems) -> dict:
    """The compare section (its keys that moved to the paper file refused), its floor and
    baseline among the filter runs."""
    moved = {"rel_tol": "a margin of the quantity in the paper file",
             "paper_runs": "the table's 'runs' in the paper file"}
    compare = {"floor": None, "baseline": None}
    with problems.attempt():
        cmp_raw = check_mapping("compare", raw.get("compare") or {})
        for key, where in moved.items():
            if key in cmp_raw:
                problems.add(ConfigError(f"compare.{key}", f"no longer a config key: it is "
                                         f"{where} (README: Adding a paper)"))
        compare = check_section({k: v for k, v in cmp_raw.items() if k not in moved},
                                COMPARE_SCHEMA, "compare", problems=problems)
    if filters:
        keys = [f.key for f in filters]
        if compare["floor"] is not None and compare["floor"] not in keys:
            problems.add(ConfigError("compare.floor", f"no filter run '{compare['floor']}'"
                                     + did_you_mean(compare["floor"], keys)
                                     + f"; runs: {', '.join(keys)}"))
        names = sorted({f.name for f in filters})
        if compare["baseline"] is not None and compare["baseline"] not in names:
            problems.add(ConfigError("compare.baseline", f"no filter '{compare['baseline']}'"
                                     + did_you_mean(compare["baseline"], names)
                                     + f"; filters: {', '.join(names)}"))
    return compare


def _check_diagnostics(top: dict, scen_name: str | None, problems: Problems) -> None:
    """The diagnostics named are those of the scenario's kind."""
    if (scen_name is not None and isinstance(top["diagnostics"], tuple)
            and (bad := [n for n in top["diagnostics"]
                         if n not in kind_of(scen_name).diagnostics])):
        kind = kind_of(scen_name)
        problems.add(ConfigError("diagnostics", f"a {kind.name} scenario has no diagnostic "
                                 f"'{bad[0]}'; its diagnostics: "
                                 f"{', '.join(kind.diagnostics) or 'none'}"))


def _experiment_name(top: dict, source: str, problems: Problems) -> str:
    """The experiment's name: 'name', else the file's stem when it makes a folder name."""
    name = top["name"] or _stem(source)
    if top["name"] is None and not_utf8(name):
        problems.add(ConfigError("name", f"the file name '{printable(name)}' is not UTF-8 text: "
                                 "it gives the experiment no usable folder name; set 'name'"))
    elif top["name"] is None and (problem := name_problem(name)):
        problems.add(ConfigError("name", f"the file name gives the experiment no usable folder "
                                 f"name: {problem}; set 'name'"))
    return name


def _validate_reference(top: dict, raw: dict, source: str, problems: Problems):
    """The paper the config names (its file found) and the table of it."""
    reference = None
    if top["paper"] is not None:
        with problems.attempt():
            reference = find_paper(top["paper"], source)
    if top["table"] is not None:
        if top["paper"] is None and raw.get("paper") is None:
            problems.add(ConfigError("table", "needs 'paper' too"))
        elif reference is not None and top["table"] not in reference.tables:
            tables = reference.tables
            problems.add(ConfigError("table", f"paper {top['paper']} has no table "
                                     f"'{top['table']}'" + did_you_mean(top["table"], tables)
                                     + f"; tables: {', '.join(tables)}"))
    return reference


def _stem(source: str) -> str:
    return Path(source).stem


def _folder_of(source: str) -> Path:
    return Path(source).resolve().parent


def load(path: str | Path, overrides: dict[str, Any] | None = None,
         sets: list[str] | tuple[str, ...] = ()) -> Experiment:
    """Read, override and validate a config file.

    overrides : top-level values from command-line flags (``trials``, ``seed``); None is skipped.
    sets : ``KEY.PATH=VALUE`` assignments (``--set``), applied before validation.
    """
    source = os.fsdecode(path) if isinstance(path, bytes) else str(path)
    data, lines = read_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError("", f"expected a mapping of keys at the top, got {describe(data)}",
                          source=source)
    origins: dict[str, str] = {}     # key path -> the flag that set it
    try:
        for assignment in sets:
            flag = f"--set {assignment.strip()}"
            try:
                for p in apply_override(data, assignment):
                    origins[p] = flag
            except ConfigError as err:
                raise ConfigError("", err.message, source=flag) from None
        for k, v in (overrides or {}).items():
            if v is not None:
                data[k] = v
                origins[k] = f"--{k} {v}"
        return validate(data, source)
    except ConfigError as err:
        raise locate(err, source, lines, origins) from None


def locate(err: ConfigError, source: str, lines: dict[str, int],
           origins: dict[str, str] | None = None) -> ConfigError:
    """``err`` with each problem located: a key a flag set (``origins``: key path -> '--set
    KEY=VALUE') is blamed on that flag, any other on its line of the file ``source``."""
    origins = origins or {}
    found = []
    for p in err.problems:
        flag = next((origins[o] for o in sorted(origins, key=len, reverse=True)
                     if p.path == o or p.path.startswith((o + ".", o + "["))), None)
        if flag is not None and not p.source:
            found.append(ConfigError(p.path, p.message, source=flag))
        else:
            found.append(p.located(source, lines))
    return gather(in_order(found, source), source)
