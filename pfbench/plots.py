"""Figures of an experiment (matplotlib, in the style of pfbench.figstyle, under
``<results>/figures/``; PNG unless ``--figure-format`` says svg or pdf).

Every experiment: the distribution over trials of each filter run's RMSE, and of each other metric
the paper's table reports as a mean, beside the mean with its 95% interval (what the tables
report) and the paper's value where it gives one. SLAM experiments also: for trial 0, the course
with the true and estimated paths and the mapped landmarks, and the effective sample size over
time (afsa2014 Fig. 5); the position, heading and landmark errors over time (ifa2021 Fig. 6,
afsa2014 Fig. 3), median and interquartile band over the first FIGURE_TRIALS trials.
Localization experiments: the position error per step, median and interquartile band over the
first FIGURE_TRIALS trials (sspf2008's error figure), with the particle count over time when
KLD-sampling adapts it, each filter's particles over the field at a few steps of a trial where
it converged and one where it did not, the paths of one trial over the map with the beacons
(the true path, dead reckoning, each filter's estimate), and from a uniform start without a
paper's convergence rate, the convergence rate and time. Figures never run a trial: they draw
the rows and the traces the run kept (``traces.npz``, pfbench.traces).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from . import figstyle as fs
from .config import Experiment
from .errors import UserError
from .kinds import kind_of
from .compare import MACHINE_FIGURE_PREFIX, MACHINE_METRICS
from .store import Traces, read_traces
from .tables import judged_title
from .traces import (SNAPSHOT_PARTICLES, error_runs, path_runs, runs_in, slam_error_curves,
                     snapshot_runs, split_curves)


def save_figure(fig, path: Path) -> None:
    """Save ``fig`` to ``path`` (its suffix names the format; see figstyle.save)."""
    fs.save(fig, path)


def _run_name(run, rows: pd.DataFrame | None = None) -> str:
    """'PF (N=100)'; a run whose particle count adapts (KLD-sampling): 'KLD-MCL (N adaptive, mean
    96, at most 5000)'."""
    if run.particles is None:
        return run.label
    if rows is not None and "mean_particles" in rows:
        m = rows.loc[rows["filter"] == run.key, "mean_particles"].dropna()
        if len(m) and abs(float(m.mean()) - run.particles) > 0.5:
            return f"{run.label} (N adaptive: mean {float(m.mean()):.0f}, at most {run.particles})"
    return f"{run.label} (N={run.particles})"


def _distribution_quantities(exp: Experiment) -> list[tuple[str, float, str, object]]:
    """(metric, scale, axis label, the paper's quantity or None) of each distribution figure:
    the RMSE, and each per-trial metric the paper's table reports as a mean."""
    unit = kind_of(exp.scenario).unit
    out = [("rmse", 1.0, fs.label("rmse", unit), None)]
    table = exp.reported
    for q in (table.quantities if table is not None else ()):
        if q.stat != "mean" or q.metric in ("time_ratio", "evals_ratio", "gain_mean", "gain_var"):
            continue
        if q.metric == "rmse" and q.scale == 1.0:
            out[0] = ("rmse", 1.0, fs.label("rmse", unit), q)
        elif q.metric not in [m for m, *_ in out]:
            out.append((q.metric, q.scale, q.title, q))
    return out


def _paper_value(exp: Experiment, run, q) -> tuple[float, float] | None:
    """The paper's value of quantity ``q`` for a filter run as (low, high): a number gives (v, v),
    a range its ends; None where the paper gives none."""
    v = exp.reported.row(run.label, run.particles).get(q.key)
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return None
    return (float(v[0]), float(v[1])) if isinstance(v, tuple) else (float(v), float(v))


# the legend's names of the paper's marks
_PAPER = "the paper's value"
_PAPER_APART = "the paper's value, not comparable (see the table)"


# A distribution figure with more filter runs than this draws small multiples (_panels)
SINGLE_PANEL_RUNS = 12


def _panels(runs: list) -> list[tuple[str, list]]:
    """How a distribution figure splits its filter runs: [(panel title, runs)]. At most
    SINGLE_PANEL_RUNS runs: one panel. More: one panel per particle count when a few filters run
    at many counts (asrl2008's SRL and ASRL at nine), else one per filter (label: its counts side
    by side)."""
    if len(runs) <= SINGLE_PANEL_RUNS:
        return [("", list(runs))]
    labels = list(dict.fromkeys(r.label for r in runs))
    counts = list(dict.fromkeys(r.particles for r in runs))
    if len(labels) <= 3 and len(counts) > len(labels):
        return [(f"N = {n}" if n is not None else "N not set",
                 [r for r in runs if r.particles == n]) for n in counts]
    return [(lab, [r for r in runs if r.label == lab]) for lab in labels]


def _tick(run, rows, title: str) -> str:
    """A run's name under its box: in a panel of one filter, its particle count; in a panel of
    one count, its filter; else its name (_run_name)."""
    name = _run_name(run, rows)
    if title.startswith("N = "):
        return name.replace(f" (N={run.particles})", "").replace(" (N adaptive:", "\n(adaptive:")
    if title and title == run.label:
        return name[len(run.label):].strip(" ()").replace("N adaptive: ", "adaptive\n") or "-"
    return name


def _trial_counts(data: list, total: int) -> tuple[str, list[str]]:
    """(the title's words on the trials, a note under each box): 'over 100 trials' when every
    run has a value in each; else 'over the trials with a value' and 'n = 16 of 100' under each
    box (steps to converge: only the converged trials have one)."""
    ns = [len(d) for d in data]
    if all(n == total for n in ns):
        return f"over {total} trials", [""] * len(ns)
    return (f"over the trials of {total} with a value (under each box: how many)",
            [f"\n{n} of {total}" for n in ns])


def _floor_value(exp: Experiment, rows: pd.DataFrame, metric: str, scale: float) -> float | None:
    """The mean of ``metric`` of the config's floor run (compare.floor), for a RMSE figure; None
    without one."""
    key = exp.compare["floor"] if hasattr(exp, "compare") else None
    if key is None or metric != "rmse":
        return None
    v = rows.loc[rows["filter"] == key, metric].dropna().to_numpy(float)
    v = v[np.isfinite(v)]
    return float(v.mean()) * scale if v.size else None


def _run_means(group, data, quantity, by_key) -> tuple[list, list, list]:
    """Each run's mean and the distances down and up to its 95% interval's ends: the table's
    (``by_key``, ours_QUANTITY and its interval) where it has the quantity, else the trials'."""
    from .metrics import summarize
    means, los, his = [], [], []
    for r, v in zip(group, data):
        q = quantity
        if by_key is not None and q is not None and f"ours_{q.key}" in by_key:
            m = by_key.loc[r.key, f"ours_{q.key}"]
            lo, hi = by_key.loc[r.key, f"ours_lo_{q.key}"], by_key.loc[r.key, f"ours_hi_{q.key}"]
        else:
            st = summarize(v)
            m, lo, hi = st["mean"], st["ci_lo"], st["ci_hi"]
        means.append(m)
        los.append(m - lo if lo == lo else 0.0)
        his.append(hi - m if hi == hi else 0.0)
    return means, los, his


def _paper_marks(ax, exp: Experiment, pos, group, quantity, by_key, shown: set[str]) -> None:
    """The paper's value of each run on its box (a diamond; a range: a bar), grey where the
    table calls it not comparable; adds the legend names drawn to ``shown``."""
    for x, r in zip(pos, group):
        v = _paper_value(exp, r, quantity)
        if v is None:
            continue
        # a value the table calls not comparable is drawn grey: not the same measure
        apart = by_key.loc[r.key].get(f"kind_{quantity.key}") == "not comparable"
        c = "0.55" if apart else "#d62728"
        name = _PAPER_APART if apart else _PAPER
        shown.add(name)
        if v[0] == v[1]:      # on its box: the paper's value and ours, the same x
            ax.plot([x - 0.1], [v[0]], "D", color=c, ms=7, mfc="none", mew=1.8, label=name,
                    zorder=6)
        else:
            ax.plot([x - 0.1] * 2, list(v), "-", color=c, lw=4, alpha=0.6, label=name, zorder=6)


