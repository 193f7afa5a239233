"""What a figure needs from a trial, kept while the trial runs.

Figures never run a trial again: a scenario kind names the trials whose traces it keeps (the
error curves of both kinds the first FIGURE_TRIALS trials; SLAM's course, map and effective
sample size trial 0; localization's particle snapshots the first SNAPSHOT_TRIALS and its paths
the first PATH_TRIALS) and what it keeps of them. A trace is a flat mapping of names to
arrays: ``FIELD`` for what the trial shares (``truth_pose``), ``RUN_KEY/FIELD`` for one filter run;
the world every trial shares (landmarks, beacons) is kept once. Plotted values are stored as
float32. The runner writes them to ``traces.npz`` in the results folder (pfbench.store) and the
figures (pfbench.plots) read them from there.

A tracer (one per kind with figures) has:

    keeps(exp, trial) -> bool: whether trial ``trial`` keeps a trace
    extras(exp, model, data, trial) -> {run key: keyword arguments its filter's run takes}
    keep(exp, trial, model, truth, data, outs) -> the trace ({run key: output} in ``outs``)
    world(exp, model) -> the arrays of the world the figures draw
"""
from __future__ import annotations

import numpy as np

# error curves (localization and SLAM) are drawn over at most this many trials
FIGURE_TRIALS = 50
# a SLAM error curve keeps at most about this many points of a trial (every k-th step or
# observation): a median over trials drawn at page width needs no more, and traces.npz stays small
SLAM_CURVE_POINTS = 300
# The trials whose particle snapshots are kept: a snapshot figure shows, of each filter, a trial
# where it converged and one where it did not, found among them.
SNAPSHOT_TRIALS = 10
# particles kept per snapshot (evenly strided over the set: after resampling their order is
# arbitrary, so every k-th particle is a fair sample)
SNAPSHOT_PARTICLES = 600
# The trials whose paths (the true one, each path_runs run's estimate) are kept for the paths
# figure, and the most points of a path kept: a longer span keeps every k-th step (and the last)
PATH_TRIALS = 1
PATH_POINTS = 2000


def _f32(a) -> np.ndarray:
    return np.asarray(a, dtype=np.float32)


