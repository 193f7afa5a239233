"""The HTML reproduction report: ``results/report/index.html`` and a page per paper (and
``other.html`` for the experiments that name none).

The same content as REPORT.md (pfbench.report gathers it: every table recomputed from its
trials), laid out for a browser: the summary, every table of a paper beside ours with the
intervals and the verdicts (coloured by verdict and named in words, so it reads without colour
too), the figures as SVG, the choices each paper left open, and the provenance of every result
(commit, versions, seed). Static files: no server, no JavaScript; they open from the file system.
The pages come from jinja2 templates (``TEMPLATES``); the SVG figures are drawn from the trials
and traces of each results folder (pfbench.plots), into ``report/figures/<experiment>/``.
"""
from __future__ import annotations

import os
import re
import tempfile
from pathlib import Path
from types import SimpleNamespace

import jinja2
from markupsafe import Markup, escape

from .figstyle import label
from .fsutil import FolderLock, atomic_write, file_digest, make_folders, own_folder
from .traces import FIGURE_TRIALS
from .version import __version__
from . import report_data as rp
from . import tables as tb
from .verdicts import DEFINITIONS

CSS = """
body { font-family: system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; margin: 0;
       color: #1d1d1f; background: #fff; line-height: 1.45; font-size: 15px; }
main { max-width: 1180px; margin: 0 auto; padding: 1.2em 1.5em 4em; }
nav { font-size: 0.9em; margin-bottom: 1em; }
h1 { font-size: 1.6em; } h2 { font-size: 1.3em; margin-top: 2em; border-bottom: 1px solid #ddd; }
h3 { font-size: 1.1em; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.6em 0 1em; font-size: 0.86em; width: 100%; }
th, td { border: 1px solid #d5d5d5; padding: 0.25em 0.45em; text-align: left;
         vertical-align: top; overflow-wrap: normal; word-break: keep-all; hyphens: manual; }
table.steps td { word-break: normal; }
table.results td, table.results th { min-width: 3em; }
th { background: #f3f3f3; }
td.num { white-space: nowrap; font-variant-numeric: tabular-nums; }
.wrap { max-width: 100%; overflow-x: auto; }
.verdict { font-weight: 600; }
.reproduced { background: #e3f4e1; } .differs { background: #fbe3e1; }
.inconclusive { background: #fff4d6; } .not-comparable { background: #eeeeee; }
.verdict .mark { font-family: monospace; margin-right: 0.3em; }
figure { margin: 1em 0; } figure img { max-width: 100%; height: auto; border: 1px solid #eee;
                                        box-sizing: border-box;
                                        display: block; }
nav.toc { font-size: 0.92em; background: #f7f7f7; padding: 0.4em 1em; border-left: 3px solid #ccc; }
nav.toc ol { margin: 0.2em 0; padding-left: 1.4em; } nav.toc li { margin: 0.1em 0; }
ul.index li { margin-bottom: 0.6em; } .robust { font-weight: 600; }
figcaption { font-size: 0.85em; color: #555; }
.prov { font-size: 0.85em; color: #444; }
code { background: #f5f5f5; padding: 0 0.2em; }
ul.notes li { margin-bottom: 0.3em; font-size: 0.92em; }
table.steps td:first-child { width: 12%; } table.steps td:nth-child(2) { width: 50%; }
table.steps .en { display: block; margin-top: 0.3em; font-style: italic; }
table.steps .damaged, table.steps .fn { display: block; font-size: 0.9em; color: #555; }
.step-status { font-weight: 600; }
"""

# A verdict's mark: readable without colour (and in print).
MARKS = {"reproduced": "[=]", "differs": "[x]", "inconclusive": "[?]",
         "not comparable": "[~]", "": ""}

