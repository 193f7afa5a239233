"""Readings of the choices a paper leaves open, each claim of its table judged under each.

A paper file declares, per table, its **readings** (``readings:``, pfbench.papers.Reading): each a
set of config key paths and values that reads an open choice of the paper one way, with the line
of the text that supports it. The config as committed is the reading ``pfbench``. ``pfbench run
CONFIG --readings`` runs the config (its results folder as always), then every reading on the same
trials (the same seed: common random numbers), and writes beside the table:

- ``readings/NAME/trials.csv`` and ``meta.json``: the trials of reading NAME, a results folder of
  its own (the reading's experiment). A filter run whose settings the reading leaves as they are is
  not run again: its rows are the config's (a filter run's random stream depends on the seed, the
  trial and its key only, pfbench.seeding, and its data on the seed and the trial: its rows do not
  depend on the other filters, which tests/test_readings.py checks);
- ``readings.csv``: one row per reading and judged claim (a cell of the paper's table, a gain, a
  factor, a pair of rows the paper orders): our value, its 95% interval, the verdict;
- ``readings.md``: one robustness line per claim ('differs under all 6 readings', 'reproduced
  only under: a, b'), then every claim under every reading.

Multiplicity: the verdicts of readings.csv are judged as one family per table across its cells and
its readings together (verdicts.decide_family over cells x readings, Holm's step-down procedure for
each kind of claim; the pairs of rows are a second family, as in a table), so that the chance of
any false 'reproduced' among all the readings stays at most 5%: more readings never give a claim
more chances. The config's own table.md is judged as always (its cells alone), so a verdict of the
``pfbench`` column of readings.md can be more cautious than table.md's.

``robustness_lines(folder)`` gives the lines of a results folder that holds readings.
"""
from __future__ import annotations

import copy
import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

from .errors import UserError
from .fsutil import atomic_write, ensure_folder, own_folder
from .papers import DEFAULT_READING, Reading
from .schema import ConfigError, did_you_mean

READINGS = "readings"           # the folder of the readings' trials, beside the table
CSV = "readings.csv"
MD = "readings.md"
# what a reading may not change: a filter run's identity (its rows would be another run's)
FIXED_KEYS = ("particles", "label", "type")
# readings.csv's columns
COLUMNS = ("reading", "claim", "kind", "label", "particles", "quantity", "paper", "ours", "lo",
           "hi", "verdict", "level", "verdict_text")
# a verdict in the readings table's cells (readings.md's legend says so)
SYMBOLS = {"reproduced": "=", "differs": "x", "inconclusive": "?", "not comparable": "-",
           "same": "<", "opposite": ">", "unresolved": "?"}
# a pair's verdict in the robustness lines
PAIR_WORDS = {"same": "in the paper's order", "opposite": "in the opposite order",
              "unresolved": "unresolved"}


@dataclass(frozen=True)
class ReadingRun:
    """A reading applied to a config: its name and title, the experiment it makes, and the
    filter runs it changes (those run again; the others' rows are the config's)."""
    name: str
    title: str
    exp: object                     # pfbench.config.Experiment
    changed: tuple[str, ...]
    reading: Reading | None = None  # None: the config as it is (``pfbench``)


def declared(exp) -> tuple[Reading, ...]:
    """The readings the paper file of ``exp`` declares for its table (() when none)."""
    if exp.reference is None or exp.table is None:
        return ()
    return tuple(exp.reference.readings.get(exp.table, ()))


def parse_names(text: str | None) -> list[str] | None:
    """The names of ``--readings NAME,NAME`` (None: every reading; 'all' too)."""
    if text is None or text.strip() in ("", "all"):
        return None
    names = [n.strip() for n in text.split(",")]
    if any(not n for n in names):
        raise UserError(f"--readings {text}: expected NAME,NAME (no empty name)")
    return names


def _where(exp, reading: Reading) -> str:
    return f"reading '{reading.name}' (paper {exp.paper} readings.{exp.table})"


