"""What the report says, whatever its format (pfbench.report writes REPORT.md, pfbench.report_html
the HTML report): the configs matched with their results folders (``collect``, ``Entry``), the
papers' findings with their numbers filled in, the verdict and ranking counts, the sections and
cells of the tables.
"""
from __future__ import annotations

import os
import re
from typing import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from . import tables as tb
from .compare import Comparison, machine_figure, pair_counts
from .tablecache import cached_compare
from .config import Experiment, load, read_yaml
from .errors import UserError
from . import papers as pp
from .outputs import anytime_of
from .figstyle import label
from .schema import did_you_mean
from . import sweep as sw
from .fsutil import aside_names, recover_aside
from .store import TIMING_COLUMNS, read_meta, read_results, read_sweep
from .regen import config_files, is_sweep

TITLE = "pfbench reproduction report"


@dataclass
class Entry:
    """One config and what its results folder holds."""
    path: Path                      # the config
    exp: Experiment                 # the experiment (a sweep: its first cell)
    folder: Path                    # results/<name>
    sweep_keys: list | None = None  # swept key paths, for a sweep
    cells: list | None = None       # a sweep's cells
    status: str = "ok"              # 'ok', or why the results cannot be reported
    table: pd.DataFrame | None = None   # the comparison's table, or a sweep's summary.csv
    meta: dict | None = None
    comparison: Comparison | None = None   # an experiment's, computed from its trials
    # a sweep's verdicts against the paper's curves it names, computed from its trials
    # (pfbench.curves.judge)
    curves: pd.DataFrame | None = None

    @property
    def name(self) -> str:
        return self.folder.name


def collect(configs: Path, results: Path, restore: bool = False,
            warn: Callable[[str], None] | None = None,
            status: Callable[[str], None] | None = None) -> list[Entry]:
    """Every config with its results, tables recomputed from the trials (``status`` is told
    which results it reads as it goes: 'reading results/NAME (2 of 9)').

    A results folder that is missing while ``.NAME.old<pid>`` beside it holds it (a
    regeneration killed between its renames) is never reported as not run: with ``restore``
    (the caller holds the results folder's lock) it is moved back, and ``warn`` told; without,
    a UserError says so."""
    entries = []
    for path in config_files(configs):
        if is_sweep(path):
            name, cells = sw.expand(path, {}, {})
            e = Entry(path, cells[0].exp, Path(results) / name, list(cells[0].values), cells)
        else:
            exp = load(path)
            e = Entry(path, exp, Path(results) / exp.name)
        entries.append(e)
    for e in entries:
        if not e.folder.exists() and aside_names(e.folder):
            if not restore:
                raise UserError(f"{e.folder}: missing, and {aside_names(e.folder)[0].name} "
                                "beside it holds it (a regeneration was killed while it "
                                "replaced the folder): 'pfbench report' or 'pfbench tables' "
                                "into that results folder restores it")
            recover_aside(e.folder, Path(results), warn)
    for k, e in enumerate(entries, 1):
        if status:
            status(f"reading {e.folder} ({k} of {len(entries)})")
        _read(e)
    return entries


def _read(e: Entry) -> None:
    """Read an entry's results; a file that cannot be read is a UserError naming it (the report
    is not written)."""
    try:
        _read_files(e)
    except UserError:
        raise
    except (OSError, UnicodeDecodeError, ValueError, pd.errors.ParserError) as exc:
        what = getattr(exc, "filename", None) or e.folder
        why = getattr(exc, "strerror", None) or (str(exc).splitlines() or [""])[0] \
            or type(exc).__name__
        raise UserError(f"{what}: cannot be read ({why}); 'pfbench tables --only "
                        f"{e.path.stem}' regenerates it") from None


