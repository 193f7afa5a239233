"""The SLAM model: a robot drives a closed waypoint path among point landmarks and senses their
range and bearing (known identities). ``SlamModel`` is what a SLAM scenario builds and a SLAM
filter reads; ``CourseData`` is one trial's truth and data.

Two vehicles (``SlamModel.motion``):

- 0, the steered vehicle of the classic FastSLAM simulators:
  x += V dt cos(theta + G), y += V dt sin(theta + G), theta += V dt sin(G) / L, with the steering
  G driven toward the next waypoint (at most ``max_steer``, turning at most ``max_rate``); the
  filters see the controls [V, G] with noise (``simulate_course``);
- 1, the odometry form: per step the odometry reports [ds, dtheta], the robot turns by dtheta and
  moves ds, and the truth also receives Gaussian noise on x, y and the heading, which each
  particle draws too (``simulate_odometry``).

Every ``obs_every`` steps a range-bearing sensor sees each landmark within ``max_range`` and the
field of view, with Gaussian noise (``sense_landmarks``).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np
from numba import typeof, types
from .._lazy import kernel

from ..angles import wrap
from ..codes import SLAM_ODOMETRY, SLAM_STEERED
from ..rng import STATE, normal
from .waypoints import next_waypoint


class Vehicle(NamedTuple):
    """A SLAM model's vehicle: speed V (m/s), control step dt (s), wheelbase L (m; the steered
    vehicle's), the largest steering angle (rad; the odometry form's largest turn rate, rad/s),
    the steered vehicle's largest steering rate (rad/s), the radius within which a waypoint
    counts as reached (m), and the laps to drive (0: until the steps run out), all floats."""

    speed: float
    dt: float
    wheelbase: float
    max_steer: float
    max_rate: float
    wp_radius: float
    laps: float


class SlamNoise(NamedTuple):
    """A SLAM model's noise standard deviations (what the data carry): the drive's (the steered
    vehicle's speed, m/s; the odometry form's x and y, m) and the turn's (the steering angle, or
    the heading, rad), then the sensor's range (m) and bearing (rad)."""

    drive: float
    turn: float
    range: float
    bearing: float


class SlamSensor(NamedTuple):
    """A SLAM model's range-bearing sensor: its range (m), half its field of view (rad) and the
    control steps between observations (a float)."""

    max_range: float
    half_fov: float
    every: float


VEHICLE = typeof(Vehicle(1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 0.0))
SLAM_NOISE = typeof(SlamNoise(0.0, 0.0, 0.0, 0.0))
SLAM_SENSOR = typeof(SlamSensor(1.0, 1.0, 1.0))


def _record(kind, values):
    """``values`` as record ``kind`` of floats (a record, or a sequence in its fields' order)."""
    return kind(*(float(v) for v in values))


@dataclass(frozen=True)
class SlamModel:
    """Everything a SLAM trial on a waypoint course needs (arrays in SI units and radians).

    waypoints (K, 2), landmarks (M, 2), start (3,): the world
    vehicle : a ``Vehicle``; noise : a ``SlamNoise`` (what the data carry); sensor : a
        ``SlamSensor`` (each also given as a sequence in the record's field order, made the
        record here)
    steps : control steps
    motion : SLAM_STEERED, the steered vehicle (noise drive, turn: sigma_V, sigma_G), or
        SLAM_ODOMETRY, the odometry form (sigma_xy, sigma_theta; see simulate_odometry)

    The measurement is the Gaussian range-bearing sensor, with its Jacobians (``provides``). The
    model takes no log-likelihood of its own, as a field model does: a SLAM filter's landmark
    EKFs update each landmark's Gaussian by the measurement's mean, Jacobian and noise
    covariance, which a likelihood function does not give, and a particle weight by another
    likelihood than the one its landmark updates assume would weigh maps that model a different
    sensor. A SLAM scenario whose sensor is not that Gaussian declares what it provides
    (``PROVIDES = ("likelihood",)``), and FastSLAM, which needs both, refuses it.
    """

    waypoints: np.ndarray
    landmarks: np.ndarray
    start: np.ndarray
    vehicle: np.ndarray
    noise: np.ndarray
    sensor: np.ndarray
    steps: int
    motion: int = SLAM_STEERED     # codes.SLAM_STEERED or SLAM_ODOMETRY

    def __post_init__(self):
        for name, kind in (("vehicle", Vehicle), ("noise", SlamNoise), ("sensor", SlamSensor)):
            object.__setattr__(self, name, _record(kind, getattr(self, name)))

    def provides(self) -> set:
        """What the model gives its filters of ``protocols.NEEDS``: the Gaussian range-bearing
        measurement (noise.range, noise.bearing), its Jacobians and so its likelihood."""
        return {"gaussian_measurement", "jacobians", "likelihood"}



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



_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]


