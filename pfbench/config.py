"""YAML experiment -> validated, frozen :class:`Experiment`.

Loading is strict: ``yaml.safe_load`` semantics with duplicate keys rejected; every section is checked
against the schema of its scenario or filter type (unknown keys, wrong types, out-of-range values);
errors are :class:`ConfigError` with the file, line and key path.
"""
from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Iterator, Mapping

from .filters import FILTERS, KIND_TYPES
from .fsutil import name_problem
from .kinds import kind_of
from .papers import Paper, Table
from .papers import find as find_paper
from .plugins import FILTER_GROUP, SCENARIO_GROUP, problem_for
from .scenarios import SCENARIOS
from .schema import ConfigError, Key, check_mapping, check_section, describe, did_you_mean
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

def apply_override(raw: dict, assignment: str) -> None:
    """Apply ``KEY.PATH=VALUE`` (VALUE read as YAML; ``*`` in the path matches every key) to raw."""
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

    walk(raw, 0, [])


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

FILTER_COMMON = {
    "type": Key("str", None, "filter type (default: the filter's key)", nullable=True),
    "label": Key("str", None, "row name in the tables, the paper's name (default: the key)",
                 nullable=True),
    "particles": Key("ints", None, "particle count, or a list: one run per count", min=2,
                     nullable=True),
}


def _validate_filters(raw: Any, scenario: str) -> tuple[FilterRun, ...]:
    kind = kind_of(scenario).name
    raw = check_mapping("filters", raw)
    if not raw:
        raise ConfigError("filters", "expected at least one filter")
    runs: list[FilterRun] = []
    for name, spec in raw.items():
        path = f"filters.{name}"
        spec = check_mapping(path, spec if spec is not None else {})
        ftype_name = spec.get("type", name)
        ftype_name = KIND_TYPES.get((ftype_name, kind), ftype_name)
        if ftype_name is None or ftype_name not in FILTERS:
            shown = ftype_name if "type" in spec else name
            where = f"{path}.type" if "type" in spec else path
            broken = problem_for(FILTER_GROUP, str(shown))
            if broken:
                raise ConfigError(where, f"filter type '{shown}': {broken}")
            raise ConfigError(where, f"unknown filter type '{shown}'" + did_you_mean(shown, FILTERS)
                              + f"; valid types: {', '.join(FILTERS)}"
                              + ("" if "type" in spec else " (set 'type' when the key is not one)"))
        ftype = FILTERS[ftype_name]
        if ftype.kind != kind:
            fits = [n for n, f in FILTERS.items() if f.kind == kind and f.scenarios is None]
            raise ConfigError(path, f"filter type '{ftype_name}' runs on {ftype.kind} scenarios, "
                              f"and '{scenario}' is a {kind} scenario; its filters: "
                              + ", ".join(fits))
        if ftype.scenarios is not None and scenario not in ftype.scenarios:
            raise ConfigError(path, f"filter type '{ftype_name}' runs only on scenario "
                              + ", ".join(ftype.scenarios))
        common = check_section({k: v for k, v in spec.items() if k in FILTER_COMMON},
                               FILTER_COMMON, path)
        params = check_section({k: v for k, v in spec.items() if k not in FILTER_COMMON},
                               ftype.schema, path)
        broken = ftype.check(params) if ftype.check else None
        if broken:
            raise ConfigError(f"{path}.{broken[0]}", broken[1])
        label = common["label"] or name
        counts = common["particles"]
        if ftype.particles and counts is None:
            raise ConfigError(f"{path}.particles", "missing required key (an integer >= 2 or a "
                              "list of them)")
        if not ftype.particles and counts is not None:
            raise ConfigError(f"{path}.particles", f"filter type '{ftype_name}' has no particles")
        for n in counts or (None,):
            key = name if n is None else f"{name}@{n}"
            runs.append(FilterRun(key, name, ftype_name, label, n, Params(params)))
    seen = {}
    for r in runs:
        row = (r.label, r.particles)
        if row in seen:
            raise ConfigError(f"filters.{r.name}.label", f"label '{r.label}' with "
                              f"{r.particles} particles is also used by filters.{seen[row]}")
        seen[row] = r.name
    return tuple(runs)


