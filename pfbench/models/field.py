"""The localization model of a beacon field: a robot drives a closed waypoint path on a field
[0, area[0]] x [0, area[1]] among known beacons, with odometry motion (pfbench.models.odometry),
a beacon sensor (pfbench.models.beacons) and kidnappings. ``FieldModel`` is what a localization
scenario builds and a localization filter reads; ``FieldData`` is one trial's truth and data;
``simulate`` draws a trial.

The robot drives toward the waypoints in turn, turning at most ``drive[1]`` a step, which draws
arcs. At each step of ``kidnaps`` the robot is put, after its move, at a pose drawn uniformly over
the field (or the next of ``kidnap_poses``), and told nothing: the odometry of that step is the
commanded move as always.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba import types
from .._lazy import kernel

from ..angles import wrap
from ..codes import MOTION_ODOMETRY
from ..rng import STATE, uniform
from .beacons import (BEACON_SENSOR, BeaconSensor, ScanLikelihoodFunction, ScanModel,
                      ScanSampleFn, ScanSamplerFunction, scan_placeholder, sense_beacons)
from .scalar import model_function
from .odometry import MOTION_NOISE, MotionNoise, noisy_odometry
from .pose import InitialBelief
from .waypoints import next_waypoint


@dataclass(frozen=True)
class FieldModel:
    """Everything a trial of the beacon field needs (SI units, radians).

    area (2,): the field is [0, area[0]] x [0, area[1]]; beacons (B, 2); waypoints (K, 2);
    start (3,); drive: [step, max_turn, waypoint radius]; motion: 0 odometry, 1 rot_trans_rot;
    mnoise: the odometry's noise (``MotionNoise``); sensor: 0 range, 1
    range_bearing; sense: the sensor (``BeaconSensor``); kidnaps (k,)
    steps; kidnap_poses (k, 3) (NaN rows: uniform); bound: the convergence bound; init: the
    filters' initial belief (``InitialBelief``); score_from, report_step, hold
    (converge_hold_steps): see the keys.

    loglik : the model's own log-likelihood of a step's observations, a numba function of
        ``beacons.SCAN_LIK_SIG`` (held as ``ScanLikelihoodFunction``), or None: the Gaussian
        range (and bearing) sensor of ``sense`` (sr, sb), computed inline by the filters
    sample : its own sampler of a step's observations given the true pose (``SCAN_SAMPLE_SIG``),
        or None: ``sense_beacons``
    theta : (p,) float64, the parameters handed to both
    A model with its own loglik keeps ``sensor`` and ``sense``: the filters still read them where
    they draw poses from the sensor (MCL's resets, the SSPF's UKF proposal), as the Gaussian
    that best describes the sensor.
    """

    area: np.ndarray
    beacons: np.ndarray
    waypoints: np.ndarray
    start: np.ndarray
    drive: np.ndarray
    motion: int
    mnoise: MotionNoise
    sensor: int
    sense: BeaconSensor
    steps: int
    kidnaps: np.ndarray
    kidnap_poses: np.ndarray
    bound: float
    init: InitialBelief
    score_from: int = 1
    report_step: int = 0
    hold: int = 10          # converge_hold_steps
    loglik: Any = None
    sample: Any = None
    theta: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self):
        object.__setattr__(self, "loglik", model_function(self.loglik, ScanLikelihoodFunction))
        object.__setattr__(self, "sample", model_function(self.sample, ScanSamplerFunction))
        object.__setattr__(self, "theta", np.ascontiguousarray(self.theta, dtype=np.float64))

    @property
    def has_likelihood(self) -> bool:
        """Whether the model brings its own log-likelihood (else: the Gaussian sensor)."""
        return self.loglik is not None

    def likelihood(self) -> tuple:
        """(loglik, 1) as the kernels take them, or (a placeholder, 0) where the model has none
        (the filters then weigh by the Gaussian sensor inline)."""
        if self.loglik is None:
            return scan_placeholder(ScanLikelihoodFunction), 0
        return self.loglik, 1

    def scan_model(self) -> ScanModel:
        """The beacons and the likelihood (``likelihood``) as the filters' kernels take them."""
        return ScanModel(self.beacons, *self.likelihood(), self.theta)

    def sampler(self) -> tuple:
        """(sample, 1) as ``simulate_field`` takes them, or (a placeholder, 0):
        ``sense_beacons``."""
        if self.sample is None:
            return scan_placeholder(ScanSamplerFunction), 0
        return self.sample, 1

    def provides(self) -> set:
        """What the model gives its filters of ``protocols.NEEDS``: a likelihood always, and a
        Gaussian measurement (the sensor's sr, sb) unless it brings its own likelihood."""
        return {"likelihood"} | (set() if self.has_likelihood else {"gaussian_measurement"})


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



_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]


@kernel(types.void(_F, _F2, _F2, _F, _F, types.int64, MOTION_NOISE, types.int64, BEACON_SENSOR, _I,
                   _F2, ScanSampleFn, types.int64, _F, STATE, _F2, _F2, _I, _I2, _F3), cache=True)
def simulate_field(area, bc, wp, start, drive, motion, mnoise, sensor, sense, kid, kpose, sample,
                   use_sample, theta, s, pose, ctrl, obs_n, obs_id, obs_z):
    """Drive the path, kidnap, and sense each step: the observations from ``sense_beacons``, or,
    with ``use_sample``, from the model's own ``sample`` (theta its parameters)."""
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
        if motion == MOTION_ODOMETRY:     # (T, dtheta): move, then turn
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
        if use_sample:
            obs_n[t] = sample(x, y, th, bc, theta, s, obs_id[t], obs_z[t])
        else:
            obs_n[t] = sense_beacons(bc, x, y, th, sensor, sense, s, obs_id[t], obs_z[t])



def simulate(model: FieldModel, state: np.ndarray) -> tuple[FieldData, FieldData]:
    """Simulate one trial; returns (truth, data), the same object: the filters read only ctrl and
    the observations."""
    T, B = model.steps, model.beacons.shape[0]
    d = FieldData(np.empty((T + 1, 3)), np.empty((T, 3)), np.zeros(T, dtype=np.int64),
                  np.zeros((T, B), dtype=np.int64), np.zeros((T, B, 2)))
    simulate_field(model.area, model.beacons, model.waypoints, model.start, model.drive,
                   model.motion, model.mnoise, model.sensor, model.sense, model.kidnaps,
                   model.kidnap_poses, *model.sampler(), model.theta, state, d.pose, d.ctrl, d.obs_n, d.obs_id, d.obs_z)
    return d, d

