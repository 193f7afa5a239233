"""Figures of an experiment (matplotlib, PNG under ``<results>/figures/``).

Every experiment: the per-trial RMSE of each filter run (box plot). SLAM experiments also, for one
trial: the course with the true and estimated paths and the mapped landmarks, the position, heading
and landmark errors over time (ifa2021 Fig. 6, afsa2014 Fig. 3), and the effective sample size over
time (afsa2014 Fig. 5). One trial's traces are recomputed by running that
trial again: it is a pure function of the experiment and the trial index.
"""
from __future__ import annotations

import os
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from .config import Experiment  # noqa: E402
from .runner import run_filter, trial_data  # noqa: E402
from .scenarios import SCENARIOS  # noqa: E402

# Fixed metadata: the same figure gives the same bytes.
_META = {"Software": None}


def _save(fig, path: Path) -> None:
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}.png")
    fig.savefig(tmp, dpi=110, metadata=_META)
    plt.close(fig)
    os.replace(tmp, path)


def _run_name(run) -> str:
    return run.label if run.particles is None else f"{run.label} (N={run.particles})"


def rmse_boxplot(exp: Experiment, rows: pd.DataFrame, path: Path) -> None:
    """Per-trial RMSE of every filter run."""
    data = [rows.loc[rows["filter"] == r.key, "rmse"].to_numpy() for r in exp.filters]
    fig, ax = plt.subplots(figsize=(max(6.0, 0.55 * len(data) + 2), 4.2))
    ax.boxplot(data, showfliers=True, flierprops={"markersize": 2})
    ax.set_xticks(range(1, len(data) + 1), [_run_name(r) for r in exp.filters], rotation=45,
                  ha="right", fontsize=8)
    ax.set_ylabel("RMSE per trial" + (" (m)" if _kind(exp) == "slam" else ""))
    ax.set_title(f"{exp.name}: RMSE over {len(rows['trial'].unique())} trials")
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    _save(fig, path)


def _kind(exp: Experiment) -> str:
    return getattr(SCENARIOS[exp.scenario], "KIND", "scalar")


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
    _save(fig, course)

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
    _save(fig, errors)

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
    _save(fig, ess)
    return [course, errors, ess]


def write_figures(exp: Experiment, rows: list[dict] | pd.DataFrame, out_dir: Path) -> list[Path]:
    """Write the experiment's figures into ``out_dir/figures``; return their paths."""
    folder = Path(out_dir) / "figures"
    folder.mkdir(parents=True, exist_ok=True)
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(rows)
    paths = [folder / "rmse.png"]
    rmse_boxplot(exp, df, paths[0])
    if _kind(exp) == "slam":
        paths += slam_trial_figures(exp, folder)
    return paths