TEMPLATES = {
    "base.html": """<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>{{ title }}</title><style>{{ css }}</style></head>
<body><main>
<nav><a href="index.html">pfbench reproduction report</a>{% for p in papers %} &middot;
<a href="{{ p.page }}">{{ p.key }}</a>{% endfor %}</nav>
{% block body %}{% endblock %}
<p class="prov">Written by <code>pfbench report</code> (pfbench {{ version }}) from the configs and
trials of this project; every table is recomputed from its <code>trials.csv</code>.</p>
</main></body></html>
""",
    "index.html": """{% extends "base.html" %}{% block body %}
<h1>pfbench reproduction report</h1>
<p>Each paper's tables re-computed from scratch by Monte Carlo trials, beside the values the paper
reports, with 95% intervals and a verdict for every value.</p>
{% if index %}<h2 id="found">{{ index_title }}</h2>
<p>{{ index_intro }}</p>
<ul class="index">{% for ln in index %}<li><strong>{{ ln.paper }} {{ ln.table }}</strong>: {{ ln.headline }}.{% for c in ln.configs %} <a href="{{ c.page }}">{{ c.name }}</a>: {{ c.counts }}{% for m in c.marks %}; <span class="robust">{{ m }}</span>{% endfor %}{% if not loop.last %};{% else %}.{% endif %}{% endfor %}</li>
{% endfor %}</ul>{% endif %}
<h2 id="summary-table">Summary</h2>
<div class="wrap"><table id="summary">
<tr>{% for h in summary_head %}<th>{{ h }}</th>{% endfor %}</tr>
{% for row in summary %}<tr>{% for c in row %}<td{% if loop.index > 3 %} class="num"{% endif %}>{{ c|safe }}</td>{% endfor %}</tr>
{% endfor %}</table></div>
<h2>What the verdicts mean</h2>
<ul class="notes">{% for d in definitions %}<li>{{ d }}</li>{% endfor %}</ul>
<p>Marks: {% for k, m in marks %}<span class="verdict {{ k|replace(' ', '-') }}"><span class="mark">{{ m }}</span>{{ k }}</span>{% if not loop.last %}, {% endif %}{% endfor %}.</p>
<h2>Papers</h2>
<ul>{% for p in papers %}<li><a href="{{ p.page }}">{{ p.key }}</a>: {{ p.citation }}</li>{% endfor %}</ul>
{% endblock %}
""",
    "paper.html": """{% extends "base.html" %}{% block body %}
<h1>{{ paper.key }}</h1>
<p>{{ paper.citation }}</p>
{% if paper.about %}<p>{{ paper.about }}</p>{% endif %}{% if elsewhere %}
<p>Not among these configs: {{ elsewhere|join(", ") }} of this paper.</p>{% endif %}
<nav class="toc" aria-label="Contents"><strong>On this page</strong><ol>
{% if findings %}<li><a href="#findings">What reproduced and what did not</a></li>{% endif %}
{% if implementation %}<li><a href="#implementation">{{ implementation_title }}</a></li>{% endif %}
{% for s in sections %}<li><a href="#{{ s.name }}">{{ s.title }}</a>{% if s.figures %} (<a href="#{{ s.name }}-figures">figures</a>){% endif %}</li>
{% endfor %}{% if choices %}<li><a href="#choices">Choices the paper left open, and the values used</a></li>{% endif %}
</ol></nav>
{% if findings %}<h2 id="findings">What reproduced and what did not</h2>
<ul class="notes">{% for f in findings %}<li>{{ f }}</li>{% endfor %}</ul>{% endif %}
{% if implementation %}<h2 id="implementation">{{ implementation_title }}</h2>
<p>{{ implementation_intro }}</p>
{% for a in implementation %}<h3>{{ a.name }} ({{ a.where }})</h3>
<div class="wrap"><table class="steps"><tr><th>Step</th><th>The text</th><th>pfbench</th></tr>
{% for st in a.steps %}<tr><td>{{ st.name }}</td><td><span lang="{{ lang }}">{{ st.text }}</span><span class="en" lang="en">{{ st.english }}</span>{% if st.damaged %}<span class="damaged">Extraction damaged: {{ st.damaged }}</span>{% endif %}</td>
<td>{% for f in st.functions %}<code class="fn">{{ f }}</code>{% endfor %}<span class="step-status">{{ status_words[st.status] }}</span>{% if st.choice %} <code>{{ st.choice }}</code>{% endif %}{% if st.note %}: {{ st.note }}{% endif %}</td></tr>
{% endfor %}</table></div>
{% endfor %}
{% if readings_outcome %}<h3 id="readings-outcome">{{ readings_title }}</h3>
<p>{{ readings_intro }}</p>
<ul class="notes">{% for line in readings_outcome %}<li>{{ line }}</li>{% endfor %}</ul>{% endif %}
{% endif %}
{% for s in sections %}
<h2 id="{{ s.name }}">{{ s.title }}</h2>
{% if s.caption %}<p>{{ s.caption }}</p>{% endif %}
{% if s.description %}<p>Ours: {{ s.description }}.</p>{% endif %}
<p class="prov">{{ s.provenance|safe }}</p>
{% if s.status != "ok" %}<p><strong>Not reported: {{ s.status }}.</strong></p>{% else %}
{% for t in s.tables %}
{% if t.title %}<h3>{{ t.title }}</h3>{% endif %}
<div class="wrap"><table class="results">
<tr>{% for h in t.head %}<th>{{ h }}</th>{% endfor %}</tr>
{% for row in t.rows %}<tr>{% for c in row %}{% if c.kind is defined %}<td class="verdict {{ c.kind|replace(' ', '-') }}"><span class="mark">{{ c.mark }}</span>{{ c.text }}</td>{% else %}<td{% if c.num %} class="num"{% endif %}>{{ c.text }}</td>{% endif %}{% endfor %}</tr>
{% endfor %}</table></div>
{% endfor %}
{% if s.reasons %}<ul class="notes">{% for r in s.reasons %}<li>Not comparable ({{ loop.index }}): {{ r }}.</li>{% endfor %}</ul>{% endif %}
{% if s.readings %}<h3>Under every reading of the paper's open choices</h3><p>{{ s.readings.intro }}</p><ul class="notes">{% for n in s.readings.lines %}<li>{{ n }}</li>{% endfor %}</ul><details><summary>Every claim under every reading</summary><p>{{ s.readings.legend }}</p><div class="wrap"><table class="results"><tr>{% for h in s.readings.head %}<th>{{ h }}</th>{% endfor %}</tr>{% for row in s.readings.rows %}<tr>{% for c in row %}<td>{{ c }}</td>{% endfor %}</tr>{% endfor %}</table></div><p>{{ s.readings.note }}</p></details>{% endif %}{% if s.notes %}<h3>Measured here</h3><ul class="notes">{% for n in s.notes %}<li>{{ n }}</li>{% endfor %}</ul>{% endif %}
{% if s.paper_notes %}<h3>The paper's table and how we read it</h3><ul class="notes">{% for n in s.paper_notes %}<li>{{ n }}</li>{% endfor %}</ul>{% endif %}
{% for f in s.figures %}<figure{% if loop.first %} id="{{ s.name }}-figures"{% endif %}><a href="{{ f.src }}" title="the figure at full size"><img src="{{ f.src }}" alt="{{ f.alt }}"></a><figcaption>{{ f.alt }} (click the figure for its full size)</figcaption></figure>
{% endfor %}{% endif %}
{% endfor %}
{% if choices %}<h2 id="choices">Choices the paper left open, and the values used</h2>
<div class="wrap"><table class="choices"><tr><th>The paper</th><th>Key</th><th>Value (config)</th></tr>
{% for c in choices %}<tr><td>{{ c[0] }}</td><td><code>{{ c[1] }}</code></td><td>{{ c[2] }}</td></tr>
{% endfor %}</table></div>{% endif %}
{% endblock %}
""",
}