def _read_files(e: Entry) -> None:
    if e.cells is not None:
        summary = e.folder / "summary.csv"
        if not summary.exists():
            e.status = "not run"
            return
        for cell in e.cells:
            meta = _meta(e.folder / "cells" / cell.name)
            why = _stale(cell.exp, meta)
            if why:
                e.status = f"{why} (cell {cell.name})"
                return
            e.meta = e.meta or meta
        trials, e.table = read_sweep(e.folder)    # checked: its trials, summary and cells agree
        if e.cells[0].curves:
            from .curves import judge
            e.curves = judge(e.cells[0].curves, trials, e.sweep_keys, e.exp.seed)
        return
    trials = e.folder / "trials.csv"
    if not trials.exists():
        e.status = "not run"
        return
    e.meta = _meta(e.folder)
    why = _stale(e.exp, e.meta)
    if why:
        e.status = why
        return
    got = read_results(e.folder)[1]      # checked: the trials are those meta.json records
    rows = pd.DataFrame(got.rows).drop(columns=list(TIMING_COLUMNS), errors="ignore")
    e.comparison = cached_compare(e.exp, rows, anytime=anytime_of(e.meta))
    e.table = e.comparison.table


def _meta(folder: Path) -> dict | None:
    return read_meta(folder) if (folder / "meta.json").exists() else None


def _stale(exp: Experiment, meta: dict | None) -> str:
    """Why results with this meta.json are not those of the experiment ('' when they are)."""
    if meta is None:
        return "no meta.json"
    if meta.get("experiment_hash") != exp.hash:
        return "stale: the config changed since these results were made"
    if meta.get("trials") != exp.trials:
        return f"stale: {meta.get('trials')} trials, the config asks for {exp.trials}"
    return ""


# ---- values of config keys (the choices a paper left open)

def config_value(e: Entry, path: str) -> list:
    """The distinct values a config gives a key path ('trials', 'scenario.steps',
    'filters.<name>.<key>'), over a sweep's cells; [] when the key does not apply."""
    exps = [c.exp for c in e.cells] if e.cells else [e.exp]
    out = []
    for exp in exps:
        for v in _values(exp, path):
            if v not in out:
                out.append(v)
    return out


def _values(exp: Experiment, path: str) -> list:
    parts = path.split(".")
    if parts == ["trials"]:
        return [exp.trials]
    if parts[0] == "scenario" and len(parts) == 2:
        if parts[1] == "name":
            return [exp.scenario]
        return [exp.scenario_params[parts[1]]] if parts[1] in exp.scenario_params else []
    if parts[0] == "filters" and len(parts) == 3:
        out = []
        for f in exp.filters:
            if f.name != parts[1]:
                continue
            v = f.particles if parts[2] == "particles" else (
                f.type if parts[2] == "type" else f.params.get(parts[2], _MISSING))
            if v is not _MISSING and v not in out:
                out.append(v)
        return out
    raise ValueError(f"unknown key path {path!r}")


_MISSING = object()


def _fmt_value(v) -> str:
    if v is None:
        return "unset"
    if isinstance(v, float):
        return f"{v:g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_fmt_value(x) for x in v) + "]"
    return str(v)


# ---- numbers in the findings: {config:run:column} or {config:run:column:ci}

def fill(text: str, entries: dict[str, Entry], problems: list[str] | None = None) -> str:
    """Replace each {config:run:column[:ci]} by the value in that experiment's table (its 95%
    interval too with :ci); '(not run)' where its results are missing. A reference to an
    experiment, run or column that does not exist is a UserError, or with ``problems``, shown
    as '(broken reference)' and its reason appended there."""
    def one(m) -> str:
        try:
            return _value(m, entries)
        except UserError as exc:
            if problems is None:
                raise
            problems.append(str(exc))
            if m.group(1) not in entries:       # a config of another folder, or a typo
                return f"({m.group(1)}: not among these configs)"
            return f"(broken reference {m.group(0)[1:-1]})"
    return pp.REF.sub(one, text)