@kernel(types.int64(_F2, types.float64, types.float64, types.float64, types.float64, types.float64,
                  SLAM_NOISE, STATE, _I, _F2), cache=True)
def sense_landmarks(lm, x, y, th, rmax, half_fov, noise, s, ids, zs):
    """Observe every landmark of lm within rmax and the field of view from pose (x, y, th): fill
    ids (M,) and zs (M, 2) with their indices and noisy [range, bearing]; return how many."""
    n = 0
    for j in range(lm.shape[0]):
        ex, ey = lm[j, 0] - x, lm[j, 1] - y
        r = math.sqrt(ex * ex + ey * ey)
        b = wrap(math.atan2(ey, ex) - th)
        if r <= rmax and abs(b) <= half_fov:
            ids[n] = j
            zs[n, 0] = r + noise.range * normal(s)
            zs[n, 1] = wrap(b + noise.bearing * normal(s))
            n += 1
    return n



@kernel(types.int64(_F2, _F2, _F, VEHICLE, SLAM_NOISE, SLAM_SENSOR, types.int64, STATE, _F2, _F2,
                    _I, _I2, _F3, _I), cache=True)
def simulate_course(wp, lm, start, veh, noise, sensor, steps, s, pose, ctrl, obs_n, obs_id, obs_z,
                    wp_idx):
    """Drive the course and sense the landmarks.

    pose (steps+1, 3): true poses; ctrl (steps, 2): the noisy [V, G] the filters see; per
    observation k (at control step (k+1) obs_every): obs_n[k] landmarks seen, obs_id[k, :n] their
    indices and obs_z[k, :n] their noisy [range, bearing]; wp_idx (steps+1,) the waypoint being
    driven to. Returns the number of control steps driven (fewer than ``steps`` when ``laps`` ends
    the run).
    """
    V, dt, L, maxG, rate = veh.speed, veh.dt, veh.wheelbase, veh.max_steer, veh.max_rate
    radius, laps = veh.wp_radius, veh.laps
    rmax, half_fov, every = sensor.max_range, sensor.half_fov, int(sensor.every)
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
        ctrl[t, 0] = V + noise.drive * normal(s)
        ctrl[t, 1] = G + noise.turn * normal(s)
        if (t + 1) % every == 0:
            obs_n[k] = sense_landmarks(lm, x, y, th, rmax, half_fov, noise, s, obs_id[k], obs_z[k])
            k += 1
    return steps



@kernel(types.int64(_F2, _F2, _F, VEHICLE, SLAM_NOISE, SLAM_SENSOR, types.int64, STATE, _F2, _F2,
                    _I, _I2, _F3, _I), cache=True)
def simulate_odometry(wp, lm, start, veh, noise, sensor, steps, s, pose, ctrl, obs_n, obs_id,
                      obs_z, wp_idx):
    """Drive the closed path; fill the true poses, the odometry [ds, dtheta] and the observations
    (as simulate_course); return the steps driven."""
    V, dt, maxturn, radius, laps = veh.speed, veh.dt, veh.max_steer, veh.wp_radius, veh.laps
    rmax, half_fov, every = sensor.max_range, sensor.half_fov, int(sensor.every)
    x, y, th = start[0], start[1], start[2]
    pose[0, 0], pose[0, 1], pose[0, 2] = x, y, th
    iw = 0
    lap = 0
    wp_idx[0] = 0
    k = 0
    for t in range(steps):
        iw, lap = next_waypoint(wp, iw, lap, x, y, radius)
        if laps > 0 and lap >= laps:
            return t
        dx, dy = wp[iw, 0] - x, wp[iw, 1] - y
        lim = maxturn * dt
        dth = max(-lim, min(lim, wrap(math.atan2(dy, dx) - th)))
        ds = V * dt
        ctrl[t, 0] = ds
        ctrl[t, 1] = dth
        th = th + dth + noise.turn * normal(s)
        x += ds * math.cos(th) + noise.drive * normal(s)
        y += ds * math.sin(th) + noise.drive * normal(s)
        th = wrap(th)
        pose[t + 1, 0], pose[t + 1, 1], pose[t + 1, 2] = x, y, th
        wp_idx[t + 1] = iw
        if (t + 1) % every == 0:
            obs_n[k] = sense_landmarks(lm, x, y, th, rmax, half_fov, noise, s, obs_id[k], obs_z[k])
            k += 1
    return steps



def simulate(model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Simulate one trial with the model's vehicle; returns (truth, data), the same object
    (filters use only ctrl and the observations; metrics use pose and the landmarks)."""
    return run_simulator(simulate_odometry if model.motion == SLAM_ODOMETRY else simulate_course, model, state)


def run_simulator(simulator, model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Allocate a trial's arrays, run a numba ``simulator`` with simulate_course's signature, and
    trim them to the steps driven."""
    T = model.steps
    every = int(model.sensor.every)
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