def _emphasis(text: str):
    """'*differs*: ...' (the verdicts' definitions are Markdown) with <em> for the stars."""
    return Markup(re.sub(r"\*([^*]+)\*", r"<em>\1</em>", str(escape(text))))


def _env() -> jinja2.Environment:
    return jinja2.Environment(loader=jinja2.DictLoader(TEMPLATES),
                              autoescape=jinja2.select_autoescape(["html"]),
                              keep_trailing_newline=True)


def _cell(text, num: bool = False) -> dict:
    return {"text": str(text), "num": num}


def _verdict(kind: str, text: str) -> dict:
    kind = kind if kind in MARKS else ""
    return {"kind": kind or "none", "mark": MARKS[kind], "text": text or "-"}


def _comparison_tables(e: rp.Entry) -> tuple[list[dict], list[str]]:
    """The paper's table beside ours (a table per quantity: every row for the first, the rows the paper
    gives for the others), the factors, the per-run table; and the reasons for 'not comparable',
    numbered once."""
    table = e.exp.reported
    reasons: list[str] = []
    out = []
    for k, q in enumerate(table.quantities):
        rows = []
        given = [r for _, r in e.table.iterrows() if not tb._missing(r[f"paper_{q.key}"])]
        for r in ([r for _, r in e.table.iterrows()] if k == 0 or not given else given):
            v = rp.numbered(r[f"verdict_{q.key}"] or "-", reasons)
            rows.append([_cell(r["label"]), _cell(rp._n(r["particles"]), True),
                         _cell(int(r["trials"]), True), _cell(tb.shown_cell(r, q), True),
                         _cell(tb.fmt(r[f"paper_{q.key}"], 6), True),
                         _verdict(r[f"kind_{q.key}"] or "", v)])
        # a verdict sits beside the measure it judged (judged_by), never beside ours
        ours = (f"{tb.judged_title(q, e.exp)} [95% CI]" if q.judged_by else "Ours [95% CI]")
        out.append({"title": q.title + (f", judged on {tb.judged_title(q, e.exp)}"
                                        if q.judged_by else ""),
                    "head": ["Filter", "N", "Trials", ours, "Paper", "Verdict"], "rows": rows})
    if e.comparison.factors:
        rows = [[_cell(f"{f['quantity']}: {f['to']} / {f['from']}"),
                 _cell(tb.fmt(f["paper"], 3), True),
                 _cell(f"{tb.fmt(f['ours'], 3)} [{tb.fmt(f['lo'], 3)}, {tb.fmt(f['hi'], 3)}]",
                       True), _verdict(f["kind"] or "", f["verdict"] or "-")]
                for f in e.comparison.factors]
        out.append({"title": "Factors between the paper's rows (paired trials)",
                    "head": ["Factor", "Paper", "Ours [95% CI]", "Verdict"], "rows": rows})
    if e.comparison.per_trial is not None:
        title, head, cells = tb.per_trial_cells(e.comparison.per_trial)
        out.append({"title": title, "head": head,
                    "rows": [[_cell(c, i > 0) for i, c in enumerate(row)] for row in cells]})
    head, cells = tb.ranking_table(e.comparison.rankings)
    if cells:       # each pair's status coloured as a verdict: same, opposite, unresolved
        kinds = {"same": "reproduced", "opposite": "differs", "unresolved": "inconclusive"}
        out.append({"title": tb.RANKING_TITLE, "head": head,
                    "rows": [[_cell(c) if i < 2 or c not in kinds else _pair(kinds[c], c)
                              for i, c in enumerate(row)] for row in cells]})
    return out, reasons


