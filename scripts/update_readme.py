#!/usr/bin/env python3
"""Regenerate the generated blocks of README.md: the config-key reference (from the schemas), the
trials file's metric columns of each scenario kind (from pfbench.kinds and pfbench.metrics), the
worked example (from the committed results/ifa_pf_ungm/table.csv) and the speed tables (from the
committed bench record, bench/record.json, which `pfbench bench --json` wrote).

    python scripts/update_readme.py            # print the blocks
    python scripts/update_readme.py --write    # replace them in README.md
    python scripts/update_readme.py --check    # exit 1 if README.md is stale
"""
from __future__ import annotations

import json
import math
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
                     f"{key.doc.replace('|', '/')} |")
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
        marks = " | ".join("x" if m in k.metrics else "" for k in kinds)
        out.append(f"| `{m}` | {marks} | {doc.replace('|', '/')} |")
    return "\n".join(out + [""])


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


BLOCKS = {"config-keys": keys_block, "metrics": metrics_block, "example": example_block,
          "bench": bench_block}


def render(text: str) -> str:
    for name, make in BLOCKS.items():
        begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
        i, j = text.find(begin), text.find(end)
        if i < 0 or j < 0:
            raise SystemExit(f"README.md has no {name} block")
        text = text[: i + len(begin)] + "\n" + make() + "\n" + text[j:]
    return text


def main(argv: list[str]) -> int:
    text = README.read_text()
    new = render(text)
    if "--write" in argv:
        README.write_text(new)
    elif "--check" in argv:
        if new != text:
            print("README.md is stale (config keys or the worked example): run python "
                  "scripts/update_readme.py --write", file=sys.stderr)
            return 1
    else:
        print(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
