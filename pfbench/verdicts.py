"""Verdicts: what our trials say of one value a paper prints, in one vocabulary.

For a paper value p, our estimate m with standard error se over n trials, and (where the paper
states it) the r runs behind p, whose own sampling error se_b = se sqrt(n / r) adds to ours
(se_w = sqrt(se^2 + se_b^2)):

- **reproduced**: equivalence shown by two one-sided tests at ALPHA: the (1 - 2 ALPHA) interval
  of m - p, m - p +- t(1 - ALPHA) se_w, lies inside the quantity's declared margin
  [-delta, +delta] (a paper file declares each margin with its reason), even where a difference
  smaller than the margin is detectable;
- **differs**: otherwise, when p lies outside our (widened) 95% interval m +- t(0.975) se_w;
- **inconclusive**: neither, with the number of trials that would likely decide it (keeping the
  spread and the difference seen so far), or why no number of trials can;
- **not comparable** (with the reason), and ``; paper below the model's floor`` after a
  'differs' whose paper value lies under what a near-optimal filter reaches.

A paper's range [a, b] is reproduced when our (1 - 2 ALPHA) interval lies inside
[a - delta, b + delta], differs when our 95% interval misses the range, and is inconclusive
otherwise. Quantiles are Student's t with n - 1 degrees of freedom (scipy).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from scipy import stats

ALPHA = 0.05        # each one-sided test of the equivalence; the differs test is two-sided 5%

# What each verdict means, for the report and the README (the code below decides them so).
DEFINITIONS = (
    f"*reproduced*: equivalence shown: the {1 - 2 * ALPHA:.0%} interval of ours - paper (two "
    f"one-sided tests at {ALPHA:.0%}) lies within the margin the paper file declares for the "
    "quantity, with its reason; for a paper's range, our interval lies within the range widened "
    "by the margin.",
    "*differs*: the paper's value lies outside our 95% interval (for a range: our interval "
    "misses it), with the ratio ours / paper.",
    "*inconclusive*: neither, with about how many trials would likely decide it (or why none "
    "can); a quantity without a declared margin is never called reproduced.",
    "*not comparable*: the paper's setting cannot be rebuilt (a real robot, an unpublished "
    "course, a single run) or the quantity depends on the machine (run times): shown, never "
    "judged; the notes give each reason. Where the paper file names a deterministic measure of "
    "the same cost (likelihood evaluations per step), the verdict judges that instead.",
    "Where the paper states how many runs its values come from, every interval a verdict uses "
    "adds the sampling error of a batch that size to ours. Intervals are Student's t over trials "
    "(Wilson's for rates).",
)


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
    """Our value of a quantity: the estimate, its standard error and the trials it rests on."""
    value: float
    se: float
    n: int

    def interval(self, level: float, paper_runs: int | None = None) -> tuple[float, float]:
        """The two-sided ``level`` interval, widened by a batch of ``paper_runs`` runs' error."""
        half = quantile(level, self.n) * widened_se(self, paper_runs)
        return self.value - half, self.value + half


@dataclass(frozen=True)
class Verdict:
    kind: str           # 'reproduced', 'differs', 'inconclusive', 'not comparable' or ''
    text: str           # the cell as printed
    lo: float = math.nan    # the 95% interval the 'differs' test used (widened where it was)
    hi: float = math.nan


def quantile(level: float, n: int) -> float:
    """The two-sided ``level`` quantile of Student's t with n - 1 degrees of freedom."""
    if n < 2:
        return math.nan
    return float(stats.t.ppf(0.5 + level / 2, n - 1))


def widened_se(est: Estimate, paper_runs: int | None) -> float:
    """Our standard error, with that of a batch of ``paper_runs`` runs of the same spread."""
    if not paper_runs:
        return est.se
    return est.se * math.sqrt(1.0 + est.n / paper_runs)