def curve_stride(n: int) -> int:
    """The stride k that keeps at most about SLAM_CURVE_POINTS of ``n`` values (every k-th, the
    first included); 1 when they are that few."""
    return max(1, -(-(n - 1) // SLAM_CURVE_POINTS))


def slam_error_curves(pose, truth_pose, time, lm_trace, obs_time) -> dict:
    """A SLAM run's error curves as its figures draw them, every k-th step (k =
    curve_stride(T+1)): 'error' the position error (m) at those steps, 'heading_error' the
    RMS heading error (rad) over the w = max(k, (T+1) // 100) steps up to each (the heading
    error of one step is mostly noise), 'error_time' their times (s), 'heading_window_s' w steps
    in seconds; with ``lm_trace`` (K,) (the map error after each
    observation, m; None without), 'map_error' every k'-th of it (k' = curve_stride(K)) and
    'map_time' its times. Float32 arrays."""
    pose, truth_pose = np.asarray(pose, dtype=float), np.asarray(truth_pose, dtype=float)
    k = curve_stride(pose.shape[0])
    d = pose - truth_pose
    dth = (d[:, 2] + np.pi) % (2 * np.pi) - np.pi
    cum = np.concatenate([[0.0], np.cumsum(dth * dth)])
    at = np.arange(0, pose.shape[0], k)
    w = max(k, pose.shape[0] // 100)
    lo = np.maximum(at - w + 1, 0)
    out = {"error": _f32(np.hypot(d[at, 0], d[at, 1])),
           "heading_error": _f32(np.sqrt((cum[at + 1] - cum[lo]) / (at + 1 - lo))),
           "error_time": _f32(np.asarray(time)[at]),
           "heading_window_s": np.asarray(w * (time[1] - time[0]) if len(time) > 1 else 0.0)}
    if lm_trace is not None:
        kk = curve_stride(len(lm_trace))
        out["map_error"] = _f32(np.asarray(lm_trace)[::kk])
        out["map_time"] = _f32(np.asarray(obs_time)[::kk])
    return out


# what slam_error_curves gives that every run of a trial shares: kept once per trial
SLAM_SHARED_CURVES = ("error_time", "heading_window_s", "map_time")


def split_curves(curves: dict) -> tuple[dict, dict]:
    """slam_error_curves' output as (what every run of the trial shares, SLAM_SHARED_CURVES;
    the run's own curves)."""
    shared = {n: curves[n] for n in SLAM_SHARED_CURVES if n in curves}
    return shared, {n: a for n, a in curves.items() if n not in shared}


class SlamTracer:
    """The first FIGURE_TRIALS trials: each run's error curves (slam_error_curves: position and
    heading error every k-th step, map error every k'-th observation) and their times. Trial 0
    also: the true path; each run's path, final map, landmark error per observation and
    effective sample size per update; the time of each step and observation."""

    def keeps(self, exp, trial: int) -> bool:
        return trial < FIGURE_TRIALS

    def extras(self, exp, model, data, trial: int) -> dict:
        return {}

    def keep(self, exp, trial, model, truth, data, outs) -> dict:
        T = truth.pose.shape[0] - 1
        K = data.obs_n.shape[0]
        vehicle, sensor = getattr(model, "vehicle", None), getattr(model, "sensor", None)
        dt = float(vehicle[1]) if vehicle is not None else 1.0
        every = int(sensor[2]) if sensor is not None else max(1, T // max(K, 1))
        time, obs_time = np.arange(T + 1) * dt, np.arange(1, K + 1) * every * dt
        trace = {}
        if trial == 0:
            trace = {"truth_pose": _f32(truth.pose), "time": _f32(time),
                     "obs_time": _f32(obs_time)}
        for key, out in outs.items():
            shared, own = split_curves(slam_error_curves(out["pose"], truth.pose, time,
                                                         out.get("lm_trace"), obs_time))
            trace.update(shared)
            trace.update({f"{key}/{name}": a for name, a in own.items()})
            if trial == 0:
                trace[f"{key}/pose"] = _f32(out["pose"])
                trace[f"{key}/lm_est"] = _f32(out["lm_est"])
                trace[f"{key}/lm_seen"] = np.asarray(out["lm_seen"]).astype(bool)
                trace[f"{key}/ess"] = _f32(out.get("ess", np.empty(0)))
                if "lm_trace" in out:
                    trace[f"{key}/lm_trace"] = _f32(out["lm_trace"])
        return trace

    def world(self, exp, model) -> dict:
        world = {"landmarks": _f32(model.landmarks)}
        if getattr(model, "waypoints", None) is not None:
            world["waypoints"] = _f32(model.waypoints)
        return world


def error_runs(exp) -> list:
    """The filter runs a localization error figure shows: all of them up to 6; beyond, each
    label's smallest and largest particle count."""
    if len(exp.filters) <= 6:
        return list(exp.filters)
    keep = []
    for label in dict.fromkeys(r.label for r in exp.filters):
        runs = [r for r in exp.filters if r.label == label]
        keep += [runs[0]] if len(runs) == 1 else [min(runs, key=lambda r: r.particles),
                                                  max(runs, key=lambda r: r.particles)]
    return keep


def snapshot_runs(exp) -> list:
    """The filter runs whose particles a snapshot figure shows: one per label (its largest
    particle count), at most 6."""
    return path_runs(exp)[:6]


def snapshot_steps(T: int, kidnaps) -> list[int]:
    """The steps a snapshot figure shows: the start, early in global localization, after each
    kidnapping, the end (at most 8)."""
    steps = [0, 1, 3, 10]
    for k in kidnaps:
        steps += [int(k), int(k) + 3]
    return sorted({min(t, T) for t in steps} | {T})[:8]


def path_runs(exp) -> list:
    """The filter runs a paths figure draws: of each label its largest particle count (a run
    without particles, dead reckoning, as it is), in the config's order."""
    runs = {}
    for r in exp.filters:
        if r.label not in runs or (r.particles or 0) > (runs[r.label].particles or 0):
            runs[r.label] = r
    return list(runs.values())


def path_steps(T: int, kidnaps=()) -> np.ndarray:
    """The steps (int32, ascending) a kept path holds of a trial of ``T`` steps: every one up to
    PATH_POINTS, else every k-th (k the smallest that keeps at most PATH_POINTS) and the last;
    with each kidnapping's step and the one before, so that the figure can break the true path
    where the robot was moved."""
    stride = max(1, -(-(T + 1) // PATH_POINTS))
    keep = set(range(0, T + 1, stride)) | {T}
    for k in kidnaps:
        keep |= {t for t in (int(k) - 1, int(k)) if 0 <= t <= T}
    return np.asarray(sorted(keep), dtype=np.int32)


class LocalizationTracer:
    """The first FIGURE_TRIALS trials: each shown run's position error per step and particle
    count per step (error_runs). The first SNAPSHOT_TRIALS also: the particles of snapshot_runs at
    snapshot_steps (at most SNAPSHOT_PARTICLES of each), their estimates and the true pose
    there. The first PATH_TRIALS also: the true path and each path_runs run's estimated path
    (x, y in m) at path_steps (``path_step``, ``truth_path``, ``RUN_KEY/path``)."""

    def keeps(self, exp, trial: int) -> bool:
        return trial < FIGURE_TRIALS

    def extras(self, exp, model, data, trial: int) -> dict:
        if trial >= SNAPSHOT_TRIALS:
            return {}
        from .filters import FILTERS     # the registry: numba and every kernel module, on demand
        steps = snapshot_steps(data.ctrl.shape[0], model.kidnaps)
        return {r.key: {"snapshots": steps} for r in snapshot_runs(exp)
                if FILTERS[r.type].snapshots}

    def keep(self, exp, trial, model, truth, data, outs) -> dict:
        trace = {}
        asked = self.extras(exp, model, data, trial)      # the runs given snapshot steps
        for r in error_runs(exp):
            out = outs[r.key]
            trace[f"{r.key}/error"] = _f32(np.hypot(*(out["pose"][:, :2] - truth.pose[:, :2]).T))
            if "n" in out:
                trace[f"{r.key}/n"] = np.asarray(out["n"], dtype=np.int32)
        if trial < SNAPSHOT_TRIALS:
            steps = np.asarray(snapshot_steps(data.ctrl.shape[0], model.kidnaps))
            trace["steps"] = steps
            trace["truth_pose_at"] = _f32(truth.pose[steps])
            for r in snapshot_runs(exp):
                out = outs[r.key]
                trace[f"{r.key}/pose_at"] = _f32(out["pose"][steps])
                if r.key in asked:
                    got, parts, counts = out["snapshots"]
                    if list(got) != list(steps):
                        raise ValueError(f"filter {r.type}: snapshots at steps {list(got)}, "
                                         f"asked for {list(steps)}")
                    kept = [parts[j, :counts[j]:max(1, -(-int(counts[j]) // SNAPSHOT_PARTICLES)),
                                  :2] for j in range(len(steps))]
                    trace[f"{r.key}/snap_xy"] = _f32(np.concatenate(kept))
                    trace[f"{r.key}/snap_drawn"] = np.array([len(p) for p in kept])
                    trace[f"{r.key}/snap_count"] = np.asarray(counts, dtype=np.int64)
        if trial < PATH_TRIALS:
            at = path_steps(truth.pose.shape[0] - 1, model.kidnaps)
            trace["path_step"] = at
            trace["truth_path"] = _f32(truth.pose[at, :2])
            for r in path_runs(exp):
                trace[f"{r.key}/path"] = _f32(outs[r.key]["pose"][at, :2])
        return trace

    def world(self, exp, model) -> dict:
        """The beacons (B, 2) m and their ids (the data set's, else 0 to B-1), the area (2,) m,
        the kidnapping steps, the convergence bound (m), whether the filters start uniform over
        the area (``global_start``: global localization) and, where the scenario has them
        (recorded data), each step's time ``times`` (T+1,) s from the span's start."""
        world = {"beacons": _f32(model.beacons),
                 "beacon_ids": np.asarray(getattr(model, "beacon_ids",
                                                  np.arange(len(model.beacons))), dtype=np.int64),
                 "area": np.asarray(model.area, dtype=float),
                 "kidnaps": np.asarray(model.kidnaps, dtype=np.int64),
                 "bound": np.asarray(float(model.bound)),
                 "global_start": np.asarray(int(model.init.known) == 0)}
        if getattr(model, "times", None) is not None:
            world["times"] = np.asarray(model.times, dtype=float)
        return world


def runs_in(trace: dict) -> dict[str, dict]:
    """A trace's arrays by run key, {key: {field: array}}; what the trial shares under ''."""
    out: dict[str, dict] = {}
    for name, a in trace.items():
        key, _, field = name.rpartition("/")
        out.setdefault(key, {})[field] = a
    return out
