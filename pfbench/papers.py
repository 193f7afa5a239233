"""Paper files: what a paper reports, read from YAML, beside which pfbench puts its own results.

A paper is one YAML file, ``papers/<key>.yaml`` (pfbench's own are in ``configs/papers/``): its
citation; each table as printed (the quantities with the metric of ours each corresponds to, the
values per row, the notes, the rankings and factors the paper claims, its single runs); the
choices the paper leaves open, as key paths into configs; and the findings, text whose
``{config:run:column}`` references are filled in from our results. This module holds no paper's
numbers or prose: it reads and checks the files with the strict schema machinery of configs (file,
line, key, did-you-mean). docs/how-to/papers.md describes the format.

A config names its paper (``paper: ifa2021``); the file is looked up in the folders given with
``--papers`` (``search_folders``), then in ``papers/`` beside the config, then in
``configs/papers/`` of the current folder.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import UserError
from .metrics import METRICS
from .schema import ConfigError, Key, check_mapping, check_section, describe, did_you_mean
from .verdicts import Margin
from .yamlio import parse_yaml, read_regular, show_path

# our per-trial metrics a quantity can stand for, beyond the trials file's columns: the wall time
# over the baseline's on the same trial, and the gains over the baseline (pfbench.compare)
DERIVED_METRICS = ("time_ratio", "evals_ratio", "gain_mean", "gain_var")
STATS = ("mean", "var")


@dataclass(frozen=True)
class Quantity:
    """A column of a paper's table: what it is, and which statistic of ours it stands beside."""
    key: str
    title: str
    metric: str        # our per-trial metric column, or 'time_ratio', 'gain_mean', 'gain_var'
    stat: str          # 'mean' or 'var' over trials
    not_comparable: str | None = None   # why our value cannot be held against the paper's
    scale: float = 1.0                  # our metric times this is in the paper's unit
    margin: Margin | None = None        # how far ours may lie from it and still be the same
    # a deterministic measure of the same thing that the verdict uses instead (run times depend
    # on the machine: 'evals_ratio', the likelihood evaluations per step over the baseline's)
    judged_by: str | None = None


@dataclass(frozen=True)
class PerTrial:
    """A table of one metric per run, as a paper prints it (runs as columns): each paper row beside
    the first ``runs`` trials of one of our filter runs and our mean over all trials."""
    metric: str                          # our per-trial metric column
    title: str
    rows: tuple[tuple[str, str, tuple[float, ...]], ...]   # (paper's row name, our label, values)
    also: tuple[str, ...] = ()           # further metrics of ours shown per trial, no paper values

    @property
    def runs(self) -> int:
        return max(len(v) for _, _, v in self.rows)


@dataclass(frozen=True)
class Table:
    """One table of a paper: its quantities, the values of its rows, and what it claims."""
    caption: str
    quantities: tuple[Quantity, ...]
    # (label, particles or None) -> {quantity key: value, or (lo, hi) for a range}
    values: dict
    notes: tuple[str, ...] = ()
    not_comparable: str | None = None   # the reason, when no value of ours can be compared
    # quantity keys whose order across rows the paper claims or its values show
    ranking: tuple[str, ...] | None = None
    # (label, particles or None, quantity key) -> why that one paper value cannot be compared
    cell_notes: dict = field(default_factory=dict)
    per_trial: PerTrial | None = None
    # (quantity key, from label, to label, margin or None): the paper's factor between two rows
    factors: tuple[tuple[str, str, str, Margin | None], ...] = ()
    runs: int | None = None             # runs behind the values, when the paper states it
    # what our results show of this table, in a sentence with {CONFIG:RUN:COLUMN} references
    # (the report's index prints it: ``headline``)
    headline: Finding | None = None

    def row(self, label: str, particles: int | None) -> dict:
        """The paper's values for a filter run: {quantity key: value, or (lo, hi) for a range};
        a row the paper gives without a particle count matches any."""
        return self.values.get((label, particles)) or self.values.get((label, None), {})


