"""The verdict engine (pfbench.verdicts): equivalence by two one-sided tests within a declared
margin, 'differs' outside our 95% interval, 'inconclusive' otherwise; simulated error rates."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from pfbench.verdicts import ALPHA, Estimate, Margin, decide

TEN = Margin(relative=0.10, why="test")


def _est(values) -> Estimate:
    v = np.asarray(values, dtype=float)
    return Estimate(float(v.mean()), float(v.std(ddof=1) / math.sqrt(v.size)), v.size)


def test_a_closed_form_case():
    # m = 1, se = 0.05, n = 100: the 90% interval of m - p is -0.05 +- t(0.95, 99) 0.05
    half = stats.t.ppf(0.95, 99) * 0.05
    v = decide(1.05, Estimate(1.0, 0.05, 100), margin=Margin(absolute=0.15, why="x"))
    assert v.kind == "reproduced"
    assert f"[{-0.05 - half:.3g}, {-0.05 + half:.3g}]" in v.text
    # the same with a margin just inside the interval's far end: not shown
    v = decide(1.05, Estimate(1.0, 0.05, 100), margin=Margin(absolute=0.05 + half - 1e-3, why="x"))
    assert v.kind == "inconclusive"
    # and the 95% interval it printed is ours, t(0.975, 99)
    assert v.lo == pytest.approx(1.0 - stats.t.ppf(0.975, 99) * 0.05)


@settings(max_examples=300, deadline=None)
@given(m=st.floats(-10, 10), se=st.floats(1e-3, 5), n=st.integers(2, 5000),
       p=st.floats(-10, 10), rel=st.floats(0.01, 1.0))
def test_reproduced_is_the_two_one_sided_tests(m, se, n, p, rel):
    """'reproduced' exactly when both one-sided t tests reject at ALPHA (the p-value form of
    the interval inclusion)."""
    delta = abs(p) * rel
    v = decide(p, Estimate(m, se, n), margin=Margin(relative=rel, why="x"))
    d = m - p
    p_low = stats.t.sf((d + delta) / se, n - 1)         # H0: d <= -delta
    p_high = stats.t.cdf((d - delta) / se, n - 1)       # H0: d >= +delta
    tost = max(p_low, p_high)
    if abs(tost - ALPHA) > 1e-9:                        # away from the boundary
        assert (v.kind == "reproduced") == (tost < ALPHA), (v.text, tost)
    inside = abs(d) <= stats.t.ppf(0.975, n - 1) * se
    if v.kind != "reproduced":
        assert v.kind == ("inconclusive" if inside else "differs"), v.text


def test_reproduced_at_most_alpha_of_the_time_when_the_truth_sits_on_the_margin():
    rng = np.random.default_rng(16)
    paper, reps, n = 10.0, 4000, 30
    hits = sum(decide(paper, _est(rng.normal(paper * 1.10, 1.0, n)), margin=TEN).kind
               == "reproduced" for _ in range(reps))
    assert hits / reps <= ALPHA + 3 * math.sqrt(ALPHA * (1 - ALPHA) / reps)


def test_power_when_nothing_differs():
    rng = np.random.default_rng(17)
    paper, reps, n = 10.0, 1000, 100
    got = [decide(paper, _est(rng.normal(paper, 1.0, n)), margin=TEN).kind for _ in range(reps)]
    assert got.count("reproduced") / reps > 0.99            # 90% half-width 0.17 << margin 1
    # and 'differs' about 5% of the time without a margin (a two-sided 5% test)
    got = [decide(paper, _est(rng.normal(paper, 1.0, n))).kind for _ in range(reps)]
    assert abs(got.count("differs") / reps - 0.05) < 3 * math.sqrt(0.05 * 0.95 / reps)
    assert "reproduced" not in got                          # no margin, never reproduced


def test_inconclusive_says_how_many_trials_would_decide():
    est = Estimate(10.3, 0.5, 20)                           # sd 2.24
    v = decide(10.0, est, margin=TEN)
    assert v.kind == "inconclusive" and "trials would likely decide it" in v.text
    n_new = int(v.text.split("about ")[1].split(" trials")[0])
    sd = 0.5 * math.sqrt(20)
    later = decide(10.0, Estimate(10.3, sd / math.sqrt(n_new), n_new), margin=TEN)
    assert later.kind == "reproduced", later.text
    # the paper's own runs can leave a margin out of reach
    v = decide(10.0, est, margin=Margin(relative=0.02, why="x"), paper_runs=10)
    assert v.kind == "inconclusive" and "no number of trials decides it" in v.text \
        and "10 runs" in v.text


def test_the_papers_runs_widen_every_interval_the_verdict_uses():
    est = Estimate(1.0, 0.1, 400)
    v = decide(1.3, est, paper_runs=100)
    q = stats.t.ppf(0.975, 399)
    assert v.hi - 1.0 == pytest.approx(q * 0.1 * math.sqrt(1 + 400 / 100))
    assert v.kind == "inconclusive"                     # 1.3 is inside the widened interval
    assert decide(1.3, est).kind == "differs"           # and outside ours alone


def test_ranges_floors_and_what_is_not_judged():
    ten_twenty = (10.0, 20.0)
    zero = Margin(absolute=0.0, why="the range is its own tolerance")
    assert decide(ten_twenty, Estimate(15.0, 0.5, 100), margin=zero).kind == "reproduced"
    assert decide(ten_twenty, Estimate(30.0, 0.5, 100), margin=zero).text.startswith(
        "differs (x2.00 the range's middle)")
    assert decide(ten_twenty, Estimate(19.5, 1.0, 100), margin=zero).kind == "inconclusive"
    assert decide(2.0, Estimate(3.0, 0.05, 100), floor=2.5).text.endswith(
        "paper below the model's floor")
    assert decide(2.0, Estimate(3.0, 0.05, 100), not_comparable="units").kind == \
        "not comparable"
    assert decide(2.0, Estimate(3.0, 0.05, 100), judged=False).text.startswith(
        "shown, not judged")
    assert decide(None, Estimate(3.0, 0.05, 100)).kind == ""


def test_rates_get_wilson_intervals_inside_zero_one(write_config):
    import pandas as pd

    from pfbench.compare import estimate, our_interval
    from pfbench.papers import Quantity
    q = Quantity("c", "converged", "converged", "mean")
    for k, n in ((19, 20), (20, 20), (0, 20), (1, 10)):
        g = pd.DataFrame({"trial": range(n), "converged": [1.0] * k + [0.0] * (n - k)})
        lo, hi = our_interval(q, estimate(q, g, None), g)
        assert 0.0 <= lo <= k / n <= hi <= 1.0, (k, n, lo, hi)
        ci = stats.binomtest(k, n).proportion_ci(0.95, method="wilson")
        assert (lo, hi) == pytest.approx((ci.low, ci.high))