def plan(exp, names: list[str] | None = None) -> list[ReadingRun]:
    """The readings of ``exp`` to run, the config's own (``pfbench``) first: every reading its
    paper file declares for its table, or those ``names`` names. Each reading is applied to the
    config and validated as a config; a one-line UserError for a name the paper file does not
    declare, a key path the config does not have, a value the key refuses, or a reading that
    changes nothing."""
    have = declared(exp)
    if not have:
        where = (f"paper {exp.paper} declares no readings for {exp.table}" if exp.table
                 else "the config names no paper table")
        raise UserError(f"--readings: {where} (docs/how-to/readings.md)")
    by_name = {r.name: r for r in have}
    chosen = list(have)
    if names is not None:
        seen = set()
        for n in names:
            if n not in by_name:
                raise UserError(f"--readings: no reading '{n}' for {exp.paper} {exp.table}"
                                + did_you_mean(n, list(by_name))
                                + f"; readings: {', '.join(by_name)}")
            if n in seen:
                raise UserError(f"--readings: '{n}' named twice")
            seen.add(n)
        chosen = [by_name[n] for n in names]
    out = [ReadingRun(DEFAULT_READING, "the config as it is", exp, ())]
    for r in chosen:
        rexp = apply(exp, r)
        out.append(ReadingRun(r.name, r.title, rexp, changed_runs(exp, rexp), r))
    return out


def _filter_keys(ftype: str) -> dict:
    from .filters import FILTERS
    from .filters.types import FILTER_COMMON
    return {**FILTER_COMMON, **FILTERS[ftype].schema}


def targets(exp, reading: Reading) -> list[tuple[tuple[str, ...], object]]:
    """The (key path, value) pairs ``reading`` sets in ``exp``'s config, its wildcards expanded:
    ``filters.NAME.KEY`` names a filter of the config and a key its type declares,
    ``filters.*.KEY`` every filter whose type declares KEY (at least one), ``scenario.KEY`` a key
    of the scenario. A one-line UserError otherwise."""
    from .scenarios import SCENARIOS
    types = {}
    for f in exp.filters:
        types.setdefault(f.name, f.type)
    out = []
    for path, value in reading.set:
        parts = path.split(".")
        bad = f"{_where(exp, reading)}: {path}"
        if parts[0] == "scenario":
            schema = SCENARIOS[exp.scenario].SCHEMA
            if parts[1] not in schema:
                raise UserError(f"{bad}: scenario '{exp.scenario}' has no key '{parts[1]}'"
                                + did_you_mean(parts[1], list(schema)))
            out.append((("scenario", parts[1]), value))
            continue
        name, key = parts[1], parts[2]
        if key in FIXED_KEYS:
            raise UserError(f"{bad}: a reading cannot change a filter's {key} (its runs would be "
                            "other runs)")
        if name != "*" and name not in types:
            raise UserError(f"{bad}: no filter '{name}' in {exp.source}"
                            + did_you_mean(name, list(types)) + f"; filters: {', '.join(types)}")
        names = list(types) if name == "*" else [name]
        hits = [n for n in names if key in _filter_keys(types[n])]
        if name != "*" and not hits:
            raise UserError(f"{bad}: filter '{name}' (type {types[name]}) has no key '{key}'"
                            + did_you_mean(key, list(_filter_keys(types[name]))))
        if not hits:
            raise UserError(f"{bad}: no filter of {exp.source} has the key '{key}'")
        out += [(("filters", n, key), value) for n in hits]
    return out


def apply(exp, reading: Reading):
    """The experiment of ``reading``: ``exp``'s config with the reading's values set, validated
    as a config (its values checked by the keys' own rules)."""
    from .config import validate
    raw = copy.deepcopy(exp.raw)
    raw["trials"], raw["seed"] = exp.trials, exp.seed     # the config's (as run, overrides too)
    for path, value in targets(exp, reading):
        if path[0] == "scenario":
            raw.setdefault("scenario", {})[path[1]] = copy.deepcopy(value)
            continue
        filters = raw["filters"]
        if filters.get(path[1]) is None:        # a filter written as 'name:' with no keys
            filters[path[1]] = {}
        filters[path[1]][path[2]] = copy.deepcopy(value)
    try:
        rexp = validate(raw, exp.source)
    except ConfigError as err:
        raise UserError(f"{_where(exp, reading)}: {err}") from None
    if rexp.hash == exp.hash:
        raise UserError(f"{_where(exp, reading)}: changes nothing in {exp.source} (its values "
                        "are the config's); a reading must change at least one value")
    return rexp


