"""Recorded data sets pfbench reads but does not ship: CMU's Plaza 1 and Plaza 2 range-only
localization sets (Djugash, Hamner and Roth, "Navigating with ranging radios: five data sets with
ground truth", J. Field Robotics 2009).

The files come with the optional extra ``data`` (``pip install '.[data]'``), which installs the
``gtsam`` wheel: it ships them under ``gtsam/Data/``. pfbench finds them through the installed
distribution's list of files (``importlib.metadata``), without importing gtsam, and checks each
file it reads against the sha256 digest pinned here (the files of gtsam 4.3.0). A user's own copy
is a folder holding ``Plaza1_.mat`` / ``Plaza2_.mat`` (the scenario's ``data_dir``).

Each ``.mat`` holds GT (t s, x m, y m, heading rad: GPS/INS ground truth), TL (beacon id, x, y:
the surveyed beacons), DR (t, distance m, heading change rad: the odometry, each row moving GT[k]
to GT[k+1]) and TD (t, robot id, beacon id, range m). The data have no licence notice: they are
never committed to this repository.
"""
from __future__ import annotations

import functools
import hashlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .errors import UserError

# the distribution whose files hold the data, and the version the extra pins (pyproject.toml)
DISTRIBUTION = "gtsam"
PINNED_VERSION = "4.3.0"
EXTRA_HINT = "pip install '.[data]'"

# data set -> (file name, sha256 of gtsam 4.3.0's copy)
PLAZA_FILES = {
    "plaza1": ("Plaza1_.mat", "9ccbfec19942eabecfa3206bff983bf708b98d6c7db462d81c55376f92d75847"),
    "plaza2": ("Plaza2_.mat", "72f0abe0fea2050eb5ee1cffc8c43823266a35785b7cdecac4ec5eae727561a2"),
}
# where the wheel keeps them
WHEEL_FOLDER = "gtsam/Data"


class DataMissing(UserError):
    """A data set that is not on this machine (the extra not installed, a data_dir without the
    file): one line naming what to install or give."""


class DataCorrupt(UserError):
    """A data file whose sha256 is not the pinned one."""


def installed_file(name: str) -> Path | None:
    """The path of ``gtsam/Data/<name>`` in the installed gtsam distribution, or None when gtsam
    is not installed or lists no such file. gtsam is never imported."""
    from importlib.metadata import PackageNotFoundError, distribution
    try:
        dist = distribution(DISTRIBUTION)
    except PackageNotFoundError:
        return None
    for f in dist.files or ():
        if f.as_posix() == f"{WHEEL_FOLDER}/{name}":
            p = Path(dist.locate_file(f))
            return p if p.is_file() else None
    return None


def sha256(path: Path) -> str:
    """The hex sha256 of a file's bytes."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def locate(dataset: str, data_dir: str | Path | None = None, verify: bool = True) -> Path:
    """The file of data set ``dataset`` ('plaza1' or 'plaza2'): in ``data_dir`` when given, else
    in the installed extra. ``verify``: its sha256 must be the pinned one (DataCorrupt if not).
    DataMissing (one line naming the extra or the folder) when it is absent."""
    name, digest = PLAZA_FILES[dataset]
    if data_dir:
        path = Path(data_dir) / name
        if not path.is_file():
            raise DataMissing(f"data set {dataset}: no {name} in {data_dir} (give the folder that "
                              f"holds it, or leave data_dir out and {EXTRA_HINT})")
    else:
        path = installed_file(name)
        if path is None:
            raise DataMissing(f"data set {dataset} is not installed: {EXTRA_HINT} (gtsam=="
                              f"{PINNED_VERSION} ships it), or give a folder with {name} as "
                              "data_dir")
    if verify and sha256(path) != digest:
        raise DataCorrupt(f"data set {dataset}: {path} is not the pinned file (sha256 "
                          f"{digest[:12]}...; gtsam=={PINNED_VERSION})")
    return path


def missing(dataset: str, data_dir: str | Path | None = None) -> str | None:
    """Why data set ``dataset`` cannot be read here (the one-line message), or None."""
    try:
        locate(dataset, data_dir, verify=False)
    except DataMissing as err:
        return str(err)
    return None


@dataclass(frozen=True)
class PlazaRecord:
    """A Plaza data set as recorded: gt (K, 4) t, x, y, heading; beacons (B, 3) id, x, y; dr
    (K - 1, 3) t, distance, heading change; td (R, 4) t, robot, beacon id, range (s, m, rad)."""

    gt: np.ndarray
    beacons: np.ndarray
    dr: np.ndarray
    td: np.ndarray


@functools.lru_cache(maxsize=4)
def _read(path: str, stamp: float) -> PlazaRecord:
    from scipy.io import loadmat
    try:
        m = loadmat(path)
    except Exception as err:         # not a .mat file scipy reads
        raise DataCorrupt(f"{path}: not a readable .mat file ({err})") from None
    missing_keys = [k for k in ("GT", "TL", "DR", "TD") if k not in m]
    if missing_keys:
        raise DataCorrupt(f"{path}: no {missing_keys[0]} array (a Plaza file holds GT, TL, DR "
                          "and TD)")
    arr = {k: np.ascontiguousarray(m[k], dtype=np.float64) for k in ("GT", "TL", "DR", "TD")}
    for k, cols in (("GT", 4), ("TL", 3), ("DR", 3), ("TD", 4)):
        if arr[k].ndim != 2 or arr[k].shape[1] != cols or arr[k].shape[0] == 0:
            raise DataCorrupt(f"{path}: {k} has shape {arr[k].shape}, expected (rows, {cols})")
    if arr["DR"].shape[0] != arr["GT"].shape[0] - 1:
        raise DataCorrupt(f"{path}: DR has {arr['DR'].shape[0]} rows, expected one fewer than "
                          f"GT's {arr['GT'].shape[0]}")
    return PlazaRecord(arr["GT"], arr["TL"], arr["DR"], arr["TD"])


def read_plaza(dataset: str, data_dir: str | Path | None = None,
               verify: bool = True) -> PlazaRecord:
    """Data set ``dataset`` as recorded (``PlazaRecord``), read once per process."""
    path = locate(dataset, data_dir, verify)
    return _read(str(path), path.stat().st_mtime)
