"""Figures of an experiment (matplotlib, in the style of pfbench.figstyle, under
``<results>/figures/``; PNG unless ``--figure-format`` says svg or pdf).

Every experiment: the distribution over trials of each filter run's RMSE, and of each other metric
the paper's table reports as a mean, beside the mean with its 95% interval (what the tables
report) and the paper's value where it gives one. SLAM experiments also, for one trial: the course
with the true and estimated paths and the mapped landmarks, the position, heading and landmark
errors over time (ifa2021 Fig. 6, afsa2014 Fig. 3), and the effective sample size over time
(afsa2014 Fig. 5). Localization experiments: the position error per step, median and interquartile
band over the first FIGURE_TRIALS trials (sspf2008's error figure), with the particle count over
time when KLD-sampling adapts it, and each filter's particles over the field at a few steps of a
trial where it converged and one where it did not. Figures never run a trial: they draw the rows
and the traces the run kept (``traces.npz``, pfbench.traces).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from . import figstyle as fs
from .config import Experiment
from .errors import UserError
from .kinds import kind_of
from .store import Traces, read_traces
from .traces import error_runs, runs_in, snapshot_runs


def save_figure(fig, path: Path) -> None:
    """Save ``fig`` to ``path`` (its suffix names the format; see figstyle.save)."""
    fs.save(fig, path)


def _run_name(run, rows: pd.DataFrame | None = None) -> str:
    """'PF (N=100)'; a run whose particle count adapts (KLD-sampling): 'KLD-MCL (N adaptive, mean
    96, at most 5000)'."""
    if run.particles is None:
        return run.label
    if rows is not None and "mean_particles" in rows:
        m = rows.loc[rows["filter"] == run.key, "mean_particles"].dropna()
        if len(m) and abs(float(m.mean()) - run.particles) > 0.5:
            return f"{run.label} (N adaptive: mean {float(m.mean()):.0f}, at most {run.particles})"
    return f"{run.label} (N={run.particles})"


def _distribution_quantities(exp: Experiment) -> list[tuple[str, float, str, object]]:
    """(metric, scale, axis label, the paper's quantity or None) of each distribution figure:
    the RMSE, and each per-trial metric the paper's table reports as a mean."""
    unit = kind_of(exp.scenario).unit
    out = [("rmse", 1.0, fs.label("rmse", unit), None)]
    table = exp.reported
    for q in (table.quantities if table is not None else ()):
        if q.stat != "mean" or q.metric in ("time_ratio", "evals_ratio", "gain_mean", "gain_var"):
            continue
        if q.metric == "rmse" and q.scale == 1.0:
            out[0] = ("rmse", 1.0, fs.label("rmse", unit), q)
        elif q.metric not in [m for m, *_ in out]:
            out.append((q.metric, q.scale, q.title, q))
    return out


def _paper_value(exp: Experiment, run, q) -> tuple[float, float] | None:
    """The paper's value of quantity ``q`` for a filter run as (low, high): a number gives (v, v),
    a range its ends; None where the paper gives none."""
    v = exp.reported.row(run.label, run.particles).get(q.key)
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return None
    return (float(v[0]), float(v[1])) if isinstance(v, tuple) else (float(v), float(v))


# the legend's names of the paper's marks
_PAPER = "the paper's value"
_PAPER_APART = "the paper's value, not comparable (see the table)"


