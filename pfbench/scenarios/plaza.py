"""CMU's Plaza range-only data sets (Djugash, Hamner and Roth, J. Field Robotics 2009), recorded on
a real robot: localization among 4 surveyed UWB ranging beacons, with GPS/INS ground truth. The
files are not in this repository: they come with the optional extra (``pip install '.[data]'``,
pfbench.datasets) or from a folder of one's own (``data_dir``).

What a trial holds: the recorded run, the same in every trial (only the filters' random draws
differ between trials). The time span [start_s, end_s] is cut into steps of about ``step_s``
seconds, each from one ground-truth row to a later one; a step's odometry is the composition of
the recorded odometry rows (distance, heading change: turn, then move) over it, as
[rot1, trans, rot2] of the beacon field's rot_trans_rot model, whose noise grows with the distance
and the turn (``alphas``). The true pose is the ground truth at the step's end; each range is
given to the step whose end is nearest to its time (at most one per beacon of the set a step, the
rest dropped and counted in the description of the run). Plaza 2's ground-truth heading is pi off
the direction of travel and is turned by pi.

The odometry is derived from the ground truth: Plaza 1's heading increments equal it exactly,
Plaza 2's are 0.985 of it minus 7e-4 rad a step. Plaza therefore tests the range model and the
real geometry (the beacons' layout, the robot's path, the gaps in the ranges), not odometry noise.

The range model: a measured range is z = a d + b + noise (d the true distance); the ranges are
measured about 7 % long. ``fitted_on`` says where a and b come from: 'other' (the default) fits
them by least squares on the other data set's ranges against its ground truth, never on the one
judged; 'none' takes a = 1, b = 0 (the ranges as recorded); 'same' fits them on the set judged
(optimistic: the calibration has seen the answer). The filters see the calibrated ranges
(z - b) / a. The likelihood is robust: a mixture of the Gaussian of ``range_noise_m`` and, with
probability ``range_outliers``, a range uniform over [0, ``max_range_m``] (the beacon field's
``mixture_loglik``).

The filters start around the true start pose (``start: known``, tracking) or uniformly over the
area (``start: uniform``, global localization): the bounding box of the beacons and the path with
``margin_m`` around it, in a frame whose origin is that box's corner.
"""
from __future__ import annotations

import math

import numpy as np

from .. import datasets
from ..codes import FIELD_MOTIONS, SENSORS
from ..models.beacons import BeaconSensor, mixture_loglik, mixture_theta
from ..models.field import FieldData, FieldModel
from ..models.odometry import MotionNoise
from ..models.pose import InitialBelief
from ..schema import ConfigError, Key

NAME = "plaza"
KIND = "localization"
PROVIDES = ()
DESCRIPTION = ("recorded range-only localization among 4 UWB beacons (CMU Plaza 1 and 2, with "
               "odometry derived from the ground truth; data: pip install '.[data]')")

DEG = math.pi / 180.0
# the turn that makes each set's ground-truth heading the direction of travel (rad)
HEADING_FIX = {"plaza1": 0.0, "plaza2": math.pi}
OTHER = {"plaza1": "plaza2", "plaza2": "plaza1"}

