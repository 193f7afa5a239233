"""A comparison (pfbench.compare) rendered: the console's tables, table.md and table.csv."""
from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from .compare import (CONSISTENCY_METRICS, MACHINE_METRICS, Comparison, PerTrial, Ranking,
                      pair_counts)
from .config import Experiment
from .papers import Quantity
from .verdicts import METHODS, percent
from .store import atomic_write, write_csv


def md_table(head: list[str], cells: list[list]) -> list[str]:
    """A Markdown table's lines: the head, its rule, a row per cell list (a '|' in a cell
    written '/', so that it cannot split the cell)."""
    out = ["| " + " | ".join(head) + " |", "|" + "|".join(" --- " for _ in head) + "|"]
    return out + ["| " + " | ".join(str(c).replace("|", "/") for c in row) + " |" for row in cells]


def ranking_lines(rankings: list[Ranking]) -> list[str]:
    """Rankings as lines: the paper's order and ours (point estimates) at each particle count
    (for each ranked quantity), then each pair of rows judged on paired trials, and the count of
    pairs resolved in the paper's order, resolved against it, and unresolved."""
    lines = []
    pairs = [p for r in rankings for p in r.pairs]
    tested = sum(p.diff == p.diff for p in pairs)
    for r in rankings:
        where = f"{r.quantity.title}{f' at N = {r.particles}' if r.particles is not None else ''}"
        judged = "; ".join(f"{p.low} < {p.high}: "
                           + ("unresolved" if p.status == "unresolved" else
                              f"{'same order' if p.status == 'same' else 'opposite'}, resolved")
                           + (f" ({_signed(p.diff)} [{_signed(p.lo)}, {_signed(p.hi)}] "
                              f"{percent(p.level)})" if p.diff == p.diff else "")
                           for p in r.pairs)
        lines.append(f"Ranking by {where}: paper {' < '.join(r.paper)}; ours "
                     f"{' < '.join(r.ours)}" + (f". Pairs (the paired difference of the means "
                                                f"with its interval): {judged}." if judged
                                                else "."))
    if pairs:
        n = pair_counts(rankings)
        holm = (f"; Holm's step-down procedure across the table's {tested} pairs gives each "
                "interval its level, so the chance of any pair resolved the wrong way is at "
                "most 5%" if tested > 1 else "")
        lines.append(f"Pairs of rows the paper orders: {n['same']} in its order and "
                     f"{n['opposite']} in the opposite order, resolved by a paired interval that "
                     f"excludes zero{holm}; {n['unresolved']} unresolved (of {len(pairs)}).")
    return lines


RANKING_TITLE = ("Ordered pairs: each pair of rows the paper orders (the row it puts lower "
                 "first), judged on paired trials")


def ranking_table(rankings: list[Ranking], detail: bool = False
                  ) -> tuple[list[str], list[list[str]]]:
    """The paper's ordered pairs as a compact table: a row per pair of rows and quantity, a
    column per particle count, each cell 'same' (resolved in the paper's order), 'opposite'
    (resolved against it) or 'unresolved'; ``detail`` adds the paired difference of the means
    with its interval at its Holm level. Then a row per quantity with our order of the rows
    (point estimates). ([], []) without rankings."""
    if not rankings:
        return [], []
    ns = list(dict.fromkeys(r.particles for r in rankings))
    head = ["The paper's order", "Quantity"] + [
        "all rows" if n is None else f"N = {n}" for n in ns]
    rows: dict[tuple, list[str]] = {}
    for r in rankings:
        for p in r.pairs:
            row = rows.setdefault((r.quantity.title, p.low, p.high),
                                  [f"{p.low} < {p.high}", r.quantity.title] + [""] * len(ns))
            cell = p.status
            if detail and p.diff == p.diff:
                cell += (f": {_signed(p.diff)} [{_signed(p.lo)}, {_signed(p.hi)}] "
                         f"{percent(p.level)}")
            row[2 + ns.index(r.particles)] = cell
    ours: dict[str, list[str]] = {}
    for r in rankings:
        row = ours.setdefault(r.quantity.title, ["ours, by the means", r.quantity.title]
                              + [""] * len(ns))
        row[2 + ns.index(r.particles)] = " < ".join(r.ours)
    return head, list(rows.values()) + list(ours.values())