@dataclass(frozen=True)
class Curve:
    """A figure's values, or a table's row, as a curve over a swept config key: the points the
    paper gives (x increasing), what y is (our metric and statistic, times ``scale`` in the
    paper's unit), the filter runs it is about, and the declared reading error (how far a value
    read off the figure may lie from the one the paper plotted) and margin. A sweep over ``x_key``
    is judged against it point by point (pfbench.curves)."""
    caption: str
    x_key: str                          # the swept config key path (scenario.speed_mps)
    x_title: str
    metric: str                         # our per-trial metric column
    stat: str                           # 'mean' or 'var' over trials
    y_title: str
    filters: tuple[str, ...]            # filter names (config keys), run keys or labels
    reading_error: Margin               # each point's value is known to within this
    points: tuple[tuple[float, float], ...]
    margin: Margin | None = None        # how far ours may lie from it and still be the same
    scale: float = 1.0                  # our metric times this is in the paper's unit
    runs: int | None = None             # runs behind the values, when the paper states it
    notes: tuple[str, ...] = ()


@dataclass(frozen=True)
class Ref:
    """A reference of a finding to our results: ``{config:run:column}``, ``:ci`` adding the 95%
    interval. ``config``: an experiment's name (its results folder); ``run``: a filter run's key
    (``pf@50``); ``column``: a column of its comparison table (table.csv)."""
    text: str
    config: str
    run: str
    column: str
    ci: bool


REF = re.compile(r"\{([\w.-]+):([\w.@-]+):(\w+)(:ci)?\}")


@dataclass(frozen=True)
class Finding:
    """A sentence of the report's summary of a paper, with references to our results."""
    text: str
    refs: tuple[Ref, ...]
    line: int | None = None


@dataclass(frozen=True)
class Paper:
    key: str
    citation: str
    tables: dict = field(default_factory=dict)
    # (what the paper leaves open, config key paths holding the values we use)
    choices: tuple[tuple[str, tuple[str, ...]], ...] = ()
    findings: tuple[Finding, ...] = ()
    source: str = ""
    about: str = ""
    curves: dict = field(default_factory=dict)     # name -> Curve
    # the algorithms the paper proposes or uses, step by step as its text gives them, and where
    # pfbench follows each step (``Algorithm``)
    implementation: tuple = ()
    # choice id -> its index in ``choices`` (the choices that readings cover have one)
    choice_ids: dict = field(default_factory=dict)
    # table name -> the readings of the paper's open choices declared for it (Reading)
    readings: dict = field(default_factory=dict)


# ---------------------------------------------------------------- the schema of a paper file

_TOP = {
    "paper": Key("str", doc="the paper's key, which configs name (paper: KEY); the file's name "
                 "without .yaml"),
    "citation": Key("str", doc="authors, title, venue, year"),
    "about": Key("str", None, "what the paper proposes and on which model, in a paragraph (the "
                 "report prints it under the paper's heading)", nullable=True),
}
_TABLE = {
    "caption": Key("str", doc="what the table shows, in a sentence"),
    "runs": Key("int", None, "the number of runs behind its values, when the paper states it (1: "
                "a single run)", nullable=True, min=1),
    "not_comparable": Key("str", None, "why no value of ours can be held against the paper's "
                          "(the values are still shown)", nullable=True),
}
_QUANTITY = {
    "title": Key("str", doc="the column's name"),
    "metric": Key("choice", doc="our per-trial metric it stands beside",
                  choices=tuple(METRICS) + DERIVED_METRICS),
    "stat": Key("choice", "mean", "the statistic over runs the paper prints: mean or var",
                choices=STATS),
    "scale": Key("float", 1.0, "our metric times this is in the paper's unit (1000: m -> mm)",
                 min=0.0, min_exclusive=True),
    "not_comparable": Key("str", None, "why our values cannot be held against this column",
                          nullable=True),
    "judged_by": Key("choice", None, "a deterministic measure of the same quantity the verdict "
                     "uses instead of ours (evals_ratio, for a run-time ratio)", nullable=True,
                     choices=("evals_ratio",)),
}
_MARGIN = {
    "relative": Key("float", None, "as a fraction of the paper's value (0.1: within 10%)",
                    nullable=True, min=0.0),
    "absolute": Key("float", None, "in the quantity's unit", nullable=True, min=0.0),
    "why": Key("str", doc="why a difference this small means the same result"),
}
_CELL_NOTE = {
    "label": Key("str", doc="the row's label"),
    "particles": Key("int", None, "the row's particle count", nullable=True, min=1),
    "quantity": Key("str", doc="the column"),
    "note": Key("str", doc="why this value cannot be compared"),
}
_PER_TRIAL = {
    "metric": Key("choice", doc="our per-trial metric", choices=tuple(METRICS)),
    "title": Key("str", doc="the table's title"),
}
_PER_TRIAL_ROW = {
    "name": Key("str", doc="the paper's name for the row"),
    "label": Key("str", doc="the label of our filter run beside it"),
    "values": Key("floats", doc="the paper's value of each run"),
}
_FACTOR = {
    "quantity": Key("str", doc="the column"),
    "from": Key("str", doc="the row divided by"),
    "to": Key("str", doc="the row divided"),
}
_CURVE = {
    "caption": Key("str", doc="what the figure (or the table's row) shows, in a sentence"),
    "scale": Key("float", 1.0, "our metric times this is in the paper's unit", min=0.0,
                 min_exclusive=True),
    "runs": Key("int", None, "the number of runs behind the values, when the paper states it",
                nullable=True, min=1),
}
_CURVE_X = {
    "key": Key("str", doc="the config key path the sweep varies (scenario.speed_mps)"),
    "title": Key("str", doc="the axis's name, with its unit"),
}
_CURVE_Y = {
    "metric": Key("choice", doc="our per-trial metric it stands beside", choices=tuple(METRICS)),
    "stat": Key("choice", "mean", "the statistic over runs the paper plots: mean or var",
                choices=STATS),
    "title": Key("str", doc="the axis's name, with its unit"),
}
_CHOICE = {
    "what": Key("str", doc="what the paper leaves open"),
}