SCHEMA = {
    "data": Key("choice", "plaza1", "the data set: 'plaza1' (1933 s, 1859 m driven, 3529 ranges) "
                "or 'plaza2' (410 s, 1354 m, 1816 ranges)", choices=("plaza1", "plaza2")),
    "data_dir": Key("str", None, "a folder holding Plaza1_.mat and Plaza2_.mat (relative to the "
                    "experiment file); null: the files of the installed extra "
                    "(pip install '.[data]')", nullable=True),
    "verify_digest": Key("bool", True, "check each file against the sha256 of gtsam 4.3.0's copy "
                         "(false: a copy of one's own that differs)"),
    "start_s": Key("float", 0.0, "start of the time span, seconds after the first ground-truth "
                   "row", min=0.0),
    "end_s": Key("float", 0.0, "end of the time span, seconds after the first ground-truth row "
                 "(0: the end of the set)", min=0.0),
    "step_s": Key("float", 0.2, "duration of a step (s; the ground truth is at 5 Hz on Plaza 1, "
                  "10 Hz on Plaza 2; our choice)", min=0.05),
    "fitted_on": Key("choice", "other", "where the range scale and bias come from: 'other' (the "
                     "other data set, cross-calibrated: ours), 'none' (the ranges as recorded) "
                     "or 'same' (the set judged: optimistic)", choices=("other", "none", "same")),
    "range_noise_m": Key("float", 0.6, "range noise standard deviation of the likelihood, after "
                         "calibration (the residuals' is 0.53-0.55 m on both sets; our choice)",
                         min=0.0, min_exclusive=True),
    "range_outliers": Key("float", 0.05, "probability of an outlier range in the likelihood, "
                          "uniform over [0, max_range_m] (0: the Gaussian alone; our choice)",
                          min=0.0, max=1.0, max_exclusive=True),
    "max_range_m": Key("float", 100.0, "largest range of an outlier (m; the sets' largest is "
                       "about 85 m)", min=0.0, min_exclusive=True),
    "alphas": Key("floats", (0.05, 0.01, 0.05, 0.0), "odometry noise alpha1..alpha4 of the "
                  "rot_trans_rot model: turn sd alpha1 |turn| + alpha2 distance (rad/m), distance "
                  "sd alpha3 distance + alpha4 |turns| (our choice)", min=0.0,
                  check=lambda v: None if len(v) == 4 else "expected four values"),
    "start": Key("choice", "known", "what the filters know of the start: 'known' (drawn around "
                 "the true start pose: tracking) or 'uniform' (uniform over the area and heading: "
                 "global localization)", choices=("known", "uniform")),
    "initial_std_m": Key("float", 0.5, "known: position spread of the initial particles", min=0.0),
    "initial_std_deg": Key("float", 5.0, "known: heading spread of the initial particles",
                           min=0.0),
    "margin_m": Key("float", 5.0, "margin around the beacons and the path that makes the area "
                    "(m)", min=0.0),
    "converge_bound_m": Key("float", 2.0, "position error under which a filter counts as "
                            "converged (our choice: a few range sds)", min=0.0,
                            min_exclusive=True),
    "converge_hold_s": Key("float", 10.0, "seconds the error must stay under the bound at the "
                           "end of the span to count as converged", min=0.0, min_exclusive=True),
    "score_from_s": Key("float", 0.0, "first time (s into the span) the error averages count: "
                        "later than 0 scores the error after global localization", min=0.0),
}


def resolve(params: dict, base_dir) -> dict:
    """Check the time span; make data_dir absolute (relative to the experiment file). The data
    are not read here: a results folder that is up to date prints its table without them."""
    out = dict(params)
    if params["end_s"] and params["end_s"] <= params["start_s"] + params["step_s"]:
        raise ConfigError("scenario.end_s", f"expected more than start_s + step_s "
                          f"({params['start_s'] + params['step_s']:g} s), got {params['end_s']:g}")
    if params["data_dir"]:
        from pathlib import Path
        out["data_dir"] = str((Path(base_dir) / params["data_dir"]).resolve())
    return out


def unavailable(params: dict) -> str | None:
    """Why the data a config of this scenario needs cannot be read here (one line), or None."""
    p = {k: v.default for k, v in SCHEMA.items()} | dict(params)
    need = {p["data"]} | ({OTHER[p["data"]]} if p["fitted_on"] == "other" else set())
    for name in sorted(need):
        why = datasets.missing(name, p["data_dir"] or None)
        if why:
            return why
    return None


def _record(name: str, p: dict) -> datasets.PlazaRecord:
    return datasets.read_plaza(name, p["data_dir"] or None, p["verify_digest"])