def ranking_summary(rankings: list[Ranking]) -> list[str]:
    """The line that counts the ordered pairs (resolved in the paper's order, against it,
    unresolved) and says how they are judged; [] without pairs."""
    lines = ranking_lines(rankings)
    return lines[-1:] if any(r.pairs for r in rankings) else []


def _signed(v: float) -> str:
    return f"{v:+.3g}"


def per_trial_cells(pt: PerTrial) -> tuple[str, list[str], list[list[str]]]:
    """(title, header, cells) of a per-run table: a column per run, then the mean [95% CI]."""
    R = pt.runs
    head = ["row"] + [str(i + 1) for i in range(R)] + ["mean [95% CI]"]
    cells = []
    for row in pt.rows:
        shown = [fmt(float(x), 3) for x in row.values[:R]]
        if row.lo is None:
            cells.append([row.what] + shown + [""] * (R - len(shown)) + [fmt(row.mean, 3)])
        else:
            cells.append([row.what] + shown + ["-"] * (R - len(shown))
                         + [f"{fmt(row.mean, 3)} [{fmt(row.lo, 3)}, {fmt(row.hi, 3)}]"])
    return pt.title, head, cells


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


def display_columns(cmp: Comparison, se: bool = False) -> tuple[list[str], list[list[str]]]:
    """Header and cells of the human table (Markdown and the console share it); ``se``: the RMSE
    mean with its Monte Carlo standard error (table.md)."""
    exp, tab, table = cmp.exp, cmp.table, cmp.reported
    quantities = table.quantities if table else ()
    head = ["Filter", "N", "Trials", f"RMSE mean{' +- SE' if se else ''} [95% CI]",
            "RMSE var [95% CI]"]
    timed = cmp.timed
    for q in quantities:
        if q.judged_by is not None:     # the verdict beside the measure it judged; ours apart
            head += [f"{judged_title(q, exp)} [95% CI]", f"Paper {q.title}", "Ratio", "Verdict"]
            head += [apart_title(q)] if timed else []
            continue
        head += ([] if _shown_as_rmse(q) else [_ours_head(q)]) + [f"Paper {q.title}", "Ratio",
                                                                   "Verdict"]
    shown = [m for m in CONSISTENCY_METRICS if f"{m}_mean" in tab]
    head += [f"{m.upper()} +- SE [95% bound]" for m in shown]
    head += _paired_head(exp) + ["Mean ESS", "Distinct", "Evals/step"] + (["ms/trial"] if timed
                                                                           else [])
    cells = []
    for _, r in tab.iterrows():
        n = r["particles"]
        mean = fmt(r["rmse_mean"]) + (f" +- {fmt(r['rmse_se'], 2)}" if se else "")
        row = [r["label"], "-" if n is None or n != n else str(int(n)), str(int(r["trials"])),
               f"{mean} [{fmt(r['rmse_ci_lo'])}, {fmt(r['rmse_ci_hi'])}]",
               f"{fmt(r['rmse_var'])} [{fmt(r['rmse_var_ci_lo'])}, {fmt(r['rmse_var_ci_hi'])}]"]
        for q in quantities:
            if q.judged_by is not None:
                row += [judged_cell(r, q), fmt(r[f"paper_{q.key}"], 6),
                        fmt(judged_ratio(r, q), 3), r[f"verdict_{q.key}"] or "-"]
                row += [ours_cell(r, q)] if timed else []
                continue
            row += (([] if _shown_as_rmse(q) else [ours_cell(r, q)])
                    + [fmt(r[f"paper_{q.key}"], 6), fmt(r[f"ratio_{q.key}"], 3),
                       r[f"verdict_{q.key}"] or "-"])
        row += [consistency_cell(r, m) for m in shown]
        row += (_paired_cells(exp, r) if exp.compare["baseline"] else [])
        row += [fmt(r["mean_ess"]), fmt(r["distinct_frac"], 3), fmt(r["lik_evals_per_step"])]
        row += [fmt(r["wall_ms_per_trial"], 3)] if timed else []
        cells.append(row)
    return head, cells


