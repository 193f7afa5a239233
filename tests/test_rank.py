"""Many filters at once (pfbench.rank, ``pfbench rank``): blocks, the Friedman test against
scipy and its textbook formula, Wilcoxon-Holm pairs against Holm's procedure as the closed test
of Bonferroni's (conftest.holm_by_closure), the diagram's cliques."""
import json

import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2, friedmanchisquare, wilcoxon
from typer.testing import CliRunner

from pfbench import rank as rk
from pfbench.cli import app
from pfbench.dataset import load_trials

from .conftest import ROOT, holm_by_closure, one_line_exit_2, tree

runner = CliRunner()


def _trials(values: dict, ns=(50,), trials=10, extra=None) -> pd.DataFrame:
    """A trials frame: ``values[label](trial, n)`` the rmse of filter ``label`` at N = n."""
    rows = []
    for n in ns:
        for t in range(trials):
            for label, f in values.items():
                rows.append({"trial": t, "filter": f"{label.lower()}@{n}", "label": label,
                             "particles": n, "rmse": f(t, n)})
    for label, n in (extra or ()):
        rows += [{"trial": t, "filter": f"{label.lower()}@{n}", "label": label,
                  "particles": n, "rmse": 1.0} for t in range(trials)]
    return pd.DataFrame(rows)


def test_friedman_matches_scipy_and_the_textbook_formula_when_the_order_never_changes():
    # A < B < C in every one of 2 x 10 blocks: ranks 1, 2, 3 exactly, and Friedman's statistic
    # 12 n / (k (k + 1)) (sum R_j^2 - k (k + 1)^2 / 4) = 20 (14 - 12) = 40 on 2 degrees of freedom
    df = _trials({"A": lambda t, n: 1.0 + t, "B": lambda t, n: 2.0 + t,
                  "C": lambda t, n: 3.0 + t + n}, ns=(50, 100))
    r = rk.rank(df)
    assert r.filters == ["A", "B", "C"] and r.blocks == 20
    assert r.average_ranks == {"A": 1.0, "B": 2.0, "C": 3.0}
    assert r.friedman == pytest.approx(40.0, rel=1e-12)
    assert r.friedman_p == pytest.approx(chi2.sf(40.0, 2), rel=1e-9)


def test_friedman_and_wilcoxon_on_noisy_blocks_are_scipys_and_holm_is_the_closed_test():
    rng = np.random.default_rng(5)
    shift = {"A": 0.0, "B": 0.3, "C": 0.35, "D": 1.0}
    noise = {(t, lab): rng.normal() for t in range(40) for lab in shift}
    df = _trials({lab: (lambda t, n, lab=lab: shift[lab] + noise[(t, lab)]) for lab in shift},
                 trials=40)
    r = rk.rank(df)
    m = np.array([[shift[lab] + noise[(t, lab)] for lab in shift] for t in range(40)])
    stat, p = friedmanchisquare(*m.T)
    assert r.friedman == pytest.approx(stat, rel=1e-12) and r.friedman_p == pytest.approx(p)
    col = {lab: i for i, lab in enumerate(shift)}
    ps = [wilcoxon(m[:, col[q.a]] - m[:, col[q.b]]).pvalue for q in r.pairs]
    assert [q.p for q in r.pairs] == pytest.approx(ps, rel=1e-12)
    reject = holm_by_closure(ps, 0.05)
    assert [q.differs for q in r.pairs] == reject
    assert len(r.pairs) == 6 and any(reject) and not all(reject)   # the case can fail both ways


def test_blocks_keep_the_filters_at_every_shared_n_and_drop_nans():
    df = _trials({"A": lambda t, n: 1.0, "B": lambda t, n: 2.0 if t else float("nan")},
                 ns=(50, 100), extra=[("C", 100), ("D", 5000)])
    values, names, points, left, dropped = rk.block_matrix(df)
    # C ran only at N = 100 of the points where two or more filters ran; D alone at N = 5000
    assert names == ["A", "B"] and left == ["C", "D"]
    assert [p["particles"] for p in points] == [50, 100]
    assert values.shape == (18, 2) and dropped == 2          # trial 0 of both N: B is NaN
    # chosen filters: the points where every one of them ran
    values, names, points, left, dropped = rk.block_matrix(df, filters=["A", "C"])
    assert names == ["A", "C"] and [p["particles"] for p in points] == [100]
    with pytest.raises(rk.UserError, match="no such filter"):
        rk.block_matrix(df, filters=["A", "E"])
    with pytest.raises(rk.UserError, match="no such column"):
        rk.block_matrix(df, metric="nees")