def _list(raw: Any, path: str, allow_empty: bool = False) -> list:
    if raw is None and allow_empty:
        return []
    if not isinstance(raw, list) or (not raw and not allow_empty):
        raise ConfigError(path, f"expected a list, got {describe(raw)}")
    return raw


def _strings(raw: Any, path: str) -> tuple[str, ...]:
    items = _list(raw, path, allow_empty=True)
    for i, s in enumerate(items):
        if not isinstance(s, str) or not s.strip():
            raise ConfigError(f"{path}[{i}]", f"expected a non-empty string, got {describe(s)}")
    return tuple(items)


def _quantities(raw: Any, path: str) -> tuple[Quantity, ...]:
    raw = check_mapping(path, raw)
    if not raw:
        raise ConfigError(path, "expected at least one quantity")
    out = []
    for key, spec in raw.items():
        spec = check_mapping(f"{path}.{key}", spec)
        q = check_section(spec, _QUANTITY, f"{path}.{key}", ignore=("margin",))
        out.append(Quantity(str(key), q["title"], q["metric"], q["stat"], q["not_comparable"],
                            q["scale"], _margin(spec.get("margin"), f"{path}.{key}.margin"),
                            q["judged_by"]))
    return tuple(out)


def _margin(raw: Any, path: str) -> Margin | None:
    if raw is None:
        return None
    m = check_section(raw, _MARGIN, path)
    if (m["relative"] is None) == (m["absolute"] is None):
        raise ConfigError(path, "give one of 'relative' or 'absolute', with 'why'")
    return Margin(m["relative"], m["absolute"], m["why"])


def _known(name: str, options, path: str, what: str) -> str:
    if name not in options:
        raise ConfigError(path, f"no {what} '{name}'" + did_you_mean(name, list(options))
                          + f"; {what}s: {', '.join(options)}")
    return name


def _values(raw: Any, path: str, qkeys: tuple[str, ...]) -> dict:
    out: dict = {}
    for i, row in enumerate(_list(raw, path, allow_empty=True)):
        here = f"{path}[{i}]"
        row = check_mapping(here, row)
        label = Key("str", doc="").validate(f"{here}.label", row.get("label"))
        n = Key("int", None, nullable=True, min=1).validate(f"{here}.particles",
                                                            row.get("particles"))
        vals = {}
        for k, v in row.items():
            if k in ("label", "particles"):
                continue
            _known(k, qkeys, f"{here}.{k}", "quantity")
            if isinstance(v, list):             # a range the paper gives
                rng = Key("floats").validate(f"{here}.{k}", v)
                if len(rng) != 2 or rng[0] > rng[1]:
                    raise ConfigError(f"{here}.{k}", f"a range is [low, high], got {v}")
                vals[k] = rng
            else:
                vals[k] = Key("float").validate(f"{here}.{k}", v)
        if (label, n) in out:
            raise ConfigError(here, f"a second row for {label}"
                              + (f" at {n} particles" if n else ""))
        out[(label, n)] = vals
    return out


