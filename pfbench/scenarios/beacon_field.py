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

Range outliers (``range_outliers`` eps > 0): each range is, with probability eps, a random
reading uniform over [0, max_range_m] (a reflection, a crosstalk, a beacon heard through a wall)
instead of the true range with its Gaussian noise: Thrun, Burgard and Fox's beam model reduced to
its "hit" and "random" parts. The world draws them with the model's own sampler
(pfbench.models.beacons.mixture_sample); the filters weigh by the mixture's log-likelihood
(``mixture_loglik``), or, with ``outlier_likelihood: gaussian``, by the Gaussian alone, as a
filter that ignores the outliers does. Bearing outliers (``bearing_outliers`` eps_b > 0, the
range_bearing sensor's): each bearing is, with probability eps_b, uniform over the field of view
instead of the true bearing with its Gaussian noise, drawn and weighed the same way. Without
outliers the sensor is the Gaussian one, its draws and the filters' arithmetic those of a field
without these keys.

Kidnapping: at each step in ``kidnap_steps`` the robot is put, after its move, at a pose drawn
uniformly over the field (or the next of ``kidnap_poses``), and told nothing: the odometry of that
step is the commanded move as always.

The world (area, beacons, start pose, waypoints) is a world file (scenarios.worlds); the model
(FieldModel) and its simulator live in pfbench.models.field. Another beacon world is a world file
and a scenario module of a few lines that takes this module's resolve, build and simulate and
its own defaults:

    from pfbench.scenarios.beacon_field import build, resolve, schema, simulate
    NAME, KIND, DESCRIPTION = "beacon_hall", "localization", "a hall with four beacons"
    SCHEMA = schema(world="worlds/beacon_hall.yaml", steps=120, sensor="range_bearing")
"""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from ..codes import FIELD_MOTIONS, SENSORS
from ..models.beacons import BeaconSensor, mixture_loglik, mixture_sample, mixture_theta
from ..models.field import FieldData, FieldModel, simulate  # noqa: F401  (this module's simulate)
from ..models.odometry import MotionNoise
from ..models.pose import InitialBelief
from ..schema import ConfigError, Key
from .worlds import load_world

NAME = "beacon_field"
KIND = "localization"
# What the measurement gives (a likelihood; a Gaussian measurement unless the filters weigh
# by the outlier mixture) is read from the model (FieldModel.provides), as the keys decide it.
PROVIDES = ()
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
    "range_outliers": Key("float", 0.0, "probability that a range is an outlier, uniform over "
                          "[0, max_range_m], instead of the true range with Gaussian noise (0: "
                          "none, the papers' sensor; Thrun, Burgard and Fox's beam model's hit "
                          "and random parts)", min=0.0, max=1.0, max_exclusive=True),
    "bearing_outliers": Key("float", 0.0, "range_bearing: probability that a bearing is an "
                            "outlier, uniform over the field of view, instead of the true bearing "
                            "with Gaussian noise (0: none, the papers' sensor; our addition)",
                            min=0.0, max=1.0, max_exclusive=True),
    "outlier_likelihood": Key("choice", "mixture", "range_outliers or bearing_outliers > 0: the "
                              "filters weigh by 'mixture', the model's own likelihood of the "
                              "outlier mixture the data are drawn from, or by 'gaussian', the "
                              "Gaussian of range_noise_m (and bearing_noise_deg) alone (a filter "
                              "that ignores the outliers)", choices=("mixture", "gaussian")),
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


def resolve(params: dict, base_dir) -> dict:
    """Load and check the world file (see worlds.load_world; beacons in the place of
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
    if params.get("bearing_outliers", 0.0) > 0.0 and params["sensor"] != "range_bearing":
        raise ConfigError("scenario.bearing_outliers", "a range sensor has no bearings: "
                          "bearing_outliers needs sensor: range_bearing")
    if any(k > params["steps"] for k in params["kidnap_steps"]):
        raise ConfigError("scenario.kidnap_steps", f"every step must be within the "
                          f"{params['steps']} steps")
    return out


def build(p) -> FieldModel:
    if p["motion"] == "odometry":
        mnoise = MotionNoise.additive(p["trans_noise_m"], p["turn_noise_deg"] * DEG)
    else:
        mnoise = MotionNoise.rot_trans_rot(*p["alphas"])
    kid = np.asarray(sorted(p["kidnap_steps"]), dtype=np.int64)
    if p["kidnap_poses"]:
        kp = np.asarray(p["kidnap_poses"], dtype=np.float64).reshape(-1, 3)
        kp[:, 2] *= DEG
    else:
        kp = np.full((kid.size, 3), np.nan)
    sense = BeaconSensor(max_range=float(p["max_range_m"]),
                         half_fov=float(0.5 * p["field_of_view_deg"] * DEG),
                         sr=float(p["range_noise_m"]), sb=float(p["bearing_noise_deg"] * DEG),
                         nearest=int(p["answer"] == "nearest"))
    own = {}
    eps = float(p.get("range_outliers", 0.0))
    eps_b = float(p.get("bearing_outliers", 0.0))
    if eps > 0.0 or eps_b > 0.0:
        own = {"sample": mixture_sample,
               "theta": mixture_theta(SENSORS[p["sensor"]], sense, eps, sense.max_range, eps_b)}
        if p.get("outlier_likelihood", "mixture") == "mixture":
            own["loglik"] = mixture_loglik
    return FieldModel(
        np.asarray(p["area"], dtype=np.float64), np.asarray(p["beacons"], dtype=np.float64),
        np.asarray(p["waypoints"], dtype=np.float64),
        np.asarray(p["start"], dtype=np.float64) * np.array([1.0, 1.0, DEG]),
        np.array([p["step_m"], p["max_turn_deg"] * DEG, p["waypoint_radius_m"]]),
        FIELD_MOTIONS[p["motion"]], mnoise, SENSORS[p["sensor"]], sense,
        int(p["steps"]), kid, kp, float(p["converge_bound_m"]),
        InitialBelief(known=int(p["initial"] == "known"), x=float(p["start"][0]),
                      y=float(p["start"][1]), heading=float(p["start"][2] * DEG),
                      sd_m=float(p["initial_std_m"]), sd_rad=float(p["initial_std_deg"] * DEG)),
        int(p["score_from"]),
        int(p["report_step"]), int(p["converge_hold_steps"]), **own)


def schema(**defaults) -> dict:
    """SCHEMA with other defaults (``world="worlds/my_field.yaml"``, ``steps=120``, ...): what a
    scenario module of another beacon world declares as its SCHEMA, beside this module's resolve,
    build and simulate. A name that is no key, or a default its key refuses, raises ValueError."""
    unknown = [k for k in defaults if k not in SCHEMA]
    if unknown:
        raise ValueError(f"beacon_field.schema: no key '{unknown[0]}' (its keys: "
                         f"{', '.join(SCHEMA)})")
    out = dict(SCHEMA)
    for name, value in defaults.items():
        try:
            value = SCHEMA[name].validate(name, value)
        except ConfigError as err:
            raise ValueError(f"beacon_field.schema: {err}") from None
        out[name] = replace(SCHEMA[name], default=value)
    return out


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate", "resolve", "schema"]
