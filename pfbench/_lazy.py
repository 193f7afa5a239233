"""Kernels built on first use: ``@kernel(signature, cache=True, ...)`` is ``numba.njit`` with an
explicit signature, except that numba compiles it (or loads it from its disk cache) when the
kernel is first called, from Python or from another kernel being compiled, not when its module is
imported. An experiment then builds the kernels of the filters and scenario it uses, and nothing
else: importing every filter module costs no compilation.

A kernel is a stand-in for its numba dispatcher: calling it, or naming it inside another kernel,
builds the dispatcher with the declared signatures once and uses it; attributes (``py_func``,
``signatures``, ...) are the dispatcher's.

A kernel is called from Python or from other kernels. One that is also taken by its address, as
a first-class function value (a model function, through pfbench.models.scalar.ModelFunction; a
public kernel of pfbench.kernels, which a plug-in may hand over as a value), is declared
``by_address=True`` and keeps numba's C-callable wrapper, the entry whose address such a value
holds. The others leave the wrapper out (numba's ``no_cfunc_wrapper``): LLVM optimises it with
the kernel's body inlined, and leaving it out takes about a tenth off compiling pfbench's
kernels, with the kernel's own code, and so every number, the same.

A kernel declared ``inline="always"`` is compiled into each kernel that calls it: numba copies
its Python function's body into the caller before typing it, and never calls a compiled version.
Its signatures compile only when it is called from Python (or, for one taken by address, when
a kernel naming it compiles, as before); a kernel being compiled sees a dispatcher of it with
nothing compiled (``LazyKernel.built_by_callers``). Compiling the kernels of every committed
config then skips 53 inlined ones alone: 200 CPU-seconds instead of 235, measured side by side,
with the code of every kernel the same.
"""
from __future__ import annotations

import contextlib
import functools
import threading
import types as pytypes

import numba

_LOCK = threading.RLock()
_RECORD = threading.local()     # .calls: the kernels called from Python while recording


class LazyKernel:
    """A numba function whose declared signatures compile on first use."""

    def __init__(self, func, sigs, options: dict):
        self._func, self._sigs, self._options = func, sigs, options
        self._disp = None
        self._shell = None
        functools.update_wrapper(self, func)

    @property
    def dispatcher(self):
        """The numba dispatcher, built (compiled or loaded from the cache) on first use."""
        disp = self._disp
        if disp is None:
            with _LOCK:
                if self._disp is None:
                    self._disp = numba.njit(self._sigs, **self._options)(self._func)
                disp = self._disp
        return disp

    @property
    def inlined(self) -> bool:
        """Whether numba copies the kernel's body into each kernel that calls it
        (``inline="always"``)."""
        return self._options.get("inline") == "always"

    @property
    def built_by_callers(self) -> bool:
        """Whether compiling a kernel that names this one builds it (compiles its signatures or
        loads them from the cache): every kernel but an inlined one, which only a call from
        Python builds. An inlined kernel taken by address is built as before, so that a value
        of it handed to a kernel is the dispatcher of its signatures."""
        return not self.inlined or self.taken_by_address

    def _seen_by_numba(self):
        """The dispatcher a kernel being compiled sees for this one: the built one, or for an
        inlined kernel not built yet one with no signature compiled (numba reads its Python
        function and options to inline it, and compiles nothing of it)."""
        if self._disp is not None or self.built_by_callers:
            return self.dispatcher
        if self._shell is None:
            with _LOCK:
                if self._shell is None:
                    # a call numba could not inline (none of pfbench's) would compile it for the
                    # call's types, as an inlined body is typed
                    self._shell = numba.njit(**self._options)(self._func)
        return self._shell

    @property
    def taken_by_address(self) -> bool:
        """Whether the kernel keeps numba's C-callable wrapper (``kernel(..., by_address=True)``),
        the entry a first-class function value of it calls."""
        return not self._options.get("no_cfunc_wrapper", False)

    @property
    def _numba_type_(self):         # what numba sees when another kernel names this one
        return self._seen_by_numba()._numba_type_

    @property
    def built(self) -> bool:
        """Whether the kernel has been compiled or loaded (for tests and diagnostics)."""
        return self._disp is not None

    def __call__(self, *args, **kwargs):
        calls = getattr(_RECORD, "calls", None)
        if calls is not None:               # recording(): noted, not run
            calls.append(self)
            return blank(self)
        return self.dispatcher(*args, **kwargs)

    def __getattr__(self, name):
        if name.startswith("__") or name not in _dispatcher_names():
            # not a dispatcher's: no build for it (pytest's collection, for one, asks every
            # object of a test module for its fixture and mark attributes)
            raise AttributeError(name)
        if name in ("targetoptions", "py_func"):   # numba's inlining reads these of a callee
            return getattr(self._seen_by_numba(), name)
        return getattr(self.dispatcher, name)

    def __repr__(self) -> str:
        return f"<kernel {self.__qualname__} ({'built' if self.built else 'not built yet'})>"


