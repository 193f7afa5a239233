"""Verdicts: what our trials say of one value a paper prints, in one vocabulary.

For a paper value p, our estimate m over n trials, and (where the paper states it) the r runs
behind p, whose own sampling error adds to ours (an interval's half-widths grow by
sqrt(1 + n / r): se_w = sqrt(se^2 + se_b^2) with se_b = se sqrt(n / r)):

- **reproduced**: equivalence shown by two one-sided tests at level a: the (1 - 2a) interval of
  m - p lies inside the quantity's declared margin [-delta, +delta] (a paper file declares each
  margin with its reason);
- **differs**: otherwise, when p lies outside our (widened) (1 - a) interval;
- **inconclusive**: neither, with the number of trials that would likely decide it (keeping the
  spread and the difference seen so far), or why no number of trials can; or too few trials
  for the quantity's interval (MIN_TRIALS: two, three for a bootstrap);
- **not comparable** (with the reason), and ``; paper below the model's floor`` after a
  'differs' whose paper value lies under what a near-optimal filter reaches.

One cell alone is judged at a = ALPHA. The cells of one table are judged together
(``decide_family``): each kind of claim ('reproduced', 'differs') is a family of tests whose
p-values Holm's step-down procedure adjusts (holm_levels), so that the chance of any false
'reproduced', or of any false 'differs', in a table stays at most ALPHA however many cells it
has. A cell's intervals are printed at the level Holm's procedure tested it at.

A paper's range [a, b] is reproduced when our equivalence interval lies inside
[a - delta, b + delta], differs when our interval misses the range, inconclusive otherwise.

Intervals (``Estimate.method``): Student's t with n - 1 degrees of freedom (scipy.special); Wilson's for
a rate; the bias-corrected and accelerated (BCa) bootstrap, paired by trial, for gains, variances,
ratios and heavy-tailed counts (scipy.stats.bootstrap, seeded); and, for trials run until
decided, an asymptotic confidence sequence (``cs``: valid at every look):

    m +- se sqrt(n) sqrt( 2 (n rho^2 + 1) / (n^2 rho^2) log( sqrt(n rho^2 + 1) / a ) )

the Gaussian-mixture boundary of I. Waudby-Smith, D. Arbour, R. Sinha, E. H. Kennedy and
A. Ramdas, "Time-uniform central limit theory and asymptotic confidence sequences", Annals of
Statistics (2024), with rho chosen before the first trial to be tightest at the most trials
allowed. The probability that it ever misses the true value, over all looks, is at most a
(asymptotically); its equivalence test uses the (1 - a) sequence (each one-sided test at a).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, replace
from typing import Callable

from ._special import functions

ALPHA = 0.05        # each family's error: any false 'reproduced', or any false 'differs'

# The interval each method gives, as a table names it.
METHODS = {
    "t": "Student's t over trials",
    "wilson": "Wilson's score interval (a rate)",
    "bca": "BCa bootstrap, paired by trial (9999 resamples, seeded)",
    "cs": "asymptotic confidence sequence (valid at every look; Waudby-Smith et al. 2024)",
}

# The fewest trials each method's interval needs: Student's t and Wilson's need two (one trial
# has no spread); a bootstrap three (two trials that differ give no distribution to resample).
MIN_TRIALS = {"t": 2, "wilson": 2, "cs": 2, "bca": 3}
_SHORT = {"t": "Student's t", "wilson": "Wilson's interval", "cs": "a confidence sequence",
          "bca": "a bootstrap"}

# What each verdict means, for the report and the docs (the code below decides them so).
DEFINITIONS = (
    f"*reproduced*: equivalence shown: the {1 - 2 * ALPHA:.0%} interval of ours - paper (two "
    f"one-sided tests at {ALPHA:.0%}) lies within the margin the paper file declares for the "
    "quantity, with its reason; for a paper's range, our interval lies within the range widened "
    "by the margin.",
    "*differs*: the paper's value lies outside our 95% interval (for a range: our interval "
    "misses it), with the ratio ours / paper.",
    "*inconclusive*: neither, with about how many trials would likely decide it (or why none "
    "can), or too few trials for an interval at all; a quantity without a declared margin is "
    "never called reproduced.",
    "*not comparable*: the paper's setting cannot be rebuilt (a real robot, an unpublished "
    "course, a single run) or the quantity depends on the machine (run times): shown, never "
    "judged; the notes give each reason. Where the paper file names a deterministic measure of "
    "the same cost (likelihood evaluations per step), the verdict judges that instead.",
    f"Many cells, one table: the levels above hold for a cell alone. A table's cells are judged "
    f"together: Holm's step-down procedure adjusts each kind of claim across the table, so the "
    f"chance of any false 'reproduced', or of any false 'differs', in a table is at most "
    f"{ALPHA:.0%}; each verdict prints the interval, at the level it was tested, that decided "
    "it.",
    "Where the paper states how many runs its values come from, every interval a verdict uses "
    "adds the sampling error of a batch that size to ours. Intervals: Student's t over trials; "
    "Wilson's for rates; the BCa bootstrap, paired by trial, for gains, variances, ratios and "
    "counts; with --until-decided, a confidence sequence valid at every look.",
)


def cs_rho2(max_trials: int, alpha: float = ALPHA) -> float:
    """The mixture's rho^2 that makes the (1 - alpha) confidence sequence tightest near
    ``max_trials`` (Waudby-Smith et al. 2024, their approximation for t_opt)."""
    la = -2.0 * math.log(alpha)
    return (la + math.log(la + 1.0)) / max(int(max_trials), 1)


def cs_multiplier(n: int, level: float, rho2: float) -> float:
    """The (two-sided ``level``) confidence sequence's half-width at n trials over the standard
    error se = sd / sqrt(n)."""
    a = 1.0 - level
    if n < 2 or a <= 0:
        return math.inf if n >= 2 else math.nan
    v = n * rho2 + 1.0
    return math.sqrt(2.0 * v / (n * rho2) * math.log(math.sqrt(v) / a))


@dataclass(frozen=True)
class Margin:
    """How far ours may lie from the paper's value and still be the same: ``relative`` (a fraction
    of the paper's value) or ``absolute`` (in the quantity's unit), with the reason."""
    relative: float | None = None
    absolute: float | None = None
    why: str = ""

    def width(self, paper: float) -> float:
        if self.absolute is not None:
            return self.absolute
        return abs(paper) * (self.relative or 0.0)

    def describe(self) -> str:
        if self.absolute is not None:
            return f"+-{self.absolute:g}"
        return f"+-{self.relative:.0%}"


@dataclass(frozen=True)
class Estimate:
    """Our value of a quantity: the estimate, its standard error, the trials it rests on, and how
    its intervals are made (METHODS): 't' and 'cs' from the standard error; 'wilson' and 'bca'
    from ``bounds(level) -> (lo, hi)``; ``rho2``: the confidence sequence's mixture (cs_rho2)."""
    value: float
    se: float
    n: int
    method: str = "t"
    bounds: Callable[[float], tuple[float, float]] | None = field(default=None, compare=False,
                                                                   repr=False)
    rho2: float | None = None

    def interval(self, level: float, paper_runs: int | None = None) -> tuple[float, float]:
        """The two-sided ``level`` interval, widened by a batch of ``paper_runs`` runs' error."""
        if self.method in ("t", "cs") or self.bounds is None:
            half = multiplier(self, level) * widened_se(self, paper_runs)
            return self.value - half, self.value + half
        lo, hi = self.bounds(level)
        w = math.sqrt(1.0 + self.n / paper_runs) if paper_runs else 1.0
        return self.value - (self.value - lo) * w, self.value + (hi - self.value) * w

    def equivalence_level(self, alpha: float) -> float:
        """The level of the interval whose inclusion in the margin is two one-sided tests at
        ``alpha``: 1 - 2 alpha; a confidence sequence's (1 - alpha), each side then valid at
        every look."""
        return 1.0 - alpha if self.method == "cs" else 1.0 - 2.0 * alpha

    def anytime(self, max_trials: int) -> Estimate:
        """The same estimate with a confidence sequence tuned for ``max_trials``."""
        return replace(self, method="cs", bounds=None, rho2=cs_rho2(max_trials))