def _value(m, entries: dict[str, Entry]) -> str:
    name, run, col, ci = m.groups()
    e = entries.get(name)
    if e is None:
        raise UserError(f"{m.group(0)}: no experiment '{name}' among the configs"
                        + did_you_mean(name, list(entries)))
    if e.table is None:
        return "(not run)"
    runs = list(e.table["filter"]) if "filter" in e.table else []
    if run not in runs:
        raise UserError(f"{m.group(0)}: no filter run '{run}' in {name}"
                        + did_you_mean(run, runs) + f"; runs: {', '.join(runs)}")
    if col not in e.table.columns:
        raise UserError(f"{m.group(0)}: no column '{col}' in {name}'s table"
                        + did_you_mean(col, list(e.table.columns)))
    r = e.table[e.table["filter"] == run].iloc[0]
    v = r[col]
    if isinstance(v, str):
        return v
    text = _num(float(v))
    if ci:
        lo, hi = _interval_columns(col)
        if lo not in e.table.columns:
            raise UserError(f"{m.group(0)}: '{col}' has no interval (no column {lo})")
        text += f" [{_num(float(r[lo]))}, {_num(float(r[hi]))}]"
    return text


def home_names(paper: pp.Paper) -> set[str]:
    """The experiment names of the configs the paper file sits with (``configs/`` of
    ``configs/papers/KEY.yaml``): what its findings may name beyond the configs reported."""
    src = Path(paper.source)
    home = src.parent.parent if src.parent.name == "papers" else src.parent
    names: set[str] = set()
    if not paper.source or not home.is_dir():
        return names
    for p in home.iterdir():
        if p.suffix not in (".yaml", ".yml") or not p.is_file():
            continue
        try:
            raw, _ = read_yaml(p)
        except UserError:
            continue
        if isinstance(raw, dict):
            names.add(str(raw.get("name") or p.stem))
    return names


def here(finding: pp.Finding, entries) -> bool:
    """Whether every experiment a finding names is among the configs reported."""
    return all(r.config in entries for r in finding.refs)


def findings(paper: pp.Paper, entries: dict[str, Entry],
             warn: Callable[[str], None] | None = None) -> list[str]:
    """A paper's findings with their references filled in. A finding about an experiment that
    is not among these configs but is a config beside the paper file (a report of some of a
    paper's configs) is left out; a broken reference (an experiment found nowhere, a run or a
    column that does not exist) is a UserError naming the paper file and the finding's line:
    a report is never written with one. (``warn`` is not used; kept for callers.)"""
    out = []
    home: set[str] | None = None
    for i, f in enumerate(paper.findings):
        where = f"{paper.source}:{f.line}" if f.line else paper.source
        if not here(f, entries):
            home = home_names(paper) if home is None else home
            lost = [r for r in f.refs if r.config not in entries and r.config not in home]
            if not lost:
                continue            # about a table whose config is not among these
            r = lost[0]
            raise UserError(f"{where}: findings[{i}]: {r.text}: no experiment '{r.config}' "
                            "among the configs or beside the paper file"
                            + did_you_mean(r.config, sorted(set(entries) | home)))
        try:
            out.append(fill(f.text, entries))
        except UserError as exc:
            raise UserError(f"{where}: findings[{i}]: {exc}") from None
    return out


def tables_elsewhere(paper: pp.Paper, entries: list[Entry]) -> list[str]:
    """The paper's tables that no config here fills (a report of some of its configs)."""
    filled = {e.exp.table for e in entries if e.exp.paper == paper.key}
    return [k for k in paper.tables if k not in filled]


def _num(v: float) -> str:
    """Three significant digits, whole numbers from 100 on (no exponents in prose)."""
    if v != v:
        return "-"
    return f"{v:.0f}" if abs(v) >= 100 else f"{v:.3g}"


def _interval_columns(col: str) -> tuple[str, str]:
    if col.startswith("ours_"):
        return f"ours_lo_{col[5:]}", f"ours_hi_{col[5:]}"
    stem = col.removesuffix("_mean")
    return f"{stem}_ci_lo", f"{stem}_ci_hi"


# ---- counting verdicts