def distribution_figure(exp: Experiment, rows: pd.DataFrame, path: Path, metric: str = "rmse",
                        scale: float = 1.0, ylabel: str = "RMSE", quantity=None,
                        table: pd.DataFrame | None = None) -> None:
    """Each filter run's ``metric`` over trials (box: quartiles, whiskers 1.5 IQR, points beyond),
    beside it the mean with its 95% interval as the table reports it (black), and the paper's
    value (red diamond; a range: a red bar) where ``quantity`` has one. A log axis where the
    values span more than a factor of 30."""
    from .metrics import summarize
    runs = list(exp.filters)
    data = [rows.loc[rows["filter"] == r.key, metric].dropna().to_numpy(float) * scale
            for r in runs]
    data = [d[np.isfinite(d)] for d in data]    # a diverged trial's inf has no place on an axis
    keep = [i for i, d in enumerate(data) if d.size]
    if not keep:
        return
    runs, data = [runs[i] for i in keep], [data[i] for i in keep]
    fig, ax = fs.pyplot().subplots(figsize=(max(6.4, 0.62 * len(runs) + 2.4), 4.4))
    pos = np.arange(1, len(runs) + 1)
    ax.boxplot(data, positions=pos - 0.12, widths=0.32, showfliers=True,
               flierprops={"markersize": 2, "alpha": 0.5}, medianprops={"color": "0.35"},
               patch_artist=True, boxprops={"facecolor": "0.93", "edgecolor": "0.45"},
               whiskerprops={"color": "0.45"}, capprops={"color": "0.45"})
    by_key = table.set_index("filter") if table is not None and len(table) else None
    means, los, his = [], [], []
    for r, d in zip(runs, data):
        q = quantity
        if by_key is not None and q is not None and f"ours_{q.key}" in by_key:
            m = by_key.loc[r.key, f"ours_{q.key}"]
            lo, hi = by_key.loc[r.key, f"ours_lo_{q.key}"], by_key.loc[r.key, f"ours_hi_{q.key}"]
        else:
            st = summarize(d)
            m, lo, hi = st["mean"], st["ci_lo"], st["ci_hi"]
        means.append(m)
        los.append(m - lo if lo == lo else 0.0)
        his.append(hi - m if hi == hi else 0.0)
    ax.errorbar(pos + 0.16, means, yerr=[los, his], fmt="o", color="black", ms=4, capsize=3,
                lw=1.1, label="mean and its 95% interval")
    shown: set[str] = set()
    if quantity is not None and by_key is not None:
        for x, r in zip(pos, runs):
            v = _paper_value(exp, r, quantity)
            if v is None:
                continue
            # a value the table calls not comparable is drawn grey: it is not the same measure
            apart = by_key.loc[r.key].get(f"kind_{quantity.key}") == "not comparable"
            c = "0.55" if apart else "#d62728"
            name = _PAPER_APART if apart else _PAPER
            lab = None if name in shown else name
            shown.add(name)
            if v[0] == v[1]:
                ax.plot([x + 0.34], [v[0]], "D", color=c, ms=6, mfc="none", mew=1.6, label=lab)
            else:
                ax.plot([x + 0.34] * 2, list(v), "-", color=c, lw=3, alpha=0.6, label=lab)
    values = np.concatenate(data)
    pos_v = values[values > 0]
    if len(pos_v) and values.min() > 0 and pos_v.max() / pos_v.min() > 30:
        ax.set_yscale("log")
    ax.set_xlim(0.4, len(runs) + 0.6)       # room for the paper's marks beside the last run
    ax.set_xticks(pos, [_run_name(r, rows) for r in runs], rotation=40, ha="right")
    ax.set_ylabel(ylabel)
    n = rows["trial"].nunique()
    paper = [w for w, name in (("red: the paper", _PAPER),
                               ("grey: the paper, not comparable", _PAPER_APART))
             if name in shown]
    ax.set_title(f"{exp.name}: {ylabel} over {n} trials (box: quartiles; black: mean, 95% "
                 "interval" + "".join(f"; {w}" for w in paper) + ")")
    ax.grid(axis="x", visible=False)
    fs.legend_outside(ax)
    save_figure(fig, path)


def _moving(x: np.ndarray, win: int, rms: bool = False) -> np.ndarray:
    """Moving mean (``rms``: root mean square) over ``win`` samples, 'valid' part."""
    if win <= 1:
        return x
    k = np.ones(win) / win
    return np.sqrt(np.convolve(x * x, k, mode="valid")) if rms else np.convolve(x, k, mode="valid")


