"""The waypoint course of ifa2021 Table 3 (configs/papers/ifa2021.yaml): FastSLAM on a 100 m x 80 m course.

Vehicle (the steered model of the classic FastSLAM simulators):
    x += V dt cos(theta + G),  y += V dt sin(theta + G),  theta += V dt sin(G) / L
with the steering G driven toward the next waypoint, at most ``max_steer_deg`` and turning at most
``max_steer_rate_dps``; a waypoint counts as reached within ``waypoint_radius_m``. The filters see
the controls with noise (speed and steering). Every ``obs_every`` control steps a range-bearing
sensor sees each landmark within ``max_range_m`` and the field of view, with Gaussian noise, and
reports its identity (known data association).
The course (waypoints, landmarks, start pose) is data: ``world`` names a YAML file, resolved
relative to the experiment file's folder, loaded and checked at validation.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import types
from .._lazy import kernel

from ..angles import wrap
from ..rng import STATE, normal
from ..schema import ConfigError, Key
from ..yamlio import read_yaml

NAME = "waypoint_course"
KIND = "slam"
DESCRIPTION = "steered vehicle on a waypoint course with point landmarks (ifa2021 Table 3)"

SCHEMA = {
    "world": Key("str", "worlds/ifa_course.yaml", "course file (waypoints, landmarks, start pose), "
                 "relative to the experiment file"),
    "steps": Key("int", 8000, "control steps per trial (ifa2021: 8000)", min=1),
    "laps": Key("int", 0, "stop after this many laps (0: drive until the steps run out)", min=0),
    "speed_mps": Key("float", 3.0, "speed V (ifa2021: 3 m/s)", min=0.0, min_exclusive=True),
    "dt_s": Key("float", 0.025, "control interval (ifa2021: 0.025 s)", min=0.0, min_exclusive=True),
    "wheelbase_m": Key("float", 2.0, "wheelbase L (ifa2021: 2 m)", min=0.0, min_exclusive=True),
    "max_steer_deg": Key("float", 30.0, "steering limit (ifa2021: 30 deg)", min=0.0,
                         min_exclusive=True),
    "max_steer_rate_dps": Key("float", 20.0, "steering rate limit (ifa2021: 20 deg/s)", min=0.0,
                              min_exclusive=True),
    "waypoint_radius_m": Key("float", 1.0, "distance at which a waypoint counts as reached (not "
                             "given; the classic simulator's 1 m)", min=0.0, min_exclusive=True),
    "speed_noise_mps": Key("float", 0.5, "standard deviation of the speed the filters see "
                           "(ifa2021: 0.5 m/s)", min=0.0),
    "steer_noise_deg": Key("float", 5.0, "standard deviation of the steering the filters see "
                           "(ifa2021: 5 deg)", min=0.0),
    "range_noise_m": Key("float", 0.3, "range noise standard deviation (ifa2021: 0.3 m)", min=0.0,
                         min_exclusive=True),
    "bearing_noise_deg": Key("float", 1.0, "bearing noise standard deviation (not given; the "
                             "classic simulator's 1 deg)", min=0.0, min_exclusive=True),
    "max_range_m": Key("float", 30.0, "sensor range (not given; the classic simulator's 30 m)",
                       min=0.0, min_exclusive=True),
    "obs_every": Key("int", 8, "control steps between observations (not given; the classic "
                     "simulator's 8)", min=1),
    "field_of_view_deg": Key("float", 180.0, "sensor field of view centred on the heading (the "
                             "classic simulator sees the half-plane ahead)", min=0.0, max=360.0,
                             min_exclusive=True),
}


@dataclass(frozen=True)
class SlamModel:
    """Everything a trial of the course needs (arrays in SI units and radians).

    waypoints (K, 2), landmarks (M, 2), start (3,): the world
    vehicle : [V, dt, L, max_steer, max_rate, wp_radius, laps]
    noise : [sigma_V, sigma_G, sigma_r, sigma_b]  (what the data carry)
    sensor : [max_range, half_fov, obs_every]
    steps : control steps
    motion : 0 = the steered vehicle (noise [sigma_V, sigma_G, ...]); 1 = odometry form (noise
        [sigma_xy, sigma_theta, ...], see scenarios/landmark_world.py)
    """

    waypoints: np.ndarray
    landmarks: np.ndarray
    start: np.ndarray
    vehicle: np.ndarray
    noise: np.ndarray
    sensor: np.ndarray
    steps: int
    motion: int = 0


def load_world(path: Path, where: str = "scenario.world", points_key: str = "landmarks",
               origin: str = "centre") -> dict:
    """Read and check a course file (area, start, waypoints and the point features under
    ``points_key``); return plain lists (they enter the experiment's hash). ``origin``: 'centre'
    (the area is centred on the origin) or 'corner' (it is [0, width] x [0, height])."""
    try:
        raw, _ = read_yaml(path)
    except ConfigError as err:
        line = f":{err.line}" if err.line else ""
        raise ConfigError(where, f"the world file {path}{line}: {err.message}") from None
    if not isinstance(raw, dict):
        raise ConfigError(where, f"{path}: expected a mapping with area, start, waypoints, "
                          f"{points_key}")

    def points(key, n_min, width=2):
        pts = raw.get(key)
        try:
            arr = np.asarray(pts, dtype=float)
        except (TypeError, ValueError):
            arr = np.empty((0, 0))
        if arr.ndim != 2 or arr.shape[1] != width or len(arr) < n_min or not np.isfinite(arr).all():
            raise ConfigError(where, f"{path}: '{key}' must be a list of at least {n_min} "
                              f"[{', '.join(['x', 'y', 'heading'][:width])}] entries")
        return arr

    try:
        area = np.asarray(raw.get("area", []), dtype=float)
    except (TypeError, ValueError):
        area = np.empty(0)
    if area.shape != (2,) or not np.isfinite(area).all() or not (area > 0).all():
        raise ConfigError(where, f"{path}: 'area' must be [width, height]: two finite numbers of "
                          "metres > 0")
    try:
        start = np.asarray(raw.get("start", []), dtype=float)
    except (TypeError, ValueError):
        start = np.empty(0)
    if start.shape != (3,) or not np.isfinite(start).all():
        raise ConfigError(where, f"{path}: 'start' must be [x, y, heading]")
    wp = points("waypoints", 2)
    lm = points(points_key, 1)
    half = area / 2
    for key, arr in (("waypoints", wp), (points_key, lm), ("start", start[None, :2])):
        if origin == "centre":
            outside = np.any(np.abs(arr) > half, axis=1)
            where_ = "centred on the origin"
        else:
            outside = np.any((arr < 0) | (arr > area), axis=1)
            where_ = "[0, width] x [0, height]"
        if outside.any():
            i = int(np.argmax(outside))
            raise ConfigError(where, f"{path}: {key}[{i}] = {arr[i].tolist()} lies outside the "
                              f"{area[0]:g} m x {area[1]:g} m area {where_}")
    return {"area": area.tolist(), "waypoints": wp.tolist(), points_key: lm.tolist(),
            "start": start.tolist()}


def resolve(params: dict, base_dir: Path) -> dict:
    """Load the course file named by ``world`` (relative to base_dir) into the parameters, and
    check that landmarks are in range along the path."""
    path = Path(params["world"])
    if not path.is_absolute():
        path = base_dir / path
    out = dict(params)
    world = load_world(path)
    del world["area"]       # not used by the course's model (and kept out of its hash)
    out.update(world)
    wp = np.asarray(out["waypoints"])
    lm = np.asarray(out["landmarks"])
    seen = np.sum(np.hypot(*(lm[None, :, :] - wp[:, None, :]).transpose(2, 0, 1))
                  <= params["max_range_m"], axis=1)
    if seen.min() < 2:
        i = int(np.argmin(seen))
        raise ConfigError("scenario.world", f"{path}: only {seen[i]} landmark(s) within "
                          f"max_range_m = {params['max_range_m']:g} of waypoint {i}; the filters "
                          "need at least 2 in range along the path")
    return out


def build(p) -> SlamModel:
    deg = math.pi / 180.0
    return SlamModel(
        np.asarray(p["waypoints"], dtype=np.float64), np.asarray(p["landmarks"], dtype=np.float64),
        np.asarray(p["start"], dtype=np.float64),
        np.array([p["speed_mps"], p["dt_s"], p["wheelbase_m"], p["max_steer_deg"] * deg,
                  p["max_steer_rate_dps"] * deg, p["waypoint_radius_m"], float(p["laps"])]),
        np.array([p["speed_noise_mps"], p["steer_noise_deg"] * deg, p["range_noise_m"],
                  p["bearing_noise_deg"] * deg]),
        np.array([p["max_range_m"], 0.5 * p["field_of_view_deg"] * deg, float(p["obs_every"])]),
        int(p["steps"]))


_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]


@kernel(types.int64(_F2, types.float64, types.float64, types.float64, types.float64, types.float64,
                  _F, STATE, _I, _F2), cache=True)
def sense(lm, x, y, th, rmax, half_fov, noise, s, ids, zs):
    """Observe every landmark of lm within rmax and the field of view from pose (x, y, th): fill
    ids (M,) and zs (M, 2) with their indices and noisy [range, bearing]; return how many."""
    n = 0
    for j in range(lm.shape[0]):
        ex, ey = lm[j, 0] - x, lm[j, 1] - y
        r = math.sqrt(ex * ex + ey * ey)
        b = wrap(math.atan2(ey, ex) - th)
        if r <= rmax and abs(b) <= half_fov:
            ids[n] = j
            zs[n, 0] = r + noise[2] * normal(s)
            zs[n, 1] = wrap(b + noise[3] * normal(s))
            n += 1
    return n


@kernel(types.UniTuple(types.int64, 2)(_F2, types.int64, types.int64, types.float64, types.float64,
                                     types.float64), cache=True)
def next_waypoint(wp, iw, lap, x, y, radius):
    """(waypoint to drive to, laps completed) from (x, y): the next waypoint once the current one
    is within ``radius``, the lap count growing when the path closes."""
    dx, dy = wp[iw, 0] - x, wp[iw, 1] - y
    if dx * dx + dy * dy < radius * radius:
        iw += 1
        if iw == wp.shape[0]:
            iw = 0
            lap += 1
    return iw, lap


@kernel(types.int64(_F2, _F2, _F, _F, _F, _F, types.int64, STATE, _F2, _F2, _I, _I2, _F3, _I),
      cache=True)
def simulate_course(wp, lm, start, veh, noise, sensor, steps, s, pose, ctrl, obs_n, obs_id, obs_z,
                    wp_idx):
    """Drive the course and sense the landmarks.

    pose (steps+1, 3): true poses; ctrl (steps, 2): the noisy [V, G] the filters see; per
    observation k (at control step (k+1) obs_every): obs_n[k] landmarks seen, obs_id[k, :n] their
    indices and obs_z[k, :n] their noisy [range, bearing]; wp_idx (steps+1,) the waypoint being
    driven to. Returns the number of control steps driven (fewer than ``steps`` when ``laps`` ends
    the run).
    """
    V, dt, L, maxG, rate, radius, laps = veh[0], veh[1], veh[2], veh[3], veh[4], veh[5], veh[6]
    rmax, half_fov, every = sensor[0], sensor[1], int(sensor[2])
    x, y, th = start[0], start[1], start[2]
    pose[0, 0], pose[0, 1], pose[0, 2] = x, y, th
    G = 0.0
    iw = 0
    lap = 0
    wp_idx[0] = 0
    k = 0
    for t in range(steps):
        # steer toward the current waypoint (the next one once this is reached)
        iw, lap = next_waypoint(wp, iw, lap, x, y, radius)
        if laps > 0 and lap >= laps:
            return t
        dx, dy = wp[iw, 0] - x, wp[iw, 1] - y
        dG = wrap(math.atan2(dy, dx) - th - G)
        lim = rate * dt
        G += max(-lim, min(lim, dG))
        G = max(-maxG, min(maxG, G))
        x += V * dt * math.cos(th + G)
        y += V * dt * math.sin(th + G)
        th = wrap(th + V * dt * math.sin(G) / L)
        pose[t + 1, 0], pose[t + 1, 1], pose[t + 1, 2] = x, y, th
        wp_idx[t + 1] = iw
        ctrl[t, 0] = V + noise[0] * normal(s)
        ctrl[t, 1] = G + noise[1] * normal(s)
        if (t + 1) % every == 0:
            obs_n[k] = sense(lm, x, y, th, rmax, half_fov, noise, s, obs_id[k], obs_z[k])
            k += 1
    return steps


@dataclass
class CourseData:
    """A trial's data: what the filters see (controls, observations) and the truth."""

    pose: np.ndarray        # (T+1, 3) true poses
    ctrl: np.ndarray        # (T, 2) noisy [V, G]
    obs_n: np.ndarray       # (K,)
    obs_id: np.ndarray      # (K, M)
    obs_z: np.ndarray       # (K, M, 2)
    waypoint: np.ndarray    # (T+1,)
    steps: int              # control steps driven


def simulate(model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Simulate one trial; returns (truth, data), here the same object (filters use only ctrl and
    the observations; metrics use pose and the landmarks)."""
    return run_simulator(simulate_course, model, state)


def run_simulator(simulator, model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Allocate a trial's arrays, run a numba ``simulator`` with simulate_course's signature, and
    trim them to the steps driven."""
    T = model.steps
    every = int(model.sensor[2])
    K = T // every
    M = model.landmarks.shape[0]
    pose = np.zeros((T + 1, 3))
    ctrl = np.zeros((T, 2))
    obs_n = np.zeros(K, dtype=np.int64)
    obs_id = np.zeros((K, M), dtype=np.int64)
    obs_z = np.zeros((K, M, 2))
    wp_idx = np.zeros(T + 1, dtype=np.int64)
    driven = simulator(model.waypoints, model.landmarks, model.start, model.vehicle, model.noise,
                       model.sensor, T, state, pose, ctrl, obs_n, obs_id, obs_z, wp_idx)
    k = driven // every
    data = CourseData(pose[:driven + 1], ctrl[:driven], obs_n[:k], obs_id[:k], obs_z[:k],
                      wp_idx[:driven + 1], driven)
    return data, data
