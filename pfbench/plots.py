"""Figures of an experiment (matplotlib, PNG under ``<results>/figures/``).

Every experiment: the per-trial RMSE of each filter run (box plot). SLAM experiments also, for one
trial: the course with the true and estimated paths and the mapped landmarks, the position, heading
and landmark errors over time (ifa2021 Fig. 6, afsa2014 Fig. 3), and the effective sample size over
time (afsa2014 Fig. 5). Localization experiments: the position error per step, median and
interquartile band over the first FIGURE_TRIALS trials (sspf2008's error figure), with the particle
count over time when KLD-sampling adapts it, and the particles over the field at a few steps of one
trial. Traces are recomputed by running the trials again: each is a pure function of the
experiment and the trial index.
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
from .runner import build_model, run_filter, trial_data  # noqa: E402
from .kinds import kind_of  # noqa: E402

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


def slam_trial_figures(exp: Experiment, folder: Path, trial: int = 0) -> list[Path]:
    """The course with true and estimated paths and maps, the errors over time and the effective
    sample size over time, for one trial of a SLAM experiment."""
    model, truth, data = trial_data(exp, trial)
    runs = [(r, run_filter(exp, trial, r, model, data)[0]) for r in exp.filters]
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    fig, ax = plt.subplots(figsize=(8.0, 6.6))
    wp = np.vstack([model.waypoints, model.waypoints[:1]])
    ax.plot(wp[:, 0], wp[:, 1], "o--", color="0.7", ms=4, lw=0.8, label="waypoints")
    ax.plot(model.landmarks[:, 0], model.landmarks[:, 1], "k*", ms=8, label="landmarks")
    ax.plot(truth.pose[:, 0], truth.pose[:, 1], "k-", lw=1.6, label="true path")
    for i, (r, out) in enumerate(runs):
        c = colors[i % 10]
        ax.plot(out["pose"][:, 0], out["pose"][:, 1], "-", color=c, lw=0.9, label=_run_name(r))
        seen = out["lm_seen"].astype(bool)
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

    dt = float(model.vehicle[1])
    t = np.arange(truth.pose.shape[0]) * dt
    every = int(model.sensor[2])
    t_obs = (np.arange(1, data.obs_n.shape[0] + 1) * every) * dt
    fig, axes = plt.subplots(3, 1, figsize=(8.0, 8.4), sharex=True)
    for i, (r, out) in enumerate(runs):
        c = colors[i % 10]
        err = np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T)
        dth = np.abs((out["pose"][:, 2] - truth.pose[:, 2] + np.pi) % (2 * np.pi) - np.pi)
        axes[0].plot(t, err, lw=0.9, color=c, label=_run_name(r))
        axes[1].plot(t, dth, lw=0.9, color=c)
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
    K = data.obs_n.shape[0]
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


def _localization_runs(exp: Experiment) -> list:
    """The filter runs a localization figure shows: all of them up to 6; beyond, each label's
    smallest and largest particle count."""
    if len(exp.filters) <= 6:
        return list(exp.filters)
    keep = []
    for label in dict.fromkeys(r.label for r in exp.filters):
        runs = [r for r in exp.filters if r.label == label]
        keep += [runs[0]] if len(runs) == 1 else [min(runs, key=lambda r: r.particles),
                                                  max(runs, key=lambda r: r.particles)]
    return keep


def localization_error_figure(exp: Experiment, trials: list[int], path: Path) -> dict:
    """Position error per step over trials (median and interquartile band) of each shown run,
    with the particle count over time when a run adapts it; returns {run key: (T+1,) median}."""
    runs = _localization_runs(exp)
    err = {r.key: [] for r in runs}
    count = {r.key: [] for r in runs}
    for k in trials:
        model, truth, data = trial_data(exp, k)
        for r in runs:
            out = run_filter(exp, k, r, model, data)[0]
            err[r.key].append(np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T))
            count[r.key].append(out["n"])
    adaptive = [r for r in runs if np.ptp(np.asarray(count[r.key])) > 0]
    colors = plt.cm.tab10(np.linspace(0, 1, 10))
    fig, axes = plt.subplots(2 if adaptive else 1, 1, figsize=(8.0, 6.8 if adaptive else 4.4),
                             sharex=True, squeeze=False)
    ax = axes[0, 0]
    t = np.arange(len(err[runs[0].key][0]))
    medians = {}
    for i, r in enumerate(runs):
        e = np.asarray(err[r.key])
        q1, med, q3 = np.percentile(e, [25, 50, 75], axis=0)
        medians[r.key] = med
        c = colors[i % 10]
        ax.plot(t, med, color=c, lw=1.2, label=_run_name(r))
        ax.fill_between(t, q1, q3, color=c, alpha=0.18, lw=0)
    model = build_model(exp)
    for kstep in model.kidnaps:
        ax.axvline(kstep, color="0.3", ls=":", lw=1)
    ax.axhline(model.bound, color="0.5", ls="--", lw=0.8)
    ax.set_yscale("log")
    ax.set_ylabel("position error (m)")
    ax.set_title(f"{exp.name}: position error per step, median and interquartile band over "
                 f"{len(trials)} trials\n" + ("dotted: kidnappings; " if model.kidnaps.size else "")
                 + "dashed: the convergence bound", fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(alpha=0.3, which="both")
    if adaptive:
        ax2 = axes[1, 0]
        for i, r in enumerate(runs):
            if r in adaptive:
                n = np.asarray(count[r.key], dtype=float)
                ax2.plot(t[1:], n.mean(axis=0), color=colors[i % 10], lw=1.2,
                         label=f"{_run_name(r)}: mean over trials")
        if max(np.ptp(np.asarray(count[r.key])) for r in adaptive) > 1000:
            ax2.set_yscale("log")
        ax2.set_ylabel("particles")
        ax2.legend(fontsize=7)
        ax2.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlabel("step")
    fig.tight_layout()
    save_figure(fig, path)
    return medians


def particle_figure(exp: Experiment, path: Path, trial: int = 0) -> None:
    """The particles of each filter (one run per label: the largest count) over the field at a few
    steps of one trial: the start, during global localization, after each kidnapping, the end."""
    model, truth, data = trial_data(exp, trial)
    T = data.ctrl.shape[0]
    steps = [0, 1, 3, 10]
    for k in model.kidnaps:
        steps += [int(k), int(k) + 3]
    steps = sorted({min(t, T) for t in steps} | {T})[:8]
    runs = {}
    for r in exp.filters:
        if r.label not in runs or r.particles > runs[r.label].particles:
            runs[r.label] = r
    runs = list(runs.values())[:6]
    fig, axes = plt.subplots(len(runs), len(steps), figsize=(1.9 * len(steps) + 0.6,
                                                             1.95 * len(runs) + 0.5),
                             squeeze=False)
    for i, r in enumerate(runs):
        out = run_filter(exp, trial, r, model, data, snapshots=steps)[0]
        _, parts, counts = out["snapshots"]
        for j, t in enumerate(steps):
            ax = axes[i, j]
            P = parts[j, :counts[j]]
            ax.plot(P[:, 0], P[:, 1], ".", color="tab:blue", ms=1.5, alpha=0.4, mew=0)
            ax.plot(model.beacons[:, 0], model.beacons[:, 1], "k^", ms=4)
            ax.plot(*truth.pose[t, :2], "o", mfc="none", mec="red", ms=7, mew=1.2)
            ax.plot(*out["pose"][t, :2], "x", color="green", ms=6, mew=1.2)
            ax.set_xlim(0, model.area[0])
            ax.set_ylim(0, model.area[1])
            ax.set_aspect("equal")
            ax.set_xticks([])
            ax.set_yticks([])
            if i == 0:
                ax.set_title(f"step {t}" + (" (kidnapped)" if t in model.kidnaps else ""),
                             fontsize=8)
            if j == 0:
                ax.set_ylabel(_run_name(r), fontsize=7)
            if counts[j] != r.particles:
                ax.text(0.03, 0.03, f"{counts[j]} particles", transform=ax.transAxes,
                        fontsize=6)
    fig.suptitle(f"{exp.name}, trial {trial}: particles (blue), beacons (black), true pose (red "
                 "circle), estimate (green x)", fontsize=9)
    fig.tight_layout()
    save_figure(fig, path)


# localization figures re-run at most this many trials
FIGURE_TRIALS = 50


def write_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, out_dir: Path) -> list[Path]:
    """Write the experiment's figures into ``out_dir/figures``; return their paths."""
    folder = Path(out_dir) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    paths = [folder / "rmse.png"]
    rmse_boxplot(exp, df, paths[0])
    kind = kind_of(exp.scenario)
    if kind.figures:
        paths += globals()[kind.figures](exp, df, folder)
    return paths