def verdict_counts(e: Entry) -> dict[str, int]:
    """Paper values compared, by the kind of verdict the engine gave each: reproduced, differ,
    inconclusive, not comparable."""
    counts = {"values": 0, "reproduced": 0, "differ": 0, "inconclusive": 0, "not comparable": 0}
    kinds = list(e.comparison.kinds()) if e.comparison is not None else []
    if e.curves is not None:        # a sweep's points against the paper's curves
        kinds += [k for k in e.curves["kind"] if k]
    for kind in kinds:
        counts["values"] += 1
        counts["differ" if kind == "differs" else kind] += 1
    return counts


def ranking_counts(e: Entry) -> tuple[int, int, int]:
    """Pairs of rows the paper orders: (resolved in its order, resolved opposite, unresolved)."""
    if e.comparison is None:
        return 0, 0, 0
    n = pair_counts(e.comparison.rankings)
    return n["same"], n["opposite"], n["unresolved"]


# ---- the document

_table_md = tb.md_table


def _n(v) -> str:
    return "-" if v is None or v != v else str(int(v))


def numbered(verdict: str, reasons: list[str]) -> str:
    """A 'not comparable: WHY' verdict as 'not comparable (k)', WHY the k-th of ``reasons``
    (added there the first time): each reason is written once under the table."""
    if not verdict.startswith("not comparable: "):
        return verdict
    why = verdict.removeprefix("not comparable: ")
    if why not in reasons:
        reasons.append(why)
    return f"not comparable ({reasons.index(why) + 1})"


def comparison(e: Entry) -> list[str]:
    """The paper's table beside ours: per filter run and reported quantity, ours with its 95%
    interval, the paper's value and the verdict; reasons for 'not comparable' listed once."""
    table = e.exp.reported
    head = ["Filter", "N", "Trials"]
    for q in table.quantities:      # a verdict sits beside the measure it judged
        head += [f"{q.title}: {tb.judged_title(q, e.exp) if q.judged_by else 'ours'} "
                 "[95% CI]", "paper", "verdict"]
    reasons: list[str] = []
    cells = []
    for _, r in e.table.iterrows():
        row = [r["label"], _n(r["particles"]), str(int(r["trials"]))]
        for q in table.quantities:
            row += [tb.shown_cell(r, q), tb.fmt(r[f"paper_{q.key}"], 6),
                    numbered(r[f"verdict_{q.key}"] or "-", reasons)]
        cells.append(row)
    out = _table_md(head, cells)
    if reasons:
        out += [""] + [f"Not comparable ({i + 1}): {why}." for i, why in enumerate(reasons)]
    return out


def _figures(folder: Path, where: Path) -> list[str]:
    """The Markdown lines of the figures in ``folder`` (links relative to ``where``), but those
    of the machine's run times (compare.machine_figure): the report shows the committed results,
    the same on every machine."""
    figs = sorted(p for p in (folder / "figures").glob("*.*")
                  if p.suffix in (".png", ".svg") and not machine_figure(p.name))
    return [f"![{f.stem}]({os.path.relpath(f, where).replace(os.sep, '/')})" for f in figs]


def _provenance(e: Entry) -> str:
    m = e.meta or {}
    commit = m.get("git_commit") or "unknown"
    commit = f"`{commit[:10]}`" + (" with uncommitted changes to the code"
                                   if commit.endswith("-dirty") else "")
    trials = e.exp.trials
    cells = f" in each of {len(e.cells)} cells" if e.cells else ""
    return (f"`{e.path.as_posix()}` -> `{e.folder.as_posix()}`: {trials} trials{cells}, seed "
            f"{e.exp.seed}, scenario `{e.exp.scenario}`; results of commit {commit}, pfbench "
            f"{m.get('versions', {}).get('pfbench', '?')}.")


