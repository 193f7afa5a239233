"""Comparisons computed once: an up-to-date results folder prints its table in a fraction of a
second instead of computing its intervals again (the bootstrap intervals alone take seconds).

``compare`` (pfbench.compare) is a pure function of the experiment, its trials' rows and the
code that compares them. ``cached_compare`` keys its result on a SHA-256 of all of these: the
experiment (its settings and its paper's table), every row (run times included), ``anytime``,
the source of every module of pfbench, and the versions of Python, numpy, scipy, pandas and
pyarrow. A change of any of them is a new key: the table is computed again, never served stale.

The entries are pickles in ``pfbench-tables`` beside the kernel cache (pfbench._cache: by
default ``~/.cache/pfbench/numba/pfbench-tables``), a folder of this user's that numba's own
cache, pickles too, already trusts. An entry that cannot be read is computed again; a folder that
cannot be written caches nothing. Of each kind of entry the newest ``KEEP`` are kept: when a
store takes their number past ``PRUNE_AT`` the oldest go (pruning at every store read the time of
every entry, 13 ms for 256 of them on a small machine, after each run's trials).
"""
from __future__ import annotations

import fnmatch
import hashlib
import json
import os
import pickle
import sys
import tempfile
from dataclasses import replace
from pathlib import Path

from ._cache import sources_hash
from .version import CACHE_DIR

KEEP = 256
PRUNE_AT = KEEP + KEEP // 4
_CODE: str | None = None


def library_version(package: str) -> str:
    """The installed version of ``package``, read from its metadata without importing it ('-'
    when it is not installed): the cache keys of this module, pfbench.replay and the report's
    figures (pfbench.report_html) name the libraries they depend on so."""
    from importlib import metadata
    try:
        return metadata.version(package)
    except metadata.PackageNotFoundError:
        return "-"


def code_digest() -> str:
    """SHA-256 of every source file of the package and of the versions of Python and of the
    libraries a comparison and its printed strings depend on (numpy, scipy, pandas, pyarrow),
    read without importing them (once per process: this cache's and pfbench.replay's keys)."""
    global _CODE
    if _CODE is None:
        h = sources_hash()
        h.update(sys.version.encode())
        for package in ("numpy", "scipy", "pandas", "pyarrow"):
            h.update(f"|{package}={library_version(package)}".encode())
        _CODE = h.hexdigest()
    return _CODE


def _rows_bytes(rows) -> bytes:
    """What the key reads of trial ``rows`` (a DataFrame or a list of dicts): every value. Of a
    DataFrame, its columns and dtypes, the bytes of each column of numbers (every bit of every
    value, -0.0 and NaN's payload included: no pass in Python) and the other columns' values as
    JSON (so that 1 and "1" differ); of a list, every value as JSON."""
    import numpy as np
    import pandas as pd
    if not isinstance(rows, pd.DataFrame):
        return json.dumps(list(rows), sort_keys=True, default=repr).encode()
    parts = [json.dumps([[str(c), str(t)] for c, t in rows.dtypes.items()]).encode()]
    for _, col in rows.items():
        if isinstance(col.dtype, np.dtype) and col.dtype.kind in "biufcmM":
            parts.append(np.ascontiguousarray(col.to_numpy()).tobytes())
        else:
            parts.append(json.dumps(col.to_numpy(dtype=object).tolist(), default=repr).encode())
    return b"".join(parts)


def key(exp, rows, anytime) -> str:
    """The cache key of ``compare(exp, rows, anytime)``."""
    h = hashlib.sha256(code_digest().encode())
    h.update(repr(exp).encode())
    h.update(repr(exp.reported).encode())
    h.update(repr(anytime).encode())
    h.update(_rows_bytes(rows))
    return h.hexdigest()


def folder() -> Path | None:
    """The cache's folder (None: no kernel cache folder, so no cache)."""
    if not str(CACHE_DIR):
        return None
    return Path(CACHE_DIR).parent / "pfbench-tables"