def consistency_cell(r, metric: str) -> str:
    """'1.02 +- 0.012 [0.972, 1.03] consistent': a row's NEES (or NIS) mean over trials with its
    standard error, the 95% chi-square bounds of a consistent filter's and the check ('-' for a
    filter that reports none)."""
    v = r.get(f"{metric}_mean", math.nan)
    if v != v:
        return "-"
    lo, hi = r.get(f"{metric}_bound_lo", math.nan), r.get(f"{metric}_bound_hi", math.nan)
    bounds = f" [{fmt(lo, 3)}, {fmt(hi, 3)}] {r[f'{metric}_check']}" if lo == lo else ""
    return f"{fmt(v, 3)} +- {fmt(r[f'{metric}_se'], 2)}{bounds}"


def _shown_as_rmse(q: Quantity) -> bool:
    """A quantity that is the RMSE mean over trials: our value is the table's RMSE column."""
    return q.metric == "rmse" and q.stat == "mean" and q.scale == 1.0


def _ours_head(q: Quantity) -> str:
    what = f"{q.metric.upper()} {q.stat}" if q.metric in ("rmse", "mse") else q.title
    return f"{what} [95% CI]"


# the words of a measure a quantity is judged on instead of ours (Quantity.judged_by)
JUDGED_WORDS = {"evals_ratio": "likelihood evaluations"}


def judged_title(q: Quantity, exp: Experiment) -> str:
    """The name of the measure a quantity is judged on, over its baseline's ('likelihood
    evaluations / PF' for a run-time ratio judged on the evaluations per step)."""
    base = exp.compare["baseline"]
    who = next((f.label for f in exp.filters if f.name == base or f.key == base), base)
    what = JUDGED_WORDS.get(q.judged_by, str(q.judged_by).replace("_", " "))
    return f"{what} / {who}" if who else what


def judged_cell(r, q: Quantity, digits: int = 4) -> str:
    """The measure a quantity is judged on (``judged_by``), with its 95% interval: what its
    verdict is beside ('-' where the row has none)."""
    v = r.get(f"judged_{q.key}", math.nan)
    if v is None or v != v:
        return "-"
    return (f"{fmt(v, digits)} [{fmt(r[f'judged_lo_{q.key}'], digits)}, "
            f"{fmt(r[f'judged_hi_{q.key}'], digits)}]")


def judged_ratio(r, q: Quantity) -> float:
    """The judged measure over the paper's value (NaN without either)."""
    v, paper = r.get(f"judged_{q.key}", math.nan), r.get(f"paper_{q.key}", math.nan)
    try:
        return float(v) / float(paper) if v == v and paper == paper and float(paper) else \
            math.nan
    except (TypeError, ValueError):
        return math.nan


def shown_cell(r, q: Quantity, short: bool = False) -> str:
    """What a quantity's verdict sits beside: the measure it is judged on where it has one
    (``judged_by``), else our value (``ours_cell``)."""
    if q.judged_by is not None:
        return judged_cell(r, q, 3 if short else 4)
    return ours_cell(r, q, short)


def shown_ratio(r, q: Quantity) -> float:
    """The ratio printed beside a verdict: of the measure judged (ours, or ``judged_by``'s)
    over the paper's value."""
    return judged_ratio(r, q) if q.judged_by is not None else r[f"ratio_{q.key}"]


def apart_title(q: Quantity) -> str:
    """The column (or row) of our value of a quantity judged on another measure: shown, never
    judged."""
    return f"{q.title}, ours (not judged) [95% CI]"


def ours_cell(r, q: Quantity, short: bool = False) -> str:
    """Our value with its 95% interval, and the trials it averages where that is not all of
    them (a convergence step averages the trials that converge; ``short``: '(35 of 100)')."""
    v = r.get(f"ours_{q.key}", math.nan)
    n = r.get(f"n_{q.key}", math.nan)
    some = n == n and n is not None and int(n) < int(r["trials"])
    over = ((f" ({int(n)} of {int(r['trials'])})" if short
             else f" over {int(n)} of {int(r['trials'])} trials") if some else "")
    if v != v:
        return "-"
    d = 3 if short else 4
    return (f"{fmt(v, d)} [{fmt(r[f'ours_lo_{q.key}'], d)}, {fmt(r[f'ours_hi_{q.key}'], d)}]"
            f"{over}")