def changed_runs(exp, rexp) -> tuple[str, ...]:
    """The filter runs of reading experiment ``rexp`` whose settings differ from ``exp``'s (every
    run when the scenario or the seed differ)."""
    if rexp.scenario != exp.scenario or dict(rexp.scenario_params) != dict(exp.scenario_params) \
            or rexp.seed != exp.seed:
        return tuple(f.key for f in rexp.filters)
    base = {f.key: f for f in exp.filters}
    return tuple(f.key for f in rexp.filters if base.get(f.key) != f)


# ---------------------------------------------------------------- running the readings

def reading_folder(folder: Path, name: str) -> Path:
    return Path(folder) / READINGS / name


def up_to_date(run: ReadingRun, folder: Path) -> bool:
    """Whether ``folder``'s readings/NAME holds every trial of the reading's experiment."""
    from .store import read_results
    target = reading_folder(folder, run.name)
    if not (target / "meta.json").is_file():
        return False
    try:
        meta, got = read_results(target)
    except UserError:
        return False
    made_on = (meta.get("reading") or {}).get("config_trials_sha256")
    return (meta.get("experiment_hash") == run.exp.hash and meta.get("trials") == run.exp.trials
            and not got.rejected and made_on == _digest(folder))


def run_reading(run: ReadingRun, folder: Path, executor,
                progress: Callable[[int, int], None] | None = None) -> Path:
    """Run reading ``run`` into ``folder``/readings/NAME beside the config's results in
    ``folder`` (its trials.csv read for the filter runs the reading leaves as they are): the
    changed filter runs on every trial, then trials.csv (every filter run, as a run of the
    reading's experiment writes it) and meta.json. Returns the folder."""
    from .diagnostics import reported_metrics
    from .runner import stamp_meta
    from .store import csv_text, read_results, trial_columns, write_json
    exp, folder = run.exp, Path(folder)
    target = reading_folder(folder, run.name)
    own_folder(target, folder, "readings folder")
    changed = set(run.changed)
    sub = replace(exp, filters=tuple(f for f in exp.filters if f.key in changed))
    if reported_metrics(sub) != reported_metrics(exp):    # its rows would lack columns
        sub, changed = exp, {f.key for f in exp.filters}
    base: dict = {}
    if len(changed) < len(exp.filters):
        meta, got = read_results(folder)
        if meta.get("trials") != exp.trials or meta.get("seed") != exp.seed:
            raise UserError(f"{folder}: holds {meta.get('trials')} trials of seed "
                            f"{meta.get('seed')}; the readings need the config's {exp.trials} "
                            f"of seed {exp.seed}")
        base = {(r["trial"], r["filter"]): r for r in got.rows}
    new: dict = {}
    if progress:
        progress(0, exp.trials)
    if sub.filters:
        chunks = executor.run(sub, range(exp.trials), exp.trials, True)
        try:
            for chunk in chunks:
                for t in chunk:
                    new.setdefault(t.index, {r["filter"]: r for r in t.rows})
                if progress:
                    progress(len(new), exp.trials)
        finally:
            chunks.close()          # on Ctrl-C the workers stop now
    rows = []
    for k in range(exp.trials):
        for f in exp.filters:
            r = new[k][f.key] if f.key in changed else base.get((k, f.key))
            if r is None:
                raise UserError(f"{folder}/trials.csv: no row for {f.key} of trial {k}; run the "
                                "config again (--force)")
            rows.append({c: v for c, v in r.items() if c not in ("wall_s", "crc")})
    text = csv_text(rows, True, trial_columns(exp))
    ensure_folder(target, "readings folder")
    (target / "meta.json").unlink(missing_ok=True)
    atomic_write(target / "trials.csv", text)
    meta = stamp_meta(exp, target, text)
    meta["reading"] = {"name": run.name, "title": run.title,
                       "set": [[k, v] for k, v in run.reading.set] if run.reading else [],
                       "run_again": sorted(changed, key=[f.key for f in exp.filters].index),
                       "config_trials_sha256": _digest(folder)}
    write_json(target / "meta.json", json.loads(json.dumps(meta, default=str)))
    return target


def _digest(folder: Path) -> str | None:
    try:
        return json.loads((Path(folder) / "meta.json").read_text(encoding="utf-8")).get(
            "trials_sha256")
    except (OSError, ValueError, AttributeError):
        return None


def run_all(runs: list[ReadingRun], folder: Path, executor,
            progress_for: Callable[[ReadingRun, bool], Callable | None] | None = None) -> None:
    """Run every reading of ``runs`` (the config's own first, already in ``folder``) that
    ``folder`` does not hold up to date; ``progress_for(run, up_to_date)`` is called as each
    begins and returns its progress callback (or None)."""
    for run in runs[1:]:
        fresh = up_to_date(run, folder)
        cb = progress_for(run, fresh) if progress_for else None
        if not fresh:
            run_reading(run, folder, executor, cb)


