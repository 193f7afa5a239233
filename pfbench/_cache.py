"""Point numba's on-disk cache at a folder keyed by the package version and source hash.

numba keys a cached kernel on its own file's timestamp only; a kernel that inlines a function from
another module (a resampling scheme, the random generator) would keep stale code after that module
changes. Keying the whole cache folder on a hash of the package's numba source files means an
upgrade or an edit never meets a stale kernel. Must run before any ``@njit(cache=True)`` decorates.
"""
from __future__ import annotations

import hashlib
import os
from pathlib import Path

import numba


def _source_hash() -> str:
    """Hash of every source file of the package that holds numba code (an edit of the CLI or the
    tables does not invalidate the kernels)."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if b"@njit" in text:
            h.update(str(path.relative_to(root)).encode())
            h.update(text)
    return h.hexdigest()[:16]


def configure(version: str) -> Path:
    """Set ``numba.config.CACHE_DIR`` to ``<base>/pfbench-<version>-<srchash>`` and return it.

    ``<base>`` is ``$NUMBA_CACHE_DIR`` if the user set one, else ``$XDG_CACHE_HOME`` (or
    ``~/.cache``) ``/pfbench/numba``.
    """
    base = os.environ.get("NUMBA_CACHE_DIR")
    if not base:
        base = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"),
                            "pfbench", "numba")
    path = Path(base) / f"pfbench-{version}-{_source_hash()}"
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError:  # read-only home: let numba fall back to its own locations
        return Path(numba.config.CACHE_DIR or "")
    numba.config.CACHE_DIR = str(path)
    return path
