"""Expected curves: a paper file's curve read strictly, a sweep judged against it point by point
(a sweep on the curve reproduces it, one five margins off differs, the paper's curve is
interpolated only inside its range), the points one Holm family, and the sweep's outputs."""
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import curves as cv
from pfbench import papers
from pfbench.cli import app
from pfbench.verdicts import Margin, quantile

from .conftest import one_line_exit_2

runner = CliRunner()

CURVE = """\
paper: smith2024
citation: Smith and Lee, 2024
curves:
  fig3:
    caption: PF RMSE against the particle count
    x: {key: filters.pf.particles, title: particles}
    y: {metric: rmse, stat: mean, title: RMSE}
    filter: pf
    reading_error: {absolute: 0.05, why: read off the printed figure}
    margin: {relative: 0.1, why: a tenth}
    points: [[10, 2.0], [30, 1.5]]
"""

SWEEP = """\
paper: smith2024
curves: [fig3]
seed: 3
trials: 3
sweep:
  filters.pf.particles: [10, 20, 30, 40]
scenario:
  name: ungm
  steps: 20
filters:
  pf:
    label: PF
    particles: 10
"""


@pytest.fixture(autouse=True)
def _no_search_folders():
    yield
    papers.search_folders([])


def _sweep(tmp_path, paper=CURVE, config=SWEEP):
    (tmp_path / "papers").mkdir(exist_ok=True)
    (tmp_path / "papers" / "smith2024.yaml").write_text(paper)
    cfg = tmp_path / "sw.yaml"
    cfg.write_text(config)
    out = tmp_path / "out"
    return runner.invoke(app, ["sweep", str(cfg), "--out", str(out)]), out


@pytest.mark.parametrize("old, new, says", [
    ("metric: rmse", "metric: rmsee", "curves.fig3.y.metric: expected one of"),
    ("[[10, 2.0], [30, 1.5]]", "[[10, 2.0], [10, 1.5]]",
     "curves.fig3.points[1]: the points' x must increase: 10 follows 10"),
    ("    reading_error: {absolute: 0.05, why: read off the printed figure}\n", "",
     "curves.fig3.reading_error: missing required key"),
    ("{absolute: 0.05, why: read off the printed figure}", "{why: read off}",
     "curves.fig3.reading_error: give one of 'relative' or 'absolute'"),
    ("[[10, 2.0], [30, 1.5]]", "[[10, 2.0, 3.0]]", "curves.fig3.points[0]: a point is [x, y]"),
])
def test_a_bad_curve_is_one_line_exit_2_and_nothing_is_written(tmp_path, old, new, says):
    assert old in CURVE
    res, out = _sweep(tmp_path, paper=CURVE.replace(old, new))
    line = one_line_exit_2(res)
    assert says in line and "smith2024.yaml" in line, line
    assert not out.exists()


@pytest.mark.parametrize("old, new, says", [
    ("filters.pf.particles: [10, 20, 30, 40]", "scenario.steps: [10, 20]",
     "curves[0]: curve fig3: its x key filters.pf.particles is not swept; swept: "
     "scenario.steps"),
    ("curves: [fig3]", "curves: [fig4]", "curves[0]: paper smith2024 has no curve 'fig4'"),
    ("    particles: 10\n", "    particles: 10\n  ukf:\n    label: UKF\n", None),
])
def test_a_sweep_naming_a_curve_it_cannot_be_judged_against_is_refused(tmp_path, old, new,
                                                                        says):
    assert old in SWEEP
    paper = CURVE if says else CURVE.replace("filter: pf", "filter: [pf, ekf]")
    res, out = _sweep(tmp_path, paper=paper, config=SWEEP.replace(old, new))
    line = one_line_exit_2(res)
    assert (says or "curve fig3: no filter run 'ekf' in the config") in line, line
    assert "sw.yaml" in line
    assert not out.exists()


