"""Expected curves: a sweep judged point by point against a curve a paper gives.

A paper file's ``curves:`` section (pfbench.papers.Curve) gives a figure's values, or a table's
row, as points (x, y) over a config key, each known to within a declared reading error. A sweep
config names the curves it is judged against (``curves: [NAME, ...]`` beside ``paper:``); the
curve's x key must be one of the keys it sweeps.

At each swept value x of that key, for each filter run the curve is about:

- the paper's value p(x): the point's y where x is one of the curve's points (to 1e-9
  relative); inside the curve's range, the linear interpolation between the two points around
  it (said so in the row); outside it, none (never extrapolated: the row is shown, not judged);
- the reading error e(x) (interpolated the same way) widens p into the range [p - e, p + e],
  judged as a paper's range is (pfbench.verdicts): 'reproduced' when our equivalence interval
  lies within the range widened by the curve's margin, 'differs' when our interval misses the
  range, 'inconclusive' otherwise;
- the points of one curve are one family, as the cells of one table: Holm's procedure adjusts
  each kind of claim across them (verdicts.decide_family).

``judge`` returns a row per point; ``write`` puts them in the sweep's folder as curves.csv and
curves.md.
"""
from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from .fsutil import atomic_write
from .papers import Curve, Quantity
from .schema import ConfigError, did_you_mean
from .store import write_csv
from .verdicts import ALPHA, Claim, decide_family, percent

if TYPE_CHECKING:     # pandas loads where a curve is judged: an up-to-date sweep replays without it
    import pandas as pd

FILES = ("curves.csv", "curves.md")


def resolve(names, keys: list[str], cells) -> tuple:
    """The curves a sweep names, as ((name, Curve), ...), checked against the sweep: each a
    curve of its paper, its x key swept with numeric values, each of its filters a run of the
    config, its metric one the scenario's trials have (ConfigError at the key 'curves')."""
    if names is None:
        return ()
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, list) or not all(isinstance(n, str) and n for n in names):
        raise ConfigError("curves", f"expected a list of curve names of the paper, got "
                          f"{names!r}")
    if not names:
        return ()
    exp = cells[0].exp
    if exp.reference is None:
        raise ConfigError("curves", "needs 'paper' too: the paper file whose curves they are")
    from .kinds import kind_of
    have = exp.reference.curves
    out = []
    for i, name in enumerate(names):
        where = f"curves[{i}]"
        if name not in have:
            raise ConfigError(where, f"paper {exp.reference.key} has no curve '{name}'"
                              + did_you_mean(name, list(have))
                              + (f"; curves: {', '.join(have)}" if have else
                                 "; its file declares none"))
        c = have[name]
        if c.x_key not in keys:
            raise ConfigError(where, f"curve {name}: its x key {c.x_key} is not swept; swept: "
                              f"{', '.join(keys)}")
        for cell in cells:
            x = cell.values[c.x_key]
            if isinstance(x, bool) or not isinstance(x, (int, float)) or not math.isfinite(x):
                raise ConfigError(where, f"curve {name}: the swept value {x!r} of {c.x_key} is "
                                  "not a finite number")
        runs = {r for cell in cells for f in cell.exp.filters for r in (f.name, f.key, f.label)}
        for f in c.filters:
            if f not in runs:
                raise ConfigError(where, f"curve {name}: no filter run '{f}' in the config"
                                  + did_you_mean(f, sorted(runs))
                                  + "; filters: "
                                  + ", ".join(sorted({x.name for x in exp.filters})))
        kind = kind_of(exp.scenario)
        if c.metric not in kind.metrics:
            raise ConfigError(where, f"curve {name}: metric {c.metric} is not one of a "
                              f"{exp.scenario} trial's ({', '.join(kind.metrics)})")
        out.append((name, c))
    return tuple(out)


def _same(a: float, b: float) -> bool:
    return math.isclose(a, b, rel_tol=1e-9, abs_tol=1e-12)