def _pair(kind: str, text: str) -> dict:
    """An ordered pair's cell, coloured as the verdict it stands for, named in words."""
    return {"kind": kind, "mark": "", "text": text}


def _sweep_tables(e: rp.Entry) -> list[dict]:
    head, cells = rp.sweep_cells(e)
    n = len(e.sweep_keys)
    rows = [[_cell(c, i < n or i > n + 1) for i, c in enumerate(row)] for row in cells]
    out = [{"title": f"Swept: {', '.join(_key_words(k) for k in e.sweep_keys)}", "head": head,
            "rows": rows}]
    from . import curves as cv
    for name, c in (e.cells[0].curves if e.curves is not None else ()):
        g = e.curves[e.curves["curve"] == name]
        rows = [[_cell(rp._fmt_value(r[k]), True) for k in e.sweep_keys]
                + [_cell(r["label"]),
                   _cell("-" if r["paper"] != r["paper"] else
                         f"{tb.fmt(r['paper'])} +- {r['reading_error']:.2g}"
                         + (" (interpolated)" if r["how"].startswith("interpolated") else ""),
                         True),
                   _cell(f"{tb.fmt(r['ours'])} [{tb.fmt(r['ours_lo'])}, "
                         f"{tb.fmt(r['ours_hi'])}]", True),
                   _cell(r["verdict"])] for _, r in g.iterrows()]
        out.append({"title": f"Against the paper's curve {name}: {cv.counts(e.curves, name)}. "
                             + cv.describe(name, c),
                    "head": [_key_words(k) for k in e.sweep_keys]
                    + ["Filter", "paper", "ours [95% CI]", "verdict"], "rows": rows})
    return out