def test_a_sweep_is_judged_against_its_curve_and_draws_it(tmp_path):
    res, out = _sweep(tmp_path)
    assert res.exit_code == 0, res.output
    assert "curve fig3: 3 points judged" in res.output
    got = pd.read_csv(out / "curves.csv", keep_default_na=False)
    assert list(got["x"]) == [10, 20, 30, 40]
    assert list(got["how"].str[:12]) == ["", "interpolated", "", "outside the "]
    md = (out / "curves.md").read_text()
    assert "## fig3" in md and "1.75 +- 0.05 (interpolated between x = 10 and 30)" in md
    assert (out / "figures" / "rmse.png").is_file()
    # the same trials judged again give the same verdicts
    trials = pd.read_csv(out / "trials.csv").drop(columns=["crc"])
    curve = papers.read(tmp_path / "papers" / "smith2024.yaml").curves["fig3"]
    again = cv.judge((("fig3", curve),), trials, ["filters.pf.particles"], 3)
    assert list(again["verdict"]) == list(got["verdict"])


# ---------------------------------------------------------------- verdicts on constructed sweeps

def _curve(points, reading=0.0, margin=0.1, filters=("pf",)):
    return papers.Curve("test", "scenario.speed_mps", "speed", "rmse", "mean", "RMSE",
                        tuple(filters), Margin(absolute=reading, why="r"), tuple(points),
                        Margin(relative=margin, why="m") if margin else None)


def _trials(means: dict, n: int, sd: float, seed: int = 0) -> pd.DataFrame:
    """n trials per x whose RMSE has exactly the mean means[x] and standard deviation sd."""
    rng = np.random.default_rng(seed)
    rows = []
    for x, mu in means.items():
        z = rng.standard_normal(n)
        z = (z - z.mean()) / z.std(ddof=1)
        rows += [{"scenario.speed_mps": x, "trial": t, "filter": "pf@100", "label": "PF",
                  "particles": 100, "rmse": mu + sd * z[t]} for t in range(n)]
    return pd.DataFrame(rows)


POINTS = [(1.0, 2.0), (2.0, 2.5), (3.0, 3.5)]


def test_a_sweep_on_the_curve_is_reproduced_with_enough_trials():
    # the standard error 0.2 / sqrt(400) = 0.01 is a twentieth of the smallest margin (0.2)
    got = cv.judge((("c", _curve(POINTS, reading=0.02)),),
                   _trials(dict(POINTS), 400, 0.2), ["scenario.speed_mps"])
    assert list(got["kind"]) == ["reproduced"] * 3, list(got["verdict"])
    assert all("Holm over 3" in v for v in got["verdict"])
    # with 4 trials the same means decide nothing
    few = cv.judge((("c", _curve(POINTS, reading=0.02)),),
                   _trials(dict(POINTS), 4, 0.2), ["scenario.speed_mps"])
    assert "reproduced" not in set(few["kind"])


def test_a_sweep_five_margins_off_differs_at_every_point():
    off = {x: y * 1.5 for x, y in POINTS}          # 5 margins of 10% above
    got = cv.judge((("c", _curve(POINTS, reading=0.02)),), _trials(off, 400, 0.2),
                   ["scenario.speed_mps"])
    assert list(got["kind"]) == ["differs"] * 3
    assert all(v.startswith("differs (x1.50 the paper's value") for v in got["verdict"])


def test_the_paper_curve_is_interpolated_inside_its_range_and_never_extrapolated():
    c = _curve(POINTS, reading=0.1)
    assert cv.paper_at(c, 2.0) == (2.5, 0.1, "")
    y, e, how = cv.paper_at(c, 2.25)
    assert math.isclose(y, 2.75) and math.isclose(e, 0.1)
    assert how == "interpolated between x = 2 and 3"
    assert cv.paper_at(c, 0.999) is None and cv.paper_at(c, 3.001) is None
    rel = papers.Curve("t", "k", "x", "rmse", "mean", "y", ("pf",),
                       Margin(relative=0.1, why="r"), tuple(POINTS))
    assert math.isclose(cv.paper_at(rel, 1.5)[1], 0.5 * (0.2 + 0.25))
    # a sweep over 0.5 .. 3.5 on the interpolated curve: the inner points reproduced, the outer
    # ones shown and never judged
    xs = [0.5, 1.5, 2.5, 3.5]
    means = {x: (cv.paper_at(c, x) or (9.0,))[0] for x in xs}
    got = cv.judge((("c", c),), _trials(means, 400, 0.2), ["scenario.speed_mps"])
    assert list(got["kind"].fillna("")) == ["", "reproduced", "reproduced", ""]
    assert got["paper"].isna().tolist() == [True, False, False, True]
    assert got["how"][0].startswith("outside the paper's curve (x from 1 to 3)")
    assert "Holm over 2" in got["verdict"][1]
    assert cv.counts(got, "c") == ("2 points judged: 2 reproduced, 0 differ, 0 inconclusive "
                                   "(2 against the paper's curve interpolated); 2 outside the "
                                   "paper's curve, not judged")