def paper_at(curve: Curve, x: float) -> tuple[float, float, str] | None:
    """(the paper's value at x, its reading error there, how it was found: '' at a point,
    'interpolated between x = a and b' inside the range); None outside the curve's range."""
    xs = [p[0] for p in curve.points]
    ys = [p[1] for p in curve.points]
    err = curve.reading_error
    for px, py in curve.points:
        if _same(x, px):
            return py, err.width(py), ""
    if not xs[0] < x < xs[-1]:
        return None
    j = next(k for k in range(1, len(xs)) if x < xs[k])
    t = (x - xs[j - 1]) / (xs[j] - xs[j - 1])
    y = ys[j - 1] + t * (ys[j] - ys[j - 1])
    e = err.width(ys[j - 1]) + t * (err.width(ys[j]) - err.width(ys[j - 1]))
    return y, e, f"interpolated between x = {xs[j - 1]:g} and {xs[j]:g}"


def _matches(curve: Curve, run_key: str, label: str) -> bool:
    return any(f in (run_key, run_key.split("@")[0], label) for f in curve.filters)


def _quantity(name: str, c: Curve) -> Quantity:
    return Quantity(name, c.y_title, c.metric, c.stat, scale=c.scale, margin=c.margin)


def judge(curves: tuple, trials: pd.DataFrame, keys: list[str], seed: int = 0) -> pd.DataFrame:
    """A row per curve, swept cell and filter run the curve is about: the paper's value there
    (paper_at), ours with its 95% interval, and the verdict (the curve's points judged together,
    Holm-adjusted). ``trials``: the sweep's trials (a column per swept key)."""
    import pandas as pd

    from .compare import estimate
    rows = []
    for name, c in curves:
        q = _quantity(name, c)
        claims, here = [], []
        lo_x, hi_x = c.points[0][0], c.points[-1][0]
        for vals, g in trials.groupby(keys + ["filter", "label"], sort=False, dropna=False):
            run_key, label = vals[-2], vals[-1]
            if not _matches(c, str(run_key), str(label)):
                continue
            cell = dict(zip(keys, vals[:len(keys)]))
            x = float(cell[c.x_key])
            est = estimate(q, g, None, seed,
                           f"curve:{name}:{','.join(f'{k}={cell[k]}' for k in keys)}:{run_key}")
            r = {"curve": name, **cell, "filter": run_key, "label": label,
                 "particles": g["particles"].iloc[0], "x": x, "trials": est.n, "ours": est.value,
                 "ours_se": est.se}
            r["ours_lo"], r["ours_hi"] = est.interval(1 - ALPHA)
            at = paper_at(c, x)
            if at is None:
                r.update(paper=math.nan, reading_error=math.nan, paper_lo=math.nan,
                         paper_hi=math.nan, ratio=math.nan,
                         how=f"outside the paper's curve (x from {lo_x:g} to {hi_x:g}): not "
                             "judged")
                paper = None
            else:
                p, e, how = at
                r.update(paper=p, reading_error=e, paper_lo=p - e, paper_hi=p + e,
                         ratio=est.value / p if p else math.nan, how=how)
                paper = (p - e, p + e) if e > 0 else p
            claims.append(Claim(paper, est, c.margin, c.runs))
            here.append(r)
        for r, v in zip(here, decide_family(claims)):
            # a point's range is the paper's value widened by its reading error
            text = (v.text.replace("the range's middle", "the paper's value")
                    .replace("lies in the range", "lies within the paper's value +- its "
                             "reading error"))
            r.update(kind=v.kind, verdict=text or r["how"], verdict_lo=v.lo,
                     verdict_hi=v.hi, verdict_level=v.level)
            rows.append(r)
    return pd.DataFrame(rows)