def short_verdict(r, q: Quantity) -> str:
    """A verdict in a few words, for the console's headline table (table.md has it in full):
    the kind, with the ratio ours / paper where it differs, the trials that would likely decide an
    inconclusive cell, and whether the paper's value lies below the model's floor."""
    kind = r.get(f"kind_{q.key}") or ""
    text = r.get(f"verdict_{q.key}") or ""
    floor = ", below floor" if "below the model's floor" in text else ""
    if kind == "differs":
        ratio = shown_ratio(r, q)
        return ("differs" + ("" if ratio != ratio else f" x{ratio:.2f}")) + floor
    if kind == "inconclusive":
        return _short_kind(kind, r.get(f"needed_{q.key}", math.nan))
    if kind == "reproduced":
        return "reproduced" + floor
    if kind == "not comparable":
        return "not judged" if text.startswith("shown, not judged") else "not comparable"
    return "-"


def _run_cells(r) -> list[str]:
    n = r["particles"]
    return [str(r["label"]), "-" if n is None or n != n else str(int(n))]


def headline_tables(cmp: Comparison) -> list[tuple[str, list[str], list[list[str]]]]:
    """The console's tables, one per quantity of the paper's table: for each filter run our value
    with its 95% interval, the paper's and the verdict in a few words, so that they fit 100
    columns. Beyond the first quantity only the rows the paper gives a value. The rest (variances,
    paired differences, diagnostics, run times, the verdicts in full) is in table.md and
    ``pfbench run --wide``. Returns (quantity title, header, cells) for each."""
    table = cmp.reported
    quantities = table.quantities if table else ()
    tab = cmp.table
    if not quantities:
        head = ["Filter", "N", "RMSE mean [95% CI]"] + (["ms/trial"] if cmp.timed else [])
        cells = [_run_cells(r) + [f"{fmt(r['rmse_mean'])} [{fmt(r['rmse_ci_lo'])}, "
                                  f"{fmt(r['rmse_ci_hi'])}]"]
                 + ([fmt(r["wall_ms_per_trial"], 3)] if cmp.timed else [])
                 for _, r in tab.iterrows()]
        return [("", head, cells)]
    out = []
    for k, q in enumerate(quantities):
        rows = [r for _, r in tab.iterrows()]
        given = [r for r in rows if not _missing(r[f"paper_{q.key}"])]
        ours = [r for r in rows if not _missing(r.get(f"ours_{q.key}"))]
        # the first quantity: every row; the others: the rows the paper gives (or, where it gives
        # none, the rows we have a value for)
        if q.judged_by is not None:     # the verdict beside the measure judged; ours apart
            judged = [r for r in rows if not _missing(r.get(f"judged_{q.key}"))]
            cells = [_run_cells(r) + [judged_cell(r, q, 3), fmt(r[f"paper_{q.key}"], 6),
                                      short_verdict(r, q)] for r in (given or judged)]
            if cells:
                out.append((f"{q.title}, judged on {judged_title(q, cmp.exp)}",
                            ["Filter", "N", "Judged [95% CI]", "Paper", "Verdict"], cells))
            cells = [_run_cells(r) + [ours_cell(r, q, short=True)] for r in ours]
            if cells:
                out.append((f"{q.title}, ours (the machine's: not judged)",
                            ["Filter", "N", "Ours [95% CI]"], cells))
            continue
        cells = [_run_cells(r) + [ours_cell(r, q, short=True), fmt(r[f"paper_{q.key}"], 6),
                                  short_verdict(r, q)]
                 for r in (rows if k == 0 else given or ours)]
        if cells:
            out.append((q.title, ["Filter", "N", "Ours [95% CI]", "Paper", "Verdict"], cells))
    pairs: dict[tuple, list] = {}
    for f in cmp.factors:        # a table per pair of rows: factor = to / from, paired trials
        pairs.setdefault((f["to"], f["from"]), []).append(
            [f["quantity"], fmt(f["paper"], 3),
             f"{fmt(f['ours'], 3)} [{fmt(f['lo'], 3)}, {fmt(f['hi'], 3)}]",
             _short_kind(f["kind"], f.get("needed"))])
    for (to, frm), cells in pairs.items():
        out.append((f"factor {to} / {frm} (paired trials)",
                    ["Quantity", "Paper", "Ours [95% CI]", "Verdict"], cells))
    head, cells = ranking_counts_table(cmp.rankings)
    if cells:
        out.append(("ordered pairs, counted (--wide: each pair)", head, cells))
    return out