def carry(old: Path, new: Path, warn: Callable[[str], None] | None = None) -> bool:
    """Keep the readings of results folder ``old`` in ``new`` (a regeneration's staging folder)
    when ``new`` holds the same trials file: they were run on those trials. Otherwise they are
    dropped, and ``warn`` says so. Returns whether they were kept."""
    import shutil
    old, new = Path(old), Path(new)
    if not (old / READINGS).is_dir() or (new / READINGS).exists():
        return False
    try:
        same = (old / "trials.csv").read_bytes() == (new / "trials.csv").read_bytes()
    except OSError:
        same = False
    if not same:
        if warn:
            warn(f"{old}: the config's trials changed, so its readings are dropped; "
                 "'pfbench tables --readings' runs them again")
        return False
    own_folder(new / READINGS, new, "readings folder")
    shutil.copytree(old / READINGS, new / READINGS, symlinks=True)
    for name in (CSV, MD):
        if (old / name).is_file():
            atomic_write(new / name, (old / name).read_bytes())
    return True


def committed(exp, folder: Path) -> list[ReadingRun]:
    """The readings of ``exp`` (every one its paper file declares) whose trials results folder
    ``folder`` holds (readings/NAME/trials.csv); [] when it holds none."""
    if not declared(exp) or not (Path(folder) / READINGS).is_dir():
        return []
    return [r for r in plan(exp)[1:]
            if (reading_folder(folder, r.name) / "trials.csv").is_file()]


# ---------------------------------------------------------------- the claims a table judges

@dataclass(frozen=True)
class JudgedClaim:
    """A claim of the paper's table as one reading's trials give it: what it is, our value and
    its 95% interval, and the claim the verdict engine judges (verdicts.Claim)."""
    id: str
    kind: str           # 'cell', 'gain', 'factor' or 'pair'
    label: str
    particles: int | None
    quantity: str
    paper: object
    ours: float
    lo: float
    hi: float
    claim: object


def _fmt(v) -> str:
    """A value in three significant digits, trailing zeros kept (3.00, 2.98, 81.4)."""
    if isinstance(v, str):
        return v
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    text = f"{v:#.3g}"
    return text[:-1] if text.endswith(".") else text


def claims(exp, rows) -> list[JudgedClaim]:
    """The claims of ``exp``'s paper table that our trials ``rows`` judge, in the table's order:
    each cell with a paper value that can be judged (a gain's cells are 'gain'), each factor,
    then each pair of rows the paper orders (judged on paired trials)."""
    import pandas as pd
    from . import compare as cp
    from .metrics import summarize
    from .tables import judged_title
    from .verdicts import ALPHA, Claim
    table = exp.reported
    if table is None:
        return []
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    by_key = {f.key: df[df["filter"] == f.key] for f in exp.filters}
    floor = None
    if exp.compare["floor"] is not None:
        floor = summarize(by_key[exp.compare["floor"]]["rmse"])["ci_lo"]
    pairs = cp.baseline_runs(exp)
    out = []
    for run in exp.filters:
        g = by_key[run.key]
        base = by_key.get(pairs.get(run.key))
        for q in table.quantities:
            r: dict = {}
            judge, claim = cp._paper_cell(exp, table, run, q, r, g, base, floor, None, {})
            if (claim.paper is None or claim.not_comparable or not claim.judged
                    or (isinstance(claim.paper, float) and math.isnan(claim.paper))):
                continue
            lo, hi = judge.interval(1 - ALPHA)
            kind = "gain" if q.metric in ("gain_mean", "gain_var") else "cell"
            paper = r[f"paper_{q.key}"]
            # a quantity judged on another measure is named by that measure, never by ours
            title = q.title if q.judged_by is None else judged_title(q, exp)
            out.append(JudgedClaim(f"{kind}:{run.key}:{q.key}", kind, run.label,
                                   run.particles, title, paper, judge.value, lo, hi, claim))
    for row, claim in cp.factor_claims(exp, table, by_key):
        out.append(JudgedClaim(f"factor:{row['quantity']}:{row['from']}:{row['to']}", "factor",
                               f"{row['to']} / {row['from']}", None, row["quantity"],
                               row["paper"], row["ours"], row["lo"], row["hi"], claim))
    for q, n, low, high, est in _ordered_pairs(exp, table, by_key):
        lo, hi = est.interval(1 - ALPHA)
        out.append(JudgedClaim(f"pair:{q.key}:{n if n is not None else ''}:{low}<{high}",
                               "pair", f"{low} < {high}", n, q.title, "<", est.value, lo, hi,
                               Claim(0.0, est)))
    return out