def _experiment_section(e: Entry, where: Path) -> list[str]:
    table = e.exp.reported
    out = _head(e, f"{_table_name(e.exp.table)}: `{e.path.stem}`",
                f"The paper's table: {table.caption}."
                + (f" The paper states {table.runs} run{'s' if table.runs > 1 else ''} behind "
                   "its values." if table.runs else "") if table else None)
    if e.status != "ok":
        return out
    if table is not None:
        out += comparison(e) + [""]
        if e.comparison.per_trial is not None:
            title, head, cells = tb.per_trial_cells(e.comparison.per_trial)
            out += [f"{title}:", ""] + _table_md(head, cells) + [""]
        head, cells = tb.ranking_table(e.comparison.rankings)
        if cells:
            out += [f"{tb.RANKING_TITLE}:", ""] + _table_md(head, cells) + [""]
        # the baseline's paired columns are in table.md, not here: their legend goes too
        notes = [n for n in tb.footnotes(e.comparison) if not n.startswith("'RMSE - ")]
        if notes:
            out += ["Measured here:", ""] + [f"- {n}" for n in notes] + [""]
        if table.notes:
            out += ["The paper's table and how we read it:", ""]
            out += [f"- {n}" for n in table.notes] + [""]
    out += [f"Full table with the diagnostics: [{e.name}/table.md]"
            f"({os.path.relpath(e.folder / 'table.md', where).replace(os.sep, '/')}).", ""]
    out += _readings(e, where)
    return out + _figures(e.folder, where) + [""]


def _readings(e: Entry, where: Path) -> list[str]:
    """The robustness lines of the readings the results folder holds, and their table on
    demand (pfbench.readings.report_lines); none without readings."""
    from . import readings as rd
    link = os.path.relpath(e.folder / rd.MD, where).replace(os.sep, "/")
    return rd.report_lines(e.folder, link)


def _head(e: Entry, title: str, paper: str | None = None) -> list[str]:
    """A section's heading, what the paper and we ran, where the numbers come from; and why
    nothing follows when the results cannot be reported."""
    out = [f"### {title}", ""]
    if paper:
        out += [paper, ""]
    if e.exp.description:
        out += [f"Ours: {e.exp.description}.", ""]
    out += [_provenance(e), ""]
    if e.status != "ok":
        out += [f"**Not reported: {e.status}.** Run `pfbench tables --only {e.path.stem}` to "
                "regenerate it.", ""]
    return out


def _table_name(key: str | None) -> str:
    """'table3' -> 'Table 3'; another key as it is."""
    if key is None:
        return "Experiment"
    m = re.fullmatch(r"table(\d+)", key)
    return f"Table {m.group(1)}" if m else key.capitalize()


def _sweep_section(e: Entry, where: Path) -> list[str]:
    out = _head(e, f"Sweep: `{e.path.stem}`")
    if e.status != "ok":
        return out
    keys = e.sweep_keys
    head, cells = sweep_cells(e)
    out += [f"Swept: {', '.join(f'`{k}`' for k in keys)}. The RMSE and the experiment's other "
            "headline metrics, mean [95% CI] over the trials of each cell, and the likelihood "
            "evaluations per step (run times depend on the machine: the sweep's console table "
            "and its timings.csv hold them):", ""]
    out += _table_md(head, cells) + [""]
    if e.curves is not None:
        from .curves import markdown
        md = markdown(e.cells[0].curves, e.curves, keys).splitlines()
        # its sections one level below the sweep's heading
        out += [f"#### Against the paper's curve {ln[3:]}" if ln.startswith("## ") else ln
                for ln in md[2:]] + [""]
    return out + _figures(e.folder, where) + [""]


def sweep_cells(e: Entry) -> tuple[list[str], list[list[str]]]:
    """A sweep's table: per cell and filter run, the RMSE and the other metrics its figures draw
    (plots.sweep_metrics), mean [95% CI], and the likelihood evaluations per step."""
    from .plots import sweep_metrics
    keys, s = e.sweep_keys, e.table
    metrics = [m for m in sweep_metrics(e.exp) if f"{m}_mean" in s]
    head = [label(k) for k in keys] + ["Filter", "N"] + [f"{label(m)} [95% CI]" for m in metrics] \
        + ["Evals/step"]
    cells = [[_fmt_value(r[k]) for k in keys] + [r["label"], _n(r["particles"])]
             + [f"{tb.fmt(r[f'{m}_mean'])} [{tb.fmt(r[f'{m}_ci_lo'])}, "
                f"{tb.fmt(r[f'{m}_ci_hi'])}]" for m in metrics]
             + [tb.fmt(r.get("lik_evals_per_step_mean"))] for _, r in s.iterrows()]
    return head, cells