def _table(raw: Any, path: str) -> Table:
    raw = check_mapping(path, raw)
    parts = ("quantities", "values", "notes", "ranking", "cell_notes", "per_trial", "factors",
             "headline")
    top = check_section(raw, _TABLE, path, ignore=parts)
    if "quantities" not in raw:
        raise ConfigError(f"{path}.quantities", "missing required key (a mapping of column key "
                          "-> title, metric, stat)")
    quantities = _quantities(raw["quantities"], f"{path}.quantities")
    qkeys = tuple(q.key for q in quantities)
    values = _values(raw.get("values"), f"{path}.values", qkeys)
    labels = sorted({lab for lab, _ in values})
    ranking = None
    if raw.get("ranking") is not None:
        ranking = tuple(_known(k, qkeys, f"{path}.ranking[{i}]", "quantity")
                        for i, k in enumerate(_strings(raw["ranking"], f"{path}.ranking")))
    cell_notes = {}
    for i, c in enumerate(_list(raw.get("cell_notes"), f"{path}.cell_notes", True)):
        c = check_section(c, _CELL_NOTE, f"{path}.cell_notes[{i}]")
        _known(c["quantity"], qkeys, f"{path}.cell_notes[{i}].quantity", "quantity")
        cell_notes[(c["label"], c["particles"], c["quantity"])] = c["note"]
    per_trial = None
    if raw.get("per_trial") is not None:
        p = f"{path}.per_trial"
        spec = check_mapping(p, raw["per_trial"])
        top_pt = check_section(spec, _PER_TRIAL, p, ignore=("rows", "also"))
        rows = []
        for i, r in enumerate(_list(spec.get("rows"), f"{p}.rows")):
            r = check_section(r, _PER_TRIAL_ROW, f"{p}.rows[{i}]")
            rows.append((r["name"], r["label"], tuple(r["values"])))
        also = tuple(_known(m, tuple(METRICS), f"{p}.also[{i}]", "metric")
                     for i, m in enumerate(_strings(spec.get("also"), f"{p}.also")))
        per_trial = PerTrial(top_pt["metric"], top_pt["title"], tuple(rows), also)
    factors = []
    for i, f in enumerate(_list(raw.get("factors"), f"{path}.factors", True)):
        here = f"{path}.factors[{i}]"
        f = check_mapping(here, f)
        margin = _margin(f.get("margin"), f"{here}.margin")
        f = check_section(f, _FACTOR, here, ignore=("margin",))
        _known(f["quantity"], qkeys, f"{here}.quantity", "quantity")
        for end in ("from", "to"):
            _known(f[end], labels, f"{here}.{end}", "row label")
        factors.append((f["quantity"], f["from"], f["to"], margin))
    return Table(top["caption"], quantities, values, _strings(raw.get("notes"), f"{path}.notes"),
                 top["not_comparable"], ranking, cell_notes, per_trial, tuple(factors),
                 top["runs"], headline(raw.get("headline"), f"{path}.headline"))


def _points(raw: Any, path: str) -> tuple[tuple[float, float], ...]:
    """A curve's [[x, y], ...]: numbers, x strictly increasing."""
    out = []
    for i, pt in enumerate(_list(raw, path)):
        here = f"{path}[{i}]"
        xy = Key("floats").validate(here, pt)
        if len(xy) != 2:
            raise ConfigError(here, f"a point is [x, y], got {pt}")
        if not all(map(math.isfinite, xy)):
            raise ConfigError(here, f"a point's x and y are finite numbers, got {pt}")
        if out and not xy[0] > out[-1][0]:
            raise ConfigError(here, f"the points' x must increase: {xy[0]:g} follows "
                              f"{out[-1][0]:g}")
        out.append((float(xy[0]), float(xy[1])))
    return tuple(out)


def _curve(raw: Any, path: str) -> Curve:
    raw = check_mapping(path, raw)
    parts = ("x", "y", "filter", "reading_error", "margin", "points", "notes")
    top = check_section(raw, _CURVE, path, ignore=parts)
    for part, what in (("x", "{key: CONFIG.KEY.PATH, title: ...}"),
                       ("y", "{metric: rmse, stat: mean, title: ...}"),
                       ("filter", "the filter runs it is about: a filter's name under "
                        "'filters', a run key (pf@100) or a label, or a list of them"),
                       ("reading_error", "{absolute: or relative: ..., why: how the values "
                        "were read}"),
                       ("points", "[[x, y], ...] with x increasing")):
        if part not in raw:
            raise ConfigError(f"{path}.{part}", f"missing required key ({what})")
    x = check_section(raw["x"], _CURVE_X, f"{path}.x")
    y = check_section(raw["y"], _CURVE_Y, f"{path}.y")
    filters = raw["filter"]
    filters = _strings([filters] if isinstance(filters, str) else filters, f"{path}.filter")
    if not filters or len(set(filters)) != len(filters):
        raise ConfigError(f"{path}.filter", f"expected one or more distinct names, got "
                          f"{describe(raw['filter'])}")
    return Curve(top["caption"], x["key"], x["title"], y["metric"], y["stat"], y["title"],
                 filters, _margin(raw["reading_error"], f"{path}.reading_error"),
                 _points(raw["points"], f"{path}.points"),
                 _margin(raw.get("margin"), f"{path}.margin"), top["scale"], top["runs"],
                 _strings(raw.get("notes"), f"{path}.notes"))