def _key_words(key: str) -> str:
    """A config key path in words ('scenario.speed_mps' -> 'robot speed (m/s)')."""
    return label(key)


def _provenance_html(e: rp.Entry) -> str:
    m = e.meta or {}
    v = m.get("versions", {})
    commit = m.get("git_commit") or "unknown"
    cells = f" in each of {len(e.cells)} cells" if e.cells else ""
    versions = ", ".join(f"{k} {escape(str(x))}" for k, x in v.items())
    return (f"<code>{escape(e.path.as_posix())}</code> &rarr; <code>{escape(e.folder.as_posix())}"
            f"</code>: {e.exp.trials} trials{cells}, seed {e.exp.seed}, scenario "
            f"<code>{escape(e.exp.scenario)}</code>, experiment hash <code>{e.exp.hash}</code>; "
            f"results of commit <code>{escape(commit[:12])}</code>"
            + (f", on {escape(str(m.get('platform')))}" if m.get("platform") else "")
            + (f"; {versions}" if versions else "") + ".")


def _draw_figures(e: rp.Entry, into: Path) -> list[Path]:
    """The entry's figures as SVG into ``into`` (from its trials and traces)."""
    from . import plots
    from .store import read_trials
    into.mkdir(parents=True, exist_ok=True)
    if e.cells:
        from .kinds import kind_of
        return plots.sweep_figures(e.table, e.sweep_keys, into, e.name,
                                   plots.sweep_metrics(e.exp), fmt="svg",
                                   unit=kind_of(e.exp.scenario).unit, into=into,
                                   curves=e.cells[0].curves)
    rows = read_trials(e.folder / "trials.csv").rows
    return plots.write_figures(e.exp, rows, e.folder, "svg", e.table, into=into)


# A report's figures, kept once drawn: an entry of the table cache's folder per results folder
# (pfbench.tablecache), ``<key>.figures.pkl``, a zlib-compressed pickle of {file name: SVG bytes}.
_FIGURES = "*.figures.pkl"


def figures_key(e: rp.Entry) -> str:
    """What a results folder's report figures are drawn from: the package's code and the
    versions of the libraries it reads them with (tablecache.code_digest) and matplotlib's, the
    experiment and its paper table (of a sweep, every cell's, with the paper's curves; not the
    path its config was read from, which draws nothing), and the bytes of every file of the
    folder but its figures (trials, traces, meta, a sweep's cells), each by its path inside the
    folder. A SHA-256."""
    import hashlib
    from dataclasses import replace

    from .tablecache import code_digest, library_version

    def exp_text(exp) -> str:
        return f"{replace(exp, source='')!r}|{exp.reported!r}"
    cells = [(c.name, c.values, exp_text(c.exp), c.curves) for c in e.cells or ()]
    h = hashlib.sha256(code_digest().encode())
    h.update(f"|matplotlib={library_version('matplotlib')}|{e.name}|{exp_text(e.exp)}"
             f"|{e.sweep_keys!r}|{cells!r}".encode())
    folder = Path(e.folder)
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder)
        if "figures" in rel.parts or not path.is_file() or path.is_symlink():
            continue
        h.update(f"|{rel.as_posix()}|".encode())
        h.update(file_digest(path))
    return h.hexdigest()