def _ordered_pairs(exp, table, by_key) -> list:
    """(quantity, particles, low, high, estimate of low - high) for each pair of rows the paper
    orders by a ranked quantity (as compare.rankings enumerates them), where both rows ran and
    their paired per-trial difference exists."""
    from . import compare as cp
    if table.ranking is None:
        return []
    out = []
    counts = sorted({n for (_, n) in table.values}, key=lambda v: (v is None, v or 0))
    for q in (q for key in table.ranking for q in table.quantities if q.key == key):
        for n in counts:
            runs = {}
            for (lab, m), vals in table.values.items():
                if m != n or q.key not in vals:
                    continue
                run = next((f for f in exp.filters if f.label == lab
                            and (n is None or f.particles == n)), None)
                if run is not None:
                    runs[lab] = run
            if len(runs) < 2:
                continue
            value = {lab: table.values[(lab, n)][q.key] for lab in runs}
            order = sorted(runs, key=lambda lab: value[lab])
            for i, low in enumerate(order):
                for high in order[i + 1:]:
                    if value[low] == value[high]:
                        continue
                    est = cp._pair_estimate(q, by_key.get(runs[low].key),
                                            by_key.get(runs[high].key))
                    if est is not None:
                        out.append((q, n, low, high, est))
    return out


# ---------------------------------------------------------------- judging across readings

def judge(found: dict[str, list[JudgedClaim]]) -> list[dict]:
    """readings.csv's rows: every claim of every reading (``found``: reading name -> its claims,
    the config's own first), judged as one family per kind of claim across all readings: the
    cells, gains and factors in one (Holm's step-down procedure, verdicts.decide_family), the
    pairs of rows in another."""
    from .verdicts import decide_family
    flat = [(name, c) for name, cs in found.items() for c in cs]
    cells = [(n, c) for n, c in flat if c.kind != "pair"]
    pairs = [(n, c) for n, c in flat if c.kind == "pair"]
    out = []
    for group, is_pair in ((cells, False), (pairs, True)):
        # a claim a reading leaves as it is (the same trials, the same estimate) is one test,
        # however many readings share it
        keys = [(c.id, repr(c.ours), repr(c.lo), repr(c.hi), c.claim.est.n) for _, c in group]
        unique = list(dict.fromkeys(keys))
        at = {k: i for i, k in enumerate(unique)}
        first = {}
        for (_, c), k in zip(group, keys):
            first.setdefault(k, c.claim)
        decided = decide_family([first[k] for k in unique])
        verdicts = [decided[at[k]] for k in keys]
        for (name, c), v in zip(group, verdicts):
            kind = v.kind
            if is_pair:
                kind = ("unresolved" if v.kind != "differs" else
                        "same" if v.hi < 0 else "opposite")
            paper = c.paper if not isinstance(c.paper, tuple) else f"{c.paper[0]:g}-{c.paper[1]:g}"
            out.append({"reading": name, "claim": c.id, "kind": c.kind, "label": c.label,
                        "particles": c.particles, "quantity": c.quantity, "paper": paper,
                        "ours": c.ours, "lo": c.lo, "hi": c.hi, "verdict": kind,
                        "level": v.level, "verdict_text": v.text})
    order = {c.id: i for i, c in enumerate(next(iter(found.values()), []))}
    names = list(found)
    out.sort(key=lambda r: (order.get(r["claim"], len(order)), names.index(r["reading"])))
    return out


