"""The 50 m x 60 m landmark world of afsa2014 (configs/papers/afsa2014.yaml): FastSLAM with unknown data
association, odometry-form motion.

Motion: per step the odometry reports [ds, dtheta], the robot turns by dtheta and moves ds,
    theta += dtheta,  x += ds cos(theta),  y += ds sin(theta),
and the truth also receives Gaussian noise on x, y (``process_noise_xy_m``) and heading
(``process_noise_heading_deg``), which each particle draws too. The robot heads for the next
waypoint at ``speed_mps`` (the paper's top speed, 0.3 m/s), turning at most ``max_turn_dps``.
Sensor: range and bearing to every landmark within ``max_range_m`` (15 m) every ``obs_every``
steps, with the paper's noise. afsa2014 calls its noise values "variance"; they are read as
standard deviations unless ``noise_values`` is 'variance'.

Outliers (``range_outliers`` eps_r, ``bearing_outliers`` eps_b, both 0 by default, as afsa2014):
each range is, with probability eps_r, uniform over [0, max_range_m], and each bearing,
independently, with probability eps_b uniform over the field of view, instead of the true value
with its Gaussian noise. The world draws them with the model's own sampler
(pfbench.models.slam.slam_mixture_sample); the model's own likelihood is their mixture
(``slam_mixture_loglik``), and it then provides no Gaussian measurement: FastSLAM, whose landmark
EKFs need one, is refused; a particle SLAM filter weighs by it. With ``outlier_likelihood:
gaussian`` the model keeps the Gaussian sensor (FastSLAM runs, on a sensor it mis-models).
Without outliers the draws and every filter's arithmetic are those of a world without these keys.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..codes import SLAM_ODOMETRY
from ..models.slam import (CourseData, SlamModel, simulate,  # noqa: F401  (this module's simulate)
                           slam_mixture_loglik, slam_mixture_sample, slam_mixture_theta)
from ..schema import Key
from .worlds import resolve_course

NAME = "landmark_world"
KIND = "slam"
# the Gaussian range-bearing sensor with its Jacobians (FastSLAM's landmark EKFs need both), with
# the keys' defaults; outliers weighed by their mixture take the Gaussian measurement away (the
# model, built from a config's keys, says so: SlamModel.provides)
PROVIDES = ("gaussian_measurement", "jacobians", "likelihood")
DESCRIPTION = "odometry-driven robot in a 50 m x 60 m landmark world (afsa2014)"

SCHEMA = {
    "world": Key("str", "worlds/afsa_world.yaml", "world file (area, start, waypoints of the closed "
                 "path, landmarks), relative to the experiment file"),
    "steps": Key("int", 2000, "steps per trial (afsa2014 does not say; 2000 x 0.5 s is about "
                 "2.5 laps of our path)", min=1),
    "laps": Key("int", 0, "stop after this many laps (0: until the steps run out)", min=0),
    "speed_mps": Key("float", 0.3, "speed (afsa2014: top speed 0.3 m/s)", min=0.0,
                     min_exclusive=True),
    "dt_s": Key("float", 0.5, "time per step (not given; our choice)", min=0.0, min_exclusive=True),
    "max_turn_dps": Key("float", 20.0, "turn-rate limit toward the next waypoint (not given)",
                        min=0.0, min_exclusive=True),
    "waypoint_radius_m": Key("float", 0.5, "distance at which a waypoint counts as reached",
                             min=0.0, min_exclusive=True),
    "noise_values": Key("choice", "std", "how to read the noise values below: 'std' (standard "
                        "deviations, the default) or 'variance' (as afsa2014 calls them)",
                        choices=("std", "variance")),
    "process_noise_xy_m": Key("float", 0.01, "process noise on x and y per step (afsa2014: 0.01)",
                              min=0.0),
    "process_noise_heading_deg": Key("float", 0.2, "process noise on the heading per step "
                                     "(afsa2014: 0.2 deg)", min=0.0),
    "range_noise_m": Key("float", 0.01, "range noise (afsa2014: 0.01 m)", min=0.0,
                         min_exclusive=True),
    "bearing_noise_deg": Key("float", 0.1, "bearing noise (afsa2014: 0.1 deg)", min=0.0,
                             min_exclusive=True),
    "max_range_m": Key("float", 15.0, "sensor range (afsa2014: 15 m)", min=0.0,
                       min_exclusive=True),
    "obs_every": Key("int", 1, "steps between observations (not given: every step)", min=1),
    "field_of_view_deg": Key("float", 360.0, "sensor field of view centred on the heading (not "
                             "given: all around)", min=0.0, max=360.0, min_exclusive=True),
    "range_outliers": Key("float", 0.0, "probability that a range is an outlier, uniform over "
                          "[0, max_range_m], instead of the true range with Gaussian noise (0: "
                          "none, afsa2014's sensor; our addition)", min=0.0, max=1.0,
                          max_exclusive=True),
    "bearing_outliers": Key("float", 0.0, "probability that a bearing is an outlier, uniform "
                            "over the field of view, instead of the true bearing with Gaussian "
                            "noise (0: none, afsa2014's sensor; our addition)", min=0.0,
                            max=1.0, max_exclusive=True),
    "outlier_likelihood": Key("choice", "mixture", "range_outliers or bearing_outliers > 0: the "
                              "model's likelihood is 'mixture', its own of the outlier mixture "
                              "the data are drawn from (it then provides no Gaussian measurement: "
                              "FastSLAM is refused), or 'gaussian', the Gaussian sensor of "
                              "range_noise_m and bearing_noise_deg alone (FastSLAM runs, ignoring "
                              "the outliers)", choices=("mixture", "gaussian")),
}


def resolve(params: dict, base_dir):
    """Load and check the world file (worlds.resolve_course)."""
    return resolve_course(params, base_dir)


def build(p) -> SlamModel:
    deg = math.pi / 180.0
    noise = np.array([p["process_noise_xy_m"], p["process_noise_heading_deg"] * deg,
                      p["range_noise_m"], p["bearing_noise_deg"] * deg])
    if p["noise_values"] == "variance":
        # the values are variances in their units: deg^2 for the angles
        noise = np.array([math.sqrt(p["process_noise_xy_m"]),
                          math.sqrt(p["process_noise_heading_deg"]) * deg,
                          math.sqrt(p["range_noise_m"]), math.sqrt(p["bearing_noise_deg"]) * deg])
    model = SlamModel(
        np.asarray(p["waypoints"], dtype=np.float64), np.asarray(p["landmarks"], dtype=np.float64),
        np.asarray(p["start"], dtype=np.float64),
        np.array([p["speed_mps"], p["dt_s"], 1.0, p["max_turn_dps"] * deg, 0.0,
                  p["waypoint_radius_m"], float(p["laps"])]),
        noise, np.array([p["max_range_m"], 0.5 * p["field_of_view_deg"] * deg,
                         float(p["obs_every"])]), int(p["steps"]), motion=SLAM_ODOMETRY)
    eps_r = float(p.get("range_outliers", 0.0))
    eps_b = float(p.get("bearing_outliers", 0.0))
    if eps_r == 0.0 and eps_b == 0.0:
        return model
    own = {"sample": slam_mixture_sample,
           "theta": slam_mixture_theta(model.sensor, model.noise, eps_r, eps_b)}
    if p.get("outlier_likelihood", "mixture") == "mixture":
        own["loglik"] = slam_mixture_loglik
    return replace(model, **own)



__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate", "resolve"]
