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
field of view, with Gaussian noise (``sense_landmarks``), unless the model brings its own
measurement model.

A SLAM model may bring its own log-likelihood of one range-bearing observation of one landmark
and its own sampler of a step's observations (``SlamModel.loglik``, ``.sample``, with their
parameters ``.theta``): numba functions of the signatures

- ``SLAM_LIK_SIG``, ``loglik(X, Y, H, LX, LY, zr, zb, theta, out)``: out[i] = log p(z | pose i,
  landmark i), the log density of the observation z = [zr, zb] (m, rad) of a landmark at
  (LX[i], LY[i]) seen from the pose (X[i], Y[i], H[i]) (m, m, rad), for i < X.size, with its
  constants; -inf where that pose and landmark cannot have produced z. Every argument array is
  float64[::1] (a particle filter that keeps its landmarks as (M, N) arrays hands row j). It is
  the likelihood of an observation given that the landmark was seen (known identity), not of
  seeing it;
- ``SLAM_SAMPLE_SIG``, ``sample(x, y, th, lm, theta, s, ids, zs) -> n``: the observations seen
  from the true pose (x, y, th) of the landmarks lm (M, 2) into ids[:n], zs[:n] ([range,
  bearing]), its random numbers from the generator state ``s`` (``pfbench.rng``); it decides
  what is in view. The signature is the beacon field's ``SCAN_SAMPLE_SIG``.