def _curves(raw: Any) -> dict:
    """The ``curves:`` section: name -> Curve."""
    return {str(name): _curve(c, f"curves.{name}")
            for name, c in check_mapping("curves", raw or {}).items()}


def _findings(raw: Any, lines: dict[str, int]) -> tuple[Finding, ...]:
    out = []
    for i, text in enumerate(_strings(raw, "findings")):
        refs = tuple(Ref(m.group(0), m.group(1), m.group(2), m.group(3), bool(m.group(4)))
                     for m in REF.finditer(text))
        # a brace that is not a reference is a typo of one
        rest = REF.sub("", text)
        if "{" in rest or "}" in rest:
            bad = rest[rest.find("{"):][:40] if "{" in rest else rest[:rest.find("}") + 1][-40:]
            raise ConfigError(f"findings[{i}]", f"'{bad}...' is not a reference "
                              "{CONFIG:RUN:COLUMN} or {CONFIG:RUN:COLUMN:ci}")
        out.append(Finding(text, refs, lines.get(f"findings[{i}]")))
    return tuple(out)


def headline(raw: Any, path: str) -> Finding | None:
    """A table's ``headline:``: what our results show of it, in one sentence whose
    ``{CONFIG:RUN:COLUMN}`` (or ``:ci``) references the report fills in as a finding's; the
    report's index prints it beside the table's verdict counts. None where the table has none;
    a ConfigError for an empty text, a text of several lines, or a brace that is not a
    reference."""
    if raw is None:
        return None
    if not isinstance(raw, str) or not raw.strip():
        raise ConfigError(path, f"expected a sentence, got {describe(raw)}")
    text = " ".join(raw.split())
    rest = REF.sub("", text)
    if "{" in rest or "}" in rest:
        bad = rest[rest.find("{"):][:40] if "{" in rest else rest[:rest.find("}") + 1][-40:]
        raise ConfigError(path, f"'{bad}...' is not a reference {{CONFIG:RUN:COLUMN}} or "
                          "{CONFIG:RUN:COLUMN:ci}")
    refs = tuple(Ref(m.group(0), m.group(1), m.group(2), m.group(3), bool(m.group(4)))
                 for m in REF.finditer(text))
    return Finding(text, refs)


# ---------------------------------------------------------------- the algorithms, step by step

STATUSES = ("follows", "open", "departs")
_CHOICE_ID = re.compile(r"[a-z0-9_]+")


@dataclass(frozen=True)
class Step:
    """A step of an algorithm as the paper's text gives it, and where pfbench does it."""
    name: str                   # a few words: what the step does
    text: str                   # the text's words, quoted in the original language
    english: str                # their translation
    functions: tuple[str, ...]  # the functions of pfbench that do it (dotted import paths)
    status: str                 # 'follows', 'open' (a choice the text leaves open), 'departs'
    note: str = ""              # how: the reading pfbench takes, or why it departs
    choice: str | None = None   # the id of the paper's open choice (its ``choices:`` entry)
    damaged: str | None = None  # where the text's extraction is damaged, if it is


@dataclass(frozen=True)
class Algorithm:
    """An algorithm the paper proposes or uses: its steps as the text gives them."""
    name: str
    where: str                  # where the paper gives it (section, equations)
    steps: tuple[Step, ...]


_ALGORITHM = {
    "algorithm": Key("str", doc="the algorithm's name (IFA-PF, stepwise EWA resampling, ...)"),
    "where": Key("str", doc="where the paper gives it: section, equations"),
}
_STEP = {
    "step": Key("str", doc="what the step does, in a few words"),
    "text": Key("str", doc="the step in the paper's words, quoted exactly in the original "
                "language"),
    "english": Key("str", doc="the quote translated into English, saying no more than it says"),
    "damaged": Key("str", None, "where the text's extraction is damaged (symbols, numbers "
                   "lost) and how the quote reads it", nullable=True),
    "status": Key("choice", doc="how pfbench does the step: 'follows' the text, makes a choice "
                  "it leaves 'open', or 'departs' from it", choices=STATUSES),
    "choice": Key("str", None, "open: the id of the open choice (the paper's choices)",
                  nullable=True),
    "note": Key("str", None, "open: the readings the text allows and pfbench's default; "
                "departs: what pfbench does instead and why; follows: anything to add",
                nullable=True),
}


