"""Two results folders compared (``pfbench compare A B``): each metric's change per filter run,
with its interval, flagged only when it is both significant and larger than a factor (the rule
of asv's ``compare``: a change counts when the ratio passes the factor and the test says it is
real), so a CI job can fail on a drift and not on noise.

A filter run is matched by its run key (``pf@100``) and, in a sweep, its cell (the swept values).
For each matched run and metric, the change is B's mean over trials less A's:

- *paired by trial* when both folders ran from the same seed (trial t of each then draws the
  same simulated data): the mean of the per-trial differences over the trials both hold,
  with Student's t interval (scipy.stats.ttest_rel);
- *unpaired* otherwise: Welch's interval on the difference of the two means
  (scipy.stats.ttest_ind, equal_var=False).

The tests over every metric and run compared form one family, judged by Holm's procedure
(pfbench.verdicts.holm_levels) at ALPHA; each interval is drawn at the level Holm tests it at, so
it excludes 0 exactly when its test rejects. A change is *flagged* when it is significant and
B's mean over A's lies outside [1 / threshold, threshold] (either way: a drift, better or
worse). Metrics constant in both (a particle count) are compared exactly: any difference is
significant.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .errors import UserError
from .metrics import METRICS
from .rank import cell_columns

if TYPE_CHECKING:
    import pandas as pd

ALPHA = 0.05
THRESHOLD = 1.05


@dataclass
class Change:
    """One metric of one filter run, A against B."""
    run: str                 # the run key, with the sweep cell where there is one
    label: str
    metric: str
    paired: bool
    n_a: int
    n_b: int
    mean_a: float
    mean_b: float
    diff: float              # mean_b - mean_a (paired: the mean per-trial difference)
    lo: float                # its interval at confidence 1 - level
    hi: float
    p: float
    level: float = ALPHA
    ratio: float = math.nan  # mean_b / mean_a
    significant: bool = False
    flagged: bool = False


@dataclass
class RunsComparison:
    """What ``compare_runs`` found."""
    changes: list[Change]
    paired: bool
    threshold: float
    only_a: list[str] = field(default_factory=list)     # runs in A only
    only_b: list[str] = field(default_factory=list)
    alpha: float = ALPHA

    @property
    def flagged(self) -> list[Change]:
        return [c for c in self.changes if c.flagged]

    def as_dict(self) -> dict:
        def num(v):
            if isinstance(v, float) and not math.isfinite(v):
                return None if math.isnan(v) else ("inf" if v > 0 else "-inf")
            return v
        return {"paired": self.paired, "threshold": self.threshold, "alpha": self.alpha,
                "compared": len(self.changes), "flagged": len(self.flagged),
                "only_in_a": self.only_a, "only_in_b": self.only_b,
                "changes": [{k: num(v) for k, v in vars(c).items()} for c in self.changes]}


def _run_names(df: pd.DataFrame) -> pd.Series:
    cells = cell_columns(df)
    name = df["filter"].astype(str)
    for c in cells:
        name = name + " " + c + "=" + df[c].astype(str)
    return name


def _ratio(a: float, b: float) -> float:
    if a == b:
        return 1.0
    if a == 0:
        return math.copysign(math.inf, b)
    return b / a


def _test(a: np.ndarray, b: np.ndarray, paired: bool) -> tuple[float, float, object]:
    """(difference, p, result or None): the t test of B - A; None when the values have no
    spread (an exact comparison: p 0 when they differ, 1 when not)."""
    from scipy.stats import ttest_ind, ttest_rel
    if paired:
        d = b - a
        diff = float(d.mean())
        if np.all(d == d[0]):
            return diff, (1.0 if diff == 0 else 0.0), None
        res = ttest_rel(b, a)
    else:
        diff = float(b.mean() - a.mean())
        if np.all(a == a[0]) and np.all(b == b[0]):
            return diff, (1.0 if diff == 0 else 0.0), None
        res = ttest_ind(b, a, equal_var=False)
    return diff, float(res.pvalue), res


def compare_frames(a: pd.DataFrame, b: pd.DataFrame, paired: bool,
                   metrics: Sequence[str] | None = None, threshold: float = THRESHOLD,
                   alpha: float = ALPHA) -> RunsComparison:
    """Compare the trials of two results (frames of pfbench.dataset.load_trials), paired by
    trial or not (module docstring); ``metrics``: those compared (default: every metric both
    hold a value of)."""
    from .verdicts import holm_levels
    if not (isinstance(threshold, (int, float)) and math.isfinite(threshold)
            and threshold >= 1):
        raise UserError(f"--threshold {threshold}: a factor of 1 or more (1.05: a 5% change)")
    a, b = a.copy(), b.copy()
    a["_run"], b["_run"] = _run_names(a), _run_names(b)
    runs_a, runs_b = list(dict.fromkeys(a["_run"])), list(dict.fromkeys(b["_run"]))
    common = [r for r in runs_a if r in set(runs_b)]
    if not common:
        raise UserError("the two results share no filter run (run key and sweep cell): "
                        "nothing to compare")
    held = [m for m in METRICS if m in a and m in b
            and a[m].notna().any() and b[m].notna().any()]
    if metrics:
        bad = [m for m in metrics if m not in held]
        if bad:
            raise UserError(f"--metric {bad[0]}: not a metric both results hold (they hold "
                            f"{', '.join(held)})")
        held = list(dict.fromkeys(metrics))
    ga, gb = a.groupby("_run", sort=False), b.groupby("_run", sort=False)
    changes, results = [], []
    for run in common:
        ra, rb = ga.get_group(run), gb.get_group(run)
        if paired:
            both = ra.merge(rb, on="trial", suffixes=("_a", "_b"))
        for m in held:
            if paired:
                x = both[[f"{m}_a", f"{m}_b"]].dropna().to_numpy(float)
                va, vb = x[:, 0], x[:, 1]
            else:
                va = ra[m].dropna().to_numpy(float)
                vb = rb[m].dropna().to_numpy(float)
            if len(va) < 2 or len(vb) < 2:
                continue
            diff, p, res = _test(va, vb, paired)
            changes.append(Change(run, str(ra["label"].iloc[0]), m, paired, len(va), len(vb),
                                  float(va.mean()), float(vb.mean()), diff, diff, diff, p,
                                  ratio=_ratio(float(va.mean()), float(vb.mean()))))
            results.append(res)
    if not changes:
        raise UserError("no metric has two trials or more on both sides: nothing to compare")
    levels = holm_levels([c.p for c in changes], alpha)
    for c, res, level in zip(changes, results, levels):
        c.level = level
        if res is not None:
            ci = res.confidence_interval(1 - level)
            c.lo, c.hi = float(ci.low), float(ci.high)
        c.significant = bool(c.p <= level)
        c.flagged = c.significant and not (1 / threshold <= c.ratio <= threshold)
    only_a = [r for r in runs_a if r not in set(runs_b)]
    only_b = [r for r in runs_b if r not in set(runs_a)]
    return RunsComparison(changes, paired, float(threshold), only_a, only_b, alpha)


def compare_runs(folder_a, folder_b, metrics: Sequence[str] | None = None,
                 threshold: float = THRESHOLD, alpha: float = ALPHA) -> RunsComparison:
    """Compare two results folders (of ``pfbench run`` or ``pfbench sweep``): paired by trial
    when their seeds are the same, unpaired otherwise (module docstring)."""
    from .dataset import load_trials
    a, b = load_trials(folder_a), load_trials(folder_b)
    seed_a = a.attrs["meta"][str(folder_a)].get("seed")
    seed_b = b.attrs["meta"][str(folder_b)].get("seed")
    paired = seed_a is not None and seed_a == seed_b
    return compare_frames(a.drop(columns=["folder", "experiment"]),
                          b.drop(columns=["folder", "experiment"]), paired, metrics, threshold,
                          alpha)


def _pct(v: float, base: float) -> str:
    if base == 0 or not math.isfinite(v):
        return f"{v:+.4g}"
    return f"{100 * v / abs(base):+.1f}%"


def rows(cmp: RunsComparison, only_changed: bool = False) -> tuple[list[str], list[list[str]]]:
    """The console's table: head and rows (``only_changed``: the significant ones)."""
    head = ["Run", "Metric", "A", "B", "Change [interval]", "B / A", "p", "Holm level",
            "Flag"]
    out = []
    for c in cmp.changes:
        if only_changed and not c.significant:
            continue
        flag = ("FLAGGED" if c.flagged else "significant" if c.significant else "")
        out.append([c.run, c.metric, f"{c.mean_a:.4g}", f"{c.mean_b:.4g}",
                    f"{_pct(c.diff, c.mean_a)} [{_pct(c.lo, c.mean_a)}, "
                    f"{_pct(c.hi, c.mean_a)}]", f"{c.ratio:.4g}", f"{c.p:.3g}",
                    f"{c.level:.3g}", flag])
    return head, out


def summary_line(cmp: RunsComparison) -> str:
    how = ("paired by trial (same seed)" if cmp.paired
           else "unpaired, Welch (different seeds)")
    sig = sum(c.significant for c in cmp.changes)
    line = (f"{len(cmp.changes)} changes compared ({how}; Holm over {len(cmp.changes)} at "
            f"{cmp.alpha:g}): {sig} significant, {len(cmp.flagged)} flagged (significant and "
            f"B / A outside [1/{cmp.threshold:g}, {cmp.threshold:g}])")
    if cmp.only_a or cmp.only_b:
        line += (f"; runs in A only: {', '.join(cmp.only_a) or 'none'}, in B only: "
                 f"{', '.join(cmp.only_b) or 'none'}")
    return line + "."
