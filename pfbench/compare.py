"""Trials -> the comparison with a paper: statistics of every filter run over the trials, the
paper's values beside ours with verdicts, the factors between rows, the per-run table and the
rankings. Numbers only: pfbench.tables renders a comparison (console, table.md), pfbench.report
puts it in the report.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field, replace

import numpy as np
import pandas as pd

from .config import Experiment
from .metrics import chi2_mean_bounds, paired, summarize
from .papers import Quantity, Table
from .verdicts import ALPHA, MIN_TRIALS, Claim, Estimate, decide_family

# Per-trial metrics summarised as their mean over trials in every table.
MEAN_COLUMNS = ("mean_ess", "resample_count", "diversity_l1", "distinct_frac",
                "lik_evals_per_step")


@dataclass(frozen=True)
class Pair:
    """Two rows the paper orders (``low`` below ``high`` in its table) and what our paired trials
    say: the mean per-trial difference low - high with its interval at ``level`` (the level
    Holm's procedure tested it at, across the pairs of the table), and 'same' (resolved: the
    interval lies below zero), 'opposite' (resolved: above zero) or 'unresolved' (it holds
    zero, or no paired per-trial values exist)."""
    low: str
    high: str
    diff: float
    lo: float
    hi: float
    status: str
    level: float = 1 - ALPHA


@dataclass(frozen=True)
class Ranking:
    """The order of a paper's rows by a quantity at one particle count, the paper's and ours
    (point estimates), and each pair of rows judged on paired trials."""
    quantity: Quantity
    particles: int | None
    paper: list[str]
    ours: list[str]
    pairs: tuple[Pair, ...] = ()

    @property
    def same(self) -> bool:
        return self.paper == self.ours


def pair_counts(rankings: list[Ranking]) -> dict[str, int]:
    """Over every pair of every ranking: how many are resolved in the paper's order ('same'),
    against it ('opposite'), and unresolved."""
    pairs = [p for r in rankings for p in r.pairs]
    return {k: sum(p.status == k for p in pairs) for k in ("same", "opposite", "unresolved")}


@dataclass(frozen=True)
class PerTrialRow:
    """One row of a per-run table: the paper's runs, or our first trials, with the mean (and,
    for ours, its 95% interval over all trials)."""
    what: str
    values: np.ndarray
    mean: float
    lo: float | None = None
    hi: float | None = None


@dataclass(frozen=True)
class PerTrial:
    """A paper's table of single runs (runs as columns) beside our first trials."""
    title: str
    runs: int
    rows: list[PerTrialRow]