def ranking_counts_table(rankings: list[Ranking]) -> tuple[list[str], list[list[str]]]:
    """The ordered pairs counted per quantity and particle count, for the console's short
    tables (ranking_table has each pair): quantity, N, and how many pairs are resolved in the
    paper's order, against it, and unresolved. ([], []) without pairs."""
    cells = []
    for r in rankings:
        if r.pairs:
            n = pair_counts([r])
            cells.append([r.quantity.title, "-" if r.particles is None else str(r.particles),
                          str(n["same"]), str(n["opposite"]), str(n["unresolved"])])
    return (["Quantity", "N", "Same", "Opposite", "Unresolved"], cells) if cells else ([], [])


def _short_kind(kind: str, needed=None) -> str:
    if kind == "inconclusive" and needed == needed and needed:
        return f"inconclusive (~{int(needed)} trials)"
    return kind or "-"


def _missing(v) -> bool:
    return v is None or (isinstance(v, float) and v != v)


def console_tables(cmp: Comparison) -> list[tuple[str, list[str], list[list[str]]]]:
    """The console's two narrower tables: the comparison with the paper, and the diagnostics
    (and the per-run table where the paper has one)."""
    exp, tab, table = cmp.exp, cmp.table, cmp.reported
    quantities = table.quantities if table else ()
    comp_head = ["Filter", "N", "Trials"]
    if not quantities:
        comp_head.append("RMSE mean [95% CI]")
    timed = cmp.timed
    for q in quantities:
        if q.judged_by is not None:
            comp_head += [f"{judged_title(q, exp)} [95% CI]", f"Paper {q.title}", "Verdict"]
            comp_head += [apart_title(q)] if timed else []
        else:
            comp_head += [_ours_head(q), f"Paper {q.title}", "Verdict"]
    diag_head = (["Filter", "N", "RMSE var"] + _paired_head(exp)
                 + ["Mean ESS", "Distinct", "Evals/step"] + (["ms/trial"] if timed else []))
    long = len(quantities) > 2      # one row per filter run and quantity, or the table gets too wide
    if long:
        comp_head = ["Quantity", "Filter", "N", "Trials", "Ours [95% CI]", "Paper", "Verdict"]
    comp, diag = [], []
    if long:
        for q in quantities:
            for _, r in tab.iterrows():
                n = r["particles"]
                v = r[f"verdict_{q.key}"] or "-"
                who = [r["label"], "-" if n is None or n != n else str(int(n)),
                       str(int(r["trials"]))]
                what = (f"{q.title}, judged on {judged_title(q, exp)}" if q.judged_by
                        else q.title)
                comp.append([what] + who + [shown_cell(r, q), fmt(r[f"paper_{q.key}"], 6),
                             "not comparable (table.md)" if v.startswith("not comparable") else v])
                if q.judged_by is not None and timed:   # ours, its own unjudged row
                    comp.append([f"{q.title}, ours (not judged)"] + who
                                + [ours_cell(r, q), "-", "-"])
    for _, r in tab.iterrows():
        n = r["particles"]
        who = [r["label"], "-" if n is None or n != n else str(int(n))]
        if not long:
            row = who + [str(int(r["trials"]))]
            if not quantities:
                row.append(f"{fmt(r['rmse_mean'])} [{fmt(r['rmse_ci_lo'])}, "
                           f"{fmt(r['rmse_ci_hi'])}]")
            for q in quantities:
                row += [shown_cell(r, q), fmt(r[f"paper_{q.key}"], 6),
                        r[f"verdict_{q.key}"] or "-"]
                row += [ours_cell(r, q)] if q.judged_by is not None and timed else []
            comp.append(row)
        diag.append(who + [fmt(r["rmse_var"])]
                    + (_paired_cells(exp, r) if exp.compare["baseline"] else [])
                    + [fmt(r["mean_ess"]), fmt(r["distinct_frac"], 3),
                       fmt(r["lik_evals_per_step"])]
                    + ([fmt(r["wall_ms_per_trial"], 3)] if timed else []))
    out = [("", comp_head, comp), ("diagnostics", diag_head, diag)]
    if cmp.per_trial is not None:
        out.append(per_trial_cells(cmp.per_trial))
    head, cells = ranking_table(cmp.rankings, detail=True)
    if cells:
        out.append(("ordered pairs (paired trials)", head, cells))
    return out