def _kept_figures(e: rp.Entry, into: Path, drawing=None) -> list[Path]:
    """The entry's figures as SVG into ``into``: the same bytes again where this code drew them
    from the same folder before (figures_key), else drawn and kept; ``drawing(e, kept)`` is told
    which, first. An entry that cannot be read, or a cache that cannot be written, only means
    drawing them."""
    import pickle
    import zlib

    from .tablecache import folder, store
    where, path = folder(), None
    if where is not None:
        try:
            path = where / f"{figures_key(e)}.figures.pkl"
        except OSError:             # a file of the folder that cannot be read: draw
            path = None
    if path is not None and path.is_file():
        try:
            kept = pickle.loads(zlib.decompress(path.read_bytes()))
            if (isinstance(kept, dict) and kept and all(
                    isinstance(n, str) and isinstance(b, bytes) and n.endswith(".svg")
                    and Path(n).name == n for n, b in kept.items())):
                into.mkdir(parents=True, exist_ok=True)
                for name, data in kept.items():
                    (into / name).write_bytes(data)
                if drawing:
                    drawing(e, kept=True)
                return [into / name for name in kept]
        except Exception:           # cut short, another format: draw again
            pass
    if drawing:
        drawing(e)
    paths = _draw_figures(e, into)
    if path is not None and paths and all(p.parent == into for p in paths):
        try:
            data = {p.name: p.read_bytes() for p in paths}
            store(where, path, zlib.compress(pickle.dumps(data, protocol=4)), _FIGURES)
        except Exception:
            pass
    return paths


def _section(e: rp.Entry, out_dir: Path, figures: bool, drawing=None) -> dict:
    table = e.exp.reported
    s = {"name": e.name, "status": e.status, "description": e.exp.description,
         "provenance": _provenance_html(e), "tables": [], "reasons": [], "notes": [],
         "paper_notes": [], "figures": [], "readings": None}
    if e.cells:
        s["title"] = f"Sweep: {e.path.stem}"
        s["caption"] = None
    else:
        s["title"] = f"{rp._table_name(e.exp.table)}: {e.path.stem}"
        s["caption"] = (f"The paper's table: {table.caption}."
                        + (f" The paper states {table.runs} run{'s' if table.runs > 1 else ''} "
                           "behind its values." if table.runs else "")) if table else None
    if e.status != "ok":
        return s
    if e.cells:
        s["tables"] = _sweep_tables(e)
    elif table is not None:
        s["tables"], s["reasons"] = _comparison_tables(e)
        s["notes"] = [n for n in tb.footnotes(e.comparison) if not n.startswith("'RMSE - ")]
        s["paper_notes"] = list(table.notes)
        s["readings"] = _readings(e)
    else:
        rows = [[_cell(r["label"]), _cell(rp._n(r["particles"]), True),
                 _cell(int(r["trials"]), True),
                 _cell(f"{tb.fmt(r['rmse_mean'])} [{tb.fmt(r['rmse_ci_lo'])}, "
                       f"{tb.fmt(r['rmse_ci_hi'])}]", True)] for _, r in e.table.iterrows()]
        s["tables"] = [{"title": None, "head": ["Filter", "N", "Trials", "RMSE mean [95% CI]"],
                        "rows": rows}]
    if figures:
        into = out_dir / "figures" / e.name
        for p in sorted(_kept_figures(e, into, drawing)):
            s["figures"].append({"src": os.path.relpath(p, out_dir).replace(os.sep, "/"),
                                 "alt": figure_words(p.stem, e)})
    return s


# what a figure of a results folder shows, by its file's name (the others: a metric's
# distribution over the trials, or a sweep's metric against the swept key)
FIGURE_WORDS = {"course": "the course, the landmarks and the estimated paths",
                "errors": "the estimation errors over time, median and interquartile band over the "
                f"trials (the first {FIGURE_TRIALS} at most)",
                "ess": "trial 0's effective sample size over time",
                "particles": "the particles at chosen steps",
                "ratios": "each cost over the baseline's as the verdicts judge it (a run time on "
                "the likelihood evaluations), per filter run, beside the paper's value",
                "paths": "the true path, dead reckoning and each filter's estimated path over "
                "the map with the beacons, in one trial",
                "convergence": "the convergence rate of each filter run with its Wilson "
                "interval, and when the converged trials converged"}


def figure_words(stem: str, e: rp.Entry) -> str:
    """A figure's caption in words: what it shows, and of which experiment."""
    if stem in FIGURE_WORDS:
        what = FIGURE_WORDS[stem]
    elif e.cells:
        what = f"{label(stem)} against {', '.join(label(k) for k in e.sweep_keys)}"
    else:
        what = f"{label(stem)} over the trials, per filter run"
    return f"{what[:1].upper()}{what[1:]} ({e.path.stem})"