The built-in ``slam_mixture_loglik`` / ``slam_mixture_sample`` are the landmark world's outliers
(keys ``range_outliers``, ``bearing_outliers``): a range is, with probability eps_r, uniform over
[0, max_range], else the true range with Gaussian noise; a bearing, independently, with
probability eps_b uniform over the field of view, else the true bearing with Gaussian noise.
Without outliers they are the Gaussian sensor (the likelihood to rounding; the sampler's draws
exactly ``sense_landmarks``').
"""
from __future__ import annotations

import math
import functools
from dataclasses import dataclass, field
from typing import Any, NamedTuple

import numpy as np
from numba import typeof, types
from numba.core.typing.typeof import typeof_impl
from .._lazy import kernel

from ..angles import wrap
from ..codes import SLAM_ODOMETRY, SLAM_STEERED
from ..rng import STATE, normal, uniform
from .beacons import (SCAN_SAMPLE_SIG, mixture_bearing_logpdf, mixture_range,
                      mixture_range_logpdf)
from .scalar import ModelFunction, model_function
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

    loglik : the model's own log-likelihood of one observation of one landmark, a numba function
        of ``SLAM_LIK_SIG`` (held as ``SlamLikelihoodFunction``), or None: the Gaussian
        range-bearing sensor of ``noise`` (range, bearing)
    sample : its own sampler of a step's observations given the true pose (``SLAM_SAMPLE_SIG``,
        held as ``SlamSamplerFunction``), or None: ``sense_landmarks``
    theta : (p,) float64, the parameters handed to both

    Without ``loglik`` the measurement is the Gaussian range-bearing sensor, with its Jacobians
    (``provides``): FastSLAM's landmark EKFs update each landmark's Gaussian by the
    measurement's mean, Jacobian and noise covariance, which a likelihood function does not
    give. A model with its own ``loglik`` no longer provides the Gaussian measurement (its
    Jacobians, of the range-bearing mean, stay), so FastSLAM refuses it; a particle SLAM filter
    whose particles carry point landmarks weighs by it (``likelihood_function``). A model with
    its own ``loglik`` keeps ``noise``: the Gaussian nearest its sensor, which a filter may read
    (a landmark's first estimate, a proposal's spread).
    """

    waypoints: np.ndarray
    landmarks: np.ndarray
    start: np.ndarray
    vehicle: np.ndarray
    noise: np.ndarray
    sensor: np.ndarray
    steps: int
    motion: int = SLAM_STEERED     # codes.SLAM_STEERED or SLAM_ODOMETRY
    loglik: Any = None
    sample: Any = None
    theta: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def __post_init__(self):
        for name, kind in (("vehicle", Vehicle), ("noise", SlamNoise), ("sensor", SlamSensor)):
            object.__setattr__(self, name, _record(kind, getattr(self, name)))
        object.__setattr__(self, "loglik", model_function(self.loglik, SlamLikelihoodFunction))
        object.__setattr__(self, "sample", model_function(self.sample, SlamSamplerFunction))
        object.__setattr__(self, "theta", np.ascontiguousarray(self.theta, dtype=np.float64))

    @property
    def has_likelihood(self) -> bool:
        """Whether the model brings its own log-likelihood (else: the Gaussian sensor)."""
        return self.loglik is not None

    def likelihood_function(self) -> tuple:
        """(loglik, theta): the log-likelihood of ``SLAM_LIK_SIG`` a particle filter weighs an
        observation by, the model's own, or the Gaussian sensor's (``slam_mixture_loglik``
        without outliers: N(zr; r, noise.range^2) N(wrap(zb - b); 0, noise.bearing^2))."""
        if self.loglik is not None:
            return self.loglik, self.theta
        return (model_function(slam_mixture_loglik, SlamLikelihoodFunction),
                slam_mixture_theta(self.sensor, self.noise, 0.0, 0.0))

    def sampler(self) -> tuple:
        """(sample, 1) as the simulators take them, or (a placeholder, 0):
        ``sense_landmarks``."""
        if self.sample is None:
            return slam_placeholder(SlamSamplerFunction), 0
        return self.sample, 1

    def provides(self) -> set:
        """What the model gives its filters of ``protocols.NEEDS``: a likelihood and the
        Jacobians of the range-bearing mean always, and the Gaussian measurement (noise.range,
        noise.bearing) unless it brings its own likelihood."""
        return {"jacobians", "likelihood"} | (set() if self.has_likelihood
                                              else {"gaussian_measurement"})



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


# --- a SLAM model's own measurement model (see the module's docstring) ------------------------

SLAM_LIK_SIG = types.void(_F, _F, _F, _F, _F, types.float64, types.float64, _F, _F)
SlamLikFn = types.FunctionType(SLAM_LIK_SIG)
SLAM_SAMPLE_SIG = SCAN_SAMPLE_SIG
SlamSampleFn = types.FunctionType(SLAM_SAMPLE_SIG)


class SlamLikelihoodFunction(ModelFunction):
    """A SLAM model's log-likelihood of one observation of one landmark (``SLAM_LIK_SIG``) as
    the kernels take it: the address of its compiled entry (see
    ``pfbench.models.scalar.ModelFunction``)."""

    SIG, SIG_NAME, WHAT = SLAM_LIK_SIG, "SLAM_LIK_SIG", "landmark log-likelihood"
    ARGS = ("(X: float64[::1], Y: float64[::1], H: float64[::1], LX: float64[::1], "
            "LY: float64[::1], zr: float64, zb: float64, theta: float64[::1], "
            "out: float64[::1]) -> void")


class SlamSamplerFunction(ModelFunction):
    """A SLAM model's sampler of a step's observations (``SLAM_SAMPLE_SIG``) as the kernels
    take it."""

    SIG, SIG_NAME, WHAT = SLAM_SAMPLE_SIG, "SLAM_SAMPLE_SIG", "landmark sampler"
    ARGS = ("(x: float64, y: float64, th: float64, lm: float64[:, ::1], theta: float64[::1], "
            "s: uint64[::1], ids: int64[::1], zs: float64[:, ::1]) -> int64")


@typeof_impl.register(SlamLikelihoodFunction)
def _typeof_slam_likelihood(val, c):
    return SlamLikFn


@typeof_impl.register(SlamSamplerFunction)
def _typeof_slam_sampler(val, c):
    return SlamSampleFn


@functools.cache
def slam_placeholder(cls):
    """The placeholder of a ``cls`` (SlamLikelihoodFunction or SlamSamplerFunction) that the
    kernels take where the model has none (and never call), looked up once."""
    return cls(no_slam_loglik if cls is SlamLikelihoodFunction else no_slam_sample)


@kernel(SLAM_LIK_SIG, cache=True, by_address=True)
def no_slam_loglik(X, Y, H, LX, LY, zr, zb, theta, out):
    """The placeholder of a SLAM model without its own log-likelihood (never called)."""
    out[:] = np.nan


@kernel(SLAM_SAMPLE_SIG, cache=True, by_address=True)
def no_slam_sample(x, y, th, lm, theta, s, ids, zs):
    """The placeholder of a SLAM model without its own sampler (never called)."""
    return 0


# theta of the built-in outliers: the sensor's visibility and noise, the outlier probabilities
(SLAM_MIX_MAX_RANGE, SLAM_MIX_HALF_FOV, SLAM_MIX_SR, SLAM_MIX_SB, SLAM_MIX_EPS_R, SLAM_MIX_EPS_B,
 SLAM_MIX_RMAX) = range(7)


def slam_mixture_theta(sensor: SlamSensor, noise: SlamNoise, eps_r: float,
                       eps_b: float) -> np.ndarray:
    """theta of ``slam_mixture_loglik`` / ``slam_mixture_sample``: the sensor's range (m) and
    half field of view (rad), the noise's range (m) and bearing (rad) standard deviations, the
    range and bearing outlier probabilities, and the range outliers' largest range (the
    sensor's, m)."""
    return np.array([sensor.max_range, sensor.half_fov, noise.range, noise.bearing, eps_r, eps_b,
                     sensor.max_range], dtype=np.float64)


@kernel(SLAM_LIK_SIG, cache=True, by_address=True, error_model="numpy")
def slam_mixture_loglik(X, Y, H, LX, LY, zr, zb, theta, out):
    """log p(z | pose, landmark) of the range and bearing outlier mixtures (theta:
    ``slam_mixture_theta``): log((1 - eps_r) N(zr; r, sr^2) + eps_r U(zr; 0, rmax)) +
    log((1 - eps_b) N(wrap(zb - b); 0, sb^2) + eps_b U(zb; -half_fov, half_fov)); without
    outliers the Gaussian sensor's log density."""
    sr, sb, half_fov = theta[SLAM_MIX_SR], theta[SLAM_MIX_SB], theta[SLAM_MIX_HALF_FOV]
    eps_r, eps_b, rmax = theta[SLAM_MIX_EPS_R], theta[SLAM_MIX_EPS_B], theta[SLAM_MIX_RMAX]
    for i in range(X.size):
        dx, dy = LX[i] - X[i], LY[i] - Y[i]
        out[i] = (mixture_range_logpdf(zr, math.sqrt(dx * dx + dy * dy), sr, eps_r, rmax)
                  + mixture_bearing_logpdf(zb, math.atan2(dy, dx) - H[i], sb, eps_b, half_fov))


@kernel(SLAM_SAMPLE_SIG, cache=True, by_address=True)
def slam_mixture_sample(x, y, th, lm, theta, s, ids, zs):
    """The landmarks within the sensor's range and field of view seen from (x, y, th), as
    ``sense_landmarks``, each range with probability eps_r uniform over [0, rmax] and each
    bearing with probability eps_b uniform over the field of view (theta:
    ``slam_mixture_theta``); without outliers ``sense_landmarks``' draws exactly."""
    rmax, half_fov = theta[SLAM_MIX_MAX_RANGE], theta[SLAM_MIX_HALF_FOV]
    sr, sb = theta[SLAM_MIX_SR], theta[SLAM_MIX_SB]
    eps_r, eps_b, rout = theta[SLAM_MIX_EPS_R], theta[SLAM_MIX_EPS_B], theta[SLAM_MIX_RMAX]
    n = 0
    for j in range(lm.shape[0]):
        ex, ey = lm[j, 0] - x, lm[j, 1] - y
        r = math.sqrt(ex * ex + ey * ey)
        b = wrap(math.atan2(ey, ex) - th)
        if r <= rmax and abs(b) <= half_fov:
            ids[n] = j
            zs[n, 0] = mixture_range(r, sr, eps_r, rout, s) if eps_r > 0.0 else r + sr * normal(s)
            if eps_b > 0.0 and uniform(s) < eps_b:
                zs[n, 1] = half_fov * (2.0 * uniform(s) - 1.0)
            else:
                zs[n, 1] = wrap(b + sb * normal(s))
            n += 1
    return n


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
                    _I, _I2, _F3, _I, SlamSampleFn, types.int64, _F), cache=True)
