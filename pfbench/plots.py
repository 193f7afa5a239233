"""Figures of an experiment (matplotlib, PNG under ``<results>/figures/``).

Every experiment: the per-trial RMSE of each filter run (box plot). SLAM experiments also, for one
trial: the course with the true and estimated paths and the mapped landmarks, the position, heading
and landmark errors over time (ifa2021 Fig. 6, afsa2014 Fig. 3), and the effective sample size over
time (afsa2014 Fig. 5). Localization experiments: the position error per step, median and
interquartile band over the first FIGURE_TRIALS trials (sspf2008's error figure), with the particle
count over time when KLD-sampling adapts it, and the particles over the field at a few steps of one
trial. Figures never run a trial: they draw the rows and the traces the run kept
(``traces.npz``, pfbench.traces).
"""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from .config import Experiment  # noqa: E402
from .fsutil import write_through_temp  # noqa: E402
from .errors import UserError  # noqa: E402
from .kinds import kind_of  # noqa: E402
from .store import Traces, read_traces  # noqa: E402
from .traces import error_runs, runs_in, snapshot_runs  # noqa: E402

# Fixed metadata: the same figure gives the same bytes.
_META = {"Software": None}


def save_figure(fig, path: Path) -> None:
    """Save ``fig`` to ``path`` through a temporary file (removed if the save fails)."""
    try:
        write_through_temp(path, lambda tmp: fig.savefig(tmp, dpi=110, metadata=_META),
                           ".png")
    finally:
        plt.close(fig)


def _run_name(run) -> str:
    return run.label if run.particles is None else f"{run.label} (N={run.particles})"


def rmse_boxplot(exp: Experiment, rows: pd.DataFrame, path: Path) -> None:
    """Per-trial RMSE of every filter run."""
    data = [rows.loc[rows["filter"] == r.key, "rmse"].to_numpy() for r in exp.filters]
    fig, ax = plt.subplots(figsize=(max(6.0, 0.55 * len(data) + 2), 4.2))
    ax.boxplot(data, showfliers=True, flierprops={"markersize": 2})
    ax.set_xticks(range(1, len(data) + 1), [_run_name(r) for r in exp.filters], rotation=45,
                  ha="right", fontsize=8)
    unit = kind_of(exp.scenario).unit
    ax.set_ylabel("RMSE per trial" + (f" ({unit})" if unit else ""))
    ax.set_title(f"{exp.name}: RMSE over {len(rows['trial'].unique())} trials")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    save_figure(fig, path)