def slam_trial_figures(exp: Experiment, traces: Traces, folder: Path, trial: int = 0,
                       fmt: str = "png", rows: pd.DataFrame | None = None) -> list[Path]:
    """The course with true and estimated paths and maps, the errors over time and the effective
    sample size over time, for one trial of a SLAM experiment (from its trace)."""
    tr = runs_in(traces.trials[trial])
    shared, world = tr[""], traces.world
    truth = shared["truth_pose"]
    runs = [(r, tr[r.key]) for r in exp.filters]
    fig, ax = fs.pyplot().subplots(figsize=(8.6, 6.4))
    if "waypoints" in world:
        wp = np.vstack([world["waypoints"], world["waypoints"][:1]])
        ax.plot(wp[:, 0], wp[:, 1], "o", color="0.6", ms=3, label="waypoints", zorder=1)
    ax.plot(world["landmarks"][:, 0], world["landmarks"][:, 1], "*", color="0.15", ms=7,
            label="landmarks", zorder=2)
    ax.plot(truth[:, 0], truth[:, 1], "-", color="black", lw=2.2, alpha=0.35, label="true path",
            zorder=3)
    for i, (r, out) in enumerate(runs):
        c = fs.colour(i)
        ax.plot(out["pose"][:, 0], out["pose"][:, 1], color=c, ls=fs.linestyle(i), lw=1.0,
                label=_run_name(r, rows), zorder=4)
        seen = out["lm_seen"].astype(bool)
        ax.plot(out["lm_est"][seen, 0], out["lm_est"][seen, 1], fs.marker(i), color=c, ms=4,
                mfc="none", mew=0.9, zorder=5)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{exp.name}, trial {trial}: true path (grey), estimated paths, and each "
                 "filter's mapped landmarks (its marker)")
    fs.legend_outside(ax)
    course = folder / f"course.{fmt}"
    save_figure(fig, course)

    t, t_obs = shared["time"], shared["obs_time"]
    T = len(t)
    win = max(1, T // 100)          # a moving RMS: a heading error per step is mostly noise
    fig, axes = fs.pyplot().subplots(3, 1, figsize=(8.6, 8.2), sharex=True)
    for i, (r, out) in enumerate(runs):
        c, ls = fs.colour(i), fs.linestyle(i)
        err = np.hypot(*(out["pose"][:, :2] - truth[:, :2]).T)
        dth = (out["pose"][:, 2] - truth[:, 2] + np.pi) % (2 * np.pi) - np.pi
        dense = T > 2000        # in an SVG or PDF, thousands of vertices a line: an image
        axes[0].plot(t, err, lw=1.0, color=c, ls=ls, label=_run_name(r, rows), rasterized=dense)
        axes[1].plot(t[win - 1:], _moving(dth, win, rms=True), lw=1.0, color=c, ls=ls,
                     rasterized=dense)
        if "lm_trace" in out:
            axes[2].plot(t_obs, out["lm_trace"], lw=1.0, color=c, ls=ls,
                         rasterized=len(t_obs) > 2000)
    axes[0].set_ylabel("position error (m)")
    axes[1].set_ylabel("heading error (rad)" + (f", RMS over {win} steps" if win > 1 else ""))
    axes[2].set_ylabel("landmark error (m)")
    axes[2].set_xlabel("time (s)")
    axes[0].set_title(f"{exp.name}, trial {trial}: errors over time (landmarks: the "
                      "highest-weight particle's map)")
    fig.tight_layout(rect=(0, 0.06, 1, 1))
    fs.legend_below(fig, axes, ncol=min(3, len(runs)))
    errors = folder / f"errors.{fmt}"
    save_figure(fig, errors)

    fig, ax = fs.pyplot().subplots(figsize=(8.6, 3.8))
    K = t_obs.shape[0]
    win = max(1, K // 50)           # a moving mean, or thousands of jumps hide each other
    for i, (r, out) in enumerate(runs):
        if r.particles is not None and out["ess"].size:
            ax.plot(t_obs[win - 1:], _moving(out["ess"], win), lw=1.1, color=fs.colour(i),
                    ls=fs.linestyle(i), label=f"{_run_name(r, rows)}: mean "
                    f"{np.mean(out['ess']):.2f}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Neff = 1 / sum W^2")
    ax.set_title(f"{exp.name}, trial {trial}: effective sample size before resampling"
                 + (f" (moving mean of {win} observations)" if win > 1 else ""))
    fs.legend_outside(ax)
    ess = folder / f"ess.{fmt}"
    save_figure(fig, ess)
    return [course, errors, ess]


def localization_error_figure(exp: Experiment, traces: Traces, path: Path,
                              rows: pd.DataFrame | None = None) -> dict:
    """Position error per step over the traced trials (median and interquartile band) of each
    shown run, with the particle count over time when a run adapts it; returns {run key: (T+1,)
    median}."""
    runs = error_runs(exp)
    trials = sorted(traces.trials)
    by_trial = [runs_in(traces.trials[k]) for k in trials]
    err = {r.key: np.asarray([tr[r.key]["error"] for tr in by_trial], dtype=float) for r in runs}
    # a particle count over the trials that report one (an optional output, given or not in
    # each trial on its own)
    count = {r.key: np.asarray([tr[r.key]["n"] for tr in by_trial if "n" in tr[r.key]])
             for r in runs if any("n" in tr[r.key] for tr in by_trial)}
    adaptive = [r for r in runs if r.key in count and np.ptp(count[r.key]) > 0]
    fig, axes = fs.pyplot().subplots(2 if adaptive else 1, 1, figsize=(8.6, 6.6 if adaptive else 4.4),
                             sharex=True, squeeze=False)
    ax = axes[0, 0]
    t = np.arange(err[runs[0].key].shape[1])
    medians = {}
    for i, r in enumerate(runs):
        q1, med, q3 = np.percentile(err[r.key], [25, 50, 75], axis=0)
        medians[r.key] = med
        c = fs.colour(i)
        # drawn widest first: a curve that lies on another's stays visible by its style
        ax.plot(t, med, color=c, ls=fs.linestyle(i), lw=2.4 - 0.35 * i,
                label=_run_name(r, rows), zorder=3 + i)
        ax.fill_between(t, q1, q3, color=c, alpha=0.12, lw=0, zorder=1)
    kidnaps = traces.world["kidnaps"]
    for kstep in kidnaps:
        ax.axvline(kstep, color="0.3", ls=":", lw=1)
    ax.axhline(float(traces.world["bound"]), color="0.5", ls="--", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{exp.name}: position error per step, median and interquartile band over "
                 f"{len(trials)} trials\n" + ("dotted: kidnappings; " if kidnaps.size else "")
                 + "dashed: the convergence bound")
    ax.grid(alpha=0.3, which="both")
    fs.legend_outside(ax)
    if adaptive:
        ax2 = axes[1, 0]
        for i, r in enumerate(runs):
            if r in adaptive:
                ax2.plot(t[1:], count[r.key].astype(float).mean(axis=0), color=fs.colour(i),
                         ls=fs.linestyle(i), lw=1.2, label=f"{r.label}: mean over trials")
        if max(np.ptp(count[r.key]) for r in adaptive) > 1000:
            ax2.set_yscale("log")
        ax2.set_ylabel("particles")
        ax2.grid(alpha=0.3, which="both")
        fs.legend_outside(ax2)
    axes[-1, 0].set_xlabel("step")
    save_figure(fig, path)
    return medians


def _outcome(rows: pd.DataFrame, kidnapped: bool) -> pd.Series | None:
    """Per row, 1.0 where the filter succeeded, else 0.0: converged, or with kidnappings,
    recovered from every one; None when the rows do not say."""
    if rows is None:
        return None
    if kidnapped and "recovery_failures" in rows:
        return (rows["recovery_failures"] == 0).astype(float)
    return rows["converged"] if "converged" in rows else None


def _snapshot_trials(exp: Experiment, traces: Traces, rows: pd.DataFrame, run,
                     kidnapped: bool = False) -> list:
    """[(trial, outcome)] to show of ``run``: among the trials with snapshots, the first where it
    succeeded (converged; with kidnappings, recovered from every one) and the first where it did
    not (one of each outcome the trials have)."""
    have = sorted(k for k, tr in traces.trials.items() if f"{run.key}/snap_xy" in tr)
    if not have:
        return []
    ok = _outcome(rows, kidnapped)
    if ok is None:
        return [(have[0], None)]
    conv = rows.assign(_ok=ok)[rows["filter"] == run.key].set_index("trial")["_ok"]
    out = []
    for want in (1.0, 0.0):
        k = next((k for k in have if k in conv.index and conv[k] == want), None)
        if k is not None:
            out.append((k, want))
    return out or [(have[0], None)]


def particle_figure(exp: Experiment, traces: Traces, path: Path,
                    rows: pd.DataFrame | None = None) -> None:
    """The particles of each filter (one run per label: the largest count) over the field at a few
    steps: of each, a trial where it converged and one where it did not (each row says which
    trial, and how often the filter converged over all trials)."""
    world = traces.world
    kidnapped = bool(np.asarray(world["kidnaps"]).size)
    panels = []                 # (run, trial, outcome)
    for r in snapshot_runs(exp):
        panels += [(r, k, o) for k, o in _snapshot_trials(exp, traces, rows, r, kidnapped)]
    first = runs_in(traces.trials[panels[0][1]])[""] if panels else None
    if first is None:
        return
    steps = first["steps"]
    fig, axes = fs.pyplot().subplots(len(panels), len(steps), figsize=(1.9 * len(steps) + 1.6,
                                                               1.95 * len(panels) + 0.6),
                             squeeze=False)
    for i, (r, k, outcome) in enumerate(panels):
        tr = runs_in(traces.trials[k])
        out, truth = tr[r.key], tr[""]["truth_pose_at"]
        has = "snap_xy" in out
        ends = np.cumsum(out["snap_drawn"]) if has else None
        rate = ""
        ok = _outcome(rows, kidnapped)
        if ok is not None:
            c = ok[rows["filter"] == r.key].dropna()
            rate = (f"\n({'recovers' if kidnapped else 'converges'} in {c.mean():.0%})"
                    if len(c) else "")
        what = ({1.0: "recovered", 0.0: "did not recover", None: ""} if kidnapped else
                {1.0: "converged", 0.0: "did not converge", None: ""})[outcome]
        for j, t in enumerate(steps):
            ax = axes[i, j]
            W, H = float(world["area"][0]), float(world["area"][1])
            ax.plot(world["beacons"][:, 0], world["beacons"][:, 1], "k^", ms=4, zorder=2)
            ax.plot(*truth[j, :2], "o", mfc="none", mec="red", ms=8, mew=1.2, zorder=3)
            est = out["pose_at"][j, :2]
            ax.plot(*est, "x", color="green", ms=6, mew=1.4, zorder=4)
            if has:     # above the markers: a collapsed cloud stays visible
                P = out["snap_xy"][ends[j] - out["snap_drawn"][j]:ends[j]]
                ax.plot(P[:, 0], P[:, 1], ".", color="tab:blue", ms=2.4, alpha=0.5, mew=0,
                        zorder=5, rasterized=True)     # in an SVG or PDF: an image, not points
            if not (0 <= est[0] <= W and 0 <= est[1] <= H):
                ax.text(0.97, 0.97, "estimate off the field", transform=ax.transAxes,
                        fontsize=6, ha="right", va="top", color="green")
            ax.set_xlim(0, W)
            ax.set_ylim(0, H)
            ax.set_aspect("equal")
            for side in ("top", "right"):
                ax.spines[side].set_visible(True)
            ax.set_xticks([0, W / 2, W] if i == len(panels) - 1 else [])
            ax.set_yticks([0, H / 2, H] if j == 0 else [])
            ax.tick_params(labelsize=6)
            if i == len(panels) - 1:
                ax.set_xticklabels([f"{v:g}" for v in (0, W / 2, W)])
                ax.set_xlabel("x (m)", fontsize=7)
            ax.grid(False)
            if i == 0:
                ax.set_title(f"step {t}" + (" (kidnapped)" if t in world["kidnaps"] else ""),
                             fontsize=8)
            if j == 0:
                ax.set_yticklabels([f"{v:g}" for v in (0, H / 2, H)])
                ax.set_ylabel(f"{r.label}, trial {k}\n{what}{rate}\ny (m)", fontsize=7)
            if has and (out["snap_count"][j] != r.particles
                        or out["snap_drawn"][j] != out["snap_count"][j]):
                drawn, n = out["snap_drawn"][j], out["snap_count"][j]
                ax.text(0.03, 0.03, f"{n} particles" + (f" ({drawn} drawn)" if drawn < n else ""),
                        transform=ax.transAxes, fontsize=6)
    w, h = float(world["area"][0]), float(world["area"][1])
    fig.suptitle(f"{exp.name}: particles (blue) over the {w:g} m x {h:g} m field, beacons "
                 "(black), true pose (red circle), estimate (green x); of each filter a trial "
                 + ("where it recovered from every kidnapping and one where it did not"
                    if kidnapped else "where it converged and one where it did not"),
                 fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


def write_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, out_dir: Path,
                  fmt: str = "png", table: pd.DataFrame | None = None,
                  into: Path | None = None) -> list[Path]:
    """Write the experiment's figures into ``out_dir/figures`` (``fmt``: png, svg or pdf) from its
    rows, its comparison's ``table`` (our means with the intervals the table reports, the
    paper's values; computed here when None) and the traces its run kept
    (``out_dir/traces.npz``); return their paths. Figures of other formats already there are
    removed (a folder holds one format). ``into``: draw into that folder instead (the HTML
    report's)."""
    if fmt not in fs.FORMATS:
        raise UserError(f"--figure-format {fmt}: one of {', '.join(fs.FORMATS)}")
    kind = kind_of(exp.scenario)
    traces = read_traces(out_dir) if kind.figures else None
    if kind.figures and (traces is None or not traces.trials):
        raise UserError(f"{out_dir}: no traces.npz to draw the figures from; run the "
                        "experiment again with --resume, which keeps its trials")
    folder = Path(into) if into is not None else Path(out_dir) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    if table is None and exp.reported is not None and len(df):
        from .compare import compare
        table = compare(exp, df).table
    paths = []
    with fs.style():
        for metric, scale, ylabel, q in _distribution_quantities(exp):
            values = df[metric].dropna() if metric in df else pd.Series(dtype=float)
            if metric != "rmse" and values.isin((0.0, 1.0)).all():
                continue        # a rate (0 or 1 a trial): its table cell says all a figure could
            path = folder / f"{metric}.{fmt}"
            distribution_figure(exp, df, path, metric, scale, ylabel, q, table)
            if path.exists():
                paths.append(path)
        if kind.figures:
            paths += globals()[kind.figures](exp, df, traces, folder, fmt)
    fs.prune(folder, paths)
    return paths


def expected_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, fmt: str = "png"
                     ) -> list[str]:
    """The names of the figures :func:`write_figures` surely draws of these rows (those that
    depend on what the traces show are left out): what an up-to-date run checks are there."""
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    names = []
    for metric, *_ in _distribution_quantities(exp):
        values = df[metric].dropna() if metric in df else pd.Series(dtype=float)
        if values.empty or (metric != "rmse" and values.isin((0.0, 1.0)).all()):
            continue
        names.append(f"{metric}.{fmt}")
    kind = kind_of(exp.scenario)
    if kind.figures == "slam_figures":
        names += [f"course.{fmt}", f"errors.{fmt}", f"ess.{fmt}"]
    elif kind.figures == "localization_figures":
        names.append(f"errors.{fmt}")
    return names


def slam_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces, folder: Path,
                 fmt: str = "png") -> list[Path]:
    """A SLAM experiment's figures of its first trial (see slam_trial_figures)."""
    return slam_trial_figures(exp, traces, folder, min(traces.trials), fmt, rows)