def validate(raw: Any, source: str = "config") -> Experiment:
    """Validate the raw mapping of a config file into an :class:`Experiment`."""
    raw = check_mapping("", raw if raw is not None else {})
    if "sweep" in raw:
        raise ConfigError("sweep", "this file describes a sweep: run it with 'pfbench sweep'")
    top = check_section({k: v for k, v in raw.items()
                         if k not in ("scenario", "filters", "compare", "check")},
                        TOP_SCHEMA, "")
    if "scenario" not in raw:
        raise ConfigError("scenario", "missing required section (a mapping with 'name' and the "
                          "scenario's keys)")
    scen_raw = check_mapping("scenario", raw["scenario"])
    scen_name = scen_raw.get("name")
    if isinstance(scen_name, str) and (broken := problem_for(SCENARIO_GROUP, scen_name)):
        raise ConfigError("scenario.name", f"scenario '{scen_name}': {broken}")
    if not isinstance(scen_name, str) or scen_name not in SCENARIOS:
        msg = ("missing required key" if scen_name is None
               else f"unknown scenario {describe(scen_name)}" + did_you_mean(scen_name, SCENARIOS))
        raise ConfigError("scenario.name", f"{msg}; valid scenarios: {', '.join(SCENARIOS)}")
    scen_params = check_section({k: v for k, v in scen_raw.items() if k != "name"},
                                SCENARIOS[scen_name].SCHEMA, "scenario")
    resolve = getattr(SCENARIOS[scen_name], "resolve", None)
    if resolve is not None:  # files the scenario names, relative to the experiment file
        scen_params = resolve(scen_params, Path(source).resolve().parent)
    if "filters" not in raw:
        raise ConfigError("filters", "missing required section (a mapping of filter name -> "
                          "settings)")
    filters = _validate_filters(raw["filters"], scen_name)
    moved = {"rel_tol": "a margin of the quantity in the paper file",
             "paper_runs": "the table's 'runs' in the paper file"}
    for key, where in moved.items():
        if isinstance(raw.get("compare"), dict) and key in raw["compare"]:
            raise ConfigError(f"compare.{key}", f"no longer a config key: it is {where} (README: "
                              "Adding a paper)")
    compare = check_section(raw.get("compare") or {}, COMPARE_SCHEMA, "compare")
    if compare["floor"] is not None and compare["floor"] not in {f.key for f in filters}:
        keys = [f.key for f in filters]
        raise ConfigError("compare.floor", f"no filter run '{compare['floor']}'"
                          + did_you_mean(compare["floor"], keys) + f"; runs: {', '.join(keys)}")
    if compare["baseline"] is not None and compare["baseline"] not in {f.name for f in filters}:
        names = sorted({f.name for f in filters})
        raise ConfigError("compare.baseline", f"no filter '{compare['baseline']}'"
                          + did_you_mean(compare["baseline"], names) + f"; filters: {', '.join(names)}")
    check = check_section(raw.get("check") or {}, CHECK_SCHEMA, "check")
    reference = find_paper(top["paper"], source) if top["paper"] is not None else None
    if top["table"] is not None:
        if reference is None:
            raise ConfigError("table", "needs 'paper' too")
        tables = reference.tables
        if top["table"] not in tables:
            raise ConfigError("table", f"paper {top['paper']} has no table '{top['table']}'"
                              + did_you_mean(top["table"], tables) + f"; tables: {', '.join(tables)}")
    name = top["name"] or Path(source).stem
    if problem := name_problem(name):
        raise ConfigError("name", f"the file name gives the experiment no usable folder name: "
                          f"{problem}; set 'name'")
    return Experiment(name=name, source=source, paper=top["paper"], table=top["table"],
                      description=top["description"] or "", seed=top["seed"],
                      trials=top["trials"], scenario=scen_name,
                      scenario_params=Params(scen_params), filters=filters,
                      compare=Params(compare), check=Params(check), raw=copy.deepcopy(raw),
                      reference=reference)


def load(path: str | Path, overrides: dict[str, Any] | None = None,
         sets: list[str] | tuple[str, ...] = ()) -> Experiment:
    """Read, override and validate a config file.

    overrides : top-level values from command-line flags (``trials``, ``seed``); None is skipped.
    sets : ``KEY.PATH=VALUE`` assignments (``--set``), applied before validation.
    """
    source = str(path)
    data, lines = read_yaml(path)
    if data is None:
        data = {}
    if not isinstance(data, dict):
        raise ConfigError("", f"expected a mapping of keys at the top, got {describe(data)}",
                          source=source)
    try:
        for assignment in sets:
            apply_override(data, assignment)
        for k, v in (overrides or {}).items():
            if v is not None:
                data[k] = v
        return validate(data, source)
    except ConfigError as err:
        raise err.located(source, lines) from None