def slam_figures(exp: Experiment, rows: pd.DataFrame, folder: Path) -> list[Path]:
    """A SLAM experiment's figures of one trial (see slam_trial_figures)."""
    return slam_trial_figures(exp, folder)


def localization_figures(exp: Experiment, rows: pd.DataFrame, folder: Path) -> list[Path]:
    """A localization experiment's error curves over trials and its particles in one trial."""
    trials = sorted(rows["trial"].unique())[:FIGURE_TRIALS]
    paths = [folder / "errors.png", folder / "particles.png"]
    localization_error_figure(exp, [int(k) for k in trials], paths[0])
    particle_figure(exp, paths[1], int(trials[0]))
    return paths


def sweep_figures(summ: pd.DataFrame, keys: list[str], out_dir: Path, title: str) -> list[Path]:
    """One figure per metric against the first swept key; a line per filter run (and per value
    of the other swept keys) with its 95% band; a log axis where the values span decades."""
    folder = out_dir / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    x = keys[0]
    others = keys[1:]
    paths = []
    numeric = pd.to_numeric(summ[x], errors="coerce")
    for m, ylabel in (("rmse", "RMSE per trial"), ("wall_s", "wall time per trial (s)"),
                      ("heading_rmse", "heading RMSE (rad)"),
                      ("landmark_error", "landmark error (m)")):
        if f"{m}_mean" not in summ or summ[f"{m}_mean"].isna().all():
            continue
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
        path = folder / f"{m}.png"
        save_figure(fig, path)
        paths.append(path)
    return paths