def _counts(rows: pd.DataFrame, column: str, trials: str | None = None) -> str:
    """'PF N=50: 3, UKF: 1' (or with ``trials``: 'PF N=50: 3 in 2 trials'): a count per row."""
    return ", ".join(f"{r['label']}" + (f" N={int(r['particles'])}" if r["particles"] ==
                                        r["particles"] and r["particles"] is not None else "")
                     + f": {int(r[column])}"
                     + (f" in {int(r[trials])} trial{'s' if int(r[trials]) != 1 else ''}"
                        if trials else "") for _, r in rows.iterrows())


def footnotes(cmp: Comparison) -> list[str]:
    """Lines that explain the table: rankings, factors, the floor row, underflow events."""
    exp, tab = cmp.exp, cmp.table
    notes = ranking_summary(cmp.rankings)      # the pairs themselves: ranking_table
    for f in cmp.factors:
        notes.append(f"{f['quantity']}, {f['to']} / {f['from']}: paper {fmt(f['paper'], 3)} "
                     f"({fmt(f['paper_from'], 4)} -> {fmt(f['paper_to'], 4)}); ours "
                     f"{fmt(f['ours'], 3)} [{fmt(f['lo'], 3)}, {fmt(f['hi'], 3)}] (paired "
                     f"trials): {f['verdict'] or '-'}.")
    table = cmp.reported
    judged = multiplicity(cmp)
    if judged > 1:
        notes.append(f"This table's verdicts are judged together: {judged} cells"
                     f"{' and factors' if cmp.factors else ''} are tested, and Holm's step-down "
                     "procedure adjusts the 'differs' tests and the 'reproduced' (equivalence) "
                     "tests across them, so the chance of any false 'differs', or of any false "
                     "'reproduced', in the table is at most 5%. Each verdict prints the interval "
                     "that decided it at the level it was tested (table.csv: verdict_lo_Q, "
                     "verdict_hi_Q, verdict_level_Q).")
    if table is not None and table.runs:
        notes.append(f"The paper's values come from {table.runs} run"
                     f"{'s' if table.runs > 1 else ''}: the verdicts' intervals add the sampling "
                     "error of a batch that size to ours (half-widths times sqrt(1 + n_ours / "
                     "runs), for a mean: standard error sqrt(se_ours^2 + se_batch^2), se_batch = "
                     "se_ours sqrt(n_ours / runs)); the 95% interval beside our value does not.")
    for q in (table.quantities if table is not None else ()):
        if q.margin is not None:
            m = q.margin
            zero = (m.absolute if m.absolute is not None else m.relative) == 0
            head = (f"'{q.title}' is held to the paper's value as printed, with no margin"
                    if zero else f"Margin of '{q.title}': ours counts as the paper's value "
                    f"within {m.describe()}")
            notes.append(f"{head}. {m.why}")
    if exp.compare["baseline"]:
        notes.append(f"'RMSE - {exp.compare['baseline']}': mean per-trial RMSE difference to the "
                     "baseline on the same truth, with its 95% interval; 'Wins': fraction of trials "
                     "where the row's RMSE is lower.")
    notes += consistency_notes(cmp)
    if exp.compare["floor"] is not None:
        r = tab[tab["filter"] == exp.compare["floor"]].iloc[0]
        notes.append(f"Floor: {r['label']} with N = {int(r['particles'])} reaches RMSE "
                     f"{r['rmse_mean']:.3f} [{r['rmse_ci_lo']:.3f}, {r['rmse_ci_hi']:.3f}]; no filter "
                     "can average below what a near-optimal filter reaches, so a paper value under "
                     "that interval is marked 'paper below the model's floor'.")
    machine = [q.title for q in (table.quantities if table is not None else ())
               if q.metric in MACHINE_METRICS]
    if machine and not cmp.timed:
        notes.append(f"Run times depend on the machine, so this file leaves out our value of "
                     f"{', '.join(repr(t) for t in machine)} (no verdict depends on it): the "
                     "console table of `pfbench run` shows it, and timings.csv beside trials.csv "
                     "holds each filter run's wall time (not committed).")
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


