"""pfbench: reproduce the tables of particle-filter papers for mobile robots."""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("pfbench")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0+src"

from . import _cache

CACHE_DIR = _cache.configure(__version__)

_API = ("Result", "load_results", "run_experiment", "run_until_decided")


def __getattr__(name):
    """The Python API (pfbench.api), imported on first use: ``import pfbench`` stays light."""
    if name in _API:
        from . import api
        return getattr(api, name)
    raise AttributeError(f"module 'pfbench' has no attribute {name!r}")


__all__ = ["__version__", "CACHE_DIR", "Result", "load_results", "run_experiment",
           "run_until_decided"]