def counts(frame: pd.DataFrame, name: str) -> str:
    """'3 points judged: 1 reproduced, 2 differ, 0 inconclusive; 4 outside the curve'."""
    g = frame[frame["curve"] == name]
    k = g["kind"].fillna("")
    judged = int(k.isin(["reproduced", "differs", "inconclusive"]).sum())
    out = (f"{judged} point{'s' if judged != 1 else ''} judged: "
           f"{int((k == 'reproduced').sum())} reproduced, {int((k == 'differs').sum())} "
           f"differ{'s' if int((k == 'differs').sum()) == 1 else ''}, "
           f"{int((k == 'inconclusive').sum())} inconclusive")
    inter = int(g["how"].str.startswith("interpolated").sum())
    if inter:
        out += f" ({inter} against the paper's curve interpolated)"
    outside = int(g["paper"].isna().sum())
    if outside:
        out += f"; {outside} outside the paper's curve, not judged"
    other = int(((k == "not comparable") | ((k == "") & g["paper"].notna())).sum())
    if other:
        out += f"; {other} without a finite result"
    return out


def describe(name: str, c: Curve) -> str:
    """The lines above a curve's table: what it is, the reading error, the margin."""
    who = ", ".join(c.filters)
    margin = (f"margin {c.margin.describe()} ({c.margin.why.rstrip('.')})" if c.margin else
              "no margin declared (never called reproduced)")
    return (f"{c.caption} x: {c.x_title} ({c.x_key}); y: {c.y_title}, the {c.stat} over "
            f"trials of {c.metric}" + (f" x {c.scale:g}" if c.scale != 1 else "")
            + f", for {who}. Each value read to within {c.reading_error.describe()} "
            f"({c.reading_error.why.rstrip('.')}); {margin}.")


def _num(v: float) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.4g}"


def markdown(curves: tuple, frame: pd.DataFrame, keys: list[str]) -> str:
    """curves.md: per curve, what it is, the counts, and a row per point."""
    lines = ["# The sweep against the papers' curves", "",
             "Each point: the paper's value (interpolated linearly between its points where the "
             "sweep's x lies between them; never beyond them) widened by its reading error, "
             "judged as a paper's range; the points of a curve are judged together (Holm). "
             f"Ours: the mean over trials with its {percent(1 - ALPHA)} interval.", ""]
    others = list(keys)
    for name, c in curves:
        g = frame[frame["curve"] == name] if len(frame) else frame
        lines += [f"## {name}", "", describe(name, c), "", counts(frame, name) + ".", ""]
        for note in c.notes:
            lines.append(f"- {note}")
        if c.notes:
            lines.append("")
        head = [k.split(".")[-1] for k in others] + ["Filter", "N", "paper", "ours [95% CI]",
                                                     "verdict"]
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        for _, r in g.iterrows():
            paper = ("-" if math.isnan(r["paper"]) else
                     f"{r['paper']:.4g} +- {r['reading_error']:.2g}"
                     + (f" ({r['how']})" if r["how"].startswith("interpolated") else ""))
            n = r["particles"]
            cells = [str(r[k]) for k in others] + [
                str(r["label"]), "-" if n != n or n is None else str(int(n)), paper,
                f"{_num(r['ours'])} [{_num(r['ours_lo'])}, {_num(r['ours_hi'])}]",
                str(r["verdict"]).replace("|", "/")]
            lines.append("| " + " | ".join(cells) + " |")
        lines.append("")
    return "\n".join(lines)


def write(folder: Path, curves: tuple, frame: pd.DataFrame, keys: list[str]) -> list[Path]:
    """curves.csv and curves.md in a sweep's folder (none, and any stale ones removed, when the
    sweep names no curve)."""
    paths = [Path(folder) / f for f in FILES]
    if not curves:
        for p in paths:
            if p.is_file():
                p.unlink()
        return []
    write_csv(paths[0], frame)
    atomic_write(paths[1], markdown(curves, frame, keys))
    return paths


def figure_points(curves: tuple, metric: str, x_key: str):
    """The paper's curves to draw on a sweep's figure of ``metric`` (its means) against
    ``x_key``: (label, x, y, reading error) in our metric's unit, for each curve of that
    metric's mean over that key."""
    out = []
    for name, c in curves:
        if c.metric == metric and c.stat == "mean" and c.x_key == x_key:
            xs = np.array([p[0] for p in c.points])
            ys = np.array([p[1] for p in c.points])
            err = np.array([c.reading_error.width(y) for y in ys])
            out.append((f"paper: {name} ({', '.join(c.filters)})", xs, ys / c.scale,
                        err / c.scale))
    return out
