"""The distribution functions pfbench's intervals and verdicts read (stdtrit, stdtr, ndtri,
chdtri: the t, normal and chi-square quantiles and tails that scipy.stats' t, norm and chi2 call),
without importing the whole of scipy.special.

They are ufuncs of one compiled module, ``scipy.special._ufuncs``. Importing it the usual way runs
scipy.special's ``__init__`` first, which brings in scipy's array-API layer (numpy.f2py and
numpy.testing among it): 0.09 s on this project's 2-core machine, where the module alone takes
5 ms. ``functions`` loads the module alone, and the values are the same functions' (scipy.special
exports these very objects).
"""
from __future__ import annotations

import importlib
import os
import sys
import threading
import types

# the compiled module of scipy.special that holds the distribution functions (pfbench.runner
# imports it ahead, in a thread, while a run waits for its workers)
UFUNCS = "scipy.special._ufuncs"
_PACKAGE = "scipy.special"
_LOCK = threading.Lock()


def functions():
    """The module of scipy's special functions' ufuncs (``.stdtrit``, ``.stdtr``, ``.ndtri``,
    ``.chdtri``): the one scipy.special imported, where it is, else loaded alone (_alone); where
    that fails, through scipy.special as usual."""
    module = sys.modules.get(UFUNCS)
    if module is not None:
        return module
    with _LOCK:
        module = sys.modules.get(UFUNCS)
        if module is None:
            module = _alone() or importlib.import_module(UFUNCS)
    return module


def _alone():
    """``scipy.special._ufuncs`` imported without scipy.special's ``__init__``, or None.

    Its compiled modules import their siblings by their full names, so for the moment of the
    import ``scipy.special`` is a bare package module (the real folder, nothing run), which
    then leaves ``sys.modules``; a later ``import scipy.special`` runs the package as usual and
    finds these modules imported. Code that picked the bare module up in that moment (another
    thread) finds every name of the real package through it (its ``__getattr__``)."""
    if _PACKAGE in sys.modules:
        return None
    try:
        import scipy
        bare = types.ModuleType(_PACKAGE)
        bare.__path__ = [os.path.join(os.path.dirname(scipy.__file__), "special")]
        bare.__getattr__ = _real_attribute
        sys.modules[_PACKAGE] = bare
        try:
            module = importlib.import_module(UFUNCS)
        finally:
            if sys.modules.get(_PACKAGE) is bare:
                del sys.modules[_PACKAGE]
            if scipy.__dict__.get("special") is bare:     # (scipy's own getattr imports it)
                del scipy.special
    except Exception:
        for name in [m for m in sys.modules if m.startswith(_PACKAGE + ".")]:
            del sys.modules[name]
        return None
    return module


def _real_attribute(name: str):
    """An attribute of the bare package module, read from the real scipy.special."""
    real = importlib.import_module(_PACKAGE) if not name.startswith("__") else None
    if real is None or real.__dict__.get("__getattr__") is _real_attribute:
        raise AttributeError(name)          # (the bare module itself, still in its moment)
    return getattr(real, name)
