"""World files: the YAML data of a robot world (its area, start pose, the waypoints of its
closed path and its point features: landmarks or beacons), named by a scenario's ``world`` key,
resolved relative to the experiment file's folder and checked at validation. A new world of an
existing scenario is a new world file; a new scenario over the same model reuses ``load_world``.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..schema import ConfigError
from ..yamlio import read_yaml


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



def resolve_course(params: dict, base_dir: Path) -> dict:
    """A SLAM world's ``resolve``: load the course file named by ``params['world']`` (relative to
    base_dir) into the parameters, and check that at least two landmarks are within
    ``params['max_range_m']`` of every waypoint."""
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