def function_problem(path: str) -> str | None:
    """Why the dotted path ``path`` names no importable function (or object), or None: its
    longest importable module prefix, then attributes."""
    import importlib
    parts = path.split(".")
    if not all(p.isidentifier() for p in parts) or len(parts) < 2:
        return f"'{path}' is not a dotted path module.function"
    for cut in range(len(parts) - 1, 0, -1):
        module = ".".join(parts[:cut])
        try:
            obj = importlib.import_module(module)
        except ModuleNotFoundError as exc:
            if exc.name and (module == exc.name or module.startswith(exc.name + ".")):
                continue    # no such module: a shorter prefix may be the module
            return f"'{path}': importing {module} fails (no module {exc.name})"
        except Exception as exc:      # a module that fails to import is a problem of its own
            return f"'{path}': importing {module} fails ({type(exc).__name__}: {exc})"
        for attr in parts[cut:]:
            if not hasattr(obj, attr):
                return f"'{path}': {module} has no {'.'.join(parts[cut:])}"
            obj = getattr(obj, attr)
        return None
    return f"'{path}': no module {parts[0]}"


def _step(raw: Any, path: str) -> Step:
    raw = check_mapping(path, raw)
    for need in ("text", "english"):
        v = raw.get(need)
        if v is None or (isinstance(v, str) and not v.strip()):
            raise ConfigError(f"{path}.{need}", "a step needs the text's words ('text', quoted "
                              "in the original) and their translation ('english')")
    s = check_section(raw, _STEP, path, ignore=("pfbench",))
    funcs = raw.get("pfbench")
    funcs = [funcs] if isinstance(funcs, str) else funcs
    if not funcs:
        raise ConfigError(f"{path}.pfbench", "missing: the function(s) of pfbench that do the "
                          "step, as dotted paths (pfbench.filters.swarm.ifa_move)")
    funcs = _strings(funcs, f"{path}.pfbench")
    for k, f in enumerate(funcs):
        problem = function_problem(f)
        if problem:
            raise ConfigError(f"{path}.pfbench" + (f"[{k}]" if len(funcs) > 1 else ""),
                              f"{problem}: name a function that exists")
    if s["choice"] is not None and not _CHOICE_ID.fullmatch(s["choice"]):
        raise ConfigError(f"{path}.choice", f"'{s['choice']}' is not a choice id ([a-z0-9_]+)")
    if s["status"] != "follows" and not (s["note"] or "").strip():
        why = ("what pfbench does instead and why" if s["status"] == "departs"
               else "the readings the text allows and pfbench's default")
        raise ConfigError(f"{path}.note", f"a step with status {s['status']} needs a note: {why}")
    return Step(s["step"], s["text"], s["english"], funcs, s["status"], s["note"] or "",
                s["choice"], s["damaged"])


def implementation(raw: Any) -> tuple[Algorithm, ...]:
    """The paper file's ``implementation:``: per algorithm, its steps as the text gives them
    (quoted, translated) and the functions of pfbench that do each (each must import), with
    whether pfbench follows the step, reads a choice it leaves open, or departs from it."""
    out = []
    names: set[str] = set()
    for i, a in enumerate(_list(raw, "implementation", allow_empty=True)):
        here = f"implementation[{i}]"
        a = check_mapping(here, a)
        top = check_section(a, _ALGORITHM, here, ignore=("steps",))
        if top["algorithm"] in names:
            raise ConfigError(f"{here}.algorithm", f"a second algorithm '{top['algorithm']}'")
        names.add(top["algorithm"])
        steps = tuple(_step(s, f"{here}.steps[{j}]")
                      for j, s in enumerate(_list(a.get("steps"), f"{here}.steps")))
        out.append(Algorithm(top["algorithm"], top["where"], steps))
    return tuple(out)


