"""The 40 m x 40 m beacon field of sspf2008 and asrl2008 (configs/papers/): localization of a
robot whose initial pose is unknown, optionally kidnapped.

Motion: per step the odometry reports [rot1, trans, rot2] (turn, move, turn):
    theta += rot1,  x += trans cos(theta),  y += trans sin(theta),  theta += rot2.
``motion: odometry`` is sspf2008's (T, dtheta) form (rot1 = 0, trans = T, rot2 = dtheta) with
Gaussian noise of standard deviations ``trans_noise_m`` and ``turn_noise_deg``;
``motion: rot_trans_rot`` is asrl2008's model: each part gets Gaussian noise of standard deviation
    rot1: alpha1 |rot1| + alpha2 |trans|,  trans: alpha3 |trans| + alpha4 (|rot1| + |rot2|),
    rot2: alpha1 |rot2| + alpha2 |trans|
(asrl2008 prints the trans term as alpha4 |rot1 + rot2| + alpha3 |trans|; the odometry robots of
Thrun, Burgard and Fox's book, whose model it follows, use |rot1| + |rot2|). The robot's true motion
is the commanded one with that noise; the filters get the commanded odometry.
The robot drives toward the world file's waypoints in turn, turning at most ``max_turn_deg`` a
step, which draws arcs.

Sensor ``range`` (sspf2008's RF beacons): each step one beacon within ``max_range_m`` answers
(chosen at random, or the nearest) with its identity and a noisy range. Sensor ``range_bearing``
(asrl2008's camera landmarks): range and bearing to every beacon within ``max_range_m`` and the
field of view.

Kidnapping: at each step in ``kidnap_steps`` the robot is put, after its move, at a pose drawn
uniformly over the field (or the next of ``kidnap_poses``), and told nothing: the odometry of that
step is the commanded move as always.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import types
from .._lazy import kernel

from ..angles import wrap
from ..rng import STATE, uniform
from ..models.beacons import sense_beacons
from ..models.odometry import noisy_odometry
from ..schema import ConfigError, Key
from .waypoint_course import load_world, next_waypoint

NAME = "beacon_field"
KIND = "localization"
DESCRIPTION = "robot localization among 6 beacons in a 40 m x 40 m field (sspf2008, asrl2008)"

DEG = math.pi / 180.0

SCHEMA = {
    "world": Key("str", "worlds/beacon_field.yaml", "world file (area, beacons, start pose, "
                 "waypoints of the path), relative to the experiment file"),
    "steps": Key("int", 80, "steps per trial (sspf2008: 80, one per beacon answer)", min=1),
    "step_m": Key("float", 0.5, "distance driven per step (not given; our choice)", min=0.0,
                  min_exclusive=True),
    "max_turn_deg": Key("float", 15.0, "turn toward the next waypoint per step (not given)",
                        min=0.0, min_exclusive=True),
    "waypoint_radius_m": Key("float", 1.0, "distance at which a waypoint counts as reached",
                             min=0.0, min_exclusive=True),
    "motion": Key("choice", "odometry", "'odometry': sspf2008's (T, dtheta) with Gaussian noise; "
                  "'rot_trans_rot': asrl2008's model with alpha1..alpha4",
                  choices=("odometry", "rot_trans_rot")),
    "trans_noise_m": Key("float", 0.05, "odometry: noise of the distance per step (not given)",
                         min=0.0),
    "turn_noise_deg": Key("float", 2.0, "odometry: noise of the heading change per step (not "
                          "given)", min=0.0),
    "alphas": Key("floats", (0.0014, 0.000125, 0.01, 0.26), "rot_trans_rot: alpha1..alpha4 "
                  "(asrl2008, decoded from damaged text)", min=0.0,
                  check=lambda v: None if len(v) == 4 else "expected four values"),
    "sensor": Key("choice", "range", "'range': one beacon answers each step with its identity "
                  "and range (sspf2008); 'range_bearing': every beacon in view (asrl2008)",
                  choices=("range", "range_bearing")),
    "answer": Key("choice", "random", "range: which beacon in range answers, 'random' or "
                  "'nearest'", choices=("random", "nearest")),
    "max_range_m": Key("float", 20.0, "detection radius of a beacon / camera range (not given)",
                       min=0.0, min_exclusive=True),
    "field_of_view_deg": Key("float", 360.0, "range_bearing: field of view centred on the "
                             "heading", min=0.0, max=360.0, min_exclusive=True),
    "range_noise_m": Key("float", 0.1, "range noise standard deviation (not given)", min=0.0,
                         min_exclusive=True),
    "bearing_noise_deg": Key("float", 2.0, "range_bearing: bearing noise standard deviation (not "
                             "given)", min=0.0, min_exclusive=True),
    "kidnap_steps": Key("ints", (), "steps after whose move the robot is put somewhere else "
                        "without telling the filter", min=1, empty_ok=True),
    "kidnap_poses": Key("floats", (), "x, y, heading (deg) of each kidnapping in turn, flat "
                        "(empty: uniform over the field)", empty_ok=True),
    "converge_bound_m": Key("float", 0.5, "position error under which a filter counts as "
                            "converged (and recovered after a kidnapping)", min=0.0,
                            min_exclusive=True),
    "converge_hold_steps": Key("int", 10, "steps the error must stay under the bound at the end "
                               "of a stretch (before the first kidnapping, between two, before "
                               "the end) to count as converged or recovered", min=1),
    "initial": Key("choice", "unknown", "what the filters know of the start: 'unknown' (particles "
                   "uniform over the field and heading: global localization) or 'known' (drawn "
                   "around the true start: tracking)", choices=("unknown", "known")),
    "initial_std_m": Key("float", 0.1, "known: position spread of the initial particles", min=0.0),
    "initial_std_deg": Key("float", 2.0, "known: heading spread of the initial particles",
                           min=0.0),
    "score_from": Key("int", 1, "first step the error averages (rmse, position, x, y and heading "
                      "error) count: later than 1 scores tracking after the global localization",
                      min=1),
    "report_step": Key("int", 0, "step whose position error is reported as error_at_step (0: "
                       "none)", min=0),
}


@dataclass(frozen=True)
class FieldModel:
    """Everything a trial of the beacon field needs (SI units, radians).

    area (2,): the field is [0, area[0]] x [0, area[1]]; beacons (B, 2); waypoints (K, 2);
    start (3,); drive: [step, max_turn, waypoint radius]; motion: 0 odometry, 1 rot_trans_rot;
    mnoise (4,): [sigma_trans, sigma_turn, 0, 0] or alpha1..alpha4; sensor: 0 range, 1
    range_bearing; sense: [max_range, half_fov, sigma_r, sigma_b, nearest (0/1)]; kidnaps (k,)
    steps; kidnap_poses (k, 3) (NaN rows: uniform); bound: the convergence bound; init: the
    filters' initial belief (see init_particles); score_from, report_step, hold
    (converge_hold_steps): see the keys.
    """

    area: np.ndarray
    beacons: np.ndarray
    waypoints: np.ndarray
    start: np.ndarray
    drive: np.ndarray
    motion: int
    mnoise: np.ndarray
    sensor: int
    sense: np.ndarray
    steps: int
    kidnaps: np.ndarray
    kidnap_poses: np.ndarray
    bound: float
    init: np.ndarray        # [known (0/1), x, y, heading, sd_xy, sd_heading]
    score_from: int = 1
    report_step: int = 0
    hold: int = 10          # converge_hold_steps


@dataclass
class FieldData:
    """Truth and measurements of one trial: pose (T+1, 3) true poses; ctrl (T, 3) the odometry
    [rot1, trans, rot2]; obs_n (T,), obs_id (T, B), obs_z (T, B, 2) [range, bearing] of the beacons
    seen at each step."""

    pose: np.ndarray
    ctrl: np.ndarray
    obs_n: np.ndarray
    obs_id: np.ndarray
    obs_z: np.ndarray


def resolve(params: dict, base_dir) -> dict:
    """Load and check the world file (see waypoint_course.load_world; beacons in the place of
    landmarks, the field [0, width] x [0, height]) into the params; check the kidnappings."""
    out = dict(params)
    out.update(load_world(Path(base_dir) / params["world"], points_key="beacons",
                          origin="corner"))
    if len(params["kidnap_poses"]) not in (0, 3 * len(params["kidnap_steps"])):
        raise ConfigError("scenario.kidnap_poses", "give x, y, heading for every kidnapping (3 "
                          "numbers each), or none")
    for key in ("score_from", "report_step"):
        if params[key] > params["steps"]:
            raise ConfigError(f"scenario.{key}", f"expected a step within the {params['steps']} "
                              f"steps, got {params[key]}")
    if any(k > params["steps"] for k in params["kidnap_steps"]):
        raise ConfigError("scenario.kidnap_steps", f"every step must be within the "
                          f"{params['steps']} steps")
    return out


def build(p) -> FieldModel:
    if p["motion"] == "odometry":
        mnoise = np.array([p["trans_noise_m"], p["turn_noise_deg"] * DEG, 0.0, 0.0])
    else:
        mnoise = np.asarray(p["alphas"], dtype=np.float64)
    kid = np.asarray(sorted(p["kidnap_steps"]), dtype=np.int64)
    if p["kidnap_poses"]:
        kp = np.asarray(p["kidnap_poses"], dtype=np.float64).reshape(-1, 3)
        kp[:, 2] *= DEG
    else:
        kp = np.full((kid.size, 3), np.nan)
    return FieldModel(
        np.asarray(p["area"], dtype=np.float64), np.asarray(p["beacons"], dtype=np.float64),
        np.asarray(p["waypoints"], dtype=np.float64),
        np.asarray(p["start"], dtype=np.float64) * np.array([1.0, 1.0, DEG]),
        np.array([p["step_m"], p["max_turn_deg"] * DEG, p["waypoint_radius_m"]]),
        0 if p["motion"] == "odometry" else 1, mnoise,
        0 if p["sensor"] == "range" else 1,
        np.array([p["max_range_m"], 0.5 * p["field_of_view_deg"] * DEG, p["range_noise_m"],
                  p["bearing_noise_deg"] * DEG, 1.0 if p["answer"] == "nearest" else 0.0]),
        int(p["steps"]), kid, kp, float(p["converge_bound_m"]),
        np.array([1.0 if p["initial"] == "known" else 0.0, p["start"][0], p["start"][1],
                  p["start"][2] * DEG, p["initial_std_m"], p["initial_std_deg"] * DEG]),
        int(p["score_from"]),
        int(p["report_step"]), int(p["converge_hold_steps"]))


_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]



@kernel(types.void(_F, _F2, _F2, _F, _F, types.int64, _F, types.int64, _F, _I, _F2, STATE, _F2,
                 _F2, _I, _I2, _F3), cache=True)
def simulate_field(area, bc, wp, start, drive, motion, mnoise, sensor, sense, kid, kpose, s, pose,
                   ctrl, obs_n, obs_id, obs_z):
    step, maxturn, radius = drive[0], drive[1], drive[2]
    x, y, th = start[0], start[1], start[2]
    pose[0, 0], pose[0, 1], pose[0, 2] = x, y, th
    iw = 0
    lap = 0
    ik = 0
    for t in range(ctrl.shape[0]):
        iw, lap = next_waypoint(wp, iw, lap, x, y, radius)
        want = wrap(math.atan2(wp[iw, 1] - y, wp[iw, 0] - x) - th)
        turn = max(-maxturn, min(maxturn, want))
        if motion == 0:           # (T, dtheta): move, then turn
            r1, tr, r2 = 0.0, step, turn
        else:                     # turn, move
            r1, tr, r2 = turn, step, 0.0
        ctrl[t, 0], ctrl[t, 1], ctrl[t, 2] = r1, tr, r2
        a1, a2, a3 = noisy_odometry(r1, tr, r2, motion, mnoise, s)
        th += a1
        x += a2 * math.cos(th)
        y += a2 * math.sin(th)
        th = wrap(th + a3)
        while ik < kid.size and kid[ik] == t + 1:
            if math.isnan(kpose[ik, 0]):
                x = area[0] * uniform(s)
                y = area[1] * uniform(s)
                th = math.pi * (2.0 * uniform(s) - 1.0)
            else:
                x, y, th = kpose[ik, 0], kpose[ik, 1], wrap(kpose[ik, 2])
            ik += 1
        pose[t + 1, 0], pose[t + 1, 1], pose[t + 1, 2] = x, y, th
        obs_n[t] = sense_beacons(bc, x, y, th, sensor, sense, s, obs_id[t], obs_z[t])


def simulate(model: FieldModel, state: np.ndarray) -> tuple[FieldData, FieldData]:
    """Simulate one trial; returns (truth, data), the same object: the filters read only ctrl and
    the observations."""
    T, B = model.steps, model.beacons.shape[0]
    d = FieldData(np.empty((T + 1, 3)), np.empty((T, 3)), np.zeros(T, dtype=np.int64),
                  np.zeros((T, B), dtype=np.int64), np.zeros((T, B, 2)))
    simulate_field(model.area, model.beacons, model.waypoints, model.start, model.drive,
                   model.motion, model.mnoise, model.sensor, model.sense, model.kidnaps,
                   model.kidnap_poses, state, d.pose, d.ctrl, d.obs_n, d.obs_id, d.obs_z)
    return d, d


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate", "resolve"]