def _choices(paper: pp.Paper, entries: list[Entry]) -> list[str]:
    choices = paper.choices
    if not choices:
        return []
    out = ["### Choices the paper left open, and the values used", "",
           "Each value with the configs that use it; 'unset' is the key's default of none "
           "(the key reference, docs/reference/config.md, says what that means).", "",
           "| The paper | Key | Value (config) |", "| --- | --- | --- |"]
    out += [f"| {what} | `{key}` | {vals} |" for what, key, vals in choice_rows(paper, entries)]
    return out + [""]


def choice_rows(paper: pp.Paper, entries: list[Entry]) -> list[tuple[str, str, str]]:
    """(what the paper left open, the key, its values with the configs that use each) for each
    key of the paper's choices that some config sets."""
    rows = []
    for what, keys in paper.choices:
        for key in keys:
            by_value: dict[str, list[str]] = {}      # the value -> the configs that use it
            for e in entries:
                v = config_value(e, key)
                if v:
                    by_value.setdefault(", ".join(_fmt_value(x) for x in v), []).append(
                        e.path.stem)
            if by_value:
                rows.append((what, key, "; ".join(f"{v} ({', '.join(names)})"
                                                  for v, names in by_value.items())))
    return rows


def _summary_row(e: Entry) -> list[str]:
    c = verdict_counts(e)
    same, opposite, unresolved = ranking_counts(e)
    total = same + opposite + unresolved
    table = "Sweep" if e.cells else _table_name(e.exp.table)
    if e.status != "ok":
        return [e.exp.paper or "-", table, f"`{e.path.stem}`", e.status, "", "", "", "", "",
                ""]
    return [e.exp.paper or "-", table, f"`{e.path.stem}`", str(e.exp.trials),
            str(c["values"]), str(c["reproduced"]), str(c["differ"]), str(c["inconclusive"]),
            str(c["not comparable"]),
            f"{same} / {opposite} / {unresolved}" if total else "-"]


def reported_papers(entries: list[Entry], configs: Path) -> dict[str, pp.Paper]:
    """The papers a report has a section for: those the configs name, and surveys (findings, no
    tables of their own) measured through other papers' configs."""
    papers = {e.exp.reference.key: e.exp.reference for e in entries if e.exp.reference}
    names = {e.name for e in entries}
    for key, path in pp.available(pp.folders_for_configs(configs)).items():
        if key not in papers:
            p = pp.read(path)
            # a survey: reported where one of its findings is about these configs
            if not p.tables and any(f.refs and here(f, names) for f in p.findings):
                papers[key] = p
    return papers


# ---- 'Did we implement it as the paper says?': each algorithm's steps beside pfbench's functions

IMPLEMENTATION_TITLE = "Did we implement it as the paper says?"
IMPLEMENTATION_INTRO = (
    "Each algorithm the paper proposes or uses, step by step as its text gives it (quoted in the "
    "original, then in English; square brackets: a reading of a symbol the text's extraction "
    "lost), beside the functions of pfbench that do the step and whether they follow the text, "
    "read a choice it leaves open (the choice's id; the reading named is pfbench's default), or "
    "depart from it.")
STATUS_WORDS = {"follows": "follows the text", "open": "open choice",
                "departs": "departs from the text"}
READINGS_TITLE = "The readings' outcome"
READINGS_INTRO = ("Every reading of the open choices above, run on the same trials as the "
                  "tables: one line per judged claim; the readings table follows.")


def md_text(text: str) -> str:
    """Prose as the text of a Markdown table cell: the characters Markdown would read as a
    cell's end, as emphasis or as a link (``|``, ``*``, ``_``, ``[``, ``]``, a backslash)
    escaped, so that a formula such as exp[-a](rand - 0.5) reads as written."""
    return re.sub(r"([\\|*_\[\]])", r"\\\1", " ".join(text.split()))


