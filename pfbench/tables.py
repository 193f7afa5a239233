"""Rows of trials -> summary table with the paper's values, ratios and verdicts -> CSV / Markdown."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from .config import Experiment
from .metrics import Z975, paired, summarize, t975
from .papers import PAPERS, Quantity, Table, reported
from .store import atomic_write, write_csv

# Per-trial metrics summarised as their mean over trials in every table.
MEAN_COLUMNS = ("mean_ess", "resample_count", "diversity_l1", "distinct_frac",
                "lik_evals_per_step")


def verdict(paper: float | None, ours: float, lo: float, hi: float, *, rel_tol: float = 0.0,
            floor: float | None = None, not_comparable: str | None = None) -> str:
    """Compare a paper value with ours (point ``ours``, 95% interval [lo, hi]).

    'reproduced' when the paper's value lies in our interval (or within ``rel_tol`` of ours; for
    a range (lo, hi) the paper gives, when our interval meets it);
    'differs (x R)' otherwise, R = ours / paper, noting when the paper's value is below ``floor``
    (the lower 95% bound of what a near-optimal filter reaches); 'not comparable: reason' if set.
    """
    if paper is None or (isinstance(paper, float) and math.isnan(paper)):
        return ""
    if not_comparable:
        return f"not comparable: {not_comparable}"
    if math.isnan(ours):
        return "not comparable: no finite result"
    if isinstance(paper, tuple):          # the paper gives a range
        if lo <= paper[1] and paper[0] <= hi:
            return "reproduced (our interval meets the paper's range)"
        return f"differs (x{ours / (0.5 * (paper[0] + paper[1])):.2f} the range's middle)"
    if lo <= paper <= hi:
        return "reproduced"
    ratio = ours / paper if paper else math.inf
    if rel_tol > 0 and abs(ratio - 1.0) <= rel_tol:
        return f"reproduced (within {rel_tol:.0%})"
    text = f"differs (x{ratio:.2f})"
    if floor is not None and paper < floor:
        text += "; paper below the model's floor"
    return text


def _stat(s: dict, q: Quantity, paper_runs: int | None = None) -> tuple[float, float, float]:
    """(our value, interval) for quantity q. With ``paper_runs``, the interval is widened by the
    sampling error a batch of that many runs has (what the paper's own value carries): half-width
    1.96 sqrt(se_ours^2 + se_batch^2), se_batch scaled from ours by sqrt(n_ours / paper_runs)."""
    if q.stat == "mean":
        v, lo, hi, se = s["mean"], s["ci_lo"], s["ci_hi"], s["se"]
    else:
        v, lo, hi, se = s["var"], s["var_ci_lo"], s["var_ci_hi"], s["var_se"]
    if paper_runs and s["n"] > 1:
        half = Z975 * se * math.sqrt(1.0 + s["n"] / paper_runs)
        lo, hi = v - half, v + half
    return v, lo, hi


def _quantity(q: Quantity, g: pd.DataFrame, base: pd.DataFrame | None,
              paper_runs: int | None) -> tuple[float, float, float, float, float]:
    """(ours, verdict interval lo, hi, our own interval lo, hi) of quantity q for one filter run
    (g: its trials; base: its baseline run's trials, or None)."""
    nan = math.nan
    if q.metric in ("gain_mean", "gain_var"):
        if base is None:
            return nan, nan, nan, nan, nan
        a = g.set_index("trial")["rmse"]
        b = base.set_index("trial")["rmse"].reindex(a.index)
        if q.metric == "gain_mean":
            p = paired(a.values, b.values)
            mb = float(b.mean())
            v, lo, hi = (-100 * p["diff_mean"] / mb, -100 * p["diff_ci_hi"] / mb,
                         -100 * p["diff_ci_lo"] / mb)
        else:
            sa, sb = summarize(a.values), summarize(b.values)
            v = 100 * (1 - sa["var"] / sb["var"])
            lo = 100 * (1 - sa["var_ci_hi"] / sb["var_ci_lo"]) if sb["var_ci_lo"] > 0 else -math.inf
            hi = 100 * (1 - sa["var_ci_lo"] / sb["var_ci_hi"])
        return v, lo, hi, lo, hi
    s = summarize(_metric_values(q.metric, g, base) * q.scale)
    v, lo, hi = _stat(s, q)
    _, vlo, vhi = _stat(s, q, paper_runs)
    return v, vlo, vhi, lo, hi


def _metric_values(metric: str, g: pd.DataFrame, base: pd.DataFrame | None):
    """Per-trial values of ``metric`` for one filter run (g); 'time_ratio' is the wall time over the
    baseline run's on the same trial (NaN without a baseline)."""
    if metric != "time_ratio":
        return g[metric]
    if base is None:
        return pd.Series([math.nan] * len(g))
    a = g.set_index("trial")["wall_s"]
    return a / base.set_index("trial")["wall_s"].reindex(a.index)


def ranking_comparisons(exp: Experiment, tab: pd.DataFrame) -> list[tuple]:
    """For a table whose paper claims an order of its rows: per ranked quantity and particle count
    with two or more rows, (quantity, N or None, the paper's order, ours, the same order)."""
    table = reported(exp.paper, exp.table)
    if table is None or table.ranking is None:
        return []
    keys = (table.ranking,) if isinstance(table.ranking, str) else tuple(table.ranking)
    out = []
    counts = sorted({n for (_, n) in table.values}, key=lambda v: (v is None, v or 0))
    for q in (q for key in keys for q in table.quantities if q.key == key):
        for n in counts:
            labels = [lab for (lab, m) in table.values
                      if m == n and q.key in table.values[(lab, m)]]
            ours = {}
            for lab in labels:
                # a paper that gives no particle count (n None) is matched by label alone
                r = tab[(tab["label"] == lab) & ((tab["particles"] == n) if n is not None else True)]
                if len(r):
                    ours[lab] = float(r.iloc[0][f"ours_{q.key}"])
            if len(ours) < 2:
                continue
            paper_order = sorted(ours, key=lambda lab: table.values[(lab, n)][q.key])
            our_order = sorted(ours, key=lambda lab: ours[lab])
            out.append((q, n, paper_order, our_order, paper_order == our_order))
    return out


def rankings(exp: Experiment, tab: pd.DataFrame) -> list[str]:
    """The ranking comparisons as lines: the paper's order and ours at each particle count (for
    each ranked quantity), whether they agree, and how often over all."""
    comps = ranking_comparisons(exp, tab)
    lines = [f"Ranking by {q.title}{f' at N = {n}' if n is not None else ''}: paper "
             f"{' < '.join(paper_order)}; ours {' < '.join(our_order)}: "
             f"{'same order' if same else 'differs'}."
             for q, n, paper_order, our_order, same in comps]
    if len(comps) > 1:
        lines.append(f"Rankings: the same order in {sum(c[4] for c in comps)} of {len(comps)} "
                     "comparisons.")
    return lines


def baseline_runs(exp: Experiment) -> dict[str, str]:
    """For each filter run, the key of the baseline run it is paired with (the baseline filter at the
    same particle count, or its only run); empty without compare.baseline."""
    name = exp.compare["baseline"]
    if name is None:
        return {}
    base = [f for f in exp.filters if f.name == name]
    out = {}
    for f in exp.filters:
        same = [b for b in base if b.particles == f.particles]
        pick = same[0] if same else base[0] if len(base) == 1 else None
        if pick is not None and pick.key != f.key:
            out[f.key] = pick.key
    return out


def summary(exp: Experiment, rows: list[dict] | pd.DataFrame) -> pd.DataFrame:
    """One row per filter run: statistics over trials, and the paper columns when there are any."""
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    table: Table | None = reported(exp.paper, exp.table)
    by_key = {f.key: df[df["filter"] == f.key] for f in exp.filters}
    floor = None
    if exp.compare["floor"] is not None:
        floor = summarize(by_key[exp.compare["floor"]]["rmse"])["ci_lo"]
    pairs = baseline_runs(exp)
    out = []
    for run in exp.filters:
        g = by_key[run.key]
        r = {"filter": run.key, "label": run.label, "particles": run.particles, "trials": len(g)}
        for metric in ("rmse", "mse"):
            s = summarize(g[metric])
            r.update({f"{metric}_{k}": s[k] for k in ("mean", "ci_lo", "ci_hi", "var",
                                                       "var_ci_lo", "var_ci_hi", "se")})
        for metric in MEAN_COLUMNS:     # NaN where the scenario's kind has no such column
            r[metric] = summarize(g[metric])["mean"] if metric in g else math.nan
        r["underflow_steps"] = float(g["underflow_steps"].sum())
        dv = g["diverged_steps"] if "diverged_steps" in g else pd.Series(dtype=float)
        r["diverged_steps"] = float(dv.sum())
        r["diverged_trials"] = float((dv > 0).sum())
        r["wall_ms_per_trial"] = 1e3 * float(g["wall_s"].mean()) if len(g) else math.nan
        r["baseline"] = pairs.get(run.key)
        if run.key in pairs:
            a = g.set_index("trial")["rmse"]
            b = by_key[pairs[run.key]].set_index("trial")["rmse"].reindex(a.index)
            r.update({f"rmse_{k}": v for k, v in paired(a.values, b.values).items()})
        else:
            r.update(rmse_diff_mean=math.nan, rmse_diff_ci_lo=math.nan, rmse_diff_ci_hi=math.nan,
                     rmse_win_rate=math.nan)
        if table is not None:
            values = (table.values.get((run.label, run.particles))
                      or table.values.get((run.label, None), {}))
            for q in table.quantities:
                paper = values.get(q.key)
                ours, lo, hi, r[f"ours_lo_{q.key}"], r[f"ours_hi_{q.key}"] = _quantity(
                    q, g, by_key.get(pairs.get(run.key)), exp.compare["paper_runs"])
                r[f"ours_{q.key}"] = ours
                if isinstance(paper, tuple):      # a range: shown as such, ratio to its middle
                    r[f"paper_{q.key}"] = f"{paper[0]:g}-{paper[1]:g}"
                    r[f"ratio_{q.key}"] = ours / (0.5 * (paper[0] + paper[1]))
                else:
                    r[f"paper_{q.key}"] = paper
                    r[f"ratio_{q.key}"] = ours / paper if paper else math.nan
                floored_q = q.metric == "rmse" and q.stat == "mean"  # the floor is an RMSE level
                r[f"verdict_{q.key}"] = verdict(
                    paper, ours, lo, hi, rel_tol=exp.compare["rel_tol"] if floored_q else 0.0,
                    floor=floor if floored_q and run.key != exp.compare["floor"] else None,
                    not_comparable=(table.cell_notes.get((run.label, run.particles, q.key))
                                    or q.not_comparable or table.not_comparable))
        out.append(r)
    tab = pd.DataFrame(out)
    if table is not None:
        # what needs the trials themselves, kept with the summary for the printed tables
        tab.attrs["factors"] = factors(exp, table, by_key)
        tab.attrs["per_trial"] = per_trial(exp, table, by_key)
    return tab


def _run_by_label(exp: Experiment, label: str):
    return next((f for f in exp.filters if f.label == label), None)


def factors(exp: Experiment, table: Table, by_key: dict) -> list[dict]:
    """The paper's factor between two of its rows for a quantity (e.g. AFSA's error over PSO's)
    beside ours: the ratio of the means over paired trials, with a 95% interval by the delta
    method on the paired per-trial values."""
    rows = []
    for key, a_label, b_label in table.factors:
        q = next(q for q in table.quantities if q.key == key)
        a_run, b_run = _run_by_label(exp, a_label), _run_by_label(exp, b_label)
        if a_run is None or b_run is None:
            continue
        pa = table.values.get((a_label, a_run.particles), {}).get(key)
        pb = table.values.get((b_label, b_run.particles), {}).get(key)
        a = by_key[a_run.key].set_index("trial")[q.metric]
        b = by_key[b_run.key].set_index("trial")[q.metric].reindex(a.index)
        ok = a.notna() & b.notna()
        a, b = a[ok].to_numpy(float), b[ok].to_numpy(float)
        n = a.size
        if n < 2 or a.mean() == 0:
            continue
        ma, mb = a.mean(), b.mean()
        ratio = mb / ma
        cov = np.cov(np.vstack([a, b])) / n          # of the two means
        var = (cov[1, 1] - 2 * ratio * cov[0, 1] + ratio * ratio * cov[0, 0]) / (ma * ma)
        half = t975(n - 1) * math.sqrt(max(var, 0.0))
        paper = pb / pa if pa and pb is not None else math.nan
        rows.append({"quantity": q.title, "from": a_label, "to": b_label, "paper_from": pa,
                     "paper_to": pb, "paper": paper, "ours": ratio, "lo": ratio - half,
                     "hi": ratio + half,
                     "verdict": verdict(paper, ratio, ratio - half, ratio + half)})
    return rows


def per_trial(exp: Experiment, table: Table, by_key: dict) -> tuple[str, list[str],
                                                                     list[list[str]]] | None:
    """The paper's per-run table (runs as columns) beside our first trials and our mean over all."""
    spec = table.per_trial
    if spec is None:
        return None
    R = spec.runs
    head = ["row"] + [str(i + 1) for i in range(R)] + ["mean [95% CI]"]
    cells = []
    for name, label, vals in spec.rows:
        run = _run_by_label(exp, label)
        cells.append([f"paper: {name}"] + [fmt(v, 3) for v in vals]
                     + [""] * (R - len(vals)) + [fmt(float(np.mean(vals)), 3)])
        if run is None:
            continue
        g = by_key[run.key].sort_values("trial")
        for metric in (spec.metric, *spec.also):
            v = g[metric].to_numpy(float)
            s = summarize(v)
            what = f"ours: {label}" + ("" if metric == spec.metric else f", {metric}")
            cells.append([what] + [fmt(x, 3) for x in v[:R]] + ["-"] * (R - min(R, v.size))
                         + [f"{fmt(s['mean'], 3)} [{fmt(s['ci_lo'], 3)}, "
                            f"{fmt(s['ci_hi'], 3)}]"])
    return spec.title, head, cells


def fmt(v, digits=4) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return str(v)


def _paired_cells(exp: Experiment, r) -> list[str]:
    """[difference to the baseline with its interval, win rate] for row r ('-' for the baseline)."""
    if r["baseline"] is None or r["baseline"] != r["baseline"]:
        return ["-", "-"]
    return [f"{r['rmse_diff_mean']:+.3g} [{r['rmse_diff_ci_lo']:+.3g}, {r['rmse_diff_ci_hi']:+.3g}]",
            f"{r['rmse_win_rate']:.0%}"]


def _paired_head(exp: Experiment) -> list[str]:
    b = exp.compare["baseline"]
    return [f"RMSE - {b} [95% CI]", f"Wins vs {b}"] if b else []


def display_columns(exp: Experiment, tab: pd.DataFrame) -> tuple[list[str], list[list[str]]]:
    """Header and cells of the human table (Markdown and the console share it)."""
    table = reported(exp.paper, exp.table)
    quantities = table.quantities if table else ()
    head = ["Filter", "N", "Trials", "RMSE mean [95% CI]", "RMSE var [95% CI]"]
    for q in quantities:
        head += ([] if q.metric == "rmse" else [_ours_head(q)]) + [f"Paper {q.title}", "Ratio",
                                                                   "Verdict"]
    head += _paired_head(exp) + ["Mean ESS", "Distinct", "Evals/step", "ms/trial"]
    cells = []
    for _, r in tab.iterrows():
        n = r["particles"]
        row = [r["label"], "-" if n is None or n != n else str(int(n)), str(int(r["trials"])),
               f"{fmt(r['rmse_mean'])} [{fmt(r['rmse_ci_lo'])}, {fmt(r['rmse_ci_hi'])}]",
               f"{fmt(r['rmse_var'])} [{fmt(r['rmse_var_ci_lo'])}, {fmt(r['rmse_var_ci_hi'])}]"]
        for q in quantities:
            row += (([] if q.metric == "rmse" else [ours_cell(r, q)])
                    + [fmt(r[f"paper_{q.key}"], 6), fmt(r[f"ratio_{q.key}"], 3),
                       r[f"verdict_{q.key}"] or "-"])
        row += (_paired_cells(exp, r) if exp.compare["baseline"] else [])
        row += [fmt(r["mean_ess"]), fmt(r["distinct_frac"], 3), fmt(r["lik_evals_per_step"]),
                fmt(r["wall_ms_per_trial"], 3)]
        cells.append(row)
    return head, cells


def _ours_head(q: Quantity) -> str:
    what = f"{q.metric.upper()} {q.stat}" if q.metric in ("rmse", "mse") else q.title
    return f"{what} [95% CI]"


def ours_cell(r, q: Quantity) -> str:
    v = r.get(f"ours_{q.key}", math.nan)
    if v != v:
        return "-"
    return f"{fmt(v)} [{fmt(r[f'ours_lo_{q.key}'])}, {fmt(r[f'ours_hi_{q.key}'])}]"


def console_tables(exp: Experiment, tab: pd.DataFrame) -> list[tuple[str, list[str], list[list[str]]]]:
    """The console's two narrower tables: the comparison with the paper, and the diagnostics."""
    table = reported(exp.paper, exp.table)
    quantities = table.quantities if table else ()
    comp_head = ["Filter", "N", "Trials"]
    if not quantities:
        comp_head.append("RMSE mean [95% CI]")
    for q in quantities:
        comp_head += [_ours_head(q), f"Paper {q.title}", "Verdict"]
    diag_head = (["Filter", "N", "RMSE var"] + _paired_head(exp)
                 + ["Mean ESS", "Distinct", "Evals/step", "ms/trial"])
    long = len(quantities) > 2      # one row per filter run and quantity, or the table gets too wide
    if long:
        comp_head = ["Quantity", "Filter", "N", "Trials", "Ours [95% CI]", "Paper", "Verdict"]
    comp, diag = [], []
    if long:
        for q in quantities:
            for _, r in tab.iterrows():
                n = r["particles"]
                v = r[f"verdict_{q.key}"] or "-"
                comp.append([q.title, r["label"], "-" if n is None or n != n else str(int(n)),
                             str(int(r["trials"])), ours_cell(r, q),
                             fmt(r[f"paper_{q.key}"], 6),
                             "not comparable (table.md)" if v.startswith("not comparable") else v])
    for _, r in tab.iterrows():
        n = r["particles"]
        who = [r["label"], "-" if n is None or n != n else str(int(n))]
        if not long:
            row = who + [str(int(r["trials"]))]
            if not quantities:
                row.append(f"{fmt(r['rmse_mean'])} [{fmt(r['rmse_ci_lo'])}, "
                           f"{fmt(r['rmse_ci_hi'])}]")
            for q in quantities:
                row += [ours_cell(r, q), fmt(r[f"paper_{q.key}"], 6),
                        r[f"verdict_{q.key}"] or "-"]
            comp.append(row)
        diag.append(who + [fmt(r["rmse_var"])]
                    + (_paired_cells(exp, r) if exp.compare["baseline"] else [])
                    + [fmt(r["mean_ess"]), fmt(r["distinct_frac"], 3),
                           fmt(r["lik_evals_per_step"]), fmt(r["wall_ms_per_trial"], 3)])
    out = [("", comp_head, comp), ("diagnostics", diag_head, diag)]
    if tab.attrs.get("per_trial"):
        title, head, cells = tab.attrs["per_trial"]
        out.append((title, head, cells))
    return out


def _counts(rows: pd.DataFrame, column: str, trials: str | None = None) -> str:
    """'PF N=50: 3, UKF: 1' (or with ``trials``: 'PF N=50: 3 in 2 trials'): a count per row."""
    return ", ".join(f"{r['label']}" + (f" N={int(r['particles'])}" if r["particles"] ==
                                        r["particles"] and r["particles"] is not None else "")
                     + f": {int(r[column])}"
                     + (f" in {int(r[trials])} trial{'s' if int(r[trials]) != 1 else ''}"
                        if trials else "") for _, r in rows.iterrows())


def footnotes(exp: Experiment, tab: pd.DataFrame) -> list[str]:
    """Lines that explain the table: the floor row, underflow events."""
    notes = rankings(exp, tab)
    for f in tab.attrs.get("factors", []):
        notes.append(f"{f['quantity']}, {f['to']} / {f['from']}: paper {fmt(f['paper'], 3)} "
                     f"({fmt(f['paper_from'], 4)} -> {fmt(f['paper_to'], 4)}); ours "
                     f"{fmt(f['ours'], 3)} [{fmt(f['lo'], 3)}, {fmt(f['hi'], 3)}] (paired "
                     f"trials): {f['verdict'] or '-'}.")
    if exp.compare["paper_runs"]:
        notes.append(f"The paper's values come from {exp.compare['paper_runs']} runs: a verdict's "
                     "interval adds the sampling error of a batch that size to ours (half-width "
                     "1.96 sqrt(se_ours^2 + se_batch^2)).")
    if exp.compare["baseline"]:
        notes.append(f"'RMSE - {exp.compare['baseline']}': mean per-trial RMSE difference to the "
                     "baseline on the same truth, with its 95% interval; 'Wins': fraction of trials "
                     "where the row's RMSE is lower.")
    if exp.compare["floor"] is not None:
        r = tab[tab["filter"] == exp.compare["floor"]].iloc[0]
        notes.append(f"Floor: {r['label']} with N = {int(r['particles'])} reaches RMSE "
                     f"{r['rmse_mean']:.3f} [{r['rmse_ci_lo']:.3f}, {r['rmse_ci_hi']:.3f}]; no filter "
                     "can average below what a near-optimal filter reaches, so a paper value under "
                     "that interval is marked 'paper below the model's floor'.")
    hit = tab[tab["underflow_steps"] > 0]
    if len(hit):
        notes.append("Steps where every weight was zero (the measurement was ignored), summed over "
                     f"trials: {_counts(hit, 'underflow_steps')}.")
    hit = tab[tab["diverged_steps"] > 0] if "diverged_steps" in tab else tab.iloc[:0]
    if len(hit):
        notes.append("Steps whose estimate left the world (a lost filter's particles drifting past "
                     "its border) or was not a finite number, summed over trials, with the trials "
                     f"they occur in: {_counts(hit, 'diverged_steps', 'diverged_trials')}. The "
                     "error averages include those steps.")
    return notes


def markdown(exp: Experiment, tab: pd.DataFrame, meta: dict | None = None) -> str:
    """table.md: title, provenance, the table and the paper's notes."""
    table = reported(exp.paper, exp.table)
    lines = [f"# {exp.name}", ""]
    if exp.description:
        lines += [exp.description, ""]
    if table is not None:
        lines += [f"Paper: `{exp.paper}` {exp.table}: {PAPERS[exp.paper].citation}.", "",
                  f"Table: {table.caption}.", ""]
    trials = int(tab["trials"].max()) if len(tab) else 0
    lines += [f"Scenario `{exp.scenario}`; {trials} trials; seed {exp.seed}; experiment hash "
              f"`{exp.hash}`" + (f"; pfbench {meta['versions']['pfbench']}" if meta else "") + ".",
              "", "Intervals are 95% over trials (Student's t for the mean; a distribution-free "
              "standard error for the variance).", ""]
    head, cells = display_columns(exp, tab)
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "|".join(" --- " for _ in head) + "|")
    for row in cells:
        lines.append("| " + " | ".join(c.replace("|", "/") for c in row) + " |")
    if tab.attrs.get("per_trial"):
        title, head, cells = tab.attrs["per_trial"]
        lines += ["", f"{title}:", "", "| " + " | ".join(head) + " |",
                  "|" + "|".join(" --- " for _ in head) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in cells]
    notes = footnotes(exp, tab) + list(table.notes if table is not None else ())
    if notes:
        lines += ["", "Notes:", ""] + [f"- {n}" for n in notes]
    return "\n".join(lines) + "\n"


def write(exp: Experiment, tab: pd.DataFrame, out_dir: Path, meta: dict | None = None) -> None:
    """Write table.csv and table.md into ``out_dir`` (atomically)."""
    write_csv(Path(out_dir) / "table.csv", tab)
    atomic_write(Path(out_dir) / "table.md", markdown(exp, tab, meta))
