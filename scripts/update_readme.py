#!/usr/bin/env python3
"""Regenerate what the documentation shows of the code and of the committed results, never
written by hand:

- in docs/: the config-key reference (from the schemas), the trials file's metric columns of each
  scenario kind (from pfbench.kinds and pfbench.metrics), the worked example (from the committed
  results/ifa_pf_ungm/table.csv), the speed tables (from the committed bench record,
  bench/record.json, which `pfbench bench --json` wrote), and each paper page's findings, open
  choices and algorithms step by step beside pfbench's functions (from the committed
  results/REPORT.md);
- whole pages: the command-line reference (docs/reference/cli.md, from the typer app: every
  command and option with its help) and the Python API (docs/reference/api.md, from the
  docstrings of pfbench.api's public names);
- in README.md: the summary of the committed results (from results/REPORT.md).

A generated block sits between `<!-- NAME:begin -->` and `<!-- NAME:end -->` in a Markdown file
(README.md or any page under docs/); NAME is one of BLOCKS, or `findings:PAPER`,
`choices:PAPER` / `implementation:PAPER`.

    python scripts/update_readme.py            # list the generated blocks and pages
    python scripts/update_readme.py --write    # rewrite them
    python scripts/update_readme.py --check    # exit 1 if any is stale
"""
from __future__ import annotations

import inspect
import json
import math
import re
import sys
from pathlib import Path

import pandas as pd

from pfbench.config import CHECK_SCHEMA, COMPARE_SCHEMA, FILTER_COMMON, TOP_SCHEMA
from pfbench.filters import FILTERS
from pfbench.kinds import KINDS
from pfbench.metrics import METRICS
from pfbench.scenarios import SCENARIOS
from pfbench.schema import REQUIRED

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DOCS = ROOT / "docs"
REPORT = ROOT / "results" / "REPORT.md"
EXAMPLE = ROOT / "results" / "ifa_pf_ungm" / "table.csv"
BENCH = ROOT / "bench" / "record.json"


def _default(key) -> str:
    if key.default is REQUIRED:
        return "required"
    if key.default is None:
        return "-"
    if isinstance(key.default, bool):
        return f"`{str(key.default).lower()}`"
    return f"`{key.default}`"


def _table(title: str, schema: dict, prefix: str) -> list[str]:
    lines = [f"**{title}**", "", "| key | type | default | meaning |", "| --- | --- | --- | --- |"]
    for name, key in schema.items():
        lines.append(f"| `{prefix}{name}` | {key.expected()} | {_default(key)} | "
                     f"{_esc(key.doc.replace('|', '/'))} |")
    return lines + [""]


def keys_block() -> str:
    out = ["", "*Generated from the schemas by `python scripts/update_readme.py --write`.*", ""]
    out += _table("Top level", TOP_SCHEMA, "")
    out += _table("`compare:` (how verdicts are given)", COMPARE_SCHEMA, "compare.")
    out += _table("`check:` (what `pfbench tables --check` runs)", CHECK_SCHEMA, "check.")
    out += _table("Every filter (`filters.<key>.`)", FILTER_COMMON, "")
    for name, ftype in FILTERS.items():
        if ftype.schema:
            out += _table(f"Filter type `{name}`: {ftype.description}", ftype.schema, "")
        else:
            out += [f"**Filter type `{name}`**: {ftype.description}; no keys of its own.", ""]
    for name, mod in SCENARIOS.items():
        out += _table(f"Scenario `{name}` (`scenario.name: {name}`): {mod.DESCRIPTION}",
                      mod.SCHEMA, "scenario.")
    return "\n".join(out)


def _g(v, digits=4) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}g}"