@dataclass
class Comparison:
    """What an experiment's trials say, beside its paper's table where it has one.

    table : one row per filter run: statistics over trials (rmse_mean, rmse_se, rmse_ci_lo,
        ...; every mean over trials M with its Monte Carlo standard error M_se), the NEES and
        NIS where the trials have them (nees_mean, nees_se, nees_bound_lo, nees_bound_hi,
        nees_check: ``consistency``), the paired difference to the baseline run, and per
        reported quantity Q: ours_Q, its standard error ours_se_Q, its interval ours_lo_Q /
        ours_hi_Q, the trials it averages n_Q (fewer than all for a metric
        defined only on some, such as the convergence step), paper_Q, ratio_Q, verdict_Q (the
        text), kind_Q (reproduced, differs, inconclusive, not comparable, or '' without a paper
        value), the interval the verdict used verdict_lo_Q / verdict_hi_Q at verdict_level_Q,
        for a quantity judged on another measure (``judged_by``) that measure's value judged_Q
        and 95% interval judged_lo_Q / judged_hi_Q (the verdict sits beside them, never beside
        ours_Q),
        how the intervals are made method_Q (verdicts.METHODS), and for an inconclusive cell
        the trials that would likely decide it needed_Q (NaN: none would)
    factors : the paper's factors between two of its rows beside ours (dicts)
    per_trial : the paper's per-run table beside our first trials, or None
    rankings : the paper's orders of its rows beside ours
    """
    exp: Experiment
    table: pd.DataFrame
    factors: list[dict] = field(default_factory=list)
    per_trial: PerTrial | None = None
    rankings: list[Ranking] = field(default_factory=list)
    anytime: int | None = None      # verdicts on confidence sequences tuned for that many trials
    # per column n_Q of a quantity measured in run time: each row's trials it is taken over (the
    # trials paired with a baseline run), which the trials file alone determines
    untimed_n: dict = field(default_factory=dict)
    # what pfbench run prints of it (pfbench.tables.console_parts), once computed
    _console: dict | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def reported(self) -> Table | None:
        """The paper's table this experiment compares with (None: no paper)."""
        return self.exp.reported

    def kinds(self) -> list[str]:
        """The kind of every judged or compared value: each cell of the paper's table with a
        verdict, then each factor ('reproduced', 'differs', 'inconclusive', 'not comparable')."""
        table = self.reported
        out = [k for q in (table.quantities if table is not None else ())
               if f"kind_{q.key}" in self.table for k in self.table[f"kind_{q.key}"]]
        out += [f["kind"] for f in self.factors]
        return [k for k in out if isinstance(k, str) and k]

    @property
    def timed(self) -> bool:
        """Whether the table holds run times (the trials came with their timings)."""
        return bool(len(self.table)) and bool(self.table["wall_ms_per_trial"].notna().any())

    def without_timings(self) -> "Comparison":
        """The comparison with what the machine determines left out (the run times, and our
        value of a quantity measured in run time, such as time over the PF): what a results
        folder commits, the same on any machine. A verdict on run time is judged on a
        deterministic measure (``judged_by``) or not judged at all, so no verdict changes. The
        count n_Q of such a quantity is the trials it is taken over (those paired with the
        baseline run), the same with or without the timings file."""
        tab = self.table.copy()
        tab["wall_ms_per_trial"] = math.nan
        if "wall_ms_per_trial_se" in tab:
            tab["wall_ms_per_trial_se"] = math.nan
        for q in (self.reported.quantities if self.reported is not None else ()):
            if q.metric in MACHINE_METRICS:
                for c in ("ours", "ours_se", "ours_lo", "ours_hi", "ratio"):
                    if f"{c}_{q.key}" in tab:
                        tab[f"{c}_{q.key}"] = math.nan
                if f"n_{q.key}" in self.untimed_n and f"n_{q.key}" in tab:
                    tab[f"n_{q.key}"] = self.untimed_n[f"n_{q.key}"]
        # an order by run time is the machine's too (its pairs are never judged: no verdict goes)
        ranked = [r for r in self.rankings if r.quantity.metric not in MACHINE_METRICS]
        return replace(self, table=tab, rankings=ranked)


# metrics that are rates (a fraction of trials): Wilson intervals, never outside [0, 1]
RATE_METRICS = ("converged",)
# counts and step counts, skewed and bounded below: BCa bootstrap intervals
SKEWED_METRICS = ("recovery_failures", "recovery_steps", "converge_step")
# quantities that depend on the machine that ran them: shown, never judged
MACHINE_METRICS = ("time_ratio",)
# the figures of those (pfbench.plots: a family 'time_...'), drawn only where a timings file gives
# the run times: never part of the committed results, nor of a report made of them
MACHINE_FIGURE_PREFIX = "time_"
BOOTSTRAP_RESAMPLES = 9999
BOOTSTRAP_MIN = MIN_TRIALS["bca"]     # the trials a bootstrap interval needs


def machine_figure(name: str) -> bool:
    """Whether the figure file ``name`` shows what the machine measured (MACHINE_FIGURE_PREFIX)."""
    return name.startswith(MACHINE_FIGURE_PREFIX)


def interval_method(q: Quantity) -> str:
    """How quantity q's intervals are made (verdicts.METHODS): Wilson's for a rate, the BCa
    bootstrap for a gain, a variance or a skewed count, Student's t otherwise."""
    if q.metric in RATE_METRICS and q.stat == "mean":
        return "wilson"
    if q.metric in ("gain_mean", "gain_var") or q.stat == "var" or q.metric in SKEWED_METRICS:
        return "bca"
    return "t"


