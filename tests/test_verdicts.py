"""The verdict engine (pfbench.verdicts): equivalence by two one-sided tests within a declared
margin, 'differs' outside our 95% interval, 'inconclusive' otherwise; simulated error rates."""
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from pfbench.verdicts import ALPHA, Estimate, Margin, decide

from .conftest import holm_by_closure

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


def test_too_few_trials_for_an_interval_is_inconclusive_and_says_so():
    """One trial (Student's t) or two (a bootstrap): no interval, so neither 'differs' nor
    'reproduced', and never 'not comparable' (the setting is comparable; the trials are few)."""
    one = decide(2.0, Estimate(3.0, math.nan, 1), margin=TEN)
    assert one.kind == "inconclusive"
    assert one.text == "inconclusive: 1 trial gives no interval (Student's t needs at least 2)"
    two = decide(2.0, Estimate(30.0, math.nan, 2, "bca"), margin=TEN)
    assert two.kind == "inconclusive" and "2 trials give no interval" in two.text
    assert "a bootstrap needs at least 3" in two.text
    none = decide(2.0, Estimate(math.nan, math.nan, 0), margin=TEN)
    assert none.kind == "not comparable"


def test_ranges_floors_and_what_is_not_judged():
    ten_twenty = (10.0, 20.0)
    zero = Margin(absolute=0.0, why="the range is its own tolerance")
    assert decide(ten_twenty, Estimate(15.0, 0.5, 100), margin=zero).kind == "reproduced"
    assert decide(ten_twenty, Estimate(30.0, 0.5, 100), margin=zero).text.startswith(
        "differs (x2.00 the range's middle; our 95% interval [29, 31])")
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

    from pfbench.compare import estimate
    from pfbench.papers import Quantity
    q = Quantity("c", "converged", "converged", "mean")
    for k, n in ((19, 20), (20, 20), (0, 20), (1, 10)):
        g = pd.DataFrame({"trial": range(n), "converged": [1.0] * k + [0.0] * (n - k)})
        lo, hi = estimate(q, g, None).interval(0.95)
        assert 0.0 <= lo <= k / n <= hi <= 1.0, (k, n, lo, hi)
        ci = stats.binomtest(k, n).proportion_ci(0.95, method="wilson")
        assert (lo, hi) == pytest.approx((ci.low, ci.high))


@settings(max_examples=200, deadline=None)
@given(m=st.floats(-10, 10), se=st.floats(1e-2, 5), n=st.integers(3, 2000),
       p=st.floats(-10, 10))
def test_the_differs_p_value_is_the_t_tests(m, se, n, p):
    from pfbench.verdicts import Claim, p_differs
    want = 2 * stats.t.sf(abs(m - p) / se, n - 1)
    got = p_differs(Claim(p, Estimate(m, se, n)))
    if want > 1e-11:
        assert got == pytest.approx(want, rel=1e-5, abs=1e-12)


def test_holm_levels_follow_the_step_down():
    from pfbench.verdicts import holm_levels
    p = [0.001, 0.04, 0.012, 0.3, 0.0001]
    levels = holm_levels(p)
    # sorted: 0.0001 (5 left: 0.01), 0.001 (4: 0.0125), 0.012 (3: 0.0167), 0.04 (2: 0.025 stop)
    assert levels == pytest.approx([0.05 / 4, 0.05 / 2, 0.05 / 3, 0.05 / 2, 0.05 / 5])
    reject = holm_by_closure(p, 0.05)
    assert reject == [True, False, True, False, True]
    assert [pi <= a for pi, a in zip(p, levels)] == reject
    assert holm_levels([0.2]) == [0.05] and holm_levels([]) == []


@settings(max_examples=300, deadline=None)
@given(p=st.lists(st.one_of(st.floats(0, 1), st.sampled_from([0.0, 0.01, 0.0125, 0.05, 1.0])),
                  min_size=1, max_size=40),
       alpha=st.sampled_from([0.05, 0.01, 0.1]))
def test_holm_rejects_what_the_closed_test_of_bonferronis_rejects(p, alpha):
    """The step-down written in verdicts rejects exactly what Holm's procedure, as the closed
    test of Bonferroni's (conftest.holm_by_closure), rejects, ties and p-values on a level's
    edge included."""
    from pfbench.verdicts import holm_levels
    levels = holm_levels(p, alpha)
    assert [pi <= a for pi, a in zip(p, levels)] == holm_by_closure(p, alpha)