@dataclass(frozen=True)
class Verdict:
    kind: str           # 'reproduced', 'differs', 'inconclusive', 'not comparable' or ''
    text: str           # the cell as printed
    lo: float = math.nan    # the interval the 'differs' test used (widened where it was)
    hi: float = math.nan
    level: float = math.nan     # its level
    needed: int | None = None   # 'inconclusive': the trials that would likely decide it (None:
                                # none would)


@dataclass(frozen=True)
class Claim:
    """One cell to judge: the paper's value (a number, a range (a, b), or None), ours, and what
    decide() takes besides."""
    paper: object
    est: Estimate
    margin: Margin | None = None
    paper_runs: int | None = None
    floor: float | None = None
    not_comparable: str | None = None
    judged: bool = True

    @property
    def testable(self) -> bool:
        p = self.paper
        return (p is not None and not (isinstance(p, float) and math.isnan(p))
                and not self.not_comparable and self.judged and self.est.n >= 2
                and not math.isnan(self.est.value) and not math.isnan(self.est.se))


def multiplier(est: Estimate, level: float) -> float:
    """The half-width of est's two-sided ``level`` interval over its standard error."""
    if est.method == "cs":
        return cs_multiplier(est.n, level, est.rho2 or cs_rho2(est.n))
    return quantile(level, est.n)