def _readings(e: rp.Entry) -> dict | None:
    """The readings of an experiment's results folder for its section: the robustness lines and
    the readings table (pfbench.readings); None when it holds none."""
    from . import readings as rd
    rows = rd.read_csv(e.folder)
    if not rows:
        return None
    names = list(dict.fromkeys(r["reading"] for r in rows))
    head, cells = rd.grid(rows)
    return {"intro": f"{len(names)} readings ({', '.join(names)}); each claim of the table "
                     "across them:", "lines": rd.lines_of(rows), "legend": rd.LEGEND,
            "head": head, "rows": cells, "note": rd.family_note(rows, len(names))}


def build(configs: Path, results: Path, out_dir: Path, figures: bool = True,
          entries: list | None = None, status=None) -> dict[str, bytes]:
    """Every file of the HTML report, by its path under ``out_dir``: index.html, a page per
    paper (other.html: the experiments that name none), and (``figures``) the SVG figures.
    ``entries``: collected already (pfbench.report.collect). ``status(line)``: told whose
    figures it draws as it goes."""
    env = _env()
    entries = list(entries) if entries is not None else rp.collect(configs, results)
    count = [0, sum(e.status == "ok" for e in entries)]

    def drawing(e, kept: bool = False):
        count[0] += 1
        if status:
            status(f"the figures of {e.name} ({count[0]} of {count[1]}): as drawn before" if kept
                   else f"drawing the figures of {e.name} ({count[0]} of {count[1]})")
    papers = rp.reported_papers(entries, configs)
    by_name = {e.name: e for e in entries}
    # the experiments that name no paper get a page of their own, as REPORT.md's last section
    others = [e for e in entries if e.exp.reference is None]
    other = SimpleNamespace(key="other", citation="experiments that name no paper", about=None)
    nav = [{"key": k, "page": f"{k}.html", "citation": papers[k].citation} for k in sorted(papers)]
    nav += [{"key": other.key, "page": "other.html", "citation": other.citation}] if others else []
    files: dict[str, bytes] = {}
    with tempfile.TemporaryDirectory() as tmp:
        stage = Path(tmp)
        summary = []
        for e in sorted(entries, key=lambda e: (e.exp.paper or "~", e.cells is not None,
                                                e.exp.table or "", e.path.stem)):
            row = rp._summary_row(e)
            page = (f"{e.exp.paper}.html#{e.name}" if e.exp.paper in papers
                    else f"other.html#{e.name}" if e in others else None)
            row[2] = (f'<a href="{page}">{e.path.stem}</a>' if page else e.path.stem)
            summary.append([str(c).replace("`", "") if i != 2 else c for i, c in enumerate(row)])
        index = [{"paper": ln.paper, "table": ln.table, "headline": ln.headline.rstrip("."),
                  "configs": [{"name": c.path.stem, "page": f"{c.exp.paper}.html#{c.name}",
                               "counts": counts, "marks": marks}
                              for c, counts, marks in ln.configs]}
                 for ln in rp.index_lines(entries, papers, by_name)]
        files["index.html"] = env.get_template("index.html").render(
            index=index, index_title=rp.INDEX_TITLE, index_intro=rp.INDEX_INTRO,
            title="pfbench reproduction report", css=CSS, papers=nav, version=__version__,
            definitions=[_emphasis(d) for d in DEFINITIONS], marks=[(k, m) for k, m in MARKS.items() if k],
            summary_head=["Paper", "Table", "Config", "Trials", "Paper values", "Reproduced",
                          "Differ", "Inconclusive", "Not comparable",
                          "Ordered pairs: same / opposite / unresolved"],
            summary=summary).encode()
        for key in sorted(papers):
            p = papers[key]
            mine = [e for e in entries if e.exp.paper == key]
            mine.sort(key=lambda e: (e.cells is not None, e.exp.table or "", e.path.stem))
            sections = [_section(e, stage, figures, drawing) for e in mine]
            files[f"{key}.html"] = env.get_template("paper.html").render(
                title=f"{key}: pfbench reproduction", css=CSS, papers=nav, version=__version__,
                paper=p, sections=sections, choices=rp.choice_rows(p, mine or entries),
                findings=rp.findings(p, by_name) if p.findings else [],
                implementation=p.implementation, lang="zh",
                implementation_title=rp.IMPLEMENTATION_TITLE,
                implementation_intro=rp.IMPLEMENTATION_INTRO, status_words=rp.STATUS_WORDS,
                readings_outcome=rp.readings_outcome(mine) if p.implementation else [],
                readings_title=rp.READINGS_TITLE, readings_intro=rp.READINGS_INTRO,
                elsewhere=[rp._table_name(k) for k in rp.tables_elsewhere(p, entries)]
                if mine else [],
                ).encode()
        if others:
            files["other.html"] = env.get_template("paper.html").render(
                title="other experiments: pfbench", css=CSS, papers=nav, version=__version__,
                paper=other, sections=[_section(e, stage, figures, drawing) for e in others],
                choices=[], findings=[]).encode()
        for path in sorted(stage.rglob("*.svg")):
            files[path.relative_to(stage).as_posix()] = path.read_bytes()
    return files