def slam_trial_figures(exp: Experiment, traces: Traces, folder: Path, trial: int = 0) -> list[Path]:
    """The course with true and estimated paths and maps, the errors over time and the effective
    sample size over time, for one trial of a SLAM experiment (from its trace)."""
    tr = runs_in(traces.trials[trial])
    shared, world = tr[""], traces.world
    truth = shared["truth_pose"]
    runs = [(r, tr[r.key]) for r in exp.filters]
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    fig, ax = plt.subplots(figsize=(8.0, 6.6))
    if "waypoints" in world:
        wp = np.vstack([world["waypoints"], world["waypoints"][:1]])
        ax.plot(wp[:, 0], wp[:, 1], "o--", color="0.7", ms=4, lw=0.8, label="waypoints")
    ax.plot(world["landmarks"][:, 0], world["landmarks"][:, 1], "k*", ms=8, label="landmarks")
    ax.plot(truth[:, 0], truth[:, 1], "k-", lw=1.6, label="true path")
    for i, (r, out) in enumerate(runs):
        c = colors[i % 10]
        ax.plot(out["pose"][:, 0], out["pose"][:, 1], "-", color=c, lw=0.9, label=_run_name(r))
        seen = out["lm_seen"]
        ax.plot(out["lm_est"][seen, 0], out["lm_est"][seen, 1], "+", color=c, ms=7, mew=1.2)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(f"{exp.name}, trial {trial}: paths and mapped landmarks (+)")
    ax.legend(fontsize=7, loc="upper right", framealpha=0.85)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    course = folder / "course.png"
    save_figure(fig, course)

    t, t_obs = shared["time"], shared["obs_time"]
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 8.4), sharex=True)
    for i, (r, out) in enumerate(runs):
        c = colors[i % 10]
        err = np.hypot(*(out["pose"][:, :2] - truth[:, :2]).T)
        dth = np.abs((out["pose"][:, 2] - truth[:, 2] + np.pi) % (2 * np.pi) - np.pi)
        axes[0].plot(t, err, lw=0.9, color=c, label=_run_name(r))
        axes[1].plot(t, dth, lw=0.9, color=c)
        if "lm_trace" in out:
            axes[2].plot(t_obs, out["lm_trace"], lw=0.9, color=c)
    axes[0].set_ylabel("position error (m)")
    axes[1].set_ylabel("heading error (rad)")
    axes[2].set_ylabel("landmark error (m)")
    axes[2].set_xlabel("time (s)")
    axes[0].set_title(f"{exp.name}, trial {trial}: errors over time (landmarks: the "
                      "highest-weight particle's map)", fontsize=9)
    axes[0].legend(fontsize=7)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    errors = folder / "errors.png"
    save_figure(fig, errors)

    fig, ax = plt.subplots(figsize=(8.0, 3.8))
    K = t_obs.shape[0]
    win = max(1, K // 50)           # a moving mean, or thousands of jumps hide each other
    for i, (r, out) in enumerate(runs):
        if r.particles is not None and out["ess"].size:
            smooth = np.convolve(out["ess"], np.ones(win) / win, mode="valid")
            ax.plot(t_obs[win - 1:], smooth, lw=1.0, color=colors[i % 10],
                    label=f"{_run_name(r)}: mean {np.mean(out['ess']):.2f}")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("Neff = 1 / sum W^2")
    ax.set_title(f"{exp.name}, trial {trial}: effective sample size before resampling"
                 + (f" (moving mean of {win} observations)" if win > 1 else ""), fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    ess = folder / "ess.png"
    save_figure(fig, ess)
    return [course, errors, ess]


def localization_error_figure(exp: Experiment, traces: Traces, path: Path) -> dict:
    """Position error per step over the traced trials (median and interquartile band) of each
    shown run, with the particle count over time when a run adapts it; returns {run key: (T+1,)
    median}."""
    runs = error_runs(exp)
    trials = sorted(traces.trials)
    by_trial = [runs_in(traces.trials[k]) for k in trials]
    err = {r.key: np.asarray([tr[r.key]["error"] for tr in by_trial], dtype=float) for r in runs}
    count = {r.key: np.asarray([tr[r.key]["n"] for tr in by_trial]) for r in runs
             if "n" in by_trial[0][r.key]}
    adaptive = [r for r in runs if r.key in count and np.ptp(count[r.key]) > 0]
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    fig, axes = plt.subplots(2 if adaptive else 1, 1, figsize=(8.0, 6.8 if adaptive else 4.4),
                             sharex=True, squeeze=False)
    ax = axes[0, 0]
    t = np.arange(err[runs[0].key].shape[1])
    medians = {}
    for i, r in enumerate(runs):
        q1, med, q3 = np.percentile(err[r.key], [25, 50, 75], axis=0)
        medians[r.key] = med
        c = colors[i % 10]
        ax.plot(t, med, color=c, lw=1.2, label=_run_name(r))
        ax.fill_between(t, q1, q3, color=c, alpha=0.18, lw=0)
    kidnaps = traces.world["kidnaps"]
    for kstep in kidnaps:
        ax.axvline(kstep, color="0.3", ls=":", lw=1)
    ax.axhline(float(traces.world["bound"]), color="0.5", ls="--", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{exp.name}: position error per step, median and interquartile band over "
                 f"{len(trials)} trials\n" + ("dotted: kidnappings; " if kidnaps.size else "")
                 + "dashed: the convergence bound", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    if adaptive:
        ax2 = axes[1, 0]
        for i, r in enumerate(runs):
            if r in adaptive:
                ax2.plot(t[1:], count[r.key].astype(float).mean(axis=0), color=colors[i % 10],
                         lw=1.2, label=f"{_run_name(r)}: mean over trials")
        if max(np.ptp(count[r.key]) for r in adaptive) > 1000:
            ax2.set_yscale("log")
        ax2.set_ylabel("particles")
        ax2.legend(fontsize=7)
        ax2.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlabel("step")
    fig.tight_layout()
    save_figure(fig, path)
    return medians


def particle_figure(exp: Experiment, traces: Traces, path: Path, trial: int = 0) -> None:
    """The particles of each filter (one run per label: the largest count) over the field at a few
    steps of one trial: the start, during global localization, after each kidnapping, the end."""
    tr = runs_in(traces.trials[trial])
    world = traces.world
    steps = tr[""]["steps"]
    truth = tr[""]["truth_pose_at"]
    runs = snapshot_runs(exp)
    fig, axes = plt.subplots(len(runs), len(steps), figsize=(1.9 * len(steps) + 0.6,
                                                             1.95 * len(runs) + 0.5),
                             squeeze=False)
    for i, r in enumerate(runs):
        out = tr[r.key]
        has = "snap_xy" in out
        ends = np.cumsum(out["snap_drawn"]) if has else None
        for j, t in enumerate(steps):
            ax = axes[i, j]
            if has:
                P = out["snap_xy"][ends[j] - out["snap_drawn"][j]:ends[j]]
                ax.plot(P[:, 0], P[:, 1], ".", color="tab:blue", ms=1.5, alpha=0.4, mew=0)
            ax.plot(world["beacons"][:, 0], world["beacons"][:, 1], "k^", ms=4)
            ax.plot(*truth[j, :2], "o", mfc="none", mec="red", ms=7, mew=1.2)
            ax.plot(*out["pose_at"][j, :2], "x", color="green", ms=6, mew=1.2)
            ax.set_xlim(0, world["area"][0])
            ax.set_ylim(0, world["area"][1])
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"step {t}" + (" (kidnapped)" if t in world["kidnaps"] else ""),
                             fontsize=8)
            if j == 0:
                ax.set_ylabel(_run_name(r), fontsize=7)
            if not has:
                ax.text(0.03, 0.03, "no particles kept", transform=ax.transAxes, fontsize=6)
            elif out["snap_count"][j] != r.particles or out["snap_drawn"][j] != r.particles:
                drawn, n = out["snap_drawn"][j], out["snap_count"][j]
                ax.text(0.03, 0.03, f"{n} particles" + (f" ({drawn} drawn)" if drawn < n else ""),
                        transform=ax.transAxes, fontsize=6)
    fig.suptitle(f"{exp.name}, trial {trial}: particles (blue), beacons (black), true pose (red "
                 "circle), estimate (green x)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


def write_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, out_dir: Path) -> list[Path]:
    """Write the experiment's figures into ``out_dir/figures`` from its rows and the traces its
    run kept (``out_dir/traces.npz``); return their paths."""
    kind = kind_of(exp.scenario)
    traces = read_traces(out_dir) if kind.figures else None
    if kind.figures and (traces is None or not traces.trials):
        raise UserError(f"{out_dir}: no traces.npz to draw the figures from; run the "
                        "experiment again with --resume, which keeps its trials")
    folder = Path(out_dir) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    paths = [folder / "rmse.png"]
    rmse_boxplot(exp, df, paths[0])
    if kind.figures:
        paths += globals()[kind.figures](exp, df, traces, folder)
    return paths


def slam_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces,
                 folder: Path) -> list[Path]:
    """A SLAM experiment's figures of its first trial (see slam_trial_figures)."""
    return slam_trial_figures(exp, traces, folder, min(traces.trials))


def localization_figures(exp: Experiment, rows: pd.DataFrame, traces: Traces,
                         folder: Path) -> list[Path]:
    """A localization experiment's error curves over the traced trials and its particles in the
    first."""
    paths = [folder / "errors.png", folder / "particles.png"]
    localization_error_figure(exp, traces, paths[0])
    particle_figure(exp, traces, paths[1], min(traces.trials))
    return paths


SWEEP_FIGURES = (("rmse", "RMSE per trial"), ("heading_rmse", "heading RMSE (rad)"),
                 ("landmark_error", "landmark error (m)"))


def sweep_figures(summ: pd.DataFrame, keys: list[str], out_dir: Path, title: str,
                  which=SWEEP_FIGURES, where: Path | None = None) -> list[Path]:
    """One figure per metric of ``which`` ((metric, axis label) pairs) against the first swept
    key, into ``where`` (default: the folder's figures/, as figures/METRIC.png); a line per
    filter run (and per value of the other swept keys) with its 95% band; a log axis where the
    values span decades."""
    folder = out_dir / "figures"
    x = keys[0]
    others = keys[1:]
    paths = []
    numeric = pd.to_numeric(summ[x], errors="coerce")
    for m, ylabel in which:
        if f"{m}_mean" not in summ or summ[f"{m}_mean"].isna().all():
            continue
        folder.mkdir(parents=True, exist_ok=True)
        fig, ax = plt.subplots(figsize=(7.2, 4.2))
        for vals, g in summ.groupby(others + ["label", "particles"], sort=False, dropna=False):
            vals = vals if isinstance(vals, tuple) else (vals,)
            g = g.assign(_x=pd.to_numeric(g[x], errors="coerce")).sort_values("_x")
            name = " ".join([f"{k.split('.')[-1]}={v}" for k, v in zip(others, vals)]
                            + [str(vals[len(others)])]
                            + ([f"N={int(vals[-1])}"] if vals[-1] == vals[-1] else []))
            line, = ax.plot(g["_x"], g[f"{m}_mean"], "o-", ms=4, label=name)
            ax.fill_between(g["_x"], g[f"{m}_ci_lo"], g[f"{m}_ci_hi"], color=line.get_color(),
                            alpha=0.18)
        pos = numeric[numeric > 0]
        if len(pos) and pos.max() / pos.min() >= 100:
            ax.set_xscale("log")
        ax.set_xlabel(x)
        ax.set_ylabel(ylabel)
        ax.set_title(f"{title}: {ylabel} (mean and 95% band)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        path = where or folder / f"{m}.png"
        save_figure(fig, path)
        paths.append(path)
    return paths