def parse(raw: Any, source: str, lines: dict[str, int] | None = None) -> Paper:
    """A paper from the raw mapping of a paper file (ConfigError: file, line, key)."""
    lines = lines or {}
    try:
        raw = check_mapping("", raw if raw is not None else {})
        top = check_section(raw, _TOP, "", ignore=("tables", "choices", "findings",
                                                                "curves", "implementation",
                                                                "readings"))
        stem = Path(source).stem
        if source and top["paper"] != stem:
            raise ConfigError("paper", f"'{top['paper']}' in a file named {stem}.yaml: the key "
                              "is the file's name")
        tables = {}
        for name, t in check_mapping("tables", raw.get("tables") or {}).items():
            tables[str(name)] = _table(t, f"tables.{name}")
        choices = []
        for i, c in enumerate(_list(raw.get("choices"), "choices", True)):
            c = check_mapping(f"choices[{i}]", c)
            what = check_section(c, _CHOICE, f"choices[{i}]", ignore=("keys", "id"))["what"]
            choices.append((what, _strings(c.get("keys"), f"choices[{i}].keys")))
        ids = _choice_ids(raw.get("choices"))
        readings = _readings(raw.get("readings"), tables, ids)
        return Paper(top["paper"], top["citation"], tables, tuple(choices),
                     _findings(raw.get("findings"), lines), source, top["about"] or "",
                     curves=_curves(raw.get("curves")),
                     implementation=implementation(raw.get("implementation")),
                     choice_ids=ids, readings=readings)
    except ConfigError as err:
        raise err.located(source, lines) from None


# ---------------------------------------------------------------- readings of the open choices

@dataclass(frozen=True)
class Reading:
    """One reading of choices a paper leaves open: config key paths and the values that make it,
    applied on top of a config of the paper's table (pfbench.readings runs them)."""
    name: str                       # [a-z0-9_]+, unique within its table
    title: str                      # a short label for tables
    choices: tuple[str, ...]        # the ids of the paper's choices it reads
    set: tuple[tuple[str, Any], ...]    # (key path, value): 'filters.NAME.KEY',
                                        # 'filters.*.KEY' or 'scenario.KEY'
    why: str                        # what in the paper's text supports it


NAME_RE = re.compile(r"[a-z0-9_]+")
DEFAULT_READING = "pfbench"         # the config as committed: implicit, never declared
TITLE_MAX = 40
_READING = {
    "name": Key("str", doc="the reading's name, [a-z0-9_]+, unique within the table"),
    "title": Key("str", doc=f"a short label for tables (under {TITLE_MAX} characters)"),
    "why": Key("str", doc="one line: what in the paper's text supports this reading"),
}


def _choice_ids(raw: Any) -> dict[str, int]:
    """The ids of the paper file's choices: id -> index ([a-z0-9_]+, unique)."""
    ids: dict[str, int] = {}
    for i, c in enumerate(raw or []):
        if not isinstance(c, dict) or c.get("id") is None:
            continue
        here = f"choices[{i}].id"
        cid = c["id"]
        if not isinstance(cid, str) or not NAME_RE.fullmatch(cid):
            raise ConfigError(here, f"expected lowercase letters, digits and _, got "
                              f"{describe(cid)}")
        if cid in ids:
            raise ConfigError(here, f"'{cid}' is also the id of choices[{ids[cid]}]")
        ids[cid] = i
    return ids


def _reading_path(path: str, here: str) -> str:
    """A reading's key path, checked for its form: filters.NAME.KEY (NAME may be *) or
    scenario.KEY."""
    parts = path.split(".") if isinstance(path, str) else []
    if parts[:1] == ["filters"] and len(parts) == 3 and all(parts):
        return path
    if parts[:1] == ["scenario"] and len(parts) == 2 and parts[1] and parts[1] != "name":
        return path
    raise ConfigError(here, f"'{path}': a reading sets filters.NAME.KEY, filters.*.KEY or "
                      "scenario.KEY (not the scenario's name, trials or seed)")