def _trials_to_decide(est: Estimate, distance: float, room: float | None,
                      paper_runs: int | None) -> str:
    """How many trials would likely decide, keeping our spread and the difference seen:
    ``distance`` |m - p| (to a range: to its nearer end), ``room`` the margin's width left
    (None: no margin)."""
    sd = float(est.se) * math.sqrt(est.n)
    se_b2 = sd * sd / paper_runs if paper_runs else 0.0

    def decided(n: int) -> bool:
        se = math.sqrt(sd * sd / n + se_b2)
        if distance > quantile(0.95, n) * se:                               # 'differs'
            return True
        return room is not None and distance + quantile(1 - 2 * ALPHA, n) * se <= room

    need = []
    z95, z90 = float(stats.norm.ppf(0.975)), float(stats.norm.ppf(1 - ALPHA))
    if distance > 0:                                    # toward 'differs'
        slack = (distance / z95) ** 2 - se_b2
        if slack > 0:
            need.append(sd * sd / slack if slack > sd * sd * 1e-12 else math.inf)
    if room is not None and room > distance:            # toward 'reproduced'
        slack = ((room - distance) / z90) ** 2 - se_b2
        if slack > 0:
            need.append(sd * sd / slack if slack > sd * sd * 1e-12 else math.inf)
    if not need or sd == 0:
        why = (f"; the paper's own {paper_runs} runs leave too wide an error" if paper_runs
               else "")
        return f"no number of trials decides it{why}"
    first = float(min(need))
    if not first < 1e9:
        return "no feasible number of trials decides it (over a billion)"
    n = max(int(math.ceil(first)), est.n + 1, 2)        # the normal approximation, then t's
    while not decided(n) and n < 10 ** 9:
        n += max(1, n // 100)
    return f"about {_round_up(n)} trials would likely decide it"


def _round_up(n: float) -> int:
    """n rounded up to two significant digits."""
    if n < 100:
        return int(math.ceil(n))
    scale = 10 ** (int(math.log10(n)) - 1)
    return int(math.ceil(n / scale) * scale)


def decide(paper, est: Estimate, *, margin: Margin | None = None,
           paper_runs: int | None = None, floor: float | None = None,
           not_comparable: str | None = None, judged: bool = True) -> Verdict:
    """The verdict on the paper's value ``paper`` (a number, or a range (a, b)) given ours."""
    if paper is None or (isinstance(paper, float) and math.isnan(paper)):
        return Verdict("", "")
    lo, hi = est.interval(0.95, paper_runs)
    if not_comparable:
        return Verdict("not comparable", f"not comparable: {not_comparable}", lo, hi)
    if not judged:
        return Verdict("not comparable", "shown, not judged: it depends on the machine", lo, hi)
    if math.isnan(est.value) or est.n < 2 or math.isnan(est.se):
        return Verdict("not comparable", "not comparable: no finite result", lo, hi)
    elo, ehi = est.interval(1 - 2 * ALPHA, paper_runs)
    if isinstance(paper, tuple):
        a, b = paper
        delta = margin.width(0.5 * (a + b)) if margin else None
        if delta is not None and a - delta <= elo and ehi <= b + delta:
            return Verdict("reproduced", f"reproduced: our {1 - 2 * ALPHA:.0%} interval "
                           f"[{elo:.3g}, {ehi:.3g}] lies in the range"
                           + (f" {margin.describe()}" if delta else ""), lo, hi)
        if hi < a or lo > b:
            mid = 0.5 * (a + b)
            return Verdict("differs", f"differs (x{est.value / mid:.2f} the range's middle)",
                           lo, hi)
        distance = max(a - est.value, est.value - b, 0.0)
        room = (0.5 * (b - a) + delta) if delta is not None else None
        return Verdict("inconclusive", "inconclusive"
                       + ("" if margin else " (no margin declared)") + ": "
                       + _trials_to_decide(est, distance, room, paper_runs), lo, hi)
    delta = margin.width(paper) if margin else None
    d_lo, d_hi = elo - paper, ehi - paper
    if delta is not None and -delta <= d_lo and d_hi <= delta:
        return Verdict("reproduced", f"reproduced: ours - paper in [{d_lo:.3g}, {d_hi:.3g}] "
                       f"({1 - 2 * ALPHA:.0%}), within {margin.describe()}", lo, hi)
    if not lo <= paper <= hi:
        ratio = est.value / paper if paper else math.inf
        # a ratio of values of opposite signs (a gain against a loss) says nothing
        text = (f"differs (x{ratio:.2f})" if ratio > 0 else
                f"differs (ours {est.value:.3g} against {paper:.3g})")
        if floor is not None and paper < floor:
            text += "; paper below the model's floor"
        return Verdict("differs", text, lo, hi)
    return Verdict("inconclusive", "inconclusive" + ("" if margin else " (no margin declared)")
                   + ": " + _trials_to_decide(est, abs(est.value - paper), delta, paper_runs),
                   lo, hi)