def step_verdict(s: pp.Step) -> str:
    """A step's status in Markdown: in words, with its open choice's id and its note."""
    out = STATUS_WORDS[s.status] + (f" `{s.choice}`" if s.choice else "")
    return out + (f": {md_text(s.note)}" if s.note else "")


def implementation_md(paper: pp.Paper) -> list[str]:
    """The paper's 'Did we implement it as the paper says?' in Markdown: a table of steps per
    algorithm (step; the text, original and English; pfbench's functions and status)."""
    if not paper.implementation:
        return []
    out = [f"### {IMPLEMENTATION_TITLE}", "", IMPLEMENTATION_INTRO, ""]
    for a in paper.implementation:
        out += [f"#### {a.name} ({a.where})", ""]
        out += ["| Step | The text | pfbench |", "| --- | --- | --- |"]
        for s in a.steps:
            text = f"{md_text(s.text)}<br>*{md_text(s.english)}*"
            if s.damaged:
                text += f"<br>(extraction damaged: {md_text(s.damaged)})"
            where = ", ".join(f"`{f}`" for f in s.functions)
            out.append(f"| {md_text(s.name)} | {text} | {where}: {step_verdict(s)} |")
        out.append("")
    return out


def readings_outcome(entries: list[Entry]) -> list[str]:
    """The robustness lines of the readings of the experiments ``entries`` (the claims judged
    under each reading of the paper's open choices), from ``pfbench.readings.robustness_lines``
    of each results folder; none where that module or its readings do not exist."""
    try:
        from .readings import robustness_lines     # lazily: the readings may not be there
    except ImportError:
        return []
    out: list[str] = []
    for e in entries:
        if e.status == "ok":
            out += [str(line) for line in (robustness_lines(e.folder) or [])]
    return out


def readings_outcome_md(entries: list[Entry]) -> list[str]:
    """The place of the readings' outcome right after the implementation's tables (a heading,
    a sentence, the robustness lines), only where there are lines."""
    lines = readings_outcome(entries)
    if not lines:
        return []
    return [f"#### {READINGS_TITLE}", "", READINGS_INTRO, "", *[f"- {x}" for x in lines], ""]


# ---- the index: what was found, one line per paper table

INDEX_TITLE = "What was found"
INDEX_INTRO = ("One line per table of a paper: what our trials show of it (the paper file's "
               "headline, its numbers filled in from the results), the verdicts of its paper "
               "values, the ordered pairs of its rows where the paper claims an order, and marks "
               "for the negatives that hold however the table is read: paper values below the "
               "model's floor (what no filter can average), claims that differ under every "
               "reading of the paper's open choices, and tables where no value differs. The "
               "summary table, the sections of each paper and the verdicts' definitions follow.")


@dataclass
class IndexLine:
    """One line of the report's index: a paper's table (or a sweep judged against a paper's
    curve), what our results show of it in words, and per config its verdict counts, ordered
    pairs and marks."""
    paper: str
    table: str                      # 'Table 1', or 'Sweep'
    headline: str                   # the headline filled in, or the table's caption
    configs: list                   # [(Entry, counts text, marks)]


def index_lines(entries: list[Entry], papers: dict, by_name: dict) -> list[IndexLine]:
    """The index of a report: for each paper's table with a config among ``entries`` (in
    ``entries``' order), its headline filled in (``headline:`` of the paper file's table; its
    caption where it has none, or where the headline names a config not among these) and each
    of its configs' counts and marks (``entry_counts``, ``entry_marks``); then each sweep judged
    against a paper's curve. A broken reference in a headline is a UserError naming the paper
    file (the report is not written)."""
    out: list[IndexLine] = []
    seen: dict[tuple, IndexLine] = {}
    for e in sorted(entries, key=lambda e: (e.exp.paper or "~", e.cells is not None,
                                            e.exp.table or "", e.path.stem)):
        p = papers.get(e.exp.paper)
        if p is None or (e.cells is None and e.exp.reported is None) or \
                (e.cells is not None and e.curves is None):
            continue
        if e.cells is not None:
            # the curve's caption up to its first colon: what it is, in words
            line = IndexLine(p.key, "Sweep", "Against the paper's curve: " + "; ".join(
                c.caption.split(":")[0] for _, c in e.cells[0].curves), [])
            out.append(line)
        else:
            k = (p.key, e.exp.table)
            line = seen.get(k)
            if line is None:
                t = e.exp.reported
                line = seen[k] = IndexLine(p.key, _table_name(e.exp.table),
                                           _headline(p, e.exp.table, t, by_name), [])
                out.append(line)
        line.configs.append((e, entry_counts(e), entry_marks(e)))
    return out