def consistency_notes(cmp: Comparison) -> list[str]:
    """The note that explains the NEES and NIS columns, where the table has them."""
    shown = [m.upper() for m in CONSISTENCY_METRICS if f"{m}_mean" in cmp.table]
    if not shown:
        return []
    return [(f"{' and '.join(shown)}: the normalised estimation error squared (xhat - x)^2 / P "
            "and the normalised innovation squared nu^2 / S, averaged over the steps of each "
            "trial, then over trials, with the mean's Monte Carlo standard error; P is the "
            "filter's own posterior variance, S the variance it predicts for its innovation nu. "
            "A consistent filter averages 1: the bracket holds the two-sided 95% chi-square "
            "bounds of the mean of K = steps x trials squares of standard normals "
            "(chi2_K(0.025) / K, chi2_K(0.975) / K); above them a filter is overconfident (its "
            "variance too small for its errors), below them underconfident. The bounds take the "
            "K terms as independent: a consistent filter's innovations are, its estimation "
            "errors are correlated in time, so its NEES strays beyond them somewhat more often "
            "than 5%.")]


def table_title(exp) -> str:
    """'name  (paper table)', or 'name  (paper)' for a config without a table, or 'name'."""
    where = " ".join(str(x) for x in (exp.paper, exp.table) if x)
    return exp.name + (f"  ({where})" if where else "")


def console_parts(cmp: Comparison) -> dict:
    """Everything ``pfbench run`` prints of a comparison, as strings (JSON-able): ``title`` and
    ``trials`` (its first line), ``headline`` (headline_tables), ``wide`` (console_tables),
    ``footnotes`` and ``counts`` (verdict_counts). The console prints these, and an up-to-date
    run prints them again from pfbench.replay without computing the comparison. Computed once
    per comparison (a run records them, then prints them)."""
    if getattr(cmp, "_console", None) is not None:
        return cmp._console
    trials = int(cmp.table["trials"].max()) if len(cmp.table) else 0

    def plain(tables):
        return [[str(name), [str(h) for h in head], [[str(c) for c in row] for row in cells]]
                for name, head, cells in tables]
    cmp._console = {"title": table_title(cmp.exp), "trials": trials,
                    "headline": plain(headline_tables(cmp)), "wide": plain(console_tables(cmp)),
                    "footnotes": [str(n) for n in footnotes(cmp)],
                    "counts": verdict_counts(cmp)}
    return cmp._console


def verdict_counts(cmp: Comparison) -> str:
    """'15 cells judged: 1 reproduced, 14 differ; 2 not comparable' for the paper's table (factors
    counted with the cells); '' without one."""
    if cmp.reported is None:
        return ""
    kinds = cmp.kinds()
    n = {k: kinds.count(k) for k in ("reproduced", "differs", "inconclusive", "not comparable")}
    judged = n["reproduced"] + n["differs"] + n["inconclusive"]
    parts = [f"{n['reproduced']} reproduced", f"{n['differs']} differ"]
    if n["inconclusive"]:
        parts.append(f"{n['inconclusive']} inconclusive")
    out = f"{judged} cell{'s' if judged != 1 else ''} judged: " + ", ".join(parts)
    if n["not comparable"]:
        out += f"; {n['not comparable']} not comparable or not judged"
    return out


def multiplicity(cmp: Comparison) -> int:
    """How many cells and factors of the comparison were tested together (Holm's family)."""
    kinds = ("reproduced", "differs", "inconclusive")
    table = cmp.reported
    n = sum(int(cmp.table[f"kind_{q.key}"].isin(kinds).sum())
            for q in (table.quantities if table is not None else ())
            if f"kind_{q.key}" in cmp.table)
    return n + sum(f["kind"] in kinds for f in cmp.factors)