@functools.lru_cache(maxsize=4096)
def quantile(level: float, n: int) -> float:
    """The two-sided ``level`` quantile of Student's t with n - 1 degrees of freedom."""
    if n < 2:
        return math.nan
    return float(functions().stdtrit(n - 1, 0.5 + level / 2))     # scipy.stats.t.ppf


def widened_se(est: Estimate, paper_runs: int | None) -> float:
    """Our standard error, with that of a batch of ``paper_runs`` runs of the same spread."""
    if not paper_runs:
        return est.se
    return est.se * math.sqrt(1.0 + est.n / paper_runs)


def _distance(c: Claim) -> float:
    """|ours - paper|, or for a paper's range how far ours lies outside it (0 inside)."""
    v = c.est.value
    if isinstance(c.paper, tuple):
        return max(c.paper[0] - v, v - c.paper[1], 0.0)
    return abs(v - c.paper)


def _equivalence_bounds(c: Claim) -> tuple[float, float]:
    """Where ours must lie to be the same as the paper's value: its value (or range) widened by
    the claim's margin (a range's margin taken at its middle)."""
    if isinstance(c.paper, tuple):
        delta = c.margin.width(0.5 * (c.paper[0] + c.paper[1]))
        return c.paper[0] - delta, c.paper[1] + delta
    delta = c.margin.width(c.paper)
    return c.paper - delta, c.paper + delta


def _differs_at(c: Claim, a: float) -> bool:
    lo, hi = c.est.interval(1.0 - a, c.paper_runs)
    if math.isnan(lo) or math.isnan(hi):
        return False
    if isinstance(c.paper, tuple):
        return hi < c.paper[0] or lo > c.paper[1]
    return not lo <= c.paper <= hi


def _equivalent_at(c: Claim, a: float) -> bool:
    if c.margin is None:
        return False
    lo, hi = c.est.interval(c.est.equivalence_level(a), c.paper_runs)
    if math.isnan(lo) or math.isnan(hi):
        return False
    low, high = _equivalence_bounds(c)
    return low <= lo and hi <= high


def _p_value(test: Callable[[float], bool], top: float) -> float:
    """The smallest level a in [1e-12, top] at which ``test(a)`` holds (test is monotone: it
    holds for every larger a once it holds), by bisection on log a to 1e-6 of a; 1 where it
    never holds (a p-value under 1e-12 is reported as 1e-12: every level a table tests at is
    far above)."""
    if not test(top):
        return 1.0
    lo, hi = math.log(1e-12), math.log(top)
    if test(math.exp(lo)):
        return 1e-12
    while hi - lo > 1e-6:
        mid = 0.5 * (lo + hi)
        if test(math.exp(mid)):
            hi = mid
        else:
            lo = mid
    return math.exp(hi)