def test_the_reading_error_widens_the_paper_value():
    # ours 0.15 above the paper's value, 40 standard errors: differs without a reading error,
    # not with a reading error of 0.2 (the paper's value is then known only to +- 0.2)
    means = {x: y + 0.15 for x, y in POINTS}
    exact = cv.judge((("c", _curve(POINTS, margin=None)),), _trials(means, 400, 0.075),
                     ["scenario.speed_mps"])
    read = cv.judge((("c", _curve(POINTS, reading=0.2, margin=None)),),
                    _trials(means, 400, 0.075), ["scenario.speed_mps"])
    assert list(exact["kind"]) == ["differs"] * 3
    assert list(read["kind"]) == ["inconclusive"] * 3


def test_holm_across_the_points_of_a_curve():
    # each point alone: a two-sided t test p-value of 0.03, 'differs' at 5%; three of them
    # together: the smallest (0.03) is above 0.05 / 3, so Holm's procedure rejects none
    n, sd = 50, 1.0
    d = quantile(1 - 0.03, n) * sd / math.sqrt(n)
    one = cv.judge((("c", _curve(POINTS[:1], margin=None)),),
                   _trials({1.0: 2.0 + d}, n, sd), ["scenario.speed_mps"])
    assert list(one["kind"]) == ["differs"]
    three = cv.judge((("c", _curve(POINTS, margin=None)),),
                     _trials({x: y + d for x, y in POINTS}, n, sd), ["scenario.speed_mps"])
    assert list(three["kind"]) == ["inconclusive"] * 3
    # one point far off: it is rejected at 0.05 / 3; the next p-value, 0.03, is above 0.05 / 2,
    # so the procedure stops and the other two stay undecided
    far = {1.0: 2.0 + 10 * d, 2.0: 2.5 + d, 3.0: 3.5 + d}
    mixed = cv.judge((("c", _curve(POINTS, margin=None)),), _trials(far, n, sd),
                     ["scenario.speed_mps"])
    assert list(mixed["kind"]) == ["differs", "inconclusive", "inconclusive"]
    assert "98.3% interval" in mixed["verdict"][0]


def test_only_the_filters_a_curve_names_are_judged():
    t = _trials(dict(POINTS), 50, 0.2)
    other = t.assign(filter="ukf", label="UKF", particles=np.nan)
    got = cv.judge((("c", _curve(POINTS, filters=("PF",))),), pd.concat([t, other]),
                   ["scenario.speed_mps"])
    assert set(got["label"]) == {"PF"} and len(got) == 3


def test_an_up_to_date_sweep_draws_its_figures_again_only_for_other_curves(tmp_path, monkeypatch):
    """A sweep whose trials are all there draws its figures only when they are not known to
    show its paper's curves as they are now: not again for the same curves, again after the
    paper's points changed, and again when they change back (the figures on disk then show the
    other ones)."""
    from pfbench import plots, tablecache
    monkeypatch.setattr(tablecache, "folder", lambda: tmp_path / "cache")
    drawn = []
    original = plots.sweep_figures

    def sweep_figures(*args, **kw):
        # the figures (not the run times', drawn beside the timings file: ``where`` given)
        if kw.get("where", args[5] if len(args) > 5 else None) is None:
            drawn.append(tuple(kw.get("curves", ())))
        return original(*args, **kw)
    monkeypatch.setattr(plots, "sweep_figures", sweep_figures)
    moved = CURVE.replace("[[10, 2.0], [30, 1.5]]", "[[10, 2.0], [30, 1.8]]")
    for paper, draws in ((CURVE, 1), (CURVE, 1), (moved, 2), (moved, 2), (CURVE, 3)):
        res, out = _sweep(tmp_path, paper=paper)
        assert res.exit_code == 0, res.output
        assert len(drawn) == draws, (paper, drawn)
        assert (out / "figures" / "rmse.png").is_file()
    assert drawn[1] != drawn[0] and drawn[2] == drawn[0]