def interval_line(cmp: Comparison) -> str:
    """The sentence that names how each column's intervals are made."""
    line = ("Intervals beside our values are 95% over trials: Student's t for the RMSE mean; a "
            "distribution-free standard error for the RMSE variance")
    table = cmp.reported
    by_method: dict[str, list[str]] = {}
    for q in (table.quantities if table is not None else ()):
        col = f"method_{q.key}"
        if (col in cmp.table and not _shown_as_rmse(q)
                and (cmp.timed or q.metric not in MACHINE_METRICS)):
            for m in cmp.table[col].dropna().unique():
                by_method.setdefault(m, []).append(q.title)
    for m, titles in by_method.items():
        line += f"; {METHODS[m]} for {', '.join(titles)}"
    if cmp.factors:
        line += f"; {METHODS[cmp.factors[0]['method']]} for the factors"
    if cmp.anytime:
        line += (f". The verdicts, run until decided, use instead {METHODS['cs']}, tuned for "
                 f"{cmp.anytime} trials, for every cell, factor and pair")
    return line + "."


def markdown(cmp: Comparison, meta: dict | None = None, rows=None) -> str:
    """table.md: title, provenance, the table and the paper's notes; with the trial ``rows``,
    the section "All filters at once" (ranks_section)."""
    exp, tab, table = cmp.exp, cmp.table, cmp.reported
    lines = [f"# {exp.name}", ""]
    if exp.description:
        lines += [exp.description, ""]
    if table is not None:
        lines += [f"Paper: `{exp.paper}` {exp.table}: {exp.reference.citation}.", "",
                  f"Table: {table.caption}.", ""]
    trials = int(tab["trials"].max()) if len(tab) else 0
    lines += [f"Scenario `{exp.scenario}`; {trials} trials; seed {exp.seed}; experiment hash "
              f"`{exp.hash}`" + (f"; pfbench {meta['versions']['pfbench']}" if meta else "") + ".",
              "", interval_line(cmp), ""]
    head, cells = display_columns(cmp, se=True)
    lines.append("| " + " | ".join(head) + " |")
    lines.append("|" + "|".join(" --- " for _ in head) + "|")
    for row in cells:
        lines.append("| " + " | ".join(c.replace("|", "/") for c in row) + " |")
    if cmp.per_trial is not None:
        title, head, cells = per_trial_cells(cmp.per_trial)
        lines += ["", f"{title}:", "", "| " + " | ".join(head) + " |",
                  "|" + "|".join(" --- " for _ in head) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in cells]
    head, cells = ranking_table(cmp.rankings, detail=True)
    if cells:
        lines += ["", f"{RANKING_TITLE} (the paired difference of the means, lower row minus "
                  "upper, with its interval at the level Holm's procedure tested it):", "",
                  "| " + " | ".join(head) + " |", "|" + "|".join(" --- " for _ in head) + "|"]
        lines += ["| " + " | ".join(row) + " |" for row in cells]
    notes = footnotes(cmp) + list(table.notes if table is not None else ())
    until = (meta or {}).get("until_decided")
    if until:
        looks = ", ".join(f"{k['trials']} ({k['undecided']} undecided)" for k in until["looks"])
        notes.insert(0, f"Run until decided: batches of {until['batch']} trials, at most "
                     f"{until['max_trials']}; looks after {looks}; stopped: {until['stopped']}.")
    if notes:
        lines += ["", "Notes:", ""] + [f"- {n}" for n in notes]
    lines += ranks_section(rows, cmp.exp)
    return "\n".join(lines) + "\n"


def ranks_section(rows, exp) -> list[str]:
    """The lines of table.md's section "All filters at once": the filters ranked on RMSE in
    every block of runs at one particle count on one trial, the Friedman test, and the groups the
    pairwise Wilcoxon-Holm tests do not tell apart (pfbench.rank, computed once:
    tablecache.cached_ranking); none without ``rows``, or when fewer than two filters ran at a
    common particle count."""
    if rows is None or len(rows) == 0:
        return []
    from .tablecache import cached_ranking
    return cached_ranking(exp, rows)


def write(cmp: Comparison, out_dir: Path, meta: dict | None = None, rows=None) -> None:
    """Write table.csv (the comparison's table) and table.md into ``out_dir`` (atomically; with
    the trial ``rows``, its ranking of all filters at once),
    without the run times: they hold what the seed determines, the same bytes on any machine
    (the console shows the run times; the timings file holds them)."""
    cmp = cmp.without_timings()
    write_csv(Path(out_dir) / "table.csv", cmp.table)
    atomic_write(Path(out_dir) / "table.md", markdown(cmp, meta, rows))