def _p_closed(est: Estimate, z: float, sides: int) -> float:
    """For an interval from the standard error ('t', 'cs'): the smallest a at which a distance
    of z (widened) standard errors reaches the (1 - a) interval's end (``sides`` 2: a
    two-sided t test, 1: one side of a (1 - 2a) interval); a confidence sequence's is the same
    for both (its equivalence test uses its (1 - a) sequence)."""
    if not z < math.inf:
        return 0.0
    if est.method == "cs":
        v = est.n * (est.rho2 or cs_rho2(est.n)) + 1.0
        z = max(z, 0.0)         # z * z, not z ** 2: a square past 1e308 is inf, not an error
        return min(1.0, math.sqrt(v) * math.exp(-z * z * (v - 1.0) / (2.0 * v)))
    return float(sides * functions().stdtr(est.n - 1, -z))     # scipy.stats.t.sf


def _closed_form(c: Claim) -> bool:
    return c.est.method in ("t", "cs") or c.est.bounds is None


def p_differs(c: Claim) -> float:
    """The p-value of 'the paper's value differs from ours': the smallest a whose (1 - a)
    interval misses it (for a t interval, the two-sided t test's p-value)."""
    if _closed_form(c):
        distance = _distance(c)
        if distance <= 0:
            return 1.0
        se = widened_se(c.est, c.paper_runs)
        return _p_closed(c.est, distance / se if se > 0 else math.inf, 2)
    return _p_value(lambda a: _differs_at(c, a), 1.0)


def p_equivalent(c: Claim) -> float:
    """The p-value of 'ours is within the margin of the paper's value' (two one-sided tests: the
    larger of their p-values); 1 without a margin."""
    if c.margin is None:
        return 1.0
    if _closed_form(c):
        low, high = _equivalence_bounds(c)
        room = min(c.est.value - low, high - c.est.value)
        if room <= 0:
            return 1.0
        se = widened_se(c.est, c.paper_runs)
        p = _p_closed(c.est, room / se if se > 0 else math.inf, 1)
        return p if c.est.method == "cs" or p < 0.5 else 1.0
    return _p_value(lambda a: _equivalent_at(c, a), 1.0 if c.est.method == "cs" else 0.5)