def example_block() -> str:
    tab = pd.read_csv(EXAMPLE)
    out = ["", "| Filter | N | Trials | RMSE mean [95% CI] | Paper RMSE | Ratio | Verdict |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    for _, r in tab.iterrows():
        verdict = r["verdict_rmse_mean"] if isinstance(r["verdict_rmse_mean"], str) else "-"
        out.append(f"| {r['label']} | {int(r['particles'])} | {int(r['trials'])} | "
                   f"{_g(r['rmse_mean'])} [{_g(r['rmse_ci_lo'])}, {_g(r['rmse_ci_hi'])}] | "
                   f"{_g(r['paper_rmse_mean'], 6)} | {_g(r['ratio_rmse_mean'], 3)} | {verdict} |")
    return "\n".join(out + [""])


def metrics_block() -> str:
    kinds = list(KINDS.values())
    out = ["", "*Generated from `pfbench/kinds.py` and `pfbench/metrics.py` by `python "
           "scripts/update_readme.py --write`.*", "",
           "| column | " + " | ".join(k.name for k in kinds) + " | meaning |",
           "| --- | " + " | ".join("---" for _ in kinds) + " | --- |"]
    for m, doc in METRICS.items():
        marks = " | ".join("x" if m in k.metrics else "(x)" if m in k.reported else ""
                           for k in kinds)
        out.append(f"| `{m}` | {marks} | {_esc(doc.replace('|', '/'))} |")
    return "\n".join(out + ["", "(x): only in the trials of an experiment with a filter that "
                             "reports it (its `FilterType.reports`).", ""])


def _m(rate) -> str:
    return f"{rate / 1e6:.1f} M" if rate >= 1e6 else f"{rate / 1e6:.2f} M"


def _x(r) -> str:
    return f"{r:.2f}x" if r < 10 else f"{r:.1f}x" if r < 100 else f"{r:.0f}x"


def bench_block() -> str:
    """The speed tables, every number from the one run that bench/record.json holds."""
    recs = json.loads(BENCH.read_text())
    run = next(r for r in recs if r["workload"] == "run")
    out = ["", f"*Generated from `bench/record.json` by `python scripts/update_readme.py "
           f"--write`; the record is one run of `{run['command']}` on this machine ({run['cores']} "
           f"cores, numba {run['numba']}, numpy {run['numpy']}).*", ""]
    rate = {(r["workload"], r["impl"], r.get("mode"), r["particles"]): r["particle_steps_per_s"]
            for r in recs if "particle_steps_per_s" in r}
    sizes = sorted({r["particles"] for r in recs if r["workload"] == "ungm"
                    and r.get("mode") == "single"})
    batch = {r["impl"]: r for r in recs if r["workload"] == "ungm" and r.get("mode") == "batch"}
    out += ["UNGM bootstrap PF, particle-steps per second:", "",
            "| run | N | trials | pfbench | numpy | C reference | pfbench / numpy | "
            "pfbench / C |", "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for N in sizes:
        p, n, c = (rate.get(("ungm", i, "single", N)) for i in ("pfbench", "numpy", "c"))
        out.append(f"| one trial, 1 thread | {N:,} | 1 | {_m(p)} | {_m(n)} | "
                   f"{_m(c) if c else '-'} | {_x(p / n)} | {_x(p / c) if c else '-'} |")
    if batch:
        p, n, c = (batch.get(i) for i in ("pfbench", "numpy", "c"))
        out.append(f"| batch, {p['threads']} threads (numpy: 1) | {p['particles']} | "
                   f"{p['trials']:,} | {_m(p['particle_steps_per_s'])} | "
                   f"{_m(n['particle_steps_per_s'])} | "
                   f"{_m(c['particle_steps_per_s']) if c else '-'} | "
                   f"{_x(p['particle_steps_per_s'] / n['particle_steps_per_s'])} | "
                   f"{_x(p['particle_steps_per_s'] / c['particle_steps_per_s']) if c else '-'} |")
        out += ["", f"The same filter: the batch's mean RMSE on the same data, pfbench "
                f"{p['mean_rmse']:.3f}, numpy {n['mean_rmse']:.3f}."]
    peers = sorted({r["particles"] for r in recs if r["workload"] == "ungm-peers"})
    if peers:
        out += ["", "The same filter written with the peers (one trial, one thread):", "",
                "| N | pfbench | particles | filterpy | pfbench / particles | "
                "pfbench / filterpy |", "| --- | --- | --- | --- | --- | --- |"]
        for N in peers:
            p, a, b = (rate[("ungm-peers", i, "single", N)]
                       for i in ("pfbench", "particles", "filterpy"))
            out.append(f"| {N:,} | {_m(p)} | {_m(a)} | {_m(b)} | {_x(p / a)} | {_x(p / b)} |")
        chk = {r["impl"]: r for r in recs if r["workload"] == "ungm-peers-check"}
        out += ["", f"The check: mean RMSE over the same {chk['pfbench']['trials']} trials at "
                f"N = {chk['pfbench']['particles']}: " + ", ".join(
                    f"{k} {r['mean_rmse']:.3f}" for k, r in chk.items()) + "; paired "
                "differences to pfbench " + ", ".join(
                    f"{k} {r['paired_diff']:+.3f} (standard error {r['paired_diff_se']:.3f})"
                    for k, r in chk.items() if k != "pfbench") + "."]
    for wl, title in (("ungm-limit", "UNGM bootstrap PF"), ("mcl-limit", "MCL, beacon field"),
                      ("fastslam-limit", "FastSLAM, landmark world, nearest neighbour")):
        rows = [r for r in recs if r["workload"] == wl]
        for N in sorted({r["particles"] for r in rows}):
            rs = [r for r in rows if r["particles"] == N]
            out += ["", f"{title}, N = {N:,}: the passes alone (ns per particle and step)", "",
                    "| pass | ns | share |", "| --- | --- | --- |"]
            for r in rs:
                if r["impl"] == "pass":
                    out.append(f"| {r['filter']} | {r['ns_per_particle_step']:.1f} | "
                               f"{100 * r['share_of_limit']:.0f}% |")
                elif r["impl"] == "limit":
                    out.append(f"| **the practical limit (their sum)** | "
                               f"**{r['ns_per_particle_step']:.1f}** | |")
                else:
                    c = rate.get(("ungm", "c", "single", N)) if wl == "ungm-limit" else None
                    vs_c = (f"; {(1e9 / r['ns_per_particle_step']) / c:.2f}x the C "
                            f"reference ({1e9 / c:.1f} ns)" if c else "")
                    out.append(f"| the pfbench kernel | {r['ns_per_particle_step']:.1f} | "
                               f"{r['kernel_over_limit']:.2f}x the limit{vs_c} |")
    runs = [r for r in recs if r["workload"] == "run-path"]
    if runs:
        out += ["", "What `pfbench run` runs, beside the bare kernel (ns per particle-step on the "
                "same trials, one thread, timed alternately; run: `runner.trial_result` with the "
                "trial's simulation, each run's fresh inputs, the diagnostics its config "
                "computes, the output checks, the metrics and the traces kept for the figures; "
                "kernel: the same filters with the diagnostics off):", "",
                "| workload | N | diagnostics | kernel | run | run / kernel | target |",
                "| --- | --- | --- | --- | --- | --- | --- |"]
        for k, r in zip(runs[0::2], runs[1::2]):
            out.append(f"| {r['filter']}: `{Path(r['config']).stem}`, {r['runs']} | "
                       f"{r['particles']:,} | {', '.join(r['diagnostics']) or 'none'} | "
                       f"{k['ns_per_particle_step']:.1f} | {r['ns_per_particle_step']:.1f} | "
                       f"{r['run_over_kernel']:.2f}x | {r['target']:.1f}x"
                       f"{'' if r['meets_target'] else ' (missed)'} |")
    costs = [r for r in recs if r["workload"] == "ungm-filters"]
    if costs:
        base = next(c["seconds_per_step"] for c in costs if c["filter"] == "pf")
        out += ["", f"Every scalar filter's cost per step at N = {costs[0]['particles']} "
                "(default settings, one thread, each call's fixed cost included):", "",
                "| filter | cost grows as | us / step | x bootstrap PF |",
                "| --- | --- | --- | --- |"]
        out += [f"| {c['filter']} | {c['grows_as']} | {1e6 * c['seconds_per_step']:.2f} | "
                f"{c['seconds_per_step'] / base:.2f}x |" for c in costs]
    fs = {r["impl"]: r for r in recs if r["workload"] == "fastslam-course"}
    if fs:
        p, n = fs["pfbench"], fs["numpy"]
        out += ["", f"FastSLAM on the ifa2021 course, N = {p['particles']}, one thread: "
                f"{p['steps_per_s']:,.0f} control steps per second, against "
                f"{n['steps_per_s']:,.0f} for a straightforward numpy FastSLAM (a Python loop "
                f"over particles and observations): {_x(p['steps_per_s'] / n['steps_per_s'])}."]
    afsa = [r for r in recs if r["workload"] == "afsa-world"]
    if afsa:
        out += ["", f"The FastSLAM variants of `configs/afsa_fastslam.yaml` (one trial of "
                f"{afsa[0]['steps']} steps, an observation each, nearest-neighbour association, "
                "one thread):", "", "| filter | N | steps / s | x FastSLAM | "
                "likelihood evaluations / step |", "| --- | --- | --- | --- | --- |"]
        out += [f"| {r['filter']} | {r['particles']} | {r['steps_per_s']:,.0f} | "
                f"{r['relative_to_fastslam']:.2f}x | {r['evals_per_step']:.0f} |" for r in afsa]
    mcl = {(r["impl"], r["particles"]): r for r in recs if r["workload"] == "mcl-beacon-field"}
    if mcl:
        out += ["", "Plain MCL on the beacon field of `configs/sspf_global.yaml` (systematic "
                "resampling every step, one thread): " + "; ".join(
                    f"N = {N:,}: {mcl[('pfbench', N)]['steps_per_s']:,.0f} steps per second, "
                    f"numpy {mcl[('numpy', N)]['steps_per_s']:,.0f} "
                    f"({_x(mcl[('pfbench', N)]['steps_per_s'] / mcl[('numpy', N)]['steps_per_s'])})"
                    for N in sorted({k[1] for k in mcl})) + "."]
    more = [r for r in recs if r["workload"] in ("kld-mcl-global", "sspf-field")]
    if more:
        out += ["", "On the same trial, global localization (one thread; a particle-step is a "
                "particle a step drew):", "", "| filter | N (at most) | particles a step | "
                "steps / s | ns / particle-step |", "| --- | --- | --- | --- | --- |"]
        out += [f"| {r['filter']} | {r['particles']:,} | {r['mean_particles']:,.0f} | "
                f"{r['steps_per_s']:,.0f} | {1e9 / r['particle_steps_per_s']:,.0f} |"
                for r in more]
    return "\n".join(out + [""])


# ---- the papers' findings and open choices, from the committed report

def _report_section(paper: str) -> str:
    text = REPORT.read_text()
    m = re.search(rf"^## `{re.escape(paper)}`.*?(?=^## |\Z)", text, re.S | re.M)
    if not m:
        raise SystemExit(f"results/REPORT.md has no section for paper {paper!r}")
    return m.group(0)


def findings_block(paper: str) -> str:
    """The report's 'What reproduced and what did not' of one paper."""
    sec = _report_section(paper)
    m = re.search(r"What reproduced and what did not:\n\n(.*?)(?:\n\n|\Z)", sec, re.S)
    if not m:
        raise SystemExit(f"results/REPORT.md: paper {paper!r} has no findings")
    return ("\n*From the committed `results/REPORT.md` (`pfbench report`), by `python "
            "scripts/update_readme.py --write`.*\n\n" + m.group(1).strip() + "\n")


def choices_block(paper: str) -> str:
    """The report's table of the choices the paper left open, with the value each config uses."""
    sec = _report_section(paper)
    m = re.search(r"### Choices the paper left open, and the values used\n\n.*?\n\n"
                  r"(\| The paper.*?)(?:\n\n|\n*\Z)", sec, re.S)
    if not m:
        raise SystemExit(f"results/REPORT.md: paper {paper!r} has no table of choices")
    return ("\n*From the committed `results/REPORT.md` (`pfbench report`), by `python "
            "scripts/update_readme.py --write`; 'unset' is the key's default of none (see "
            "the [config keys](../reference/config.md)).*\n\n" + m.group(1).strip() + "\n")


def implementation_block(paper: str) -> str:
    """The report's 'Did we implement it as the paper says?' of one paper: each algorithm's steps
    as the paper's text gives them beside pfbench's functions (and the readings' outcome where
    the report has it)."""
    sec = _report_section(paper)
    m = re.search(r"^### Did we implement it as the paper says\?\n\n(.*?)(?=^### |^## |\Z)", sec,
                  re.S | re.M)
    if not m:
        raise SystemExit(f"results/REPORT.md: paper {paper!r} has no 'Did we implement it as "
                         "the paper says?'")
    return ("\n*From the committed `results/REPORT.md` (`pfbench report`), by `python "
            "scripts/update_readme.py --write`.*\n\n" + m.group(1).strip() + "\n")


def summary_block() -> str:
    """The report's summary table: per config, the paper values compared and their verdicts."""
    text = REPORT.read_text()
    m = re.search(r"^## Summary\n\n(\|.*?)(?:\n\n|\Z)", text, re.S | re.M)
    if not m:
        raise SystemExit("results/REPORT.md has no summary table")
    return ("\n*From the committed `results/REPORT.md` by `python scripts/update_readme.py "
            "--write`.*\n\n" + m.group(1).strip() + "\n")


# ---- the command line, from the typer app

def _unrich(text: str) -> str:
    return _esc(re.sub(r"\\\[", "[", (text or "").strip()))


def _esc(text: str) -> str:
    """Markdown prose with `<` and `>` shown as such (outside code spans), never read as HTML."""
    parts = re.split(r"(`[^`]*`)", text)
    return "".join(p if p.startswith("`") else p.replace("<", "&lt;").replace(">", "&gt;")
                   for p in parts)


def cli_page() -> str:
    import typer

    from pfbench.cli import app
    group = typer.main.get_command(app)
    # the click the command is made of (typer 0.2x carries its own copy): its Context class
    top = group.context_class(group, info_name="pfbench")
    out = ["# Command line", "",
           "*Generated from the typer app (`pfbench.cli`) by `python scripts/update_readme.py "
           "--write`: every command and option with its help, as `pfbench COMMAND --help` "
           "prints it. What the commands do, at length: [Running experiments]"
           "(../guide/running.md).*", "",
           "```text", "pfbench [OPTIONS] COMMAND [ARGS]...", "```", "",
           _unrich(group.help), "", "| option | meaning |", "| --- | --- |"]
    for p in group.params:
        rec = p.get_help_record(top)
        if rec and not getattr(p, "hidden", False):
            out.append(f"| `{rec[0]}` | {_unrich(rec[1]).replace('|', '/')} |")
    out.append("")
    for name, cmd in group.commands.items():
        if getattr(cmd, "hidden", False):
            continue
        ctx = cmd.context_class(cmd, info_name=name, parent=top)
        args = [p.name.upper() for p in cmd.params if p.param_type_name == "argument"]
        out += [f"## `pfbench {name}`", "", "```text",
                " ".join(["pfbench", name, "[OPTIONS]", *args]), "```", "",
                " ".join(_unrich(cmd.help).split()), "",
                "| argument or option | meaning |", "| --- | --- |"]
        for p in cmd.params:
            rec = p.get_help_record(ctx)
            if rec and not getattr(p, "hidden", False):
                opt = rec[0] if p.param_type_name != "argument" else p.name.upper()
                out.append(f"| `{opt}` | {' '.join(_unrich(rec[1]).split()).replace('|', '/')} |")
        out.append("")
    return "\n".join(out)


# ---- the Python API, from the docstrings

def _docstring_md(doc: str) -> list[str]:
    """A numpy-style docstring as Markdown: its prose as paragraphs, each `name : text` entry as
    a bullet; ``code`` as `code`."""
    doc = inspect.cleandoc(doc or "").replace("``", "`")
    out: list[str] = []
    entry = re.compile(r"^([A-Za-z_][\w, ]*) : (.*)$")
    for line in doc.splitlines():
        m = entry.match(line)
        if m:
            out.append(f"- `{m.group(1)}`: {_esc(m.group(2))}")
        elif line.startswith("    ") and out and out[-1].startswith("- "):
            out[-1] += " " + _esc(line.strip())
        elif line.startswith("    "):
            out.append(line)            # a code example, indented in the docstring
        else:
            out.append(_esc(line))
    return out


def api_page() -> str:
    import pfbench
    from pfbench import api
    from pfbench.errors import UserError
    out = ["# Python API", "",
           "*Generated from the docstrings of `pfbench.api`'s public names by `python "
           "scripts/update_readme.py --write`. How to use them: [the Python API]"
           "(../how-to/python-api.md).*", ""]
    out += _docstring_md(api.__doc__) + [""]
    names = [n for n in pfbench.__all__ if n in api.__all__]
    for name in names:
        obj = getattr(api, name)
        kind = "class" if inspect.isclass(obj) else "function"
        out += [f"## `pfbench.{name}`", "", "```text",
                f"{kind} pfbench.{name}{inspect.signature(obj)}", "```", ""]
        out += _docstring_md(obj.__doc__) + [""]
    out += ["## `pfbench.errors.UserError`", "", "```text",
            "class pfbench.errors.UserError(Exception)", "```", ""]
    out += _docstring_md(UserError.__doc__) + [""]
    out += ["## `pfbench.CACHE_DIR`, `pfbench.__version__`", "",
            "The folder of the kernel cache (see [caches](../internals/caches.md)), and the "
            "installed version.", ""]
    return "\n".join(out)


# ---- the map of the code, from the modules' docstrings

def modules_block() -> str:
    """Every module of the package with the first line of its docstring, so the map of the code
    names every module there is."""
    import ast
    out = ["", "*Generated from the modules' docstrings by `python scripts/update_readme.py "
           "--write`.*", "", "| module | what it is |", "| --- | --- |"]
    for path in sorted((ROOT / "pfbench").rglob("*.py")):
        doc = ast.get_docstring(ast.parse(path.read_text())) or ""
        first = " ".join(doc.split("\n\n")[0].split()).replace("``", "`").replace("|", "/")
        out.append(f"| `{path.relative_to(ROOT).as_posix()}` | {first} |")
    return "\n".join(out + [""])


def compatibility_block() -> str:
    """What each need means, and pfbench's own filters against its own scenarios, kind by kind:
    'yes', or what the scenario lacks (pfbench.protocols)."""
    from pfbench.filters import BUILTIN as FILTER_BUILTIN
    from pfbench.protocols import NEEDS, NOT_NAMED, UNKNOWN, compatibility
    from pfbench.scenarios import BUILTIN as SCENARIO_BUILTIN
    out = ["", "*Generated from the filters' `needs` and the scenarios' `PROVIDES` by "
           "`python scripts/update_readme.py --write`.*", "", "| need | what it is |",
           "| --- | --- |"]
    out += [f"| `{n}` | {_esc(text)} |" for n, text in NEEDS.items()]
    out += ["", "| filter | needs |", "| --- | --- |"]
    out += [f"| `{f}` | {', '.join(f'`{n}`' for n in ft.needs) or 'nothing beyond its kind'} |"
            for f, ft in FILTER_BUILTIN.items()]
    for kind, (scens, filts, cells) in compatibility(FILTER_BUILTIN, SCENARIO_BUILTIN).items():
        out += ["", f"**{kind}** scenarios", "", "| scenario | provides | "
                + " | ".join(f"`{f}`" for f in filts) + " |",
                "| --- | --- |" + " --- |" * len(filts)]
        for sc in scens:
            row = ["yes" if not cells[sc, f] else "no" if cells[sc, f] == (NOT_NAMED,) else
                   "?" if cells[sc, f] == (UNKNOWN,) else "lacks " + ", ".join(cells[sc, f])
                   for f in filts]
            given = ", ".join(f"`{n}`" for n in SCENARIO_BUILTIN[sc].PROVIDES) or "-"
            out.append(f"| `{sc}` | {given} | " + " | ".join(row) + " |")
    return "\n".join(out + [""])


BLOCKS = {"compatibility": compatibility_block, "config-keys": keys_block, "metrics": metrics_block, "example": example_block,
          "bench": bench_block, "summary": summary_block, "modules": modules_block}
PARAMETRISED = {"findings": findings_block, "choices": choices_block,
                "implementation": implementation_block}
# the blocks that must appear somewhere: a generated table never vanishes from the docs unseen
REQUIRED_BLOCKS = ("compatibility", "config-keys", "metrics", "example", "bench", "summary", "modules")
PAGES = {"reference/cli.md": cli_page, "reference/api.md": api_page}
MARK = re.compile(r"<!-- ([\w-]+(?::[\w-]+)?):begin -->")


def _make(name: str) -> str:
    if name in BLOCKS:
        return BLOCKS[name]()
    kind, _, arg = name.partition(":")
    if kind in PARAMETRISED and arg:
        return PARAMETRISED[kind](arg)
    raise SystemExit(f"unknown generated block {name!r}")


def render(text: str, where: str = "README.md") -> str:
    pos = 0
    while (m := MARK.search(text, pos)):
        name = m.group(1)
        end = f"<!-- {name}:end -->"
        j = text.find(end, m.end())
        if j < 0:
            raise SystemExit(f"{where}: the {name} block has no end marker")
        text = text[: m.end()] + "\n" + _make(name) + "\n" + text[j:]
        pos = text.find(end, m.end()) + len(end)
    return text


def sources() -> list[Path]:
    """README.md and every Markdown page under docs/ (the generated pages aside)."""
    pages = sorted(p for p in DOCS.rglob("*.md")
                   if p.relative_to(DOCS).as_posix() not in PAGES)
    return [README, *pages]


def expected() -> dict[Path, str]:
    """Every file the script writes, with what it must hold."""
    out: dict[Path, str] = {}
    seen: set[str] = set()
    for path in sources():
        text = path.read_text()
        seen |= set(MARK.findall(text))
        out[path] = render(text, str(path.relative_to(ROOT)))
    missing = [b for b in REQUIRED_BLOCKS if b not in seen]
    if missing:
        raise SystemExit(f"no page holds the generated block(s) {', '.join(missing)}")
    for rel, make in PAGES.items():
        out[DOCS / rel] = make()
    return out


def main(argv: list[str]) -> int:
    want = expected()
    if "--write" in argv:
        for path, text in want.items():
            if not path.is_file() or path.read_text() != text:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
                print(f"wrote {path.relative_to(ROOT)}")
    elif "--check" in argv:
        stale = [str(p.relative_to(ROOT)) for p, t in want.items()
                 if not p.is_file() or p.read_text() != t]
        if stale:
            print(f"stale generated docs ({', '.join(stale)}; config keys, CLI, API, results "
                  "or bench record changed): run python scripts/update_readme.py --write",
                  file=sys.stderr)
            return 1
    else:
        for path, text in want.items():
            names = MARK.findall(text) or ["(whole page)"]
            print(f"{path.relative_to(ROOT)}: {', '.join(names)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
