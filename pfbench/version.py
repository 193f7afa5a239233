"""The package's version, and the folder of its kernel cache (set here, before any kernel
loads: numba reads it when a kernel first compiles). Every module reads them from here; the
package's namespace (``pfbench.__version__``, ``pfbench.CACHE_DIR``) shows the same values."""
from importlib.metadata import PackageNotFoundError, version as _version

from . import _cache

try:
    __version__ = _version("pfbench")
except PackageNotFoundError:  # running from a source tree that is not installed
    __version__ = "0.1.0+src"

CACHE_DIR = _cache.configure(__version__)