def test_the_distribution_functions_are_scipy_stats_bit_for_bit():
    """verdicts and metrics call scipy.special's t and normal functions: the same numbers, to
    the bit, as scipy.stats' t and norm."""
    from pfbench.metrics import t975
    from pfbench.verdicts import Claim, p_differs, quantile
    quantile.cache_clear()
    for n in (2, 3, 5, 10, 30, 101, 1000, 10**6):
        assert t975(n - 1) == float(stats.t.ppf(0.975, n - 1))
        for level in (0.9, 0.95, 0.99, 1 - 0.05 / 54):
            assert quantile(level, n) == float(stats.t.ppf(0.5 + level / 2, n - 1))
        for z in (0.0, 0.5, 2.0, 7.5):
            est = Estimate(z, 1.0, n)
            assert p_differs(Claim(0.0, est)) == float(2 * stats.t.sf(z, n - 1))


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
def test_a_verdict_imports_neither_scipy_stats_nor_statsmodels():
    """A table's verdicts (t intervals, Holm) import only scipy.special: scipy.stats takes about a
    second to import and statsmodels' Holm runs the garbage collector every call."""
    code = ("import sys; from pfbench.verdicts import Claim, Estimate, decide_family; "
            "decide_family([Claim(1.0, Estimate(1.2, 0.1, 10)), Claim(2.0, Estimate(2.0, 0.1, 10),"
            " margin=None)]); from pfbench.metrics import summarize; summarize([1.0, 2.0, 4.0]); "
            "print(sorted(m for m in sys.modules if m.startswith(('scipy.stats', 'statsmodels', "
            "'matplotlib'))))")
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


@pytest.mark.slow
def test_a_table_of_many_cells_makes_no_chance_verdicts():
    """54 cells whose truth equals the paper's value: judged one by one, about 93% of tables
    would show a false 'differs'; judged together (Holm) at most 5% (simulated, 400 tables,
    3 binomial standard errors); a cell far off is still found."""
    from pfbench.verdicts import Claim, decide_family, p_differs
    rng = np.random.default_rng(54)
    reps, cells, n = 400, 54, 30
    alone = together = 0
    for _ in range(reps):
        ests = [_est(rng.normal(1.0, 1.0, n)) for _ in range(cells)]
        alone += any(p_differs(Claim(1.0, e)) < ALPHA for e in ests)    # each at 5%
        together += any(v.kind == "differs" for v in
                        decide_family([Claim(1.0, e) for e in ests]))
    tol = 3 * math.sqrt(ALPHA * (1 - ALPHA) / reps)
    assert together / reps <= ALPHA + tol
    assert alone / reps > 0.8
    far = decide_family([Claim(1.0, _est(rng.normal(1.0, 1.0, n))) for _ in range(53)]
                        + [Claim(1.0, Estimate(3.0, 0.1, 30))])
    assert far[-1].kind == "differs" and "Holm over 54" in far[-1].text
    lo, hi = far[-1].lo, far[-1].hi       # the interval printed is the one at its Holm level
    assert 3.0 - lo == pytest.approx(hi - 3.0)
    assert hi - 3.0 == pytest.approx(stats.t.ppf(1 - ALPHA / 54 / 2, 29) * 0.1)
    assert far[-1].level == pytest.approx(1 - ALPHA / 54)


def test_equivalence_across_a_table_is_holm_adjusted_too():
    """20 cells whose truth sits on the margin: a false 'reproduced' anywhere in the table at
    most 5% of the time (simulated)."""
    from pfbench.verdicts import Claim, decide_family
    rng = np.random.default_rng(20)
    reps, cells, n = 300, 20, 400
    false = 0
    for _ in range(reps):
        claims = [Claim(10.0, _est(rng.normal(11.0, 2.0, n)), TEN) for _ in range(cells)]
        false += any(v.kind == "reproduced" for v in decide_family(claims))
    assert false / reps <= ALPHA + 3 * math.sqrt(ALPHA * (1 - ALPHA) / reps)


@settings(max_examples=100, deadline=None)
@given(k=st.integers(0, 60), extra=st.integers(0, 60), level=st.floats(0.5, 1 - 1e-9))
def test_wilson_bounds_stay_inside_zero_one_at_every_level(k, extra, level):
    import pandas as pd

    from pfbench.compare import estimate
    from pfbench.papers import Quantity
    n = k + extra
    if n == 0:
        return
    q = Quantity("c", "converged", "converged", "mean")
    g = pd.DataFrame({"trial": range(n), "converged": [1.0] * k + [0.0] * extra})
    est = estimate(q, g, None)
    assert est.method == "wilson"
    lo, hi = est.interval(level)
    assert 0.0 <= lo <= k / n <= hi <= 1.0