def localization_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces, folder: Path,
                         fmt: str = "png") -> list[Path]:
    """A localization experiment's error curves over the traced trials and its particles in a
    converged and a failed trial of each filter."""
    paths = [folder / f"errors.{fmt}", folder / f"particles.{fmt}"]
    localization_error_figure(exp, traces, paths[0], rows)
    particle_figure(exp, traces, paths[1], rows)
    return [p for p in paths if p.exists()]


SWEEP_FIGURES = ("rmse", "heading_rmse", "landmark_error")


def sweep_metrics(exp: Experiment) -> list[str]:
    """The metrics a sweep of ``exp`` draws: the RMSE, its kind's headline errors, and every
    per-trial metric its paper's table reports (a convergence rate, a final error)."""
    kind = kind_of(exp.scenario)
    out = ["rmse"] + [m for m in kind.headline
                      if m not in ("rmse", "mse", "diverged_steps", "lik_evals_per_step")]
    out += [m for m in SWEEP_FIGURES if m in kind.metrics]
    table = exp.reported
    for q in (table.quantities if table is not None else ()):
        if q.metric in kind.metrics:
            out.append(q.metric)
    return list(dict.fromkeys(out))


def sweep_figures(summ: pd.DataFrame, keys: list[str], out_dir: Path, title: str,
                  which=None, where: Path | None = None, fmt: str = "png",
                  unit: str = "", into: Path | None = None, curves: tuple = ()) -> list[Path]:
    """One figure per metric of ``which`` (default: those of SWEEP_FIGURES the summary holds; a
    sweep draws sweep_metrics of its experiment) against the first swept key, into ``where``
    (default: the folder's figures/METRIC.FMT): a line per filter (and per value of the other
    swept keys; a particle count that the sweep varies is the x axis, not a line of its own) with
    its 95% band; a log axis where the swept values span two decades or more. The paper's
    ``curves`` (pfbench.curves) of a metric's mean are drawn on its figure: the points with
    their reading-error bars, joined by a dashed line."""
    folder = Path(into) if into is not None else out_dir / "figures"
    x = keys[0]
    others = keys[1:]
    paths = []
    numeric = pd.to_numeric(summ[x], errors="coerce")
    if which is None:
        which = [m for m in SWEEP_FIGURES if f"{m}_mean" in summ]
    group = others + ["label"] + ([] if x.endswith("particles") else ["particles"])
    with fs.style():
        for m in which:
            if f"{m}_mean" not in summ or summ[f"{m}_mean"].isna().all():
                continue
            ylabel = fs.label(m, unit if m == "rmse" else "")
            fig, ax = fs.pyplot().subplots(figsize=(7.8, 4.4))
            for i, (vals, g) in enumerate(summ.groupby(group, sort=False, dropna=False)):
                vals = vals if isinstance(vals, tuple) else (vals,)
                g = g.assign(_x=pd.to_numeric(g[x], errors="coerce")).sort_values("_x")
                n = g["particles"].dropna().unique()
                name = " ".join([f"{fs.label(k)} = {v}" for k, v in zip(others, vals)]
                                + [str(vals[len(others)])]
                                + ([f"(N={int(n[0])})"] if len(n) == 1
                                   and not x.endswith("particles") else []))
                c = fs.colour(i)
                ax.plot(g["_x"], g[f"{m}_mean"], color=c, ls=fs.linestyle(i),
                        marker=fs.marker(i), ms=4, lw=1.4, label=name)
                ax.fill_between(g["_x"], g[f"{m}_ci_lo"], g[f"{m}_ci_hi"], color=c,
                                alpha=0.15, lw=0)
            from .curves import figure_points
            for j, (name, px, py, perr) in enumerate(figure_points(curves, m, x)):
                ax.errorbar(px, py, yerr=perr, color="black", ls="--", lw=1.0,
                            marker=("s", "D", "^", "v")[j % 4], ms=5, mfc="white",
                            capsize=3, label=name, zorder=5)
            pos = numeric[numeric > 0]
            if len(pos) and pos.max() / pos.min() >= 100:
                ax.set_xscale("log")
            ax.set_xlabel(fs.label(x))
            ax.set_ylabel(ylabel)
            ax.set_title(f"{title}: {ylabel}, mean over trials and its 95% interval")
            fs.legend_outside(ax)
            path = where or folder / f"{m}.{fmt}"
            path.parent.mkdir(parents=True, exist_ok=True)
            save_figure(fig, path)
            paths.append(path)
    return paths