def _readings(raw: Any, tables: dict, ids: dict[str, int]) -> dict[str, tuple[Reading, ...]]:
    """The ``readings:`` section: table name -> its readings, each checked for its form (the key
    paths and values are checked against a config when one runs them: pfbench.readings)."""
    out: dict[str, tuple[Reading, ...]] = {}
    for table, items in check_mapping("readings", raw or {}).items():
        path = f"readings.{table}"
        _known(str(table), list(tables), path, "table")
        found: list[Reading] = []
        for i, item in enumerate(_list(items, path)):
            here = f"{path}[{i}]"
            item = check_mapping(here, item)
            top = check_section(item, _READING, here, ignore=("choice", "set"))
            name = top["name"]
            if not NAME_RE.fullmatch(name):
                raise ConfigError(f"{here}.name", f"'{name}': lowercase letters, digits and _")
            if name == DEFAULT_READING:
                raise ConfigError(f"{here}.name", f"'{name}' is the config as it is (implicit, "
                                  "never declared)")
            if any(r.name == name for r in found):
                raise ConfigError(f"{here}.name", f"a second reading named '{name}' in {table}")
            if len(top["title"]) >= TITLE_MAX:
                raise ConfigError(f"{here}.title", f"{len(top['title'])} characters; under "
                                  f"{TITLE_MAX}, please")
            chosen = item.get("choice")
            chosen = [chosen] if isinstance(chosen, str) else chosen
            if not isinstance(chosen, list) or not chosen:
                raise ConfigError(f"{here}.choice", "expected the id of a choice, or a list of "
                                  f"them, got {describe(item.get('choice'))}")
            for c in chosen:
                if not isinstance(c, str) or c not in ids:
                    raise ConfigError(f"{here}.choice", "no choice with the id "
                                      + (f"'{c}'" if isinstance(c, str) else describe(c))
                                      + (did_you_mean(c, list(ids)) if isinstance(c, str)
                                         else "") + f"; ids: {', '.join(ids) or 'none'} (give "
                                      "the choice an 'id')")
            sets = check_mapping(f"{here}.set", item.get("set"))
            if not sets:
                raise ConfigError(f"{here}.set", "expected at least one key path -> value")
            pairs = tuple((_reading_path(k, f"{here}.set"), v) for k, v in sets.items())
            found.append(Reading(name, top["title"], tuple(chosen), pairs, top["why"]))
        out[str(table)] = tuple(found)
    return out


def read(path: str | Path) -> Paper:
    """The paper of a paper file."""
    return _parse_bytes(read_regular(path), path)


def _parse_bytes(data: bytes, path: str | Path) -> Paper:
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ConfigError("", f"not UTF-8 text (byte {exc.start})", source=show_path(path)) \
            from None
    raw, lines = parse_yaml(text, show_path(path))
    return parse(raw, show_path(path), lines)


# ---------------------------------------------------------------- finding a paper

_search: list[Path] = []


def search_folders(folders) -> None:
    """The folders given on the command line (``--papers``), looked in first."""
    _search[:] = [Path(f) for f in folders]
    for f in _search:
        if not f.is_dir():
            raise UserError(f"--papers {f}: no such folder")


def _unique(folders) -> list[Path]:
    seen, out = set(), []
    for f in folders:
        key = Path(f).resolve()
        if key not in seen:
            seen.add(key)
            out.append(Path(f))
    return out


def folders_for(config: str | Path | None) -> list[Path]:
    """Where the paper of the config at ``config`` is looked for, in order: the --papers
    folders, papers/ beside the config, configs/papers/ of the current folder."""
    beside = [Path(config).resolve().parent / "papers"] if config else []
    return _unique([*_search, *beside, Path.cwd() / "configs" / "papers"])


def folders_for_configs(configs: str | Path) -> list[Path]:
    """Where the papers of a folder of configs are: the --papers folders and its papers/."""
    return _unique([*_search, Path(configs) / "papers"])


def available(folders) -> dict[str, Path]:
    """Paper key -> file, over ``folders`` (the first folder that has a key wins)."""
    out: dict[str, Path] = {}
    for f in folders:
        if Path(f).is_dir():
            for p in sorted(Path(f).glob("*.yaml")):
                out.setdefault(p.stem, p)
    return out


_cache: dict[tuple, Paper] = {}


def find(key: str, config: str | Path | None = None) -> Paper:
    """The paper ``key`` for the config at ``config`` (ConfigError when no file has it)."""
    folders = folders_for(config)
    files = available(folders)
    if key not in files:
        where = ", ".join(str(f) for f in folders)
        raise ConfigError("paper", f"no paper file {key}.yaml in {where}"
                          + did_you_mean(key, list(files))
                          + "; give its folder with --papers")
    path = files[key]
    # a sweep validates its config once per cell: read the file each time (a regular file of
    # bounded size: read_regular), parse it once. A problem of the paper file names its own file
    # and line (a ConfigError whose source is set: the config's lines do not apply).
    data = read_regular(path)
    stamp = (str(path.resolve()), data)
    if stamp not in _cache:
        _cache[stamp] = _parse_bytes(data, path)
    return _cache[stamp]