def _managed(name: str) -> bool:
    """Whether a file of the report's folder (by its path there) is one the report writes: the
    pages (``*.html``) and the figures (``figures/**.svg``); any other file is left alone."""
    parts = name.split("/")
    return (len(parts) == 1 and name.endswith(".html")) or \
        (parts[0] == "figures" and name.endswith(".svg"))


def _held(out_dir: Path) -> dict[str, bytes]:
    if not out_dir.is_dir() or out_dir.is_symlink():
        return {}
    return {k: p.read_bytes() for p in out_dir.rglob("*")
            if p.is_file() and not p.is_symlink()
            and _managed(k := p.relative_to(out_dir).as_posix())}


def differences(out_dir: Path, files: dict[str, bytes], check: bool = False) -> list[str]:
    """The report's files that differ from what ``out_dir`` holds (files it would add, change
    or remove); with ``check``, the pages byte for byte and a figure only by its presence: its
    bytes depend on the plotting library's version, its content on the trials the tables are
    checked on."""
    held = _held(Path(out_dir))
    differ = sorted(k for k in set(files) | set(held) if files.get(k) != held.get(k))
    if check:
        return [k for k in differ if not k.endswith(".svg") or (k in files) != (k in held)]
    return differ


def write(configs: Path, results: Path, check: bool = False, figures: bool = True,
          out_dir: Path | None = None) -> tuple[Path, list[str]]:
    """Write the HTML report into ``out_dir`` (default ``results/report/``; replacing the pages
    and figures it held, no other file), or with ``check`` compare (see differences); return
    (its index, the files that differ from what the folder held). Writing into the results
    folder holds its lock (not while 'pfbench tables' rewrites the results)."""
    out_dir = Path(out_dir) if out_dir is not None else Path(results) / "report"
    files = build(Path(configs), Path(results), out_dir, figures)
    differ = differences(out_dir, files, check)
    if check:
        return out_dir / "index.html", differ
    with FolderLock(out_dir.parent, "--out"):
        own_folder(out_dir, out_dir.parent, "--out")
        replace(out_dir, files)
    return out_dir / "index.html", differ


def replace(out_dir: Path, files: dict[str, bytes]) -> None:
    """Make ``out_dir`` hold ``files`` and none of the report's other pages and figures (only
    what changed is rewritten; files the report does not write are left alone; no link is
    followed)."""
    out_dir = Path(out_dir)
    held = _held(out_dir)
    for name in set(held) - set(files):
        (out_dir / name).unlink()
    for name, data in files.items():
        path = out_dir / name
        own_folder(path.parent, out_dir.parent, "--out")
        make_folders(path.parent, "--out")
        if held.get(name) != data:
            atomic_write(path, data)
    if out_dir.is_dir():
        for d in sorted((p for p in out_dir.rglob("*") if p.is_dir() and not p.is_symlink()),
                        reverse=True):
            if not any(d.iterdir()):
                d.rmdir()