@contextlib.contextmanager
def recording():
    """Within it, a kernel called from Python (in this thread) is not built nor run: it is
    appended to the list this yields and returns ``blank(kernel)``. What the Python around the
    kernels does with their outputs then runs on arrays they never filled: for finding which
    kernels a filter run calls (pfbench.precompile), never for numbers."""
    calls: list = []
    before = getattr(_RECORD, "calls", None)
    _RECORD.calls = calls
    try:
        yield calls
    finally:
        _RECORD.calls = before


def blank(kern: LazyKernel):
    """A value of the return type of ``kern``'s first signature: 0 for a number, a tuple of such
    for a tuple, None otherwise."""
    sigs = kern._sigs if isinstance(kern._sigs, (list, tuple)) else [kern._sigs]
    return _blank(getattr(sigs[0], "return_type", None)) if sigs else None


def _blank(t):
    from numba.core import types
    if isinstance(t, types.Boolean):
        return False
    if isinstance(t, types.Integer):
        return 0
    if isinstance(t, types.Float):
        return 0.0
    if isinstance(t, types.BaseTuple) and not isinstance(t, (types.NamedTuple,
                                                             types.NamedUniTuple)):
        return tuple(_blank(e) for e in t.types)
    return None


def _codes(code: pytypes.CodeType):
    yield code
    for c in code.co_consts:
        if isinstance(c, pytypes.CodeType):
            yield from _codes(c)


def named(func) -> list:
    """The objects a Python function's code names: its globals (and the attributes of a module
    it names), its closure's cells; in the order first named (a kernel's: what numba builds when
    it compiles the kernel)."""
    glb = getattr(func, "__globals__", {})
    names = [n for code in _codes(func.__code__) for n in code.co_names]
    values = [glb.get(n) for n in names]
    for v in list(values):
        if isinstance(v, pytypes.ModuleType):
            values += [getattr(v, n, None) for n in names]
    for cell in func.__closure__ or ():
        try:
            values.append(cell.cell_contents)
        except ValueError:              # an empty cell
            pass
    out: dict[int, object] = {}
    for v in values:
        if v is not None:
            out.setdefault(id(v), v)
    return list(out.values())


def callees(kern: LazyKernel) -> list[LazyKernel]:
    """The kernels ``kern``'s body names: those numba builds when it compiles ``kern``."""
    return [v for v in named(kern._func) if isinstance(v, LazyKernel) and v is not kern]


def size(kern: LazyKernel) -> int:
    """A measure of what compiling ``kern`` alone costs (its bytecode's length, that of the
    kernels it inlines, times its signatures); only for ordering compilations."""
    sigs = kern._sigs if isinstance(kern._sigs, (list, tuple)) else [kern._sigs]
    own = sum(len(c.co_code) for c in _codes(kern._func.__code__))
    inlined = sum(size(k) for k in callees(kern) if k.inlined)
    return max(1, len(sigs)) * own + inlined


@functools.lru_cache(maxsize=1)
def _dispatcher_names() -> frozenset:
    """The attribute names a numba dispatcher has (those of one built without compiling)."""
    return frozenset(dir(numba.njit(lambda x: x)))


def kernel(sigs, *, by_address: bool = False, **options):
    """``numba.njit(sigs, **options)``, built on first use (see the module). Kernels take numpy's
    error model unless they say otherwise: a float division by zero gives an infinity or NaN,
    which the filters count (underflow steps) and the metrics report (diverged steps), never a
    ZeroDivisionError out of a trial. ``by_address``: the kernel is also taken by its address, as
    a first-class function value, and keeps numba's C-callable wrapper (see the module)."""
    options.setdefault("error_model", "numpy")
    options.setdefault("no_cfunc_wrapper", not by_address)

    def decorate(func):
        return LazyKernel(func, sigs, options)
    return decorate


def variant(base: LazyKernel, suffix: str, **replace) -> LazyKernel:
    """A copy of the kernel ``base`` in which the global names of ``replace`` refer to other
    kernels (of the same signatures): numba compiles only what the copy calls. A kernel that
    dispatches at run time on a setting (a swarm algorithm, a resampling scheme) compiles every
    branch; a variant whose branches for the settings it never sees call stubs compiles only the
    others. The copy's name is ``base``'s with ``suffix`` (its cache entry is its own)."""
    import types as pytypes
    func = base._func
    glb = dict(func.__globals__)
    glb.update(replace)
    copy = pytypes.FunctionType(func.__code__, glb, func.__name__ + suffix, func.__defaults__,
                                func.__closure__)
    copy.__qualname__ = func.__qualname__ + suffix
    copy.__module__ = func.__module__
    copy.__doc__ = func.__doc__
    return LazyKernel(copy, base._sigs, base._options)


def stub(base: LazyKernel, func) -> LazyKernel:
    """A kernel with ``base``'s signatures and ``func``'s body: what a ``variant`` calls in place
    of a branch it never takes (``func`` should say so, or return a neutral value)."""
    func.__qualname__ = base._func.__qualname__ + "_stub"
    func.__name__ = base._func.__name__ + "_stub"
    return LazyKernel(func, base._sigs, base._options)
