"""pfbench: reproduce the tables of particle-filter papers for mobile robots."""
from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("pfbench")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0+src"

from . import _cache

CACHE_DIR = _cache.configure(__version__)

__all__ = ["__version__", "CACHE_DIR"]