def true_ranges(rec: datasets.PlazaRecord) -> tuple[np.ndarray, np.ndarray]:
    """(z, d): each recorded range and the true distance from the ground truth (interpolated at
    the range's time) to its beacon (m); ranges outside the ground truth's time are left out."""
    gt, td = rec.gt, rec.td
    keep = (td[:, 0] >= gt[0, 0]) & (td[:, 0] <= gt[-1, 0])
    td = td[keep]
    x = np.interp(td[:, 0], gt[:, 0], gt[:, 1])
    y = np.interp(td[:, 0], gt[:, 0], gt[:, 2])
    row = {int(b): i for i, b in enumerate(rec.beacons[:, 0])}
    b = np.array([row.get(int(i), -1) for i in td[:, 2]], dtype=np.int64)
    ok = b >= 0
    bx, by = rec.beacons[b[ok], 1], rec.beacons[b[ok], 2]
    return td[ok, 3], np.hypot(bx - x[ok], by - y[ok])


def calibration(p: dict) -> tuple[float, float]:
    """(a, b) of z = a d + b: fitted by least squares on the set ``fitted_on`` names, or (1, 0)."""
    if p["fitted_on"] == "none":
        return 1.0, 0.0
    name = OTHER[p["data"]] if p["fitted_on"] == "other" else p["data"]
    z, d = true_ranges(_record(name, p))
    a, b = np.polyfit(d, z, 1)
    return float(a), float(b)


def compose(dr: np.ndarray) -> tuple[float, float, float]:
    """[rot1, trans, rot2] of the odometry rows dr (k, 3) (t, distance, heading change; each
    turns, then moves) composed into one motion."""
    x = y = th = 0.0
    for d, dth in dr[:, 1:3]:
        th += dth
        x += d * math.cos(th)
        y += d * math.sin(th)
    trans = math.hypot(x, y)
    rot1 = math.atan2(y, x) if trans > 0.0 else 0.0
    rot2 = math.remainder(th - rot1, 2.0 * math.pi)
    return rot1, trans, rot2


def steps_of(rec: datasets.PlazaRecord, p: dict) -> np.ndarray:
    """The ground-truth rows (T+1,) that bound the steps of the span."""
    t = rec.gt[:, 0]
    t0 = t[0] + p["start_s"]
    t1 = t[-1] if not p["end_s"] else min(t[-1], t[0] + p["end_s"])
    if t0 >= t1:
        raise ConfigError("scenario.start_s", f"the span starts after the data set's end "
                          f"({t[-1] - t[0]:.1f} s)")
    targets = np.arange(t0, t1 + 1e-9, p["step_s"])
    rows = np.unique(np.minimum(np.searchsorted(t, targets - 1e-9), t.size - 1))
    if rows.size < 2:
        raise ConfigError("scenario.end_s", "the span holds no step")
    return rows