def simulate_course(wp, lm, start, veh, noise, sensor, steps, s, pose, ctrl, obs_n, obs_id, obs_z,
                    wp_idx, sample, use_sample, theta):
    """Drive the course and sense the landmarks.

    pose (steps+1, 3): true poses; ctrl (steps, 2): the noisy [V, G] the filters see; per
    observation k (at control step (k+1) obs_every): obs_n[k] landmarks seen, obs_id[k, :n] their
    indices and obs_z[k, :n] their noisy [range, bearing]; wp_idx (steps+1,) the waypoint being
    driven to. The observations are ``sense_landmarks``', or, with ``use_sample``, the model's own
    ``sample``'s (theta its parameters). Returns the number of control steps driven (fewer than
    ``steps`` when ``laps`` ends the run).
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
            if use_sample:
                obs_n[k] = sample(x, y, th, lm, theta, s, obs_id[k], obs_z[k])
            else:
                obs_n[k] = sense_landmarks(lm, x, y, th, rmax, half_fov, noise, s, obs_id[k],
                                           obs_z[k])
            k += 1
    return steps



@kernel(types.int64(_F2, _F2, _F, VEHICLE, SLAM_NOISE, SLAM_SENSOR, types.int64, STATE, _F2, _F2,
                    _I, _I2, _F3, _I, SlamSampleFn, types.int64, _F), cache=True)
def simulate_odometry(wp, lm, start, veh, noise, sensor, steps, s, pose, ctrl, obs_n, obs_id,
                      obs_z, wp_idx, sample, use_sample, theta):
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
            if use_sample:
                obs_n[k] = sample(x, y, th, lm, theta, s, obs_id[k], obs_z[k])
            else:
                obs_n[k] = sense_landmarks(lm, x, y, th, rmax, half_fov, noise, s, obs_id[k],
                                           obs_z[k])
            k += 1
    return steps



def simulate(model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Simulate one trial with the model's vehicle; returns (truth, data), the same object
    (filters use only ctrl and the observations; metrics use pose and the landmarks)."""
    return run_simulator(simulate_odometry if model.motion == SLAM_ODOMETRY else simulate_course, model, state)


def run_simulator(simulator, model: SlamModel, state: np.ndarray) -> tuple[CourseData, CourseData]:
    """Allocate a trial's arrays, run a numba ``simulator`` with simulate_course's signature (the
    model's sampler last: ``SlamModel.sampler`` and theta), and trim them to the steps driven."""
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
                       model.sensor, T, state, pose, ctrl, obs_n, obs_id, obs_z, wp_idx,
                       *model.sampler(), model.theta)
    k = driven // every
    data = CourseData(pose[:driven + 1], ctrl[:driven], obs_n[:k], obs_id[:k], obs_z[:k],
                      wp_idx[:driven + 1], driven)
    return data, data
