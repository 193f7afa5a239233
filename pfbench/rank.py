"""Many filters at once: a Friedman test over filters with blocks of paired runs, Wilcoxon
signed-rank tests between every two filters with Holm's procedure, and a critical-difference
diagram (J. Demsar, "Statistical comparisons of classifiers over multiple data sets", JMLR 7,
2006; the cliques of Wilcoxon-Holm tests as in H. Ismail Fawaz et al., "Deep learning for time
series classification: a review", 2019, and its cd-diagram code).

What is compared. A *filter* is a label of the trials files (``PF``, ``BA-PF``, ...). A *point*
is one results folder, one cell of a sweep (its swept values) and one particle count N; a
*block* is one trial at one point: the runs of different filters at the same N on the same
trial (the same seed, so the same simulated data) of the same folder and cell. A filter that
runs at several N takes part in one block per N; the filters compared are those that ran at
every point where two or more filters ran (``filters`` chooses them instead, and then the points
are those where every one of them ran). A block where a compared filter's metric is NaN is
dropped (counted). Within a block the filters are ranked by the metric, 1 the best (the lowest,
or the highest for the metrics in HIGHER_IS_BETTER), ties sharing the mean of their ranks.

The statistics are scipy.stats': ``friedmanchisquare`` over the blocks (three filters or more),
``wilcoxon`` (two-sided, its default zero handling) on each pair's per-block differences, and the
pairs judged together by Holm's procedure (pfbench.verdicts.holm_levels) at ALPHA.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import combinations
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

import numpy as np

from .errors import UserError
from .figstyle import pyplot, save, style
from .metrics import METRICS

if TYPE_CHECKING:
    import pandas as pd

ALPHA = 0.05
# metrics where more is better (every other: less is better)
HIGHER_IS_BETTER = frozenset({"converged", "mean_ess", "distinct_frac"})
# trials-file columns that are neither a metric nor a swept value
_NOT_CELL = frozenset({"folder", "experiment", "trial", "filter", "label", "particles", "crc",
                       "wall_s"})


@dataclass
class Pair:
    """Two filters compared block by block: ``a`` ranked before ``b`` (a lower average rank)."""
    a: str
    b: str
    n: int                    # blocks
    median_diff: float        # median over blocks of metric(a) - metric(b)
    a_better: int             # blocks where a is strictly better than b
    b_better: int
    p: float                  # Wilcoxon signed-rank, two-sided
    level: float              # the level Holm's procedure tests it at
    differs: bool             # p <= level


@dataclass
class Ranking:
    """Many filters compared at once on one metric (pfbench.rank.rank)."""
    metric: str
    higher_better: bool
    filters: list[str]                 # by average rank, best first
    average_ranks: dict[str, float]
    blocks: int
    points: list[dict]                 # folder, swept values, particles of each point
    left_out: list[str]                # filters that ran at some points only
    dropped: int                       # blocks dropped for a NaN metric
    friedman: float | None             # chi-square statistic (None: two filters)
    friedman_p: float | None
    pairs: list[Pair] = field(default_factory=list)
    cliques: list[list[str]] = field(default_factory=list)
    alpha: float = ALPHA

    def as_dict(self) -> dict:
        """The ranking as plain values (``pfbench rank --json``); NaN as None."""
        def num(v):
            return None if v is None or (isinstance(v, float) and math.isnan(v)) else v
        return {"metric": self.metric, "higher_is_better": self.higher_better,
                "filters": self.filters,
                "average_ranks": {k: round(v, 6) for k, v in self.average_ranks.items()},
                "blocks": self.blocks, "points": self.points, "left_out": self.left_out,
                "dropped_blocks": self.dropped, "friedman_chi2": num(self.friedman),
                "friedman_df": len(self.filters) - 1 if self.friedman is not None else None,
                "friedman_p": num(self.friedman_p), "alpha": self.alpha,
                "pairs": [{k: num(v) for k, v in vars(p).items()} for p in self.pairs],
                "cliques": self.cliques}


def cell_columns(trials: pd.DataFrame) -> list[str]:
    """The columns of a trials frame that name a sweep's cell (its swept values)."""
    return [c for c in trials.columns if c not in _NOT_CELL and c not in METRICS]