def recorded(rec: datasets.PlazaRecord, p: dict, a: float, b: float,
             offset: np.ndarray) -> tuple[FieldData, np.ndarray, int]:
    """The span as a trial's data (FieldData, in the area's frame), the steps' end times (T+1,) s
    and the ranges dropped (more in a step than the set has beacons)."""
    rows = steps_of(rec, p)
    T, B = rows.size - 1, rec.beacons.shape[0]
    gt = rec.gt
    fix = HEADING_FIX[p["data"]]
    pose = np.empty((T + 1, 3))
    pose[:, 0] = gt[rows, 1] - offset[0]
    pose[:, 1] = gt[rows, 2] - offset[1]
    pose[:, 2] = np.remainder(gt[rows, 3] + fix + math.pi, 2.0 * math.pi) - math.pi
    ctrl = np.empty((T, 3))
    for k in range(T):
        ctrl[k] = compose(rec.dr[rows[k]:rows[k + 1]])
    times = gt[rows, 0]
    obs_n = np.zeros(T, dtype=np.int64)
    obs_id = np.zeros((T, B), dtype=np.int64)
    obs_z = np.zeros((T, B, 2))
    row = {int(i): j for j, i in enumerate(rec.beacons[:, 0])}
    dropped = 0
    td = rec.td[(rec.td[:, 0] >= times[0]) & (rec.td[:, 0] <= times[-1])]
    ends = times[1:]
    for tr, _, bid, z in td:
        j = row.get(int(bid))
        if j is None:
            continue
        k = int(np.searchsorted(ends, tr))
        if k > 0 and (k == T or tr - ends[k - 1] < ends[k] - tr):
            k -= 1
        if obs_n[k] == B or j in obs_id[k, :obs_n[k]]:
            dropped += 1
            continue
        obs_id[k, obs_n[k]] = j
        obs_z[k, obs_n[k], 0] = (z - b) / a
        obs_n[k] += 1
    return FieldData(pose, ctrl, obs_n, obs_id, obs_z), times, dropped


def build(p) -> FieldModel:
    """The model of the span: a FieldModel whose ``record`` is the recorded trial."""
    rec = _record(p["data"], p)
    a, b = calibration(p)
    pts = np.vstack([rec.beacons[:, 1:3], rec.gt[:, 1:3]])
    m = float(p["margin_m"])
    offset = pts.min(axis=0) - m
    area = pts.max(axis=0) + m - offset
    data, times, dropped = recorded(rec, p, a, b, offset)
    sense = BeaconSensor(max_range=float(p["max_range_m"]), half_fov=math.pi,
                         sr=float(p["range_noise_m"]), sb=1.0, nearest=0)
    own = {}
    eps = float(p["range_outliers"])
    if eps > 0.0:
        own = {"loglik": mixture_loglik,
               "theta": mixture_theta(SENSORS["range"], sense, eps, sense.max_range)}
    step = float(np.mean(np.diff(times)))
    hold = max(1, int(round(p["converge_hold_s"] / step)))
    score_from = 1 + int(np.searchsorted(times[1:] - times[0], p["score_from_s"] - 1e-9))
    start = data.pose[0]
    model = PlazaModel(
        area, rec.beacons[:, 1:3] - offset, data.pose[::50, :2].copy(), start.copy(),
        np.array([step, math.pi, 1.0]), FIELD_MOTIONS["rot_trans_rot"],
        MotionNoise.rot_trans_rot(*p["alphas"]), SENSORS["range"], sense, data.ctrl.shape[0],
        np.zeros(0, dtype=np.int64), np.zeros((0, 3)), float(p["converge_bound_m"]),
        InitialBelief(known=int(p["start"] == "known"), x=float(start[0]), y=float(start[1]),
                      heading=float(start[2]), sd_m=float(p["initial_std_m"]),
                      sd_rad=float(p["initial_std_deg"] * DEG)),
        min(score_from, data.ctrl.shape[0]), 0, hold, **own)
    object.__setattr__(model, "record", data)
    object.__setattr__(model, "times", times - times[0])
    object.__setattr__(model, "calibration", (a, b))
    object.__setattr__(model, "beacon_ids", rec.beacons[:, 0].astype(np.int64))
    object.__setattr__(model, "dropped", dropped)
    return model


class PlazaModel(FieldModel):
    """A FieldModel with the recorded trial: ``record`` (FieldData), ``times`` (T+1,) s from the
    span's start, ``calibration`` (a, b), ``dropped`` (ranges left out) and ``beacon_ids`` (B,)
    (the data set's ids of the beacons)."""


def simulate(model: FieldModel, state: np.ndarray) -> tuple[FieldData, FieldData]:
    """The recorded trial (the same in every trial; ``state`` is not drawn from)."""
    return model.record, model.record


__all__ = ["NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate", "resolve", "unavailable"]