def test_bootstrap_intervals_are_seeded_and_fit_skewed_counts():
    import pandas as pd

    from pfbench.compare import estimate
    from pfbench.papers import Quantity
    rng = np.random.default_rng(3)
    q = Quantity("r", "recovery", "recovery_steps", "mean")
    g = pd.DataFrame({"trial": range(80), "recovery_steps": rng.gamma(0.5, 10.0, 80)})
    a = estimate(q, g, None, seed=7, key="x").interval(0.95)
    b = estimate(q, g, None, seed=7, key="x").interval(0.95)
    assert a == b                                           # the same trials, the same interval
    assert estimate(q, g, None, seed=8, key="x").interval(0.95) != a
    assert estimate(q, g, None).method == "bca"
    q = Quantity("f", "failures", "recovery_failures", "mean")
    # a count's interval never reaches below zero (a t interval would for few events)
    g = pd.DataFrame({"trial": range(20), "recovery_failures": [0.0] * 19 + [1.0]})
    assert estimate(q, g, None).interval(0.95)[0] >= 0.0
    assert Estimate(0.05, 0.05, 20).interval(0.95)[0] < 0.0


def _false_decisions(draw, paper, margin=None, anytime=True, reps=2000, batch=20, most=400,
                     seed=11):
    """The fraction of ``reps`` simulated runs until decided (batches of ``batch`` up to
    ``most``, looking after each) that ever decide wrongly: 'differs' (no margin) or
    'reproduced' (with one) as the engine judges a cell alone."""
    from pfbench.verdicts import Claim, p_differs, p_equivalent
    rng = np.random.default_rng(seed)
    false = 0
    for _ in range(reps):
        x = draw(rng, most)
        s1, s2 = np.cumsum(x), np.cumsum(x * x)
        for n in range(batch, most + 1, batch):
            m = s1[n - 1] / n
            est = Estimate(m, math.sqrt(max(s2[n - 1] - n * m * m, 0.0) / (n - 1) / n), n)
            claim = Claim(paper, est.anytime(most) if anytime else est, margin)
            p = p_differs(claim) if margin is None else p_equivalent(claim)
            if p < ALPHA:
                false += 1
                break
    return false / reps


def test_confidence_sequences_keep_false_decisions_under_alpha_at_every_look():
    """Runs until decided look after each of 20 batches: with fixed-n t intervals a true value
    is called 'differs' in about a quarter of the runs; with the confidence sequences at most
    ALPHA (plus 3 binomial standard errors of 2000 runs), for normal and skewed trials, and
    'reproduced' likewise when the truth sits on the margin."""
    reps = 2000
    tol = 3 * math.sqrt(ALPHA * (1 - ALPHA) / reps)
    normal = lambda rng, n: rng.normal(1.0, 1.0, n)           # noqa: E731
    skewed = lambda rng, n: rng.gamma(0.5, 2.0, n)             # noqa: E731  mean 1, skew 2.8
    assert _false_decisions(normal, 1.0, anytime=False, reps=500) > 0.15
    assert _false_decisions(normal, 1.0, reps=reps) <= ALPHA + tol
    assert _false_decisions(skewed, 1.0, reps=reps) <= ALPHA + tol
    half = Margin(relative=0.5, why="test")
    on_margin = lambda rng, n: rng.gamma(0.5, 3.0, n)          # noqa: E731  mean 1.5
    assert _false_decisions(on_margin, 1.0, half, reps=reps) <= ALPHA + tol
    # and they decide: the truth at the paper's value is shown equivalent within 400 trials
    at_paper = lambda rng, n: rng.normal(1.0, 1.0, n)          # noqa: E731
    assert _false_decisions(at_paper, 1.0, half, reps=200) > 0.95


def test_a_confidence_sequence_is_wider_than_the_t_interval_and_tuned_before_the_trials():
    from pfbench.verdicts import cs_rho2
    est = Estimate(1.0, 0.1, 100)
    lo, hi = est.interval(0.95)
    clo, chi = est.anytime(1000).interval(0.95)
    assert clo < lo and hi < chi
    assert est.anytime(1000).rho2 == cs_rho2(1000)          # from the budget, not the data
    assert est.anytime(1000).equivalence_level(ALPHA) == 1 - ALPHA