def _cached(exp, rows, salt, compute, valid):
    """``compute()``, or the entry the cache holds for (``exp``, ``rows``, ``salt``) when it was
    computed before by the same code and ``valid(entry)`` holds; a new result is stored. Rows that
    do not serialise, a missing cache folder or an unreadable entry only mean computing it."""
    where = folder()
    try:
        k = key(exp, rows, salt)
    except (TypeError, ValueError, RecursionError):     # rows that do not serialise: no cache
        where = None
    if where is not None:
        path = where / f"{k}.pickle"
        try:
            with open(path, "rb") as fh:
                entry = pickle.load(fh)
            if valid(entry):
                return entry
        except Exception:       # absent, cut short, from another pickle protocol: compute it
            pass
    result = compute()
    if where is not None:
        _store(where, path, result)
    return result


def cached_compare(exp, rows, anytime: int | None = None):
    """``pfbench.compare.compare(exp, rows, anytime)``, from the cache when it was computed
    before from the same inputs by the same code."""
    from .compare import Comparison, compare
    cmp = _cached(exp, rows, anytime, lambda: compare(exp, rows, anytime=anytime),
                  lambda entry: isinstance(entry, Comparison))
    return replace(cmp, exp=exp)


def cached_ranking(exp, rows) -> list[str]:
    """table.md's section "All filters at once" for ``exp``'s trial ``rows``
    (``pfbench.rank.markdown_section`` on RMSE), from the cache when it was computed before from
    the same rows (their run times aside) by the same code: an up-to-date folder's table.md is
    then written without scipy.stats."""
    import pandas as pd
    from .rank import markdown_section
    df = rows if isinstance(rows, pd.DataFrame) else pd.DataFrame(list(rows))
    df = df.drop(columns=["wall_s"], errors="ignore")
    return _cached(exp, df, "ranking", lambda: markdown_section(df, "rmse"),
                   lambda entry: isinstance(entry, list)
                   and all(isinstance(x, str) for x in entry))


def _store(where: Path, path: Path, cmp) -> None:
    """Write ``cmp`` to ``path`` (store). Never an error: a cache that cannot be written is no
    cache."""
    try:
        store(where, path, pickle.dumps(cmp, protocol=pickle.HIGHEST_PROTOCOL), "*.pickle")
    except Exception:
        pass


def store(where: Path, path: Path, data: bytes, kind: str) -> None:
    """Write ``data`` to the entry ``path`` of the folder ``where`` through a temporary file, and
    when the entries of its ``kind`` (a pattern of their names) pass PRUNE_AT, keep the newest
    KEEP; OSError when it cannot."""
    where.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=where, prefix=".", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise
    names = fnmatch.filter(os.listdir(where), kind)
    if len(names) > PRUNE_AT:
        entries = sorted((where / name for name in names), key=_modified)
        for old in entries[:-KEEP]:
            old.unlink(missing_ok=True)


def _modified(path: Path) -> float:
    """When ``path`` was last written (0: gone meanwhile, as another process pruned it)."""
    try:
        return path.stat().st_mtime
    except OSError:
        return 0.0


_AHEAD: list = []       # the threads of runner.import_ahead, while they may run


def hold(thread) -> None:
    """Note a thread of this process that imports modules (runner.import_ahead): ``settle``
    waits for it."""
    _AHEAD.append(thread)


def settle() -> None:
    """Wait for the threads ``hold`` noted, if one runs (before this process forks: a fork while a
    thread imports could copy a held import lock into the child)."""
    while _AHEAD:
        _AHEAD.pop().join()


def anytime_of(meta: dict | None) -> int | None:
    """The most trials a run until decided could reach (its confidence sequences are tuned for
    it), from a results folder's meta; None for a run of a fixed trial count."""
    until = (meta or {}).get("until_decided")
    return int(until["max_trials"]) if isinstance(until, dict) and "max_trials" in until else None