def test_higher_is_better_ranks_the_largest_first():
    df = _trials({"A": lambda t, n: 0.0, "B": lambda t, n: 1.0, "C": lambda t, n: 0.5})
    df["converged"] = df["rmse"]
    r = rk.rank(df, "converged")
    assert r.filters == ["B", "C", "A"] and r.average_ranks["B"] == 1.0


@pytest.mark.parametrize("differ, want", [
    (set(), [["a", "b", "c", "d"]]),
    ({("a", "c"), ("a", "d"), ("b", "d")}, [["a", "b"], ["b", "c"], ["c", "d"]]),
    ({("a", "b"), ("a", "c"), ("a", "d"), ("b", "c"), ("b", "d"), ("c", "d")}, []),
    ({("a", "d")}, [["a", "b", "c"], ["b", "c", "d"]]),
    # b and d differ, a - c do not: a run stops at the first filter that differs from one in it
    ({("b", "d"), ("a", "d")}, [["a", "b", "c"], ["c", "d"]]),
])
def test_cliques_are_the_longest_runs_of_filters_no_two_of_which_differ(differ, want):
    order = ["a", "b", "c", "d"]
    d = {frozenset((x, y)): (x, y) in differ or (y, x) in differ
         for i, x in enumerate(order) for y in order[i + 1:]}
    assert rk.cliques(order, d) == want


def test_rank_the_committed_results_and_draw_the_diagram(tmp_path):
    folder = ROOT / "results" / "ifa_pf_ungm"
    res = runner.invoke(app, ["rank", str(folder), "--json", "--out", str(tmp_path / "cd")])
    assert res.exit_code == 0, res.output
    d = json.loads(res.output)
    r = rk.rank(load_trials(folder))
    assert d["filters"] == r.filters and d["blocks"] == r.blocks == 1500
    assert (tmp_path / "cd" / "cd_rmse.png").stat().st_size > 10_000


TWO_PFS = """\
seed: 3
trials: 12
scenario:
  name: ungm
  steps: 20
filters:
  pf:
    label: PF
    particles: [20, 40]
  ba:
    label: BA-PF
    particles: [20, 40]
  ukf:
    label: UKF
"""


def test_a_runs_table_md_ranks_its_filters_at_once(tmp_path, write_config):
    out = tmp_path / "o"
    res = runner.invoke(app, ["run", str(write_config(TWO_PFS)), "--out", str(out),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    r = rk.rank(load_trials(out))
    # the UKF (no particle count) shares no N with the PFs: left out; 12 trials x 2 N blocks
    assert sorted(r.filters) == ["BA-PF", "PF"] and r.left_out == ["UKF"] and r.blocks == 24
    md = (out / "table.md").read_text()
    section = md[md.index("## All filters at once"):]
    for f in r.filters:
        assert f"| {f} | {r.average_ranks[f]:.2f} |" in section
    assert "Two filters: the Wilcoxon test alone" in section


def test_rank_refuses_bad_input_in_one_line_and_writes_nothing(tmp_path):
    folder = str(ROOT / "results" / "ifa_pf_ungm")
    before = tree(tmp_path)
    for args in (["rank", str(tmp_path / "none")],
                 ["rank", folder, "--metric", "nees", "--out", str(tmp_path / "o")],
                 ["rank", folder, "--filter", "PF", "--out", str(tmp_path / "o")],
                 ["rank", folder, folder]):
        one_line_exit_2(runner.invoke(app, args))
    assert tree(tmp_path) == before and not (tmp_path / "o").exists()


@pytest.mark.parametrize("k", [2, 3, 6, 8])
def test_min_blocks_is_where_wilcoxon_first_can_reject_under_holm(k):
    """On min_blocks(k) blocks all one way, scipy's exact Wilcoxon p reaches Holm's first
    level; on one block fewer it cannot."""
    from scipy.stats import wilcoxon
    from pfbench.rank import ALPHA, min_blocks
    m = k * (k - 1) // 2
    n = min_blocks(k)
    assert wilcoxon(np.arange(1.0, n + 1)).pvalue <= ALPHA / m
    assert wilcoxon(np.arange(1.0, n)).pvalue > ALPHA / m
