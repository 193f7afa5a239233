"""pfbench: reproduce the tables of particle-filter papers for mobile robots."""
from .version import CACHE_DIR, __version__

_API = ("Result", "load_results", "load_trials", "run_experiment", "run_until_decided")


def __getattr__(name):
    """The Python API (pfbench.api), imported on first use: ``import pfbench`` stays light."""
    if name in _API:
        from . import api
        return getattr(api, name)
    raise AttributeError(f"module 'pfbench' has no attribute {name!r}")


__all__ = ["__version__", "CACHE_DIR", "Result", "load_results", "load_trials",
           "run_experiment", "run_until_decided"]