def summary(outcomes: list[tuple[str, str]], pair: bool = False) -> str:
    """A claim's robustness over the readings, in words: ``outcomes`` (reading, verdict) in the
    readings' order. 'differs under all 6 readings'; 'reproduced only under: a, b; differs under
    the rest'; 'inconclusive under 2 of 6 (a, b); differs under the rest'."""
    words = PAIR_WORDS if pair else {}
    say = lambda k: words.get(k, k)     # noqa: E731
    n = len(outcomes)
    groups: dict[str, list[str]] = {}
    for name, v in outcomes:
        groups.setdefault(v or "not judged", []).append(name)
    if len(groups) == 1:
        (k,) = groups
        return f"{say(k)} under " + ("the one reading" if n == 1 else f"all {n} readings")
    good = "same" if pair else "reproduced"
    parts = []
    if good in groups and 2 * len(groups[good]) <= n:
        parts.append(f"{say(good)} only under: {', '.join(groups.pop(good))}")
    # the most frequent of the rest is 'the rest'; the others are named
    rest = max(groups, key=lambda k: (len(groups[k]), -list(groups).index(k)))
    for k in sorted((k for k in groups if k != rest), key=lambda k: len(groups[k])):
        names = groups[k]
        shown = f" ({', '.join(names)})" if len(names) <= 4 else ""
        parts.append(f"{say(k)} under {len(names)} of {n}{shown}")
    parts.append(f"{say(rest)} under the rest")
    return "; ".join(parts)


def lines_of(rows: list[dict]) -> list[str]:
    """One robustness line per claim of readings.csv's ``rows`` (in their order)."""
    by_claim: dict[str, list[dict]] = {}
    for r in rows:
        by_claim.setdefault(r["claim"], []).append(r)
    out = []
    for cid, rs in by_claim.items():
        told = summary([(r["reading"], r["verdict"]) for r in rs], rs[0]["kind"] == "pair")
        out.append(f"{_claim_text(rs[0])}: {told}")
    return out


def _claim_text(r: dict) -> str:
    """How a line names a claim from its readings.csv row."""
    n = r.get("particles")
    at = f" N={int(n)}" if n is not None and n == n else ""
    if r["kind"] == "pair":
        low, _, high = str(r["label"]).partition(" < ")
        return f"{r['quantity']}{at}: {low} below {high} (the paper's order)"
    if r["kind"] == "factor":
        return f"{r['quantity']} {r['label']} (paper {_fmt(r['paper'])})"
    return f"{r['label']}{at} {r['quantity']} (paper {_fmt(r['paper'])})"


def robustness_lines(folder: str | Path) -> list[str]:
    """The robustness lines of the readings a results folder holds (its readings.csv): one per
    claim of the paper's table, '<claim>: <how its verdict holds across the readings>'; [] when
    the folder holds no readings."""
    return lines_of(read_csv(folder))


def read_csv(folder: str | Path) -> list[dict]:
    """readings.csv's rows of a results folder ([] when it has none)."""
    import csv
    path = Path(folder) / CSV
    if not path.is_file():
        return []
    with open(path, encoding="utf-8", newline="") as fh:
        rows = list(csv.DictReader(fh))
    for r in rows:
        r["particles"] = int(r["particles"]) if r.get("particles") else None
        for c in ("ours", "lo", "hi", "level"):
            try:
                r[c] = float(r[c])
            except (TypeError, ValueError, KeyError):
                r[c] = math.nan
        try:
            r["paper"] = float(r["paper"])
        except (TypeError, ValueError, KeyError):
            pass
    return rows


# ---------------------------------------------------------------- writing

def judge_folder(runs: list[ReadingRun], folder: Path) -> list[dict]:
    """The judged claims of every reading of ``runs`` from their trials in ``folder`` (the
    config's own in it, each reading's in readings/NAME): readings.csv's rows."""
    from .store import read_results
    found = {}
    for run in runs:
        where = Path(folder) if run.reading is None else reading_folder(folder, run.name)
        _, got = read_results(where)
        found[run.name] = claims(run.exp, got.rows)
    return judge(found)


def write(runs: list[ReadingRun], folder: Path) -> list[str]:
    """Judge every reading of ``runs`` and write readings.csv and readings.md into ``folder``;
    returns the robustness lines."""
    import csv
    import io
    rows = judge_folder(runs, folder)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(COLUMNS)
    for r in rows:
        w.writerow(["" if r[c] is None else repr(r[c]) if isinstance(r[c], float) else r[c]
                    for c in COLUMNS])
    atomic_write(Path(folder) / CSV, buf.getvalue())
    lines = lines_of(rows)
    atomic_write(Path(folder) / MD, markdown(runs, rows, lines))
    return lines


