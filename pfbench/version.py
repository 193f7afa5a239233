"""The package's version, and the folder of its kernel cache (set here, before any kernel
loads: numba reads it when a kernel first compiles). Every module reads them from here; the
package's namespace (``pfbench.__version__``, ``pfbench.CACHE_DIR``) shows the same values.

The version is written here once, as a literal: the build reads it from this file
(pyproject.toml's ``dynamic`` version), so the installed metadata and ``__version__`` cannot
differ, and no command pays for looking the installed distribution up (a scan of every
package's metadata, some 30 ms a command)."""
from . import _cache

__version__ = "0.1.0"

CACHE_DIR = _cache.configure(__version__)