def _bootstrap(samples: tuple, statistic, value: float, seed: int, key: str) -> Estimate:
    """A BCa bootstrap estimate of statistic(*samples) (paired by trial when there are two
    samples; vectorised over the last axis), its value ``value``; seeded by the experiment's
    seed and ``key`` (pfbench.seeding.keyed_seed), so the same trials give the same interval.
    Trials that all give the same value: an interval of width 0. Fewer than BOOTSTRAP_MIN
    trials that differ: no interval (a standard error of NaN), for two values have no spread a
    bootstrap could resample, and Student's t on them would pretend to know the statistic's
    spread (of a variance of two trials, say: its two terms are always equal)."""
    samples = tuple(np.asarray(x, dtype=float) for x in samples)
    ok = np.logical_and.reduce([~np.isnan(x) for x in samples])
    samples = tuple(x[ok] for x in samples)
    n = int(ok.sum())
    if n < 2:
        return Estimate(value, math.nan, n, "bca")
    with np.errstate(invalid="ignore", over="ignore"):     # inf - inf: a diverged trial
        flat = [np.ptp(x) == 0 for x in samples]
    if all(flat):
        return Estimate(value, 0.0, n)
    if n < BOOTSTRAP_MIN:
        return Estimate(value, math.nan, n, "bca")
    from scipy import stats         # here, not at import: a run's first trial need not wait for it
    from .seeding import keyed_seed
    rng = np.random.default_rng(keyed_seed(seed, key))
    kw = dict(paired=len(samples) > 1, vectorized=True, method="BCa")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")     # a degenerate jackknife gives NaN: handled below
        res = stats.bootstrap(samples, statistic, n_resamples=BOOTSTRAP_RESAMPLES,
                              random_state=rng, **kw)
    if not np.isfinite(res.standard_error):
        return Estimate(value, math.nan, n)
    cache: dict[float, tuple[float, float]] = {}

    def bounds(level: float) -> tuple[float, float]:
        if level not in cache:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ci = stats.bootstrap(samples, statistic, n_resamples=0, bootstrap_result=res,
                                     confidence_level=min(level, 1.0 - 1e-12),
                                     **kw).confidence_interval
            cache[level] = (float(ci.low), float(ci.high))
        return cache[level]

    lo, hi = bounds(1 - ALPHA)
    if math.isnan(lo) or math.isnan(hi):
        return Estimate(value, float(res.standard_error), n)
    return Estimate(value, float(res.standard_error), n, "bca", bounds)


def _mean(x, axis=-1):
    return np.mean(x, axis=axis)