def _points(trials: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """``trials`` with a ``_point`` column (folder, cell, N as one string) and ``_who`` (the
    filter: its label, or label [run key] where a label has two runs at one point)."""
    df = trials.copy()
    cols = (["folder"] if "folder" in df else []) + cell_columns(df) + ["particles"]
    key = df[cols].astype(str).fillna("")
    df["_point"] = key.agg(" | ".join, axis=1) if cols else ""
    df["_who"] = df["label"].astype(str)
    runs = df.drop_duplicates(["_point", "filter"])
    twice = runs.duplicated(["_point", "_who"], keep=False)
    if twice.any():
        clash = set(zip(runs.loc[twice, "_point"], runs.loc[twice, "_who"]))
        hit = [(p, w) in clash for p, w in zip(df["_point"], df["_who"])]
        df.loc[hit, "_who"] = df.loc[hit, "label"].astype(str) + " [" + \
            df.loc[hit, "filter"].astype(str) + "]"
    return df, cols


def block_matrix(trials: pd.DataFrame, metric: str = "rmse",
                 filters: Sequence[str] | None = None):
    """(values, filters, points, left out, dropped): ``values`` a blocks x filters array of the
    metric (module docstring: which runs form a block, which filters are compared), the
    compared filters in the array's column order, the points (dicts of folder, swept values,
    particles), the filters left out, and the blocks dropped for a NaN."""
    if metric not in trials.columns:
        raise UserError(f"--metric {metric}: the trials have no such column (they have "
                        f"{', '.join(c for c in trials.columns if c in METRICS)})")
    df, cols = _points(trials)
    at = df.groupby("_point")["_who"].agg(lambda s: frozenset(s))
    if filters:
        want = list(dict.fromkeys(filters))
        known = set(df["_who"])
        unknown = [f for f in want if f not in known]
        if unknown:
            raise UserError(f"--filter {unknown[0]}: no such filter in the trials (they have "
                            f"{', '.join(sorted(known))})")
        points = [p for p, who in at.items() if set(want) <= who]
        if not points:
            raise UserError(f"filters {', '.join(want)}: never ran together at one particle "
                            "count on one trial")
        left = []
    else:
        shared = [p for p, who in at.items() if len(who) >= 2]
        if not shared:
            raise UserError("no two filters ran at the same particle count: nothing to rank")
        common = frozenset.intersection(*(at[p] for p in shared))
        order = list(dict.fromkeys(df["_who"]))
        want = [f for f in order if f in common]
        if len(want) < 2:
            raise UserError("fewer than two filters ran at every particle count (and cell) where "
                            "two or more ran; choose the filters with --filter (they ran: "
                            f"{', '.join(order)})")
        points = [p for p in at.index if p in set(shared)]
        left = [f for f in order if f not in common]
    if len(want) < 2:
        raise UserError("name two filters or more to rank")
    sub = df[df["_point"].isin(points) & df["_who"].isin(want)]
    wide = sub.pivot_table(index=["_point", "trial"], columns="_who", values=metric,
                           aggfunc="first", dropna=False)
    wide = wide.reindex(columns=want)
    before = len(wide)
    wide = wide.dropna()
    if len(wide) == 0:
        raise UserError(f"{metric}: no trial where every compared filter has a value")
    firsts = sub.drop_duplicates("_point").set_index("_point")
    described = []
    for p in sorted(points, key=list(firsts.index).index):
        row = firsts.loc[p]
        described.append({c: _plain(row[c]) for c in cols if not _missing(row[c])})
    return wide.to_numpy(float), want, described, left, before - len(wide)


def _missing(v) -> bool:
    return v is None or (isinstance(v, float) and math.isnan(v))


def _plain(v):
    """A numpy scalar as a Python one (JSON)."""
    return v.item() if hasattr(v, "item") else v


def average_ranks(values: np.ndarray, higher_better: bool = False) -> np.ndarray:
    """The mean over blocks (rows) of each filter's (column's) rank within its block, 1 the
    best, ties sharing the mean of their ranks (scipy.stats.rankdata)."""
    from scipy.stats import rankdata
    return rankdata(-values if higher_better else values, axis=1).mean(axis=0)


def cliques(order: list[str], differs: dict[frozenset, bool]) -> list[list[str]]:
    """The groups a critical-difference diagram joins by a bar: runs of filters consecutive in
    ``order`` (by average rank) no two of which differ (``differs[frozenset({a, b})]``), each as
    long as it can be, none inside another, single filters left out."""
    spans = []
    for i in range(len(order)):
        j = i
        while j + 1 < len(order) and not any(differs[frozenset((order[k], order[j + 1]))]
                                             for k in range(i, j + 1)):
            j += 1
        if j > i and not any(a <= i and j <= b for a, b in spans):
            spans.append((i, j))
    return [order[a:b + 1] for a, b in spans]


def _wilcoxon(d: np.ndarray) -> float:
    """The two-sided p-value of scipy's Wilcoxon signed-rank test on the differences ``d``; 1
    when every difference is zero (no evidence either way)."""
    from scipy.stats import wilcoxon
    if not np.any(d != 0):
        return 1.0
    return float(wilcoxon(d).pvalue)


def rank(trials: pd.DataFrame, metric: str = "rmse", filters: Sequence[str] | None = None,
         alpha: float = ALPHA) -> Ranking:
    """Rank the filters of ``trials`` (pfbench.dataset.load_trials: one folder or many) on
    ``metric``: average ranks, the Friedman test, Wilcoxon signed-rank tests between every two
    filters with Holm's procedure, and the cliques of the critical-difference diagram."""
    from .verdicts import holm_levels
    values, names, points, left, dropped = block_matrix(trials, metric, filters)
    from scipy.stats import friedmanchisquare   # (after block_matrix: nothing to rank, no import)
    hb = metric in HIGHER_IS_BETTER
    avg = average_ranks(values, hb)
    order = sorted(range(len(names)), key=lambda i: (avg[i], i))
    chi2 = p = None
    if len(names) >= 3:
        if len(values) >= 2:
            res = friedmanchisquare(*values.T)
            chi2, p = float(res.statistic), float(res.pvalue)
    raw = []
    for i, j in combinations(order, 2):
        d = values[:, i] - values[:, j]
        better = -d if not hb else d          # > 0: filter i better
        raw.append((i, j, d, int((better > 0).sum()), int((better < 0).sum()), _wilcoxon(d)))
    levels = holm_levels([r[-1] for r in raw], alpha)
    pairs = [Pair(names[i], names[j], len(d), float(np.median(d)), ab, bb, pv, lv,
                  bool(pv <= lv))
             for (i, j, d, ab, bb, pv), lv in zip(raw, levels)]
    ordered = [names[i] for i in order]
    differs = {frozenset((q.a, q.b)): q.differs for q in pairs}
    return Ranking(metric, hb, ordered, {names[i]: float(avg[i]) for i in order}, len(values),
                   points, left, dropped, chi2, p, pairs, cliques(ordered, differs), alpha)


def fmt_p(p: float | None) -> str:
    """A p-value in three significant digits ('< 1e-300' where it underflows)."""
    if p is None or (isinstance(p, float) and math.isnan(p)):
        return "-"
    if p < 1e-300:
        return "< 1e-300"
    return f"{p:.3g}"


def p_is(p: float | None) -> str:
    """'p = 0.012', or 'p < 1e-300'."""
    s = fmt_p(p)
    return f"p {s}" if s.startswith("<") else f"p = {s}"


def _name(metric: str) -> str:
    return metric.upper() if metric in ("rmse", "mse", "nees", "nis") else metric


def point_words(r: Ranking) -> str:
    """The points in words: the particle counts, and how many folders and cells."""
    # filters without particles (a Kalman filter's runs) have no particle count
    ns = sorted({p["particles"] for p in r.points if "particles" in p}, key=float)
    folders = {p.get("folder") for p in r.points}
    cells = {tuple((k, v) for k, v in p.items() if k not in ("folder", "particles"))
             for p in r.points} - {()}
    words = (f"N = {', '.join(str(int(float(n))) for n in ns)}" if ns
             else "filters without particles")
    if len(cells) > 1:
        words += f", {len(cells)} sweep cells"
    if len(folders) > 1:
        words += f", {len(folders)} results folders"
    return words


def head_line(r: Ranking) -> str:
    """What was ranked, in one sentence."""
    better = "highest" if r.higher_better else "lowest"
    return (f"{_name(r.metric)} ranked within each block (one trial at one particle count; "
            f"{point_words(r)}): {len(r.filters)} filters, {r.blocks} blocks"
            + (f" ({r.dropped} dropped for a NaN)" if r.dropped else "")
            + f"; rank 1 the {better}."
            + (f" Left out (not at every particle count compared): {', '.join(r.left_out)}."
               if r.left_out else ""))


def test_lines(r: Ranking) -> list[str]:
    """Friedman's test, and the pairs the Wilcoxon-Holm tests tell apart, in two sentences."""
    if r.friedman is not None:
        first = (f"Friedman test: chi-square {r.friedman:.1f} on {len(r.filters) - 1} degrees "
                 f"of freedom, {p_is(r.friedman_p)}.")
    else:
        first = "Two filters: the Wilcoxon test alone (Friedman's needs three)."
    differ = sum(q.differs for q in r.pairs)
    groups = "; ".join("{" + ", ".join(c) + "}" for c in r.cliques) or "none"
    return [first, f"Wilcoxon signed-rank tests, Holm over {len(r.pairs)} pairs at "
            f"{r.alpha:g}: {differ} pairs differ; groups not told apart: {groups}."]


def summary_lines(r: Ranking) -> list[str]:
    """A ranking in a few Markdown lines: what was compared, the average ranks, Friedman's
    test and the groups no test tells apart (table.md's section)."""
    return ([head_line(r), "", "| Filter | Average rank |", "| --- | --- |"]
            + [f"| {f} | {r.average_ranks[f]:.2f} |" for f in r.filters] + [""]
            + test_lines(r))


def pair_rows(r: Ranking) -> tuple[list[str], list[list[str]]]:
    """The pairwise table: head and rows."""
    head = ["A", "B", "blocks", "median A - B", "A better", "B better", "p (Wilcoxon)",
            "Holm level", "differs"]
    rows = [[q.a, q.b, str(q.n), f"{q.median_diff:.4g}", str(q.a_better), str(q.b_better),
             fmt_p(q.p), f"{q.level:.3g}", "yes" if q.differs else "no"] for q in r.pairs]
    return head, rows


def ranks_filters(exp) -> bool:
    """Whether a run of ``exp`` ranks its filters in table.md ("All filters at once") with the
    tests (which import scipy.stats): two filter runs or more at one particle count (filters
    without particles count as one), on enough blocks for a test to tell two apart
    (``min_blocks``), as its trials and shared particle counts promise."""
    from collections import Counter
    counts = Counter(f.particles for f in exp.filters)
    shared = [c for c in counts.values() if c >= 2]
    return bool(shared) and exp.trials * len(shared) >= min_blocks(max(2, min(shared)))


def min_blocks(filters: int, alpha: float = ALPHA) -> int:
    """The fewest blocks on which Wilcoxon's signed-rank test can tell two of ``filters``
    filters apart under Holm's procedure at ``alpha``: its smallest two-sided p-value on n
    blocks is 2 / 2^n (exact, no ties), and Holm's first level alpha / m, m the pairs."""
    pairs = filters * (filters - 1) // 2
    return max(1, math.ceil(1 + math.log2(pairs / alpha)))


def _too_few(values: np.ndarray, names: list[str], points, left, dropped, metric: str
             ) -> list[str]:
    """table.md's section for blocks too few for any test (``min_blocks``): the average ranks
    (pandas' average ranks of ties), and why no test is run."""
    import pandas as pd
    hb = metric in HIGHER_IS_BETTER
    avg = pd.DataFrame(-values if hb else values).rank(axis=1, method="average").mean()
    order = sorted(range(len(names)), key=lambda i: (avg[i], i))
    r = Ranking(metric, hb, [names[i] for i in order], {names[i]: float(avg[i]) for i in order},
                len(values), points, left, dropped, None, None, [], [], ALPHA)
    need = min_blocks(len(names))
    return ([head_line(r), "", "| Filter | Average rank |", "| --- | --- |"]
            + [f"| {f} | {r.average_ranks[f]:.2f} |" for f in r.filters] + [""]
            + [f"No test: on {len(values)} blocks Wilcoxon's signed-rank test cannot tell two "
               f"of {len(names)} filters apart under Holm's procedure at {ALPHA:g} (its smallest "
               f"p-value, 2 / 2^n, needs {need} blocks); more trials rank them with the tests."])


def markdown_section(rows, metric: str = "rmse") -> list[str]:
    """table.md's section "All filters at once" for a run's trial rows (dicts), or [] when
    fewer than two filters ran at a common particle count or the metric is missing; on blocks
    too few for any test (``min_blocks``), the average ranks alone (no scipy.stats)."""
    import pandas as pd
    df = pd.DataFrame(rows)
    if metric not in df or df[metric].isna().all():
        return []
    df = df.drop(columns=["wall_s"], errors="ignore")
    try:
        values, names, points, left, dropped = block_matrix(df, metric)
        if len(values) < min_blocks(len(names)):
            body = _too_few(values, names, points, left, dropped, metric)
        else:
            body = summary_lines(rank(df, metric))
    except UserError:
        return []
    return (["", "## All filters at once", ""] + body
            + ["", "`pfbench rank FOLDER` prints every pair and draws the critical-difference "
               "diagram."])


def draw_cd(r: Ranking, path: Path, title: str | None = None) -> Path:
    """The critical-difference diagram of a ranking (Demsar 2006): the average ranks on an
    axis (1, the best, on the left), each filter's name led to its rank, and a bar under the
    axis joining each group of filters no test tells apart (r.cliques). Returns the path."""
    plt = pyplot()
    k = len(r.filters)
    half = (k + 1) // 2
    rows = max(half, k - half)
    with style():
        fig, ax = plt.subplots(figsize=(8.0, 1.6 + 0.32 * rows + 0.18 * len(r.cliques)))
        lo, hi = 1, max(k, 2)
        ax.set_xlim(lo - 0.6 - 0.35 * (hi - lo), hi + 0.6 + 0.35 * (hi - lo))
        top = 0.0
        ax.plot([lo, hi], [top, top], color="black", lw=1.2)
        for t in range(lo, hi + 1):
            ax.plot([t, t], [top, top + 0.12], color="black", lw=1.0)
            ax.text(t, top + 0.2, str(t), ha="center", va="bottom", fontsize=10)
        left_x = lo - 0.35 * (hi - lo) - 0.2
        right_x = hi + 0.35 * (hi - lo) + 0.2
        for i, f in enumerate(r.filters):
            x = r.average_ranks[f]
            if i < half:
                y = -(0.55 + 0.32 * i + 0.18 * len(r.cliques))
                ax.plot([x, x, left_x], [top, y, y], color="0.25", lw=0.9)
                ax.text(left_x - 0.05, y, f"{f}  {x:.2f}", ha="right", va="center", fontsize=10)
            else:
                y = -(0.55 + 0.32 * (k - 1 - i) + 0.18 * len(r.cliques))
                ax.plot([x, x, right_x], [top, y, y], color="0.25", lw=0.9)
                ax.text(right_x + 0.05, y, f"{x:.2f}  {f}", ha="left", va="center",
                        fontsize=10)
        for c, members in enumerate(r.cliques):
            xs = [r.average_ranks[f] for f in members]
            y = -(0.2 + 0.18 * c)
            ax.plot([min(xs) - 0.06, max(xs) + 0.06], [y, y], color="black", lw=3.5,
                    solid_capstyle="butt")
        ax.set_ylim(-(0.75 + 0.32 * rows + 0.18 * len(r.cliques)), 0.55)
        ax.axis("off")
        friedman = (f"Friedman {p_is(r.friedman_p)}" if r.friedman is not None
                    else "two filters")
        ax.set_title(title or f"{_name(r.metric)}: average rank over {r.blocks} blocks, 1 the "
                     f"best ({friedman})\nbars join filters not told apart (Wilcoxon "
                     f"signed-rank, Holm at {r.alpha:g})", fontsize=10, loc="left")
        return save(fig, Path(path))