def _trials_to_decide(c: Claim, a_d: float, a_e: float) -> tuple[str, int | None]:
    """How many trials would likely decide claim c at levels a_d ('differs') and a_e
    ('reproduced'), keeping our spread and the difference seen (a normal approximation, then
    the interval's own multiplier)."""
    est, paper_runs = c.est, c.paper_runs
    sd = float(est.se) * math.sqrt(est.n)
    se_b2 = sd * sd / paper_runs if paper_runs else 0.0
    distance = _distance(c)
    if isinstance(c.paper, tuple):      # the margin's reach from the paper's value (or range)
        a, b = c.paper
        room = (0.5 * (b - a) + c.margin.width(0.5 * (a + b))) if c.margin else None
    else:
        room = c.margin.width(c.paper) if c.margin else None
    method = est.method if est.method in ("t", "cs") else "t"

    def decided(n: int) -> bool:
        later = Estimate(est.value, sd / math.sqrt(n), n, method, rho2=est.rho2)
        moved = replace(c, est=later)
        return _differs_at(moved, a_d) or _equivalent_at(moved, a_e)

    need = []
    z_d = float(functions().ndtri(1 - a_d / 2))       # scipy.stats.norm.ppf
    z_e = float(functions().ndtri(0.5 + est.equivalence_level(a_e) / 2))
    if distance > 0:                                    # toward 'differs'
        slack = _square(distance / z_d) - se_b2
        if slack > 0:
            need.append(sd * sd / slack if slack > sd * sd * 1e-12 else math.inf)
    if room is not None and room > distance:            # toward 'reproduced'
        slack = _square((room - distance) / z_e) - se_b2
        if slack > 0:
            need.append(sd * sd / slack if slack > sd * sd * 1e-12 else math.inf)
    need = [n for n in need if not math.isnan(n)]
    if not need or sd == 0 or not math.isfinite(sd):
        why = (f"; the paper's own {paper_runs} runs leave too wide an error" if paper_runs
               else "")
        return f"no number of trials decides it{why}", None
    first = float(min(need))
    if not first < 1e9:
        return "no feasible number of trials decides it (over a billion)", None
    lo = max(int(math.ceil(first)), est.n + 1, 2)      # the normal approximation's guess,
    hi = lo                                             # then the interval's own: the first n
    while not decided(hi):                              # that decides, to 1%
        lo, hi = hi, int(hi * 1.5) + 1
        if hi >= 10 ** 9:
            return "no feasible number of trials decides it (over a billion)", None
    while hi - lo > max(1, lo // 100):
        mid = (lo + hi) // 2
        if decided(mid):
            hi = mid
        else:
            lo = mid
    return f"about {_round_up(hi)} trials would likely decide it", _round_up(hi)


def _ratio(a: float, b: float) -> float:
    """a / b, inf for b = 0 and nan where it says nothing (inf / inf): never an error."""
    if b == 0:
        return math.inf if a > 0 else -math.inf if a < 0 else math.nan
    try:
        return a / b
    except (OverflowError, ZeroDivisionError):
        return math.inf if (a > 0) == (b > 0) else -math.inf


def _square(x: float) -> float:
    """x * x (inf past the largest float, where x ** 2 raises OverflowError)."""
    return x * x


def _round_up(n: float) -> int:
    """n rounded up to two significant digits."""
    if n < 100:
        return int(math.ceil(n))
    scale = 10 ** (int(math.log10(n)) - 1)
    return int(math.ceil(n / scale) * scale)


def percent(level: float) -> str:
    """A level as a percentage with the digits it needs (95%, 99.7%, 99.91%)."""
    for d in range(0, 6):
        s = f"{100 * level:.{d}f}"
        if abs(float(s) - 100 * level) < 1e-9 or (float(s) < 100 and d >= 1
                                                    and abs(float(s) - 100 * level) < 0.05):
            return f"{s}%"
    return f"{100 * level:.5g}%"


def decide(paper, est: Estimate, *, margin: Margin | None = None,
           paper_runs: int | None = None, floor: float | None = None,
           not_comparable: str | None = None, judged: bool = True,
           alpha_differs: float = ALPHA, alpha_equivalent: float = ALPHA,
           holm: str = "") -> Verdict:
    """The verdict on the paper's value ``paper`` (a number, or a range (a, b)) given ours, with
    'differs' tested at ``alpha_differs`` and 'reproduced' at ``alpha_equivalent`` (a table's
    cells: the levels decide_family gives them, ``holm`` the words that say so)."""
    c = Claim(paper, est, margin, paper_runs, floor, not_comparable, judged)
    return _decide(c, alpha_differs, alpha_equivalent, holm, holm)


def _decide(c: Claim, a_d: float, a_e: float, holm_d: str = "", holm_e: str = "") -> Verdict:
    paper, est, margin = c.paper, c.est, c.margin
    if paper is None or (isinstance(paper, float) and math.isnan(paper)):
        return Verdict("", "")
    lo, hi = est.interval(1.0 - a_d, c.paper_runs)
    level = 1.0 - a_d
    if c.not_comparable:
        return Verdict("not comparable", f"not comparable: {c.not_comparable}", lo, hi, level)
    if not c.judged:
        return Verdict("not comparable", "shown, not judged: it depends on the machine", lo, hi,
                       level)
    least = MIN_TRIALS.get(est.method, 2)
    if 1 <= est.n < least:
        return Verdict("inconclusive", f"inconclusive: {est.n} trial"
                       f"{'s give' if est.n != 1 else ' gives'} no interval "
                       f"({_SHORT.get(est.method, est.method)} needs at least {least})",
                       lo, hi, level)
    if not c.testable:
        return Verdict("not comparable", "not comparable: no finite result", lo, hi, level)
    eq_level = est.equivalence_level(a_e)
    elo, ehi = est.interval(eq_level, c.paper_runs)
    if _equivalent_at(c, a_e):
        if isinstance(paper, tuple):
            delta = margin.width(0.5 * (paper[0] + paper[1]))
            return Verdict("reproduced", f"reproduced: our {percent(eq_level)}{holm_e} interval "
                           f"[{elo:.3g}, {ehi:.3g}] lies in the range"
                           + (f" {margin.describe()}" if delta else ""), lo, hi, level)
        return Verdict("reproduced", f"reproduced: ours - paper in [{elo - paper:.3g}, "
                       f"{ehi - paper:.3g}] ({percent(eq_level)}{holm_e}), within "
                       f"{margin.describe()}", lo, hi, level)
    interval = f"our {percent(level)} interval [{lo:.3g}, {hi:.3g}]{holm_d}"
    if _differs_at(c, a_d):
        if isinstance(paper, tuple):
            mid = 0.5 * paper[0] + 0.5 * paper[1]
            ratio = _ratio(est.value, mid)
            return Verdict("differs", (f"differs (x{ratio:.2f} the range's middle; {interval})"
                                       if ratio > 0 else f"differs (ours {est.value:.3g} "
                                       f"against the range's middle {mid:.3g}; {interval})"),
                           lo, hi, level)
        ratio = _ratio(est.value, paper)
        # a ratio of values of opposite signs (a gain against a loss) says nothing
        text = (f"differs (x{ratio:.2f}; {interval})" if ratio > 0 else
                f"differs (ours {est.value:.3g} against {paper:.3g}; {interval})")
        if c.floor is not None and paper < c.floor:
            text += "; paper below the model's floor"
        return Verdict("differs", text, lo, hi, level)
    why, needed = _trials_to_decide(c, a_d, a_e)
    return Verdict("inconclusive", "inconclusive" + ("" if margin else " (no margin declared)")
                   + ": " + why, lo, hi, level, needed)


def holm_levels(pvalues: list[float], alpha: float = ALPHA) -> list[float]:
    """The level Holm's step-down procedure tests each p-value at (S. Holm, "A simple sequentially
    rejective multiple test procedure", Scand. J. Statistics 6, 1979): the p-values in increasing
    order, the one of rank j (0 first) among m is rejected at alpha / (m - j) while every smaller
    one was; the procedure stops at the first that is not. A rejected hypothesis's level is
    alpha / (m - j), every other's the level where the procedure stopped.

    The rejections are those of Holm's procedure as the closed test of Bonferroni's (the tests
    check it on random p-values, ties and levels' edges included); written here rather than
    taken from statsmodels' ``multipletests``, which runs the garbage collector every call, a
    tenth of a second a table."""
    m = len(pvalues)
    if m == 0:
        return []
    order = sorted(range(m), key=lambda i: pvalues[i])
    rejected = 0
    for j, i in enumerate(order):
        if not pvalues[i] <= alpha / (m - j):
            break
        rejected += 1
    levels = [alpha / (m - rejected) if rejected < m else alpha] * m
    for j, i in enumerate(order[:rejected]):
        levels[i] = alpha / (m - j)
    return levels


def decide_family(claims: list[Claim], alpha: float = ALPHA) -> list[Verdict]:
    """The verdicts of a table's cells judged together: 'differs' and 'reproduced' each a family
    over the cells that can be tested, Holm-adjusted (holm_levels); one cell alone is judged at
    ``alpha``."""
    testable = [i for i, c in enumerate(claims) if c.testable]
    m = len(testable)
    a_d = dict(zip(testable, holm_levels([p_differs(claims[i]) for i in testable], alpha)))
    with_margin = [i for i in testable if claims[i].margin is not None]
    a_e = dict(zip(with_margin, holm_levels([p_equivalent(claims[i]) for i in with_margin],
                                            alpha)))
    holm_d = f", Holm over {m}" if m > 1 else ""
    holm_e = f", Holm over {len(with_margin)}" if len(with_margin) > 1 else ""
    return [_decide(c, a_d.get(i, alpha), a_e.get(i, alpha), holm_d, holm_e)
            for i, c in enumerate(claims)]