def family_note(rows: list[dict], readings: int) -> str:
    """The footnote on multiplicity: how many claims each family holds."""
    cells = sum(r["kind"] != "pair" for r in rows)
    pairs = sum(r["kind"] == "pair" for r in rows)
    text = (f"Multiplicity: every verdict here is judged in one family across the table's claims "
            f"and the {readings} readings together ({cells} cells, gains and factors over all "
            "readings, a claim whose trials a reading leaves unchanged counted once; Holm's "
            "step-down procedure for each kind of claim, 'reproduced' and 'differs'")
    if pairs:
        text += f"; the {pairs} ordered pairs of rows over all readings a second family"
    return text + ("), so the chance of any false 'reproduced' (or 'differs') among all the "
                   "readings is at most 5%: more readings never make a verdict less cautious. "
                   "The config's own table.md judges its cells alone, so the pfbench column can "
                   "be more cautious than table.md.")


LEGEND = ("Each cell: our mean [95% interval] and the verdict (= reproduced, x differs, "
          "? inconclusive, - not comparable; for a pair of rows, the paired difference low - "
          "high: < in the paper's order, > in the opposite order, ? unresolved).")


def grid(rows: list[dict]) -> tuple[list[str], list[list[str]]]:
    """The readings table of readings.csv's ``rows``: (header, cells), a row per claim and a
    column per reading, each cell 'mean [lo, hi] symbol' (SYMBOLS)."""
    names = list(dict.fromkeys(r["reading"] for r in rows))
    by_claim: dict[str, dict[str, dict]] = {}
    for r in rows:
        by_claim.setdefault(r["claim"], {})[r["reading"]] = r
    cells = []
    for rs in by_claim.values():
        row = [_claim_text(next(iter(rs.values())))]
        for n in names:
            r = rs.get(n)
            row.append("" if r is None else f"{_fmt(r['ours'])} [{_fmt(r['lo'])}, "
                       f"{_fmt(r['hi'])}] {SYMBOLS.get(r['verdict'], r['verdict'])}")
        cells.append(row)
    return ["Claim"] + names, cells


def report_lines(folder: Path, link: str) -> list[str]:
    """The report's lines on the readings of a results folder (none when it holds none): the
    robustness lines first, then the readings table in a <details> block; ``link``: where
    readings.md is, from the report."""
    from .tables import md_table
    rows = read_csv(folder)
    if not rows:
        return []
    names = list(dict.fromkeys(r["reading"] for r in rows))
    head, cells = grid(rows)
    return ([f"Under the {len(names)} readings of the paper's open choices ({', '.join(names)}; "
             f"[readings.md]({link}) has what each reads and why), each claim of the table:", ""]
            + [f"- {line}" for line in lines_of(rows)]
            + ["", "<details><summary>Every claim under every reading</summary>", "", LEGEND,
               ""] + md_table(head, cells)
            + ["", family_note(rows, len(names)), "", "</details>", ""])


def markdown(runs: list[ReadingRun], rows: list[dict], lines: list[str]) -> str:
    """readings.md: the robustness lines, then every claim under every reading, the readings,
    and the multiplicity rule."""
    from .tables import md_table
    exp = runs[0].exp
    out = [f"# {exp.name}: readings of {exp.paper} {exp.table}", "",
           f"{len(runs)} readings of the choices the paper leaves open (the config as it is, "
           f"`{DEFAULT_READING}`, first), each run on the same {exp.trials} trials (seed "
           f"{exp.seed}: common random numbers); a filter run a reading leaves as it is keeps "
           "the config's rows.", "", "## Robustness", ""]
    out += [f"- {line}" for line in lines] or ["No claim of the paper's table is judged."]
    out += ["", "## Every claim under every reading", "", LEGEND, ""]
    head, cells = grid(rows)
    out += md_table(head, cells)
    out += ["", "## The readings", "", "| Reading | What it reads | Sets | Run again | Why |",
            "| --- | --- | --- | --- | --- |"]
    for run in runs:
        sets = ("the config as committed" if run.reading is None else
                "; ".join(f"`{k}: {v}`" for k, v in run.reading.set))
        again = "all" if run.reading is None else (
            ", ".join(run.changed) if len(run.changed) < len(run.exp.filters) else "every run")
        why = "" if run.reading is None else " ".join(run.reading.why.split())
        out.append(f"| `{run.name}` | {run.title} | {sets} | {again} | {why} |".replace("\n",
                                                                                       " "))
    out += ["", family_note(rows, len(runs))]
    return "\n".join(out) + "\n"