def distribution_figure(exp: Experiment, rows: pd.DataFrame, path: Path, metric: str = "rmse",
                        scale: float = 1.0, ylabel: str = "RMSE", quantity=None,
                        table: pd.DataFrame | None = None) -> None:
    """Each filter run's ``metric`` over trials (box: quartiles, whiskers 1.5 IQR, points beyond),
    beside it the mean with its 95% interval as the table reports it (black), and the paper's
    value (red diamond on the box; a range: a red bar) where ``quantity`` has one; the config's
    floor run's mean as a dashed line. Many runs: small multiples with a shared axis (_panels).
    A log axis where the values span more than a factor of 30. The title counts the trials: a
    run whose metric some trials lack (steps to converge) says under its box how many it has."""
    runs = list(exp.filters)
    data = [rows.loc[rows["filter"] == r.key, metric].dropna().to_numpy(float) * scale
            for r in runs]
    data = [d[np.isfinite(d)] for d in data]    # a diverged trial's inf has no place on an axis
    keep = [i for i, d in enumerate(data) if d.size]
    if not keep:
        return
    runs, data = [runs[i] for i in keep], [data[i] for i in keep]
    of_run = {r.key: d for r, d in zip(runs, data)}
    total = int(rows["trial"].nunique())
    counted, _ = _trial_counts(data, total)
    panels = _panels(runs)
    most = max(len(g) for _, g in panels)
    pw = 0.62 * most + 0.9                        # inches per panel
    ncol = max(1, min(len(panels), int((fs.MAX_WIDTH_IN - 0.8) // pw)))
    nrow = math.ceil(len(panels) / ncol)
    wide = fs.width(max(6.4, pw * ncol + 0.8)) if len(panels) > 1 else fs.width(
        max(6.4, 0.62 * len(runs) + 2.4))
    fig, axes = fs.pyplot().subplots(nrow, ncol, figsize=(wide, 3.1 * nrow + 1.3 if nrow > 1
                                                          else 4.6),
                                     sharey=True, squeeze=False)
    by_key = table.set_index("filter") if table is not None and len(table) else None
    shown: set[str] = set()
    floor = _floor_value(exp, rows, metric, scale)
    values = np.concatenate(data)
    pos_v = values[values > 0]
    log = bool(len(pos_v) and values.min() > 0 and pos_v.max() / pos_v.min() > 30)
    for p, (title, group) in enumerate(panels):
        ax = axes[p // ncol, p % ncol]
        d = [of_run[r.key] for r in group]
        _, notes = _trial_counts(d, total)
        pos = np.arange(1, len(group) + 1)
        ax.boxplot(d, positions=pos - 0.1, widths=0.36, showfliers=True,
                   flierprops={"markersize": 2.5, "alpha": 0.5}, medianprops={"color": "0.35"},
                   patch_artist=True, boxprops={"facecolor": "0.93", "edgecolor": "0.45"},
                   whiskerprops={"color": "0.45"}, capprops={"color": "0.45"})
        means, los, his = _run_means(group, d, quantity, by_key)
        ax.errorbar(pos + 0.22, means, yerr=[los, his], fmt="o", color="black", ms=4, capsize=3,
                    lw=1.1, label="our mean and its 95% interval")
        if quantity is not None and by_key is not None:
            _paper_marks(ax, exp, pos, group, quantity, by_key, shown)
        if floor is not None:
            ax.axhline(floor, color="#2ca02c", ls="--", lw=1.1, zorder=0,
                       label="the floor: mean of the floor run (no filter can do better)")
        if log:
            ax.set_yscale("log")
        ax.set_xlim(0.4, len(group) + 0.6)
        ax.set_xticks(pos, [_tick(r, rows, title) + n for r, n in zip(group, notes)],
                      rotation=0 if title else 35, ha="center" if title else "right")
        if title:
            ax.set_title(title)
        if p % ncol == 0:
            ax.set_ylabel(ylabel)
        ax.grid(axis="x", visible=False)
    for p in range(len(panels), nrow * ncol):
        axes[p // ncol, p % ncol].set_visible(False)
    paper = [w for w, name in (("red diamond on its box: the paper's value", _PAPER),
                               ("grey: the paper's, not comparable", _PAPER_APART))
             if name in shown]
    fig.suptitle(fs.wrap(f"{exp.name}: {ylabel} {counted} (box: quartiles; black: our mean "
                         "and its 95% interval" + "".join(f"; {w}" for w in paper) + ")", wide),
                 fontsize=10)
    fig.tight_layout()
    _legend_under(fig, axes.ravel()[:len(panels)])
    save_figure(fig, path)


def _legend_under(fig, axes, ncol: int = 2) -> None:
    """One legend under the figure: every distinct label of ``axes``' artists, once."""
    seen: dict = {}
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            seen.setdefault(lab, h)
    if seen:
        fig.legend(list(seen.values()), list(seen), loc="upper center", ncol=ncol,
                   frameon=False, bbox_to_anchor=(0.5, 0.0))


def _stacked(run, rows) -> str:
    """A run's name in lines, for a tick under a narrow column: 'KLD-MCL\n(N adaptive:\nmean
    101, at most 5000)'."""
    return _run_name(run, rows).replace(" (", "\n(").replace(": ", ":\n")


def wilson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The Wilson score interval of a rate of ``k`` successes in ``n`` trials
    (scipy.stats.binomtest(k, n).proportion_ci, method 'wilson'); (nan, nan) when n = 0."""
    if n <= 0:
        return math.nan, math.nan
    from scipy.stats import binomtest
    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=level, method="wilson")
    return float(ci.low), float(ci.high)


def rates(exp: Experiment, rows: pd.DataFrame) -> list[tuple[str, str, object]]:
    """The rates a figure draws, as (name, axis label, per-row outcome 0/1 or NaN, the paper's
    quantity or None): each 0-or-1 metric the paper's table reports as a mean (converged), and
    with kidnappings, recovering from every one (recovery_failures = 0)."""
    out = []
    table = exp.reported
    for q in (table.quantities if table is not None else ()):
        if q.stat == "mean" and q.metric in rows and q.scale == 1.0:
            v = rows[q.metric].dropna()
            if len(v) and v.isin((0.0, 1.0)).all():
                out.append((q.metric, fs.label(q.metric).replace(" (fraction of trials)", ""),
                            rows[q.metric].astype(float), q))
    kidnapped = any(c in rows and (rows[c].fillna(0) > 0).any()
                    for c in ("recovery_failures", "recovery_steps"))   # a kidnapping happened
    if kidnapped and rows["recovery_failures"].notna().any():
        ok = (rows["recovery_failures"] == 0).astype(float).where(
            rows["recovery_failures"].notna())
        out.append(("recovered", "recovered from every kidnapping", ok, None))
    return out


def rate_table(exp: Experiment, rows: pd.DataFrame, outcome: pd.Series) -> pd.DataFrame:
    """Per filter run: successes k, trials n with an outcome, the rate k/n and its Wilson 95%
    interval (lo, hi)."""
    out = []
    for r in exp.filters:
        v = outcome[rows["filter"] == r.key].dropna()
        k, n = int((v == 1.0).sum()), int(len(v))
        lo, hi = wilson(k, n)
        out.append({"filter": r.key, "k": k, "n": n, "rate": k / n if n else math.nan,
                    "lo": lo, "hi": hi})
    return pd.DataFrame(out)


def rate_figure(exp: Experiment, rows: pd.DataFrame, path: Path,
                table: pd.DataFrame | None = None) -> None:
    """The rates (rates()): per filter run, the fraction of trials with its Wilson 95% interval,
    'k of n' beside it, and the paper's value (red diamond) on the same run; one panel per rate.
    Up to three runs: a column each, named under it; more: a row each (horizontal bars), named
    once on the left, so that every name stays readable."""
    which = rates(exp, rows)
    if not which:
        return
    runs = list(exp.filters)
    rows_layout = len(runs) > 3
    if rows_layout:
        wide = fs.width(min(fs.MAX_WIDTH_IN, 3.4 + 3.0 * len(which)))
        fig, axes = fs.pyplot().subplots(1, len(which), figsize=(wide, 0.36 * len(runs) + 1.9),
                                         sharey=True, squeeze=False)
    else:
        wide = fs.width(max(5.0, (0.75 * len(runs) + 1.2) * len(which) + 0.6))
        fig, axes = fs.pyplot().subplots(1, len(which), figsize=(wide, 4.4), sharey=True,
                                         squeeze=False)
    by_key = table.set_index("filter") if table is not None and len(table) else None
    ns = set()
    for ax, (name, label, outcome, q) in zip(axes[0], which):
        t = rate_table(exp, rows, outcome)
        ns |= set(t["n"])
        _rate_panel(ax, exp, rows, runs, t, q, by_key, rows_layout)
        ax.set_title(label)
    if rows_layout:
        for ax in axes[0]:
            ax.set_xlabel("trials (%)")
    else:
        axes[0, 0].set_ylabel("trials (%)")
    n = f"{ns.pop()} trials" if len(ns) == 1 else "the trials with an outcome"
    fig.suptitle(fs.wrap(f"{exp.name}: rates over {n} (bar and dot: our rate, with its Wilson "
                         f"95% interval; {'beside' if rows_layout else 'under'} each: trials it "
                         "succeeded of those run)", wide),
                 fontsize=10)
    fig.tight_layout()
    _legend_under(fig, axes[0])
    save_figure(fig, path)


def _rate_panel(ax, exp: Experiment, rows: pd.DataFrame, runs: list, t: pd.DataFrame, q,
                by_key, rows_layout: bool) -> None:
    """One rate's panel of rate_figure: a bar per run (a row each with ``rows_layout``, else a
    column), its Wilson interval, 'k of n' and the paper's value where it has one."""
    pos = np.arange(len(runs), 0, -1) if rows_layout else np.arange(1, len(runs) + 1)
    for i, (r, row) in enumerate(zip(runs, t.itertuples())):
        err = [[100 * (row.rate - row.lo)], [100 * (row.hi - row.rate)]]
        if rows_layout:
            ax.barh(pos[i], 100 * row.rate, height=0.6, color=fs.colour(i), alpha=0.35)
            ax.errorbar([100 * row.rate], [pos[i]], xerr=err, fmt="o", color="black", ms=4,
                        capsize=3, lw=1.2, label="our rate and its Wilson 95% interval")
            ax.text(106, pos[i], f"{row.k} of {row.n}", va="center", fontsize=8)
        else:
            ax.bar(pos[i], 100 * row.rate, width=0.6, color=fs.colour(i), alpha=0.35)
            ax.errorbar([pos[i]], [100 * row.rate], yerr=err, fmt="o", color="black", ms=4,
                        capsize=4, lw=1.2, label="our rate and its Wilson 95% interval")
        v = _paper_value(exp, r, q) if q is not None else None
        if v is not None:
            apart = (by_key is not None and r.key in by_key.index
                     and by_key.loc[r.key].get(f"kind_{q.key}") == "not comparable")
            vals = [100 * v[0]] + ([] if v[0] == v[1] else [100 * v[1]])
            at = [pos[i]] * len(vals)
            xy = (vals, at) if rows_layout else (at, vals)
            ax.plot(*xy, "D" if v[0] == v[1] else "-", color="0.55" if apart else "#d62728",
                    ms=8, mfc="none", mew=1.8, lw=4, label=_PAPER_APART if apart else _PAPER,
                    zorder=6)
    if rows_layout:
        ax.set_yticks(pos, [_run_name(r, rows) for r in runs], fontsize=8)
        ax.set_xticks([0, 25, 50, 75, 100])
        ax.set_xlim(0, 128)
        ax.grid(axis="y", visible=False)
    else:
        ax.set_xticks(pos, [f"{_stacked(r, rows)}\n{row.k} of {row.n}"
                            for r, row in zip(runs, t.itertuples())], fontsize=8)
        ax.set_ylim(0, 105)
        ax.grid(axis="x", visible=False)


def _families(exp: Experiment) -> dict[str, list]:
    """The paper's quantities that no distribution figure draws, by family: 'gains' (gains over
    the baseline), 'ratios' (a cost over the baseline's), else one per quantity (a variance
    over trials): {file name: [(quantity, measure)]}, measure 'ours' the quantity as measured,
    'judged' the measure its verdict is judged on (``judged_by``). A cost that depends on the
    machine (a run-time ratio) judged on such a measure: that measure in 'ratios' (drawn from
    the trials, the same on every machine), the cost itself in 'time_ratios' (drawn only where a
    timings file gives the run times)."""
    out: dict[str, list] = {}
    table = exp.reported
    drawn = {q.key for *_, q in _distribution_quantities(exp) if q is not None}
    for q in (table.quantities if table is not None else ()):
        if q.key in drawn or (q.stat == "mean" and q.metric not in (
                "time_ratio", "evals_ratio", "gain_mean", "gain_var")):
            continue
        fam = ("gains" if q.metric.startswith("gain_") else
               "ratios" if q.metric.endswith("_ratio") else q.key)
        if q.judged_by is not None:
            out.setdefault(fam, []).append((q, "judged"))
            if q.metric in MACHINE_METRICS:
                fam = f"{MACHINE_FIGURE_PREFIX}{fam}"
        out.setdefault(fam, []).append((q, "ours"))
    return out


def _ticks_touch(names: list[str], pitch: float) -> bool:
    """Whether ``names`` (each in lines), under ticks ``pitch`` inches apart, would touch: a line
    of one and the same line of the next wider together than twice the pitch (a character of the
    8.5 pt tick labels about 0.059 in wide)."""
    lines = [n.splitlines() for n in names]
    return any((len(la) + len(lb)) / 2 * 0.059 > pitch
               for a, b in zip(lines, lines[1:]) for la, lb in zip(a, b))


def claims_figure(exp: Experiment, table: pd.DataFrame, qs: list, path: Path,
                  rows: pd.DataFrame | None = None) -> None:
    """One panel per (quantity, measure) of ``qs`` (a family of _families: the gains, the cost
    ratios): per filter run with a value, ours with the 95% interval the table reports (black;
    measure 'judged': the measure its verdict is judged on) and the paper's value at the same x
    (red diamond; grey where the table calls it not comparable); a line at 0 for a gain, at 1
    for a ratio (log axis)."""
    if table is None or not len(table):
        return
    by_key = table.set_index("filter")
    panels = []
    for q, measure in qs:
        if f"{measure}_{q.key}" not in by_key:
            continue
        runs = [r for r in exp.filters if r.key in by_key.index
                and np.isfinite(float(by_key.loc[r.key, f"{measure}_{q.key}"]))]
        if runs:
            title = (q.title if measure == "ours" else
                     f"{judged_title(q, exp)} (judges {q.title})")
            panels.append((q, measure, title, runs))
    if not panels:
        return
    wide = fs.width(max(5.0, sum(0.7 * len(r) + 1.3 for *_, r in panels) + 0.6))
    # names stacked in lines under ticks this far apart (inches) that would touch: each name on
    # one slanted line instead
    crowded = any(_ticks_touch([_stacked(r, rows) for r in runs],
                               ((wide - 0.6) / len(panels) - 0.7) / (len(runs) + 0.2))
                  for *_, runs in panels)
    ratio = all(q.metric.endswith("_ratio") for q, *_ in panels)
    fig, axes = fs.pyplot().subplots(1, len(panels), figsize=(wide, 4.6), squeeze=False)
    n = sorted({int(by_key.loc[r.key, "trials"]) for *_, runs in panels for r in runs})
    for ax, (q, measure, title, runs) in zip(axes[0], panels):
        x = np.arange(1, len(runs) + 1)
        m = np.array([float(by_key.loc[r.key, f"{measure}_{q.key}"]) for r in runs])
        lo = np.array([float(by_key.loc[r.key, f"{measure}_lo_{q.key}"]) for r in runs])
        hi = np.array([float(by_key.loc[r.key, f"{measure}_hi_{q.key}"]) for r in runs])
        ax.errorbar(x, m, yerr=[np.nan_to_num(m - lo), np.nan_to_num(hi - m)], fmt="o",
                    color="black", ms=5, capsize=4, lw=1.2,
                    label="ours and the table's 95% interval")
        for xi, r in zip(x, runs):
            v = _paper_value(exp, r, q)
            if v is None:
                continue
            apart = by_key.loc[r.key].get(f"kind_{q.key}") == "not comparable"
            ax.plot([xi], [v[0]], "D", color="0.55" if apart else "#d62728", ms=8, mfc="none",
                    mew=1.8, label=_PAPER_APART if apart else _PAPER, zorder=6)
            if v[1] != v[0]:
                ax.plot([xi] * 2, list(v), "-", color="#d62728", lw=4, alpha=0.6)
        shown_v = np.concatenate([lo, hi, m])
        shown_v = shown_v[np.isfinite(shown_v)]
        log = ratio or bool(shown_v.size and shown_v.min() > 0
                            and shown_v.max() / shown_v.min() > 30)
        if ratio or not log:            # no 0 on a log axis
            ax.axhline(1.0 if ratio else 0.0, color="0.4", lw=0.9, ls=":")
        if log:
            ax.set_yscale("log")        # a ratio; or variances that span decades
            if ratio:                   # plain numbers (2, 3, 4), not 2 x 10^0
                from matplotlib.ticker import FormatStrFormatter
                ax.yaxis.set_major_formatter(FormatStrFormatter("%g"))
                ax.yaxis.set_minor_formatter(FormatStrFormatter("%g"))
        ax.set_xlim(0.4, len(runs) + 0.6)
        if crowded:
            ax.set_xticks(x, [_run_name(r, rows) for r in runs], rotation=35, ha="right",
                          rotation_mode="anchor")
        else:
            ax.set_xticks(x, [_stacked(r, rows) for r in runs])
        ax.set_title(fs.wrap(title, wide / len(panels), 9.5))
        ax.grid(axis="x", visible=False)
    counted = f"{n[0]} trials" if len(n) == 1 else f"{n[0]} to {n[-1]} trials"
    what = ("over the baseline's, 1 dotted" if ratio else
            "over the baseline's, 0 dotted" if all(q.metric.startswith("gain_") for q, *_ in panels)
            else "")
    fig.suptitle(fs.wrap(f"{exp.name}: " + ", ".join(t for _, _, t, _ in panels)
                         + (f" ({what})" if what else "") + f", ours over {counted} (black: "
                         "with the table's 95% interval) beside the paper's value (red diamond, "
                         "same x)", wide), fontsize=10)
    fig.tight_layout()
    _legend_under(fig, axes[0])
    save_figure(fig, path)


def _moving(x: np.ndarray, win: int, rms: bool = False) -> np.ndarray:
    """Moving mean (``rms``: root mean square) over ``win`` samples, 'valid' part."""
    if win <= 1:
        return x
    k = np.ones(win) / win
    return np.sqrt(np.convolve(x * x, k, mode="valid")) if rms else np.convolve(x, k, mode="valid")


def slam_trial_figures(exp: Experiment, traces: Traces, folder: Path, trial: int = 0,
                       fmt: str = "png", rows: pd.DataFrame | None = None) -> list[Path]:
    """The course with true and estimated paths and maps and the effective sample size over
    time, for one trial of a SLAM experiment (from its trace), and the errors over time over the
    traced trials (slam_error_figure)."""
    tr = runs_in(traces.trials[trial])
    shared, world = tr[""], traces.world
    truth = shared["truth_pose"]
    runs = [(r, tr[r.key]) for r in exp.filters]
    fig, ax = fs.pyplot().subplots(figsize=(8.6, 6.4))
    if "waypoints" in world:
        wp = np.vstack([world["waypoints"], world["waypoints"][:1]])
        ax.plot(wp[:, 0], wp[:, 1], "o", color="0.6", ms=3, label="waypoints", zorder=1)
    ax.plot(world["landmarks"][:, 0], world["landmarks"][:, 1], "*", color="0.15", ms=7,
            label="landmarks", zorder=2)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="black", lw=2.2, alpha=0.35, label="true path",
            zorder=3)
    for i, (r, out) in enumerate(runs):
        c = fs.colour(i)
        ax.plot(out["pose"][:, 0], out["pose"][:, 1], color=c, ls=fs.linestyle(i), lw=1.0,
                label=_run_name(r, rows), zorder=4)
        seen = out["lm_seen"].astype(bool)
        ax.plot(out["lm_est"][seen, 0], out["lm_est"][seen, 1], fs.marker(i), color=c, ms=4,
                mfc="none", mew=0.9, zorder=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(fs.wrap(f"{exp.name}, trial {trial} only (of {exp.trials}): true path (grey), "
                         "estimated paths, and each filter's mapped landmarks (its marker)", 8.6))
    fig.tight_layout()
    _legend_under(fig, [ax])
    course = folder / f"course.{fmt}"
    save_figure(fig, course)

    errors = folder / f"errors.{fmt}"
    slam_error_figure(exp, traces, errors, rows)

    t_obs = shared["obs_time"]
    fig, ax = fs.pyplot().subplots(figsize=(8.6, 3.8))
    K = t_obs.shape[0]
    win = max(1, K // 50)           # a moving mean, or thousands of jumps hide each other
    for i, (r, out) in enumerate(runs):
        if r.particles is not None and out["ess"].size:
            ax.plot(t_obs[win - 1:], _moving(out["ess"], win), lw=1.1, color=fs.colour(i),
                    ls=fs.linestyle(i), label=f"{_run_name(r, rows)}: mean "
                    f"{np.mean(out['ess']):.2f}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Neff = 1 / sum W^2")
    ax.set_title(fs.wrap(f"{exp.name}, trial {trial} only (of {exp.trials}): effective sample "
                         "size before resampling"
                         + (f" (moving mean of {win} observations)" if win > 1 else ""), 8.6))
    fig.tight_layout()
    _legend_under(fig, [ax])
    ess = folder / f"ess.{fmt}"
    save_figure(fig, ess)
    return [course, errors, ess]


def _quartiles(a: np.ndarray) -> np.ndarray:
    """(3, S) the first quartile, median and third quartile over the rows (trials) of ``a`` (R, S)
    at each column, NaN ignored (NaN where a column has no number)."""
    a = np.asarray(a, dtype=float)
    if not np.isnan(a).any():
        return np.percentile(a, [25, 50, 75], axis=0)
    import warnings
    with warnings.catch_warnings():             # a column of NaN only: NaN, as said
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanpercentile(a, [25, 50, 75], axis=0)


# Curves of more points than this are drawn as pixels in a vector figure (SVG, PDF): a recorded
# span of 10,000 steps would otherwise write megabytes of path a reader never resolves. The PNG
# is the same either way.
DENSE_POINTS = 2000


def _median_band(ax, x: np.ndarray, quart: np.ndarray, c: str, others=()) -> None:
    """On ``ax``: a run's median over trials (a line in colour ``c``) with its interquartile band
    (``quart``, from _quartiles; a light fill), the other runs' medians ``others`` in light grey
    behind them (as pixels in a vector figure beyond DENSE_POINTS points)."""
    dense = len(x) > DENSE_POINTS
    for m in others:
        ax.plot(x, m, color="0.78", lw=0.9, zorder=1, rasterized=dense)
    ax.fill_between(x, quart[0], quart[2], color=c, alpha=0.25, lw=0, zorder=2,
                    label="interquartile band", rasterized=dense)
    ax.plot(x, quart[1], color=c, lw=1.8, zorder=3, label="median", rasterized=dense)


def _kept_trials_text(exp: Experiment, n: int) -> str:
    """'over 20 trials', or 'over the first 50 of 100 trials (...)' when the run kept fewer."""
    return (f"over {n} trials" if n >= exp.trials else
            f"over the first {n} of {exp.trials} trials (those whose traces the run keeps)")


def slam_error_figure(exp: Experiment, traces: Traces, path: Path,
                      rows: pd.DataFrame | None = None) -> dict:
    """The errors over time of a SLAM experiment over its traced trials: one row of panels per
    filter run (its name over the row), one column per error (position, heading as an RMS over
    the last w steps, the landmark error of the highest-weight particle's map), each its median
    over the trials with the interquartile band, the other runs' medians in light grey behind; a
    column shares its axis, from 0.
    Returns {run key: {error name: median}}."""
    trials = sorted(traces.trials)
    by_trial = [runs_in(traces.trials[k]) for k in trials]
    runs = exp.filters

    def curves(tr: dict) -> dict:
        if "error_time" in tr[""]:
            return tr
        # a trace written before the error curves were kept (trial 0 only): from its paths
        out = {"": {}}
        for r in runs:
            shared, out[r.key] = split_curves(slam_error_curves(
                tr[r.key]["pose"], tr[""]["truth_pose"], tr[""]["time"],
                tr[r.key].get("lm_trace"), tr[""]["obs_time"]))
            out[""].update(shared)
        return out

    by_trial = [curves(tr) for tr in by_trial]
    shared = by_trial[0][""]
    cols = [("error", "error_time", "position error (m)")]
    w = float(shared["heading_window_s"])
    cols.append(("heading_error", "error_time", "heading error (rad)"
                 + (f",\nRMS over the last {w:.3g} s" if w > 0 else "")))
    if "map_time" in shared and any("map_error" in tr[r.key] for tr in by_trial for r in runs):
        cols.append(("map_error", "map_time", "landmark error (m)"))
    quart = {}
    for r in runs:
        for name, _, _ in cols:
            have = [tr[r.key][name] for tr in by_trial if name in tr[r.key]]
            if have:
                quart[r.key, name] = _quartiles(np.asarray(have, dtype=float))
    ncol, nrow = len(cols), len(runs)
    wide = fs.width(3.0 * ncol + 0.6)
    fig, axes = fs.pyplot().subplots(nrow, ncol, figsize=(wide, 1.75 * nrow + 1.3), sharex=True,
                                     squeeze=False)
    for j, (name, tname, ylabel) in enumerate(cols):
        t = shared[tname]
        for i, r in enumerate(runs):
            ax = axes[i, j]
            if i:
                ax.sharey(axes[0, j])
            if (r.key, name) in quart:
                _median_band(ax, t, quart[r.key, name], fs.colour(i),
                             [quart[o.key, name][1] for o in runs
                              if o.key != r.key and (o.key, name) in quart])
            else:
                ax.text(0.5, 0.5, "not given by this filter", ha="center", va="center",
                        transform=ax.transAxes, color="0.4")
            if j == 0:              # the run's name once, over its row
                ax.set_title(_run_name(r, rows), loc="left", fontweight="bold")
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
        axes[0, j].set_ylim(bottom=0)       # the column's axis, from every run's band
        axes[-1, j].set_xlabel("time (s)")
    fig.suptitle(fs.wrap(f"{exp.name}: errors over time, median and interquartile band "
                         f"{_kept_trials_text(exp, len(trials))}; grey: the other filters' "
                         "medians; landmark error: the highest-weight particle's map",
                         wide), fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return {r.key: {name: quart[r.key, name][1] for name, _, _ in cols if (r.key, name) in quart}
            for r in runs}


def localization_error_figure(exp: Experiment, traces: Traces, path: Path,
                              rows: pd.DataFrame | None = None) -> dict:
    """Position error per step over the traced trials, one panel per shown run (a shared log
    axis): its median with the interquartile band, the other runs' medians in light grey behind
    it; a last panel with the particle count over time when a run adapts it. Returns {run key:
    (T+1,) median}."""
    runs = error_runs(exp)
    trials = sorted(traces.trials)
    by_trial = [runs_in(traces.trials[k]) for k in trials]
    err = {r.key: np.asarray([tr[r.key]["error"] for tr in by_trial], dtype=float) for r in runs}
    # a particle count over the trials that report one (an optional output, given or not in
    # each trial on its own)
    count = {r.key: np.asarray([tr[r.key]["n"] for tr in by_trial if "n" in tr[r.key]])
             for r in runs if any("n" in tr[r.key] for tr in by_trial)}
    adaptive = [r for r in runs if r.key in count and np.ptp(count[r.key]) > 0]
    n_panels = len(runs) + (1 if adaptive else 0)
    ncol = min(n_panels, 3)
    nrow = math.ceil(n_panels / ncol)
    wide = fs.width(3.1 * ncol + 0.6)
    fig, axes = fs.pyplot().subplots(nrow, ncol, figsize=(wide, 2.7 * nrow + 1.2), sharex=True,
                                     squeeze=False)
    t = np.arange(err[runs[0].key].shape[1])
    times = traces.world.get("times")          # recorded data: each step's time (s)
    if times is not None and len(times) == len(t):
        t = np.asarray(times, dtype=float)
    else:
        times = None
    quart = {r.key: _quartiles(err[r.key]) for r in runs}
    medians = {r.key: quart[r.key][1] for r in runs}
    kidnaps = traces.world["kidnaps"]
    share = None
    for i, r in enumerate(runs):
        ax = axes[i // ncol, i % ncol]
        if share is None:
            share = ax
        else:
            ax.sharey(share)
        _median_band(ax, t, quart[r.key], fs.colour(i),
                     [medians[o.key] for o in runs if o.key != r.key])
        for kstep in kidnaps:
            ax.axvline(t[int(kstep)] if int(kstep) < len(t) else kstep, color="0.3", ls=":",
                       lw=1)
        ax.axhline(float(traces.world["bound"]), color="0.5", ls="--", lw=0.8)
        ax.set_yscale("log")
        ax.set_title(_run_name(r, rows).replace(" (N adaptive:", "\n(N adaptive:"))
        ax.grid(alpha=0.3, which="both")
        if i % ncol == 0:
            ax.set_ylabel("position error (m)")
    if adaptive:
        ax2 = axes[(n_panels - 1) // ncol, (n_panels - 1) % ncol]
        for i, r in enumerate(runs):
            if r in adaptive:
                ax2.plot(t[1:], count[r.key].astype(float).mean(axis=0), color=fs.colour(i),
                         lw=1.4, label=f"{r.label}: mean over trials",
                         rasterized=len(t) > DENSE_POINTS)
        if max(np.ptp(count[r.key]) for r in adaptive) > 1000:
            ax2.set_yscale("log")
        ax2.set_title("particle count of the adaptive runs")
        ax2.set_ylabel("particles")
        ax2.grid(alpha=0.3, which="both")
        ax2.legend(frameon=False)
    for p in range(n_panels, nrow * ncol):
        axes[p // ncol, p % ncol].set_visible(False)
    for j in range(ncol):
        axes[-1, j].set_xlabel("time (s)" if times is not None else "step")
        axes[-1, j].xaxis.set_tick_params(labelbottom=True)
    kept = _kept_trials_text(exp, len(trials))
    fig.suptitle(fs.wrap(f"{exp.name}: position error per step, median and interquartile band "
                         f"{kept}; grey: the other filters' medians; "
                         + ("dotted: kidnappings; " if kidnaps.size else "")
                         + "dashed: the convergence bound", wide), fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)
    return medians


def _outcome(rows: pd.DataFrame, kidnapped: bool) -> pd.Series | None:
    """Per row, 1.0 where the filter succeeded, else 0.0: converged, or with kidnappings,
    recovered from every one; None when the rows do not say."""
    if rows is None:
        return None
    if kidnapped and "recovery_failures" in rows:
        return (rows["recovery_failures"] == 0).astype(float)
    return rows["converged"] if "converged" in rows else None


def _snapshot_trials(exp: Experiment, traces: Traces, rows: pd.DataFrame, run,
                     kidnapped: bool = False) -> list:
    """[(trial, outcome)] to show of ``run``: among the trials with snapshots, the first where it
    succeeded (converged; with kidnappings, recovered from every one) and the first where it did
    not (one of each outcome the trials have)."""
    have = sorted(k for k, tr in traces.trials.items() if f"{run.key}/snap_xy" in tr)
    if not have:
        return []
    ok = _outcome(rows, kidnapped)
    if ok is None:
        return [(have[0], None)]
    conv = rows.assign(_ok=ok)[rows["filter"] == run.key].set_index("trial")["_ok"]
    out = []
    for want in (1.0, 0.0):
        k = next((k for k in have if k in conv.index and conv[k] == want), None)
        if k is not None:
            out.append((k, want))
    return out or [(have[0], None)]


def _shown_steps(steps: list, kidnaps: list) -> list[int]:
    """The indices of the kept snapshot steps a particle figure shows, at most 5: the start,
    step 10 (global localization under way), three steps after each kidnapping, the end."""
    want = [steps[0]] + [t for t in steps if t == 10] + [int(k) + 3 for k in kidnaps]
    want.append(steps[-1])
    idx = [steps.index(t) for t in dict.fromkeys(want) if t in steps]
    return sorted(idx)[:4] + ([len(steps) - 1] if len(idx) > 4 else [])


def particle_figure(exp: Experiment, traces: Traces, path: Path,
                    rows: pd.DataFrame | None = None) -> None:
    """The particles of each filter (one run per label: the largest count) over the field at a few
    steps: of each, a trial where it converged and one where it did not (each row says which
    trial, and how often the filter converged over all trials)."""
    world = traces.world
    kidnapped = bool(np.asarray(world["kidnaps"]).size)
    panels = []                 # (run, trial, outcome)
    for r in snapshot_runs(exp):
        panels += [(r, k, o) for k, o in _snapshot_trials(exp, traces, rows, r, kidnapped)]
    first = runs_in(traces.trials[panels[0][1]])[""] if panels else None
    if first is None:
        return
    cols = _shown_steps(list(first["steps"]), list(np.asarray(world["kidnaps"])))
    steps = [first["steps"][j] for j in cols]
    side = min(1.75, (fs.MAX_WIDTH_IN - 1.4) / len(steps))
    fig, axes = fs.pyplot().subplots(len(panels), len(steps), figsize=(
        fs.width(side * len(steps) + 1.4), side * len(panels) + 1.0), squeeze=False)
    for i, (r, k, outcome) in enumerate(panels):
        tr = runs_in(traces.trials[k])
        out, truth = tr[r.key], tr[""]["truth_pose_at"]
        has = "snap_xy" in out
        ends = np.cumsum(out["snap_drawn"]) if has else None
        rate = ""
        ok = _outcome(rows, kidnapped)
        if ok is not None:
            c = ok[rows["filter"] == r.key].dropna()
            rate = (f"\n({'recovers' if kidnapped else 'converges'} in {c.mean():.0%})"
                    if len(c) else "")
        what = ({1.0: "recovered", 0.0: "did not recover", None: ""} if kidnapped else
                {1.0: "converged", 0.0: "did not converge", None: ""})[outcome]
        for j, (t, jt) in enumerate(zip(steps, cols)):
            ax = axes[i, j]
            W, H = float(world["area"][0]), float(world["area"][1])
            ax.plot(world["beacons"][:, 0], world["beacons"][:, 1], "k^", ms=4, zorder=2)
            ax.plot(*truth[jt, :2], "o", mfc="none", mec="red", ms=8, mew=1.2, zorder=3)
            est = out["pose_at"][jt, :2]
            ax.plot(*est, "x", color="green", ms=6, mew=1.4, zorder=4)
            if has:     # above the markers: a collapsed cloud stays visible
                P = out["snap_xy"][ends[jt] - out["snap_drawn"][jt]:ends[jt]]
                ax.plot(P[:, 0], P[:, 1], ".", color="tab:blue", ms=2.4, alpha=0.5, mew=0,
                        zorder=5, rasterized=True)     # in an SVG or PDF: an image, not points
            if not (0 <= est[0] <= W and 0 <= est[1] <= H):
                ax.text(0.97, 0.97, "estimate off the field", transform=ax.transAxes,
                        fontsize=8, ha="right", va="top", color="green")
            ax.set_xlim(0, W)
            ax.set_ylim(0, H)
            ax.set_aspect("equal")
            for side in ("top", "right"):
                ax.spines[side].set_visible(True)
            ax.set_xticks([0, W / 2, W] if i == len(panels) - 1 else [])
            ax.set_yticks([0, H / 2, H] if j == 0 else [])
            ax.tick_params(labelsize=8)
            if i == len(panels) - 1:
                ax.set_xticklabels([f"{v:g}" for v in (0, W / 2, W)])
                ax.set_xlabel("x (m)", fontsize=8)
            ax.grid(False)
            if i == 0:
                ax.set_title(f"step {t}" + (" (kidnapped)" if t in world["kidnaps"] else ""),
                             fontsize=8)
            if j == 0:
                ax.set_yticklabels([f"{v:g}" for v in (0, H / 2, H)])
                ax.set_ylabel(f"{r.label}, trial {k}\n{what}{rate}", fontsize=8)
            if has and out["snap_count"][jt] != r.particles:      # an adaptive count
                ax.text(0.03, 0.03, f"N={out['snap_count'][jt]}", transform=ax.transAxes,
                        fontsize=8)
    w, h = float(world["area"][0]), float(world["area"][1])
    n_snap = sum(1 for tr in traces.trials.values() if "steps" in tr)
    fig.suptitle(fs.wrap(f"{exp.name}: particles (blue) over the {w:g} m x {h:g} m field "
                         "(x, y in m), beacons (black), true pose (red circle), estimate (green "
                         "x); of each filter a trial "
                         + ("where it recovered from every kidnapping and one where it did not"
                            if kidnapped else "where it converged and one where it did not")
                         + f" (among the first {n_snap} of {exp.trials} trials, whose "
                         f"particles the run keeps; at most {SNAPSHOT_PARTICLES} of a set "
                         "drawn)",
                         fig.get_size_inches()[0]), fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def _trial_words(rows: pd.DataFrame | None, run, trial: int, kidnapped: bool,
                 times: np.ndarray | None = None) -> str:
    """What the rows say of ``run`` in ``trial``: 'RMSE 0.37 m, converged at 95 s' (at a step
    without the steps' ``times``; with kidnappings: recovered or not); '' without rows."""
    if rows is None or "rmse" not in rows:
        return ""
    mine = rows[(rows["filter"] == run.key) & (rows["trial"] == trial)]
    if not len(mine):
        return ""
    words = [f"RMSE {float(mine['rmse'].iloc[0]):.3g} m"]
    ok = _outcome(mine, kidnapped)
    if ok is not None and ok.notna().iloc[0]:
        words.append(({1.0: "recovered", 0.0: "did not recover"} if kidnapped else
                      {1.0: "converged", 0.0: "did not converge"})[float(ok.iloc[0])])
        at = converge_times(mine, run, times)
        if not kidnapped and at.size:
            words[-1] += (f" at {at[0]:.{0 if at[0] >= 10 else 1}f} s" if times is not None
                          else f" at step {at[0]:.0f}")
    return ", ".join(words)


def _broken(xy: np.ndarray, steps: np.ndarray, kidnaps) -> np.ndarray:
    """A path's points (n, 2) with a NaN row before each kidnapping's step: no line across the
    jump of a robot that was moved."""
    cut = np.searchsorted(steps, np.asarray(kidnaps, dtype=np.int64))
    cut = cut[(cut > 0) & (cut < len(steps))]
    return np.insert(np.asarray(xy, dtype=float), cut, np.nan, axis=0)


def _span_words(world: dict, steps: np.ndarray) -> str:
    """The span a paths figure shows: 'steps 0 to 150' or, with the steps' times (recorded data),
    '0 to 600 s of the span (2986 steps)'; 'one step in 5 drawn' where the trace thinned the
    path."""
    T = int(steps[-1])
    if "times" in world:
        t = world["times"]
        words = f"{float(t[int(steps[0])]):.0f} to {float(t[T]):.0f} s of the span ({T} steps)"
    else:
        words = f"steps {int(steps[0])} to {T}"
    stride = int(np.max(np.diff(steps))) if len(steps) > 1 else 1   # kidnappings add steps
    return words + (f", one step in {stride} drawn" if stride > 1 else "")


def _path_panel(ax, tr: dict, r, baseline: list, truth: np.ndarray, true_xy: np.ndarray,
                world: dict, c, dense: bool) -> None:
    """One panel of path_figure: the true path (``true_xy``, broken at kidnappings), each
    ``baseline`` run's path dashed, run ``r``'s estimate in colour ``c``, the start and ends,
    the beacons with their ids, the area as the limits (equal aspect), and how many drawn steps
    of the estimate lie off the area; ``dense``: the lines as pixels in a vector figure."""
    W, H = float(world["area"][0]), float(world["area"][1])
    ax.plot(true_xy[:, 0], true_xy[:, 1], "-", color="black", lw=1.0, alpha=0.55, zorder=2,
            rasterized=dense)
    for b in baseline:
        dr = tr[b.key]["path"]
        ax.plot(dr[:, 0], dr[:, 1], "--", color="0.5", lw=0.9, zorder=1, rasterized=dense)
    est = tr[r.key]["path"]
    ax.plot(est[:, 0], est[:, 1], "-", color=c, lw=0.9, alpha=0.85, zorder=3, rasterized=dense)
    ax.plot(*truth[0], "o", mfc="white", mec="black", ms=7, mew=1.5, zorder=5)
    ax.plot(*truth[-1], "s", color="black", ms=6, zorder=5)
    ax.plot(*est[-1], "X", color=c, mec="black", mew=0.6, ms=8, zorder=6)
    for (bx, by), bid in zip(world["beacons"], world["beacon_ids"]):
        ax.plot(bx, by, "^", color="0.15", ms=8, zorder=4)
        ax.annotate(f"B{int(bid)}", (bx, by), xytext=(4, 4), textcoords="offset points",
                    fontsize=8, color="0.15", zorder=7)
    off = ~((est[:, 0] >= 0) & (est[:, 0] <= W) & (est[:, 1] >= 0) & (est[:, 1] <= H))
    if off.any():
        ax.text(0.98, 0.02, f"off the area: {off.sum()} of {off.size} steps",
                transform=ax.transAxes, fontsize=8, ha="right", va="bottom", color=c)
    ax.set_xlim(0, W)
    ax.set_ylim(0, H)
    ax.set_aspect("equal")
    ax.grid(alpha=0.25)
    for side in ("top", "right"):
        ax.spines[side].set_visible(True)


def _path_legend(baseline: list) -> list:
    """The legend entries of path_figure (``baseline``: the dead-reckoning runs)."""
    line = fs.pyplot().Line2D
    handles = [line([], [], color="black", alpha=0.55, lw=1.2, label="true path"),
               line([], [], color=fs.colour(0), lw=1.2, label="the panel's filter's estimate")]
    handles += [line([], [], color="0.5", ls="--", lw=1.1, label=b.label) for b in baseline]
    return handles + [
        line([], [], ls="", marker="o", mfc="white", mec="black", ms=7, mew=1.5,
             label="start (true)"),
        line([], [], ls="", marker="s", color="black", ms=6, label="end (true)"),
        line([], [], ls="", marker="X", color=fs.colour(0), mec="black", mew=0.6, ms=8,
             label="end of the estimate"),
        line([], [], ls="", marker="^", color="0.15", ms=8, label="beacon (B: its id)")]


def path_figure(exp: Experiment, traces: Traces, path: Path,
                rows: pd.DataFrame | None = None) -> None:
    """The paths of the first traced trial over the map, one panel per filter (path_runs; dead
    reckoning is no panel of its own but drawn in each, dashed grey): the true path (black), the
    filter's estimate (its colour), the start and end of the true path and the estimate's end,
    the beacons with their ids; shared axes in metres over the area, equal aspect. The true path
    breaks at each kidnapping. Each panel's title: the run and what its rows say of that trial."""
    have = sorted(k for k, tr in traces.trials.items() if "truth_path" in tr)
    if not have:
        return
    trial = have[0]
    tr = runs_in(traces.trials[trial])
    world = traces.world
    runs = [r for r in path_runs(exp) if "path" in tr.get(r.key, {})]
    baseline = [r for r in runs if r.type == "dead_reckoning"]
    shown = [r for r in runs if r.type != "dead_reckoning"] or baseline
    if not shown:
        return
    steps, truth = tr[""]["path_step"], tr[""]["truth_path"]
    kidnaps = np.asarray(world["kidnaps"], dtype=np.int64)
    kidnapped = bool(kidnaps.size)
    W, H = float(world["area"][0]), float(world["area"][1])
    ncol = min(len(shown), 3)
    nrow = math.ceil(len(shown) / ncol)
    side = min(4.2, (fs.MAX_WIDTH_IN - 0.9) / ncol)
    fig, axes = fs.pyplot().subplots(nrow, ncol, figsize=(
        fs.width(side * ncol + 0.9), side * H / W * nrow + 2.0), sharex=True, sharey=True,
        squeeze=False)
    true_xy = _broken(truth, steps, kidnaps)
    dense = len(steps) > 2000          # in an SVG or PDF, thousands of vertices a line: an image
    for i, r in enumerate(shown):
        ax = axes[i // ncol, i % ncol]
        _path_panel(ax, tr, r, baseline, truth, true_xy, world, fs.colour(i), dense)
        words = _trial_words(rows, r, trial, kidnapped, world.get("times"))
        ax.set_title(_run_name(r, rows).replace(" (N adaptive: mean", " (N: mean")
                     + (f"\n{words}" if words else ""), fontsize=9)
        if i % ncol == 0:
            ax.set_ylabel("y (m)")
        if i // ncol == nrow - 1 or i + ncol >= len(shown):
            ax.set_xlabel("x (m)")
            ax.xaxis.set_tick_params(labelbottom=True)
    for p in range(len(shown), nrow * ncol):
        axes[p // ncol, p % ncol].set_visible(False)
    handles = _path_legend(baseline)
    wide = fig.get_size_inches()[0]
    which = (f"trial {trial} (the first of {exp.trials})" if exp.trials > 1 and trial == 0
             else f"trial {trial} of {exp.trials}")
    fig.suptitle(fs.wrap(f"{exp.name}: paths over the {W:.0f} m x {H:.0f} m area in {which}, "
                         f"{_span_words(world, steps)}; one panel per "
                         "filter at its largest particle count"
                         + (", the true path broken at each kidnapping" if kidnapped else ""),
                         wide), fontsize=10)
    fig.tight_layout(rect=(0, 0.07 if nrow > 1 else 0.1, 1, 1))
    fig.legend(handles=handles, loc="lower center", ncol=4, frameon=False,
               bbox_to_anchor=(0.5, 0.0), fontsize=8)
    save_figure(fig, path)


def converge_times(rows: pd.DataFrame, run, times: np.ndarray | None) -> np.ndarray:
    """When ``run`` converged in each trial where it did: its converge_step, in seconds from the
    span's start where the scenario gives each step's ``times`` (recorded data), else in steps."""
    mine = rows[(rows["filter"] == run.key) & (rows["converged"] == 1.0)]
    k = mine["converge_step"].dropna().to_numpy(float)
    if times is None:
        return k
    return np.asarray(times, dtype=float)[np.clip(k.astype(np.int64), 0, len(times) - 1)]


def _horizontal() -> dict:
    """The keyword that lays a box plot on its side: ``orientation`` from matplotlib 3.10 (where
    ``vert`` is deprecated), ``vert=False`` before."""
    import matplotlib
    new = tuple(int(v) for v in matplotlib.__version__.split(".")[:2]) >= (3, 10)
    return {"orientation": "horizontal"} if new else {"vert": False}


def draws_convergence(exp: Experiment, rows: pd.DataFrame, traces: Traces) -> bool:
    """Whether a localization experiment gets a convergence figure: its filters start uniform
    over the area (global localization), its rows say whether each converged, and no rates
    figure already draws the convergence rate (a paper's table that reports it)."""
    return (bool(np.asarray(traces.world.get("global_start", False)))
            and "converged" in rows and rows["converged"].notna().any()
            and "converged" not in [name for name, *_ in rates(exp, rows)])


def convergence_figure(exp: Experiment, rows: pd.DataFrame, traces: Traces,
                       path: Path) -> None:
    """Global localization without a paper's rate: per filter run (a row each), the fraction of
    trials that converged with its Wilson 95% interval and 'k of n' (left), and when the converged
    trials converged (right: box of quartiles, a dot a trial; s into the span on recorded data,
    else steps; the axis spans the whole run)."""
    runs = list(exp.filters)
    world = traces.world
    times = world["times"] if "times" in world else None
    t = rate_table(exp, rows, rows["converged"].astype(float))
    wide = fs.MAX_WIDTH_IN
    fig, (a1, a2) = fs.pyplot().subplots(1, 2, figsize=(wide, 0.36 * len(runs) + 2.3),
                                         sharey=True, gridspec_kw={"width_ratios": [1, 1.25]})
    _rate_panel(a1, exp, rows, runs, t, None, None, rows_layout=True)
    a1.set_xlabel("trials that converged (%)")
    a1.set_title("convergence rate")
    pos = np.arange(len(runs), 0, -1)
    last = [int(tr["path_step"][-1]) for tr in traces.trials.values() if "path_step" in tr]
    end = (float(times[-1]) if times is not None else float(last[0]) if last else
           float(np.nanmax(rows["converge_step"])) if rows["converge_step"].notna().any()
           else 1.0)
    for i, r in enumerate(runs):
        v = converge_times(rows, r, times)
        if v.size:
            a2.boxplot([v], positions=[pos[i]], widths=0.5, showfliers=False, manage_ticks=False,
                       **_horizontal(),
                       medianprops={"color": "0.2"}, patch_artist=True,
                       boxprops={"facecolor": fs.colour(i), "alpha": 0.35, "edgecolor": "0.4"},
                       whiskerprops={"color": "0.45"}, capprops={"color": "0.45"})
            a2.plot(v, np.full(v.size, pos[i]), "o", color="black", ms=3, alpha=0.7, zorder=4)
        else:
            a2.text(0.01 * end, pos[i], "none converged", va="center", fontsize=8, color="0.4")
    a1.set_yticks(pos, [_run_name(r, rows) for r in runs], fontsize=8)
    a2.set_xlim(0, end * 1.02)
    a2.set_xlabel("converged at (s into the span)" if times is not None else "converged at (step)")
    a2.set_title("when: the converged trials")
    a2.grid(axis="y", visible=False)
    n = sorted(set(t["n"]))
    counted = f"{n[0]} trials" if len(n) == 1 else "the trials"
    fig.suptitle(fs.wrap(f"{exp.name}: global localization from a uniform start over {counted}; "
                         "converged: the position error under "
                         f"{float(world['bound']):g} m from then to the end (left: the rate with "
                         "its Wilson 95% interval, k of n beside it; right: when each converged "
                         "trial converged, box: quartiles, dots: trials)", wide), fontsize=10)
    fig.tight_layout()
    save_figure(fig, path)


def write_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, out_dir: Path,
                  fmt: str = "png", table: pd.DataFrame | None = None,
                  into: Path | None = None) -> list[Path]:
    """Write the experiment's figures into ``out_dir/figures`` (``fmt``: png, svg or pdf) from its
    rows, its comparison's ``table`` (our means with the intervals the table reports, the
    paper's values; computed here when None) and the traces its run kept
    (``out_dir/traces.npz``); return their paths. Figures of other formats already there are
    removed (a folder holds one format). ``into``: draw into that folder instead (the HTML
    report's)."""
    if fmt not in fs.FORMATS:
        raise UserError(f"--figure-format {fmt}: one of {', '.join(fs.FORMATS)}")
    kind = kind_of(exp.scenario)
    traces = read_traces(out_dir) if kind.figures else None
    if kind.figures and (traces is None or not traces.trials):
        raise UserError(f"{out_dir}: no traces.npz to draw the figures from; run the "
                        "experiment again with --resume, which keeps its trials")
    folder = Path(into) if into is not None else Path(out_dir) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    if table is None and exp.reported is not None and len(df):
        from .compare import compare
        table = compare(exp, df).table
    paths = []
    with fs.style():
        for metric, scale, ylabel, q in _distribution_quantities(exp):
            values = df[metric].dropna() if metric in df else pd.Series(dtype=float)
            if metric != "rmse" and values.isin((0.0, 1.0)).all():
                continue        # a rate (0 or 1 a trial): drawn with the rates
            path = folder / f"{metric}.{fmt}"
            distribution_figure(exp, df, path, metric, scale, ylabel, q, table)
            if path.exists():
                paths.append(path)
        if len(df) and rates(exp, df):
            path = folder / f"rates.{fmt}"
            rate_figure(exp, df, path, table)
            paths += [path] if path.exists() else []
        for fam, qs in _families(exp).items():
            path = folder / f"{fam}.{fmt}"
            claims_figure(exp, table, qs, path, df)
            paths += [path] if path.exists() else []
        if kind.figures:
            paths += globals()[kind.figures](exp, df, traces, folder, fmt)
    fs.prune(folder, paths)
    return paths


def expected_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, fmt: str = "png"
                     ) -> list[str]:
    """The names of the figures :func:`write_figures` surely draws of these rows (those that
    depend on what the traces show are left out): what an up-to-date run checks are there."""
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    names = []
    for metric, *_ in _distribution_quantities(exp):
        values = df[metric].dropna() if metric in df else pd.Series(dtype=float)
        if values.empty or (metric != "rmse" and values.isin((0.0, 1.0)).all()):
            continue
        names.append(f"{metric}.{fmt}")
    kind = kind_of(exp.scenario)
    if kind.figures == "slam_figures":
        names += [f"course.{fmt}", f"errors.{fmt}", f"ess.{fmt}"]
    elif kind.figures == "localization_figures":
        names.append(f"errors.{fmt}")
    return names


def slam_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces, folder: Path,
                 fmt: str = "png") -> list[Path]:
    """A SLAM experiment's figures of its first trial (see slam_trial_figures)."""
    return slam_trial_figures(exp, traces, folder, min(traces.trials), fmt, rows)


def localization_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces, folder: Path,
                         fmt: str = "png") -> list[Path]:
    """A localization experiment's error curves over the traced trials, its particles in a
    converged and a failed trial of each filter, the paths of its first trial over the map, and
    from a uniform start without a paper's rate the convergence rate and time
    (draws_convergence)."""
    paths = [folder / f"errors.{fmt}", folder / f"particles.{fmt}", folder / f"paths.{fmt}"]
    localization_error_figure(exp, traces, paths[0], rows)
    particle_figure(exp, traces, paths[1], rows)
    path_figure(exp, traces, paths[2], rows)
    if rows is not None and len(rows) and draws_convergence(exp, rows, traces):
        paths.append(folder / f"convergence.{fmt}")
        convergence_figure(exp, rows, traces, paths[-1])
    return [p for p in paths if p.exists()]


SWEEP_FIGURES = ("rmse", "heading_rmse", "landmark_error")


def sweep_metrics(exp: Experiment) -> list[str]:
    """The metrics a sweep of ``exp`` draws: the RMSE, its kind's headline errors, and every
    per-trial metric its paper's table reports (a convergence rate, a final error)."""
    kind = kind_of(exp.scenario)
    out = ["rmse"] + [m for m in kind.headline
                      if m not in ("rmse", "mse", "diverged_steps", "lik_evals_per_step")]
    out += [m for m in SWEEP_FIGURES if m in kind.metrics]
    table = exp.reported
    for q in (table.quantities if table is not None else ()):
        if q.metric in kind.metrics:
            out.append(q.metric)
    return list(dict.fromkeys(out))


# Quantities that are positive by their definition: a sweep draws their band as a log-normal
# interval (figstyle.lognormal_band), which stays above 0
POSITIVE = ("rmse", "mse", "heading_rmse", "position_error", "heading_error", "landmark_error",
            "x_error", "y_error", "final_error", "error_at_step", "wall_s", "mean_ess",
            "mean_particles", "lik_evals_per_step", "converge_step", "recovery_steps")


def log_axis(values) -> bool:
    """Whether a sweep's x axis is logarithmic: its positive values span a factor of 8 or more
    (25 to 800 particles), so that doubling N is the same step everywhere."""
    v = pd.to_numeric(pd.Series(list(values)), errors="coerce").dropna()
    v = v[v > 0]
    return bool(len(v) and v.max() / v.min() >= 8)


def sweep_band(summ: pd.DataFrame, m: str) -> tuple[np.ndarray, np.ndarray]:
    """A sweep line's 95% band of metric ``m``: for a positive quantity (POSITIVE) the
    log-normal interval from the mean and its standard error (it cannot dip below 0); else the
    summary's normal interval."""
    if m in POSITIVE and f"{m}_se" in summ:
        return fs.lognormal_band(summ[f"{m}_mean"].to_numpy(float),
                                 summ[f"{m}_se"].to_numpy(float))
    return summ[f"{m}_ci_lo"].to_numpy(float), summ[f"{m}_ci_hi"].to_numpy(float)


def _sweep_lines(summ: pd.DataFrame, group: list[str], x: str, others: list[str],
                 m: str) -> list[tuple]:
    """The lines of a sweep figure of metric ``m``: (name, x values, means, band's low, band's
    high) per group of the summary's rows (a filter and the values of the other swept keys)."""
    lines = []
    for vals, g in summ.groupby(group, sort=False, dropna=False):
        vals = vals if isinstance(vals, tuple) else (vals,)
        g = g.assign(_x=pd.to_numeric(g[x], errors="coerce")).sort_values("_x")
        n = g["particles"].dropna().unique()
        name = " ".join([f"{fs.label(k)} = {v}" for k, v in zip(others, vals)]
                        + [str(vals[len(others)])]
                        + ([f"(N={int(n[0])})"] if len(n) == 1
                           and not x.endswith("particles") else []))
        lo, hi = sweep_band(g, m)
        lines.append((name, g["_x"].to_numpy(float), g[f"{m}_mean"].to_numpy(float), lo, hi))
    return lines


def _sweep_x_axis(ax, xvalues: pd.Series) -> None:
    """A sweep panel's x axis: logarithmic, ticked at the swept values, where they span a factor
    of 8 or more (log_axis); a light grid."""
    if log_axis(xvalues):
        ax.set_xscale("log")
        xs = sorted(pd.to_numeric(xvalues, errors="coerce").dropna().unique())
        ax.set_xticks(xs, [f"{v:g}" for v in xs])
        ax.minorticks_off()
    ax.grid(alpha=0.3)


def sweep_figures(summ: pd.DataFrame, keys: list[str], out_dir: Path, title: str,
                  which=None, where: Path | None = None, fmt: str = "png",
                  unit: str = "", into: Path | None = None, curves: tuple = ()) -> list[Path]:
    """One figure per metric of ``which`` (default: those of SWEEP_FIGURES the summary holds; a
    sweep draws sweep_metrics of its experiment) against the first swept key, into ``where``
    (default: the folder's figures/METRIC.FMT): a line per filter (and per value of the other
    swept keys; a particle count that the sweep varies is the x axis, not a line of its own) with
    its 95% band (log-normal for a positive quantity: sweep_band); more than two lines: one
    panel per line with a shared axis, the other lines in light grey behind it. A log x axis
    where the swept values span a factor of 8 or more (log_axis). The paper's ``curves``
    (pfbench.curves) of a metric's mean are drawn on its figure: the points with their
    reading-error bars, joined by a dashed line."""
    folder = Path(into) if into is not None else out_dir / "figures"
    x = keys[0]
    others = keys[1:]
    paths = []
    if which is None:
        which = [m for m in SWEEP_FIGURES if f"{m}_mean" in summ]
    group = others + ["label"] + ([] if x.endswith("particles") else ["particles"])
    n_trials = sorted({int(n) for n in summ["trials"].dropna()}) if "trials" in summ else []
    counted = ("" if not n_trials else f"{n_trials[0]} trials a cell" if len(n_trials) == 1
               else f"{n_trials[0]} to {n_trials[-1]} trials a cell")
    from .curves import figure_points
    with fs.style():
        for m in which:
            if f"{m}_mean" not in summ or summ[f"{m}_mean"].isna().all():
                continue
            ylabel = fs.label(m, unit if m == "rmse" else "")
            lines = _sweep_lines(summ, group, x, others, m)
            many = len(lines) > 2
            ncol = min(len(lines), 2) if many else 1
            nrow = math.ceil(len(lines) / ncol) if many else 1
            wide = fs.width(4.3 * ncol + 0.6 if many else 7.8)
            fig, axes = fs.pyplot().subplots(nrow, ncol, figsize=(
                wide, (2.8 * nrow + 1.4) if many else 4.6), sharex=True, sharey=True,
                squeeze=False)
            panels = ([(axes[i // ncol, i % ncol], [i]) for i in range(len(lines))] if many
                      else [(axes[0, 0], list(range(len(lines))))])
            for ax, mine in panels:
                for j, (name, px, py, lo, hi) in enumerate(lines):
                    if j not in mine:
                        ax.plot(px, py, color="0.78", lw=1.0, zorder=1)
                for j in mine:
                    name, px, py, lo, hi = lines[j]
                    c = fs.colour(j)
                    ax.fill_between(px, lo, hi, color=c, alpha=0.2, lw=0, zorder=2)
                    ax.plot(px, py, color=c, ls=fs.linestyle(0 if many else j),
                            marker=fs.marker(j), ms=4, lw=1.6, label=name, zorder=3)
                    if many:
                        ax.set_title(name)
                for k, (cname, cx, cy, cerr) in enumerate(figure_points(curves, m, x)):
                    ax.errorbar(cx, cy, yerr=cerr, color="black", ls="--", lw=1.0,
                                marker=("s", "D", "^", "v")[k % 4], ms=5, mfc="white",
                                capsize=3, label=cname, zorder=5)
                _sweep_x_axis(ax, summ[x])
            for i in range(len(lines) if many else 1, nrow * ncol):
                axes[i // ncol, i % ncol].set_visible(False)
            for j in range(ncol):
                axes[-1, j].set_xlabel(fs.label(x))
            for i in range(nrow):
                axes[i, 0].set_ylabel(ylabel)
            band = ("log-normal 95% interval" if m in POSITIVE and f"{m}_se" in summ
                    else "95% interval")
            fig.suptitle(fs.wrap(f"{title}: {ylabel}, the mean over "
                                 f"{counted or 'the trials'} with its {band} (band)"
                                 + ("; grey: the other lines" if many else ""), wide),
                         fontsize=10)
            fig.tight_layout()
            _legend_under(fig, [a for a, _ in panels], ncol=2)
            path = where or folder / f"{m}.{fmt}"
            path.parent.mkdir(parents=True, exist_ok=True)
            save_figure(fig, path)
            paths.append(path)
    return paths