def _headline(p: pp.Paper, key: str, table: pp.Table, by_name: dict) -> str:
    h = getattr(table, "headline", None)
    if h is None or not here(h, by_name):
        return table.caption
    try:
        return fill(h.text, by_name)
    except UserError as exc:
        raise UserError(f"{p.source}: tables.{key}.headline: {exc}") from None


def entry_counts(e: Entry) -> str:
    """A config's verdicts in words: '15 paper values: 1 reproduced, 14 differ; ordered pairs:
    0 same, 18 opposite, 0 unresolved' (what is zero left out, but for the reproduced)."""
    if e.status != "ok":
        return f"not reported ({e.status})"
    c = verdict_counts(e)
    if not c["values"]:
        return "no paper values"
    parts = [f"{c['reproduced']} reproduced"] + [
        f"{c[k]} {k}" for k in ("differ", "inconclusive", "not comparable") if c[k]]
    text = f"{c['values']} paper value{'s' if c['values'] != 1 else ''}: {', '.join(parts)}"
    same, opposite, unresolved = ranking_counts(e)
    if same + opposite + unresolved:
        text += (f"; ordered pairs: {same} same, {opposite} opposite, {unresolved} "
                 "unresolved")
    return text


FLOOR_WORDS = "below the model's floor"


def entry_marks(e: Entry) -> list[str]:
    """The marks of a config's robust findings: paper values below the model's floor (counted
    over the cells), claims that differ under every reading of the paper's open choices
    (pfbench.readings.robustness_lines, where readings were run), and 'no value differs' where
    every judged value is reproduced or inconclusive."""
    if e.status != "ok":
        return []
    marks = []
    c = verdict_counts(e)
    table = e.exp.reported
    if e.comparison is not None and table is not None:
        texts = [str(v) for q in table.quantities if f"verdict_{q.key}" in e.table
                 for v in e.table[f"verdict_{q.key}"] if isinstance(v, str) and v]
        below = sum(FLOOR_WORDS in v for v in texts)
        if below:
            marks.append(f"paper {FLOOR_WORDS}: {below} of {c['values']} values")
    lines = readings_outcome([e])
    if lines:
        every = [x for x in lines if re.search(r": differs under all \d+ readings$", x)]
        n = re.search(r"all (\d+) readings", every[0]).group(1) if every else None
        if every:
            marks.append(f"differs under every reading ({n} readings): {len(every)} of "
                         f"{len(lines)} claims")
    judged = c["reproduced"] + c["differ"] + c["inconclusive"]
    if judged and not c["differ"]:
        marks.append(f"no value differs ({judged} judged)")
    return marks


def index_md(lines: list[IndexLine]) -> list[str]:
    """The index in Markdown: a heading, the intro, one bullet per line (headline, then each
    config with its counts and marks)."""
    if not lines:
        return []
    out = [f"## {INDEX_TITLE}", "", INDEX_INTRO, ""]
    for ln in lines:
        configs = "; ".join(
            f"`{e.path.stem}`: {counts}" + (f" ({'; '.join(f'**{m}**' for m in marks)})"
                                              if marks else "")
            for e, counts, marks in ln.configs)
        out.append(f"- **{ln.paper} {ln.table}**: {ln.headline.rstrip('.')}. {configs}.")
    return out + [""]
