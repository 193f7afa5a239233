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
from pathlib import Path

import numpy as np

from ..models.slam import CourseData, SlamModel, simulate  # noqa: F401  (this module's simulate)
from ..schema import Key
from .worlds import resolve_course

NAME = "waypoint_course"
KIND = "slam"
# the Gaussian range-bearing sensor with its Jacobians (FastSLAM's landmark EKFs need both)
PROVIDES = ("gaussian_measurement", "jacobians", "likelihood")
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


def resolve(params: dict, base_dir: Path) -> dict:
    """Load the course file named by ``world`` (relative to base_dir) into the parameters, and
    check that landmarks are in range along the path (worlds.resolve_course)."""
    return resolve_course(params, base_dir)

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



__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate", "resolve"]
