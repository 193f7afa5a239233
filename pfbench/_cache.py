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
        if b"@njit" in text or b"@kernel(" in text:
            h.update(str(path.relative_to(root)).encode())
            h.update(text)
    return h.hexdigest()[:16]


_ROOT = os.path.dirname(os.path.abspath(__file__))


def _package_locator():
    """A numba cache locator that files this package's kernels by their path inside the package
    (``filters/pf.py``), not by the absolute folder of the copy being imported. The installed
    copy (site-packages) and a checkout's (what the test suite imports) then share one cache:
    the suite reuses what a run compiled, and a reinstall of the same source recompiles nothing
    (numba stamps each file by the hash of its contents)."""
    from numba.core import caching
    base = (getattr(caching, "UserProvidedCacheLocator", None)
            or getattr(caching, "_UserProvidedCacheLocator"))

    class PackageCacheLocator(base):
        def __init__(self, py_func, py_file):
            super().__init__(py_func, py_file)
            rel = os.path.relpath(os.path.dirname(os.path.abspath(py_file)), _ROOT)
            self._cache_path = os.path.join(numba.config.CACHE_DIR, "pfbench", rel)

        @classmethod
        def from_function(cls, py_func, py_file):
            inside = os.path.abspath(py_file).startswith(_ROOT + os.sep)
            if not numba.config.CACHE_DIR or not inside:
                return None
            return super().from_function(py_func, py_file)

    return PackageCacheLocator


def _register_locator() -> None:
    """Put the package's locator first (numba names its cache classes CacheImpl and
    UserProvidedCacheLocator, with a leading underscore before 0.61; with neither, numba's own
    locators stay)."""
    from numba.core import caching
    impl = getattr(caching, "CacheImpl", None) or getattr(caching, "_CacheImpl", None)
    if impl is None or not (hasattr(caching, "UserProvidedCacheLocator")
                            or hasattr(caching, "_UserProvidedCacheLocator")):
        return
    classes = impl._locator_classes
    if not any(getattr(c, "__name__", "") == "PackageCacheLocator" for c in classes):
        classes.insert(0, _package_locator())


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
    _register_locator()
    return path