def _ratio(a, b) -> float:
    """a / b as numpy divides: an infinity or NaN for b = 0 (a baseline of zero error, a paper
    value of zero), never a ZeroDivisionError."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return float(np.float64(a) / np.float64(b))


def _var(x, axis=-1):
    return np.var(x, axis=axis, ddof=1)


def _gain_mean(a, b, axis=-1):
    return 100.0 * (1.0 - np.mean(a, axis=axis) / np.mean(b, axis=axis))


def _gain_var(a, b, axis=-1):
    return 100.0 * (1.0 - np.var(a, axis=axis, ddof=1) / np.var(b, axis=axis, ddof=1))


def _ratio_of_means(a, b, axis=-1):
    return np.mean(b, axis=axis) / np.mean(a, axis=axis)


class _Columns:
    """A trials frame's columns as numpy arrays, each converted the first time it is read (a
    numeric column of a nullable dtype as floats, NaN for its missing values)."""

    def __init__(self, frame: pd.DataFrame):
        self._frame = frame
        self._got: dict = {}

    def __contains__(self, column) -> bool:
        return column in self._frame

    def __len__(self) -> int:
        return len(self._frame)

    def __getitem__(self, column) -> np.ndarray:
        v = self._got.get(column)
        if v is None:
            col = self._frame[column]
            if isinstance(col.dtype, pd.api.extensions.ExtensionDtype) \
                    and pd.api.types.is_numeric_dtype(col.dtype):
                v = col.to_numpy(dtype=float, na_value=math.nan)
            else:
                v = col.to_numpy()
            self._got[column] = v
        return v


class RunTrials:
    """One filter run's trials, each column a numpy array in the order of the run's rows: what
    a comparison reads of them per cell, in microseconds where a pandas selection, index and
    reindex took a millisecond (the same values, so the same bits).

    ``columns``: the trials frame's (_Columns); ``rows``: the positions of the run's rows in it
    (None: every row)."""

    def __init__(self, columns: _Columns, rows: np.ndarray | None = None):
        self._columns = columns
        self._rows = rows
        self._got: dict = {}

    @classmethod
    def of(cls, trials) -> "RunTrials":
        """``trials`` (a run's trials frame, or already a RunTrials) as a RunTrials."""
        return trials if isinstance(trials, RunTrials) else cls(_Columns(trials))

    def __contains__(self, column) -> bool:
        return column in self._columns

    def __len__(self) -> int:
        return len(self._columns) if self._rows is None else len(self._rows)

    def __getitem__(self, column) -> np.ndarray:
        v = self._got.get(column)
        if v is None:
            v = self._columns[column]
            if self._rows is not None:
                v = v[self._rows]
            self._got[column] = v
        return v

    def at_trials_of(self, other: "RunTrials", column) -> np.ndarray:
        """This run's ``column`` at each of ``other``'s trials, in other's order, as floats: NaN
        where this run has no such trial (pandas' reindex by trial)."""
        mine, wanted = self["trial"], other["trial"]
        values = np.asarray(self[column], dtype=float)
        out = np.full(len(wanted), math.nan)
        if len(mine) == 0 or len(wanted) == 0:
            return out
        order = np.argsort(mine, kind="stable")
        at = np.minimum(np.searchsorted(mine[order], wanted), len(mine) - 1)
        found = mine[order][at] == wanted
        out[found] = values[order[at[found]]]
        return out


def _skipna_sum(v):
    """The sum of ``v`` without its NaN, as pandas' Series.sum adds (NaN as 0: the same bits)."""
    v = np.asarray(v)
    if v.dtype.kind == "f":
        nan = np.isnan(v)
        if nan.any():
            v = np.where(nan, 0.0, v)
    return v.sum()


def _skipna_mean(v) -> float:
    """The mean of ``v`` without its NaN, as pandas' Series.mean computes it (the sum with NaN
    as 0, over the count of the others: the same bits); NaN when every value is."""
    v = np.asarray(v, dtype=float)
    count = v.size - int(np.isnan(v).sum())
    return float(_skipna_sum(v) / np.float64(count)) if count > 0 else math.nan


def estimate(q: Quantity, g, base, seed: int = 0, key: str = "") -> Estimate:
    """Our estimate of quantity q for one filter run (g: its trials, a frame or a RunTrials;
    base: its baseline run's trials, or None): the value, its standard error, the trials, and
    its intervals (interval_method; a bootstrap is seeded by ``seed`` and ``key``)."""
    nan = Estimate(math.nan, math.nan, 0)
    method = interval_method(q)
    g = RunTrials.of(g)
    if q.metric in ("gain_mean", "gain_var"):
        if base is None:
            return nan
        a = g["rmse"]
        b = RunTrials.of(base).at_trials_of(g, "rmse")
        if q.metric == "gain_mean":         # 100 (1 - mean_a / mean_b), paired by trial
            d = summarize(a - b)
            value = -100 * _ratio(d["mean"], _skipna_mean(b))
            return _bootstrap((a, b), _gain_mean, value, seed, key)
        sa, sb = summarize(a), summarize(b)    # 100 (1 - var_a / var_b)
        value = 100 * (1 - _ratio(sa["var"], sb["var"]))
        return _bootstrap((a, b), _gain_var, value, seed, key)
    values = _metric_values(q.metric, g, base) * q.scale
    s = summarize(values)
    if q.stat == "var":
        return _bootstrap((values,), _var, s["var"], seed, key)
    if method == "bca":
        return _bootstrap((values,), _mean, s["mean"], seed, key)
    if method == "wilson" and s["n"] > 0:
        hits = g[q.metric]
        k = int(round(float(hits[~pd.isna(hits)].sum())))
        n, scale = s["n"], q.scale

        def wilson(level: float) -> tuple[float, float]:
            from scipy import stats
            ci = stats.binomtest(k, n).proportion_ci(min(level, 1.0 - 1e-12), method="wilson")
            return ci.low * scale, ci.high * scale
        return Estimate(s["mean"], s["se"], n, "wilson", wilson)
    return Estimate(s["mean"], s["se"], s["n"])


def _metric_values(metric: str, g, base) -> np.ndarray:
    """Per-trial values of ``metric`` for one filter run (g, and its baseline run's trials base:
    frames or RunTrials); 'time_ratio' is the wall time over the baseline run's on the same
    trial, 'evals_ratio' the likelihood evaluations per step over the baseline's (NaN without a
    baseline)."""
    g = RunTrials.of(g)
    ratio_of = {"time_ratio": "wall_s", "evals_ratio": "lik_evals_per_step"}.get(metric)
    if ratio_of is None:
        return g[metric]
    if base is None or ratio_of not in g or ratio_of not in base:
        return np.full(len(g), math.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        return g[ratio_of] / RunTrials.of(base).at_trials_of(g, ratio_of)


def _pair_estimate(q: Quantity, a, b) -> Estimate | None:
    """The mean paired per-trial difference of q's metric between two rows' trials (a - b,
    frames or RunTrials), or None (a variance, a gain or a ratio has no per-trial values)."""
    if a is None or b is None or q.stat != "mean" or q.metric not in a:
        return None
    a, b = RunTrials.of(a), RunTrials.of(b)
    x = np.asarray(a[q.metric] * q.scale, dtype=float)
    y = b.at_trials_of(a, q.metric) * q.scale
    ok = ~(np.isnan(x) | np.isnan(y))
    s = summarize(x[ok] - y[ok])
    return Estimate(s["mean"], s["se"], s["n"])


def rankings(exp: Experiment, tab: pd.DataFrame, by_key: dict | None = None,
             anytime: int | None = None) -> list[Ranking]:
    """For a table whose paper claims an order of its rows: per ranked quantity and particle count
    with two or more rows, the paper's order and ours (``tab``: a comparison's table), and every
    pair of rows the paper orders judged on paired trials (``by_key``: each filter run's trials;
    without them every pair is unresolved), Holm-adjusted across all the table's pairs
    (``anytime``: with confidence sequences tuned for that many trials)."""
    table = exp.reported
    if table is None or table.ranking is None:
        return []
    keys = table.ranking
    found = []
    rows = list(zip(tab["label"].tolist(), tab["particles"].tolist()))
    filters = tab["filter"].tolist() if "filter" in tab else None
    counts = sorted({n for (_, n) in table.values}, key=lambda v: (v is None, v or 0))
    for q in (q for key in keys for q in table.quantities if q.key == key):
        for n in counts:
            labels = [lab for (lab, m) in table.values
                      if m == n and q.key in table.values[(lab, m)]]
            ours, runs = {}, {}
            values = tab[f"ours_{q.key}"].tolist()
            for lab in labels:
                # a paper that gives no particle count (n None) is matched by label alone
                i = next((i for i, (tl, tn) in enumerate(rows)
                          if tl == lab and (n is None or tn == n)), None)
                if i is not None:
                    ours[lab] = float(values[i])
                    if by_key is not None and filters is not None:
                        runs[lab] = by_key.get(filters[i])
            if len(ours) < 2:
                continue
            paper_value = {lab: table.values[(lab, n)][q.key] for lab in ours}
            paper_order = sorted(ours, key=lambda lab: paper_value[lab])
            our_order = sorted(ours, key=lambda lab: ours[lab])
            pairs = [(low, high, _pair_estimate(q, runs.get(low), runs.get(high)))
                     for i, low in enumerate(paper_order) for high in paper_order[i + 1:]
                     if paper_value[low] != paper_value[high]]
            found.append((q, n, paper_order, our_order, pairs))
    claims = [Claim(0.0, est.anytime(anytime) if anytime else est)
              for (_, _, _, _, pairs) in found for (_, _, est) in pairs if est is not None]
    verdicts = iter(decide_family(claims))
    out = []
    for q, n, paper_order, our_order, pairs in found:
        judged = []
        for low, high, est in pairs:
            if est is None:
                judged.append(Pair(low, high, math.nan, math.nan, math.nan, "unresolved"))
                continue
            v = next(verdicts)
            status = ("unresolved" if v.kind != "differs" else
                      "same" if v.hi < 0 else "opposite")
            judged.append(Pair(low, high, est.value, v.lo, v.hi, status, v.level))
        out.append(Ranking(q, n, paper_order, our_order, tuple(judged)))
    return out


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


def compare(exp: Experiment, rows: list[dict] | pd.DataFrame,
            anytime: int | None = None) -> Comparison:
    """The comparison of an experiment's trials (rows of a trials file) with its paper. The
    cells of the paper's table (with its factors) are judged together, Holm-adjusted; with
    ``anytime`` (the most trials a run until decided may reach), every verdict uses confidence
    sequences tuned for that many trials, valid however often the trials were looked at.
    Rows with ``wall_s`` (their timings) give the run times; without, those are NaN."""
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    if "wall_s" in df:          # the run times, where the trials came with them (NaN elsewhere)
        df = df.assign(wall_s=pd.to_numeric(df["wall_s"], errors="coerce"))
    table: Table | None = exp.reported
    columns = _Columns(df)
    run_of_row = columns["filter"]
    by_key = {f.key: RunTrials(columns, np.flatnonzero(run_of_row == f.key))
              for f in exp.filters}
    floor = None
    if exp.compare["floor"] is not None:
        floor = summarize(by_key[exp.compare["floor"]]["rmse"])["ci_lo"]
    pairs = baseline_runs(exp)
    steps = steps_of(exp)
    out, cells = [], []         # cells: (row, quantity, claim, the estimate judged)
    untimed: dict[str, list[int]] = {}      # Comparison.untimed_n
    for run in exp.filters:
        g = by_key[run.key]
        r = _summary_row(run, g, by_key, pairs, steps)
        if table is not None:
            base = by_key.get(pairs.get(run.key))
            for q in table.quantities:
                judge, claim = _paper_cell(exp, table, run, q, r, g, base, floor, anytime,
                                           untimed)
                cells.append((r, q, claim, judge))
        out.append(r)
    found = factor_claims(exp, table, by_key, anytime) if table is not None else []
    verdicts = decide_family([c for (_, _, c, _) in cells] + [c for (_, c) in found])
    for (r, q, _, judge), v in zip(cells, verdicts):
        _put_verdict(r, q, judge, v)
    facts = [{**row, "verdict": v.text, "kind": v.kind, "needed": v.needed}
             for (row, _), v in zip(found, verdicts[len(cells):])]
    tab = pd.DataFrame(out)
    if table is None:
        return Comparison(exp, tab, anytime=anytime)
    return Comparison(exp, tab, facts, per_trial(exp, table, by_key),
                      rankings(exp, tab, by_key, anytime), anytime, untimed)


def _summary_row(run, g: RunTrials, by_key: dict, pairs: dict, steps=None) -> dict:
    """A filter run's row of the comparison before the paper's cells: its metrics' means with
    their Monte Carlo standard errors and intervals, counters, time a trial, the paired
    difference to its baseline run, and (where the trials have them) the NEES and NIS with their
    chi-square bounds (``steps``: the steps each trial averages, for the bounds)."""
    r = {"filter": run.key, "label": run.label, "particles": run.particles, "trials": len(g)}
    for metric in ("rmse", "mse"):
        s = summarize(g[metric])
        r.update({f"{metric}_{k}": s[k] for k in ("mean", "se", "ci_lo", "ci_hi", "var",
                                                   "var_ci_lo", "var_ci_hi")})
    for metric in MEAN_COLUMNS:     # NaN where the scenario's kind has no such column
        s = summarize(g[metric]) if metric in g else {"mean": math.nan, "se": math.nan}
        r[metric], r[f"{metric}_se"] = s["mean"], s["se"]
    for metric in CONSISTENCY_METRICS:      # only where the trials file has the column
        if metric in g:
            r.update(consistency(g[metric], steps, metric))
    r["underflow_steps"] = float(_skipna_sum(g["underflow_steps"]))
    dv = g["diverged_steps"] if "diverged_steps" in g else np.empty(0)
    r["diverged_steps"] = float(_skipna_sum(dv))
    r["diverged_trials"] = float((dv > 0).sum())
    wall = np.asarray(g["wall_s"], dtype=float) if "wall_s" in g else np.empty(0)
    timed = bool((~np.isnan(wall)).any())
    r["wall_ms_per_trial"] = 1e3 * _skipna_mean(wall) if timed else math.nan
    r["wall_ms_per_trial_se"] = 1e3 * summarize(wall)["se"] if timed else math.nan
    r["baseline"] = pairs.get(run.key)
    if run.key in pairs:
        b = by_key[pairs[run.key]].at_trials_of(g, "rmse")
        r.update({f"rmse_{k}": v for k, v in paired(g["rmse"], b).items()})
    else:
        r.update(rmse_diff_mean=math.nan, rmse_diff_se=math.nan, rmse_diff_ci_lo=math.nan,
                 rmse_diff_ci_hi=math.nan, rmse_win_rate=math.nan)
    return r


# The consistency metrics (pfbench.metrics), in a table where the trials have them: the mean
# over trials with its standard error, the two-sided 95% chi-square bounds of the mean of that
# many squares of standard normals, and where the mean lies against them.
CONSISTENCY_METRICS = ("nees", "nis")
CONSISTENCY_COLUMNS = ("mean", "se", "bound_lo", "bound_hi", "check")


def consistency(values, steps, metric: str = "nees") -> dict:
    """A filter run's NEES (or NIS) over trials: ``values`` each trial's mean over its ``steps``
    steps (None: unknown, no bounds). The mean over steps and trials of K = steps x trials
    squares of standard normals, divided by K, lies within [chi2_K(0.025) / K, chi2_K(0.975) / K]
    with probability 95% for a consistent filter; the check says 'consistent' within them,
    'overconfident' above (the filter's variances too small for its errors), 'underconfident'
    below, '' without a value. (NaN trials are left out; a trial whose value is not finite makes
    the mean so, and the check 'overconfident'.)"""
    s = summarize(values)
    out = {f"{metric}_mean": s["mean"], f"{metric}_se": s["se"], f"{metric}_bound_lo": math.nan,
           f"{metric}_bound_hi": math.nan, f"{metric}_check": ""}
    if s["n"] == 0 or not steps:
        return out
    lo, hi = chi2_mean_bounds(int(s["n"]) * int(steps))
    m = s["mean"]
    out.update({f"{metric}_bound_lo": lo, f"{metric}_bound_hi": hi,
                f"{metric}_check": ("consistent" if lo <= m <= hi else
                                    "underconfident" if m < lo else "overconfident")})
    return out


def steps_of(exp: Experiment):
    """The steps a trial of ``exp`` scores (its scenario's ``steps``; None when it has none)."""
    v = exp.scenario_params.get("steps") if hasattr(exp.scenario_params, "get") else None
    return int(v) if isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0 \
        else None


def _paper_cell(exp: Experiment, table: Table, run, q: Quantity, r: dict, g: RunTrials,
                base: RunTrials | None, floor, anytime: int | None,
                untimed: dict) -> tuple:
    """The cell of quantity q in run's row r: our value, its interval and the paper's (into r);
    returns the estimate judged and the claim to judge it by."""
    paper = table.row(run.label, run.particles).get(q.key)
    est = estimate(q, g, base, exp.seed, f"{run.key}:{q.key}")
    ours = est.value
    r[f"ours_{q.key}"] = ours
    r[f"ours_se_{q.key}"] = est.se     # its Monte Carlo standard error (a bootstrap's, for BCa)
    # the 95% interval printed beside our value, by the estimate's own method
    r[f"ours_lo_{q.key}"], r[f"ours_hi_{q.key}"] = est.interval(1 - ALPHA)
    r[f"n_{q.key}"] = est.n         # the trials it averages (a conditional metric:
                                    # those where it is defined)
    if q.metric in MACHINE_METRICS:
        paired_n = 0 if base is None else int(np.isin(g["trial"], base["trial"]).sum())
        untimed.setdefault(f"n_{q.key}", []).append(paired_n)
    r[f"method_{q.key}"] = est.method
    if isinstance(paper, tuple):      # a range: shown as such, ratio to its middle
        r[f"paper_{q.key}"] = f"{paper[0]:g}-{paper[1]:g}"
        r[f"ratio_{q.key}"] = _ratio(ours, 0.5 * (paper[0] + paper[1]))
    else:
        r[f"paper_{q.key}"] = paper
        r[f"ratio_{q.key}"] = _ratio(ours, paper) if paper else math.nan
    floored_q = q.metric == "rmse" and q.stat == "mean"  # the floor is an RMSE level
    judge = est
    if q.judged_by is not None:     # a deterministic measure of the same thing
        judge = estimate(replace(q, metric=q.judged_by), g, base, exp.seed,
                         f"{run.key}:{q.key}:{q.judged_by}")
    if anytime:
        judge = judge.anytime(anytime)
    claim = Claim(paper, judge, q.margin, table.runs,
                  floor if floored_q and run.key != exp.compare["floor"] else None,
                  (table.cell_notes.get((run.label, run.particles, q.key))
                   or q.not_comparable or table.not_comparable),
                  q.judged_by is not None or q.metric not in MACHINE_METRICS)
    return judge, claim


def _put_verdict(r: dict, q: Quantity, judge, v) -> None:
    """The verdict v on quantity q's cell, into its row r."""
    text = v.text
    if q.judged_by is not None and v.kind in ("reproduced", "differs", "inconclusive"):
        text = f"{text}, judged on {q.judged_by.replace('_', ' ')} {judge.value:.3g}"
    r[f"verdict_{q.key}"] = text
    r[f"kind_{q.key}"] = v.kind
    if q.judged_by is not None:     # the measure judged, shown beside its verdict
        r[f"judged_{q.key}"] = judge.value
        r[f"judged_lo_{q.key}"], r[f"judged_hi_{q.key}"] = judge.interval(1 - ALPHA)
    r[f"verdict_lo_{q.key}"], r[f"verdict_hi_{q.key}"] = v.lo, v.hi
    r[f"verdict_level_{q.key}"] = v.level
    r[f"needed_{q.key}"] = v.needed if v.needed is not None else math.nan


def _run_by_label(exp: Experiment, label: str):
    return next((f for f in exp.filters if f.label == label), None)


def factor_claims(exp: Experiment, table: Table, by_key: dict,
                  anytime: int | None = None) -> list[tuple[dict, Claim]]:
    """The paper's factors between two of its rows for a quantity (e.g. AFSA's error over PSO's),
    each as (what it is, the claim to judge): ours is the ratio of the means over paired trials,
    with its 95% BCa bootstrap interval (paired by trial) as printed; the claim judges it on
    that bootstrap, or (``anytime``) on a confidence sequence."""
    found = []
    for key, a_label, b_label, margin in table.factors:
        q = next(q for q in table.quantities if q.key == key)
        a_run, b_run = _run_by_label(exp, a_label), _run_by_label(exp, b_label)
        if a_run is None or b_run is None:
            continue
        pa = table.values.get((a_label, a_run.particles), {}).get(key)
        pb = table.values.get((b_label, b_run.particles), {}).get(key)
        a_trials = RunTrials.of(by_key[a_run.key])
        a = np.asarray(a_trials[q.metric], dtype=float)
        b = RunTrials.of(by_key[b_run.key]).at_trials_of(a_trials, q.metric)
        ok = ~(np.isnan(a) | np.isnan(b))
        a, b = a[ok], b[ok]
        if a.size < 2 or a.mean() == 0:
            continue
        est = _bootstrap((a, b), _ratio_of_means, b.mean() / a.mean(), exp.seed,
                         f"factor:{key}:{a_label}:{b_label}")
        lo, hi = est.interval(1 - ALPHA)
        paper = pb / pa if pa and pb is not None else math.nan
        found.append(({"quantity": q.title, "from": a_label, "to": b_label, "paper_from": pa,
                       "paper_to": pb, "paper": paper, "ours": est.value, "lo": lo, "hi": hi,
                       "method": est.method},
                      Claim(paper, est.anytime(anytime) if anytime else est, margin)))
    return found


def per_trial(exp: Experiment, table: Table, by_key: dict) -> PerTrial | None:
    """The paper's per-run table beside our first trials (and our mean over all)."""
    spec = table.per_trial
    if spec is None:
        return None
    rows = []
    for name, label, vals in spec.rows:
        run = _run_by_label(exp, label)
        rows.append(PerTrialRow(f"paper: {name}", np.asarray(vals, dtype=float),
                                float(np.mean(vals))))
        if run is None:
            continue
        g = RunTrials.of(by_key[run.key])
        order = np.argsort(g["trial"], kind="stable")
        for metric in (spec.metric, *spec.also):
            v = np.asarray(g[metric], dtype=float)[order]
            s = summarize(v)
            what = f"ours: {label}" + ("" if metric == spec.metric else f", {metric}")
            rows.append(PerTrialRow(what, v[:spec.runs], s["mean"], s["ci_lo"], s["ci_hi"]))
    return PerTrial(spec.title, spec.runs, rows)
