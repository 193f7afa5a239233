"""Point numba's on-disk cache at a folder keyed by the package version and source hash.

numba keys a cached kernel on its own file's timestamp only; a kernel that inlines a function from
another module (a resampling scheme, the random generator) would keep stale code after that module
changes. Keying the whole cache folder on a hash of the package's numba source files means an
upgrade or an edit never meets a stale kernel. Must run before any ``@njit(cache=True)`` decorates.
A cache folder that cannot be written is never an error (see ``configure``).
"""
from __future__ import annotations

import hashlib
import os
import sys
import tempfile
import threading
from pathlib import Path

import numba


def sources_hash(kernels_only: bool = False):
    """A sha256 object fed with the path (in the package) and bytes of every source file of the
    package, or with ``kernels_only`` of those that hold numba code."""
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    for path in sorted(root.rglob("*.py")):
        text = path.read_bytes()
        if not kernels_only or b"@njit" in text or b"@kernel(" in text:
            h.update(str(path.relative_to(root)).encode())
            h.update(text)
    return h


def _source_hash() -> str:
    """Hash of every source file of the package that holds numba code (an edit of the CLI or the
    tables does not invalidate the kernels)."""
    return sources_hash(kernels_only=True).hexdigest()[:16]


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


def _usable(path: Path) -> str | None:
    """None when ``path`` is (or can be made) a folder this process can write a file into, else
    why not."""
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError as exc:
        return exc.strerror or type(exc).__name__
    return None


def _private_temp() -> Path | None:
    """``<temp>/pfbench-<uid>/numba``: a folder of the temporary folder that only this user owns
    and writes (a cached kernel is code: never one another user could have put there), or None."""
    uid = os.getuid() if hasattr(os, "getuid") else 0
    top = Path(tempfile.gettempdir()) / f"pfbench-{uid}"
    try:
        top.mkdir(mode=0o700, exist_ok=True)
        st = top.lstat()
        if (not top.is_dir() or top.is_symlink()
                or (hasattr(os, "getuid") and (st.st_uid != uid or st.st_mode & 0o022))):
            return None
    except OSError:
        return None
    return top / "numba"


def warn(message: str) -> None:
    """One warning line on stderr (once per message and process)."""
    if message not in _WARNED:
        _WARNED.add(message)
        sys.stderr.write(f"pfbench: warning: {message}\n")
        sys.stderr.flush()


_WARNED: set[str] = set()
# False when no folder could hold the kernel cache: kernels compile in each process
ENABLED = True


def _guard_caching() -> None:
    """Where numba finds no folder it can write a function's cache into (``cannot cache
    function``), compile that function without its disk cache, with one warning line, rather than
    fail; with the cache off (ENABLED False), every function compiles so."""
    from numba.core.dispatcher import Dispatcher
    if getattr(Dispatcher.enable_caching, "_pfbench_guard", False):
        return
    original = Dispatcher.enable_caching

    def enable_caching(self):
        if not ENABLED:
            return
        try:
            original(self)
        except (RuntimeError, OSError) as exc:
            warn(f"numba cannot cache {getattr(self.py_func, '__qualname__', 'a function')} "
                 f"({' '.join(str(exc).split())[:160]}); it compiles in each process (set "
                 "NUMBA_CACHE_DIR to a writable folder)")

    enable_caching._pfbench_guard = True
    Dispatcher.enable_caching = enable_caching


def _load_without_refresh() -> None:
    """Load a kernel from the disk cache without starting numba's compiler first.

    Before it looks in its disk cache, numba refreshes its whole compiler: it imports every
    module of lowering rules (lists, dicts, strings, sets, the typed containers, polynomials,
    dates) and reloads the typing templates. Loading machine code needs none of that, only
    numba's runtime (for the arrays a kernel allocates); the modules a kernel's own environment
    names are imported as it is rebuilt. On this project's 2-core machine, in one process with
    pfbench imported, from the first load's preparation to the end of the second trial of a UNGM
    run, the refresh made 0.77 s of what is otherwise 0.62 s (medians of 5). Here a load starts
    the runtime only; a load that finds nothing (a kernel to compile) refreshes as numba does,
    and a compilation refreshes on its own. With a numba that lacks any of the parts this relies
    on, numba's own load stays."""
    from numba.core import caching
    from numba.core.runtime import rtsys
    cache = getattr(caching, "Cache", None)
    original = getattr(cache, "load_overload", None)
    if (original is None or getattr(original, "_pfbench_lazy", False)
            or not hasattr(cache, "_load_overload")
            or not hasattr(cache, "_guard_against_spurious_io_errors")
            or not hasattr(rtsys, "initialize")):
        return

    def load_overload(self, sig, target_context):
        rtsys.initialize(target_context)
        _array_functions()
        found = None
        with self._guard_against_spurious_io_errors():
            found = self._load_overload(sig, target_context)
        return found if found is not None else original(self, sig, target_context)

    load_overload._pfbench_lazy = True
    cache.load_overload = load_overload


def start_loading() -> None:
    """What loading a first kernel from the cache needs, done ahead (a worker waiting for its
    first trials): numba's runtime, and the module of numpy's array functions that most kernels'
    environments name (_array_functions)."""
    from numba.core.registry import cpu_target
    from numba.core.runtime import rtsys
    rtsys.initialize(cpu_target.target_context)
    _array_functions()


def _array_functions() -> None:
    """Import numba's module of numpy's array functions (numba.np.arraymath), which most kernels'
    environments name, once. It checks for a BLAS by importing scipy.linalg.cython_blas, which
    would run scipy.linalg's whole ``__init__`` first (every linear-algebra routine: a tenth of a
    second, most of what a worker's first kernel load waited for); the check gets that one module
    alone (_blas_alone), and the module leaves ``sys.modules`` again: whatever needs it later
    (numba fetches its BLAS functions from it when a kernel first calls one) imports it through
    scipy.linalg as usual."""
    if "numba.np.arraymath" in sys.modules:
        return
    with _ARRAY_FUNCTIONS:
        if "numba.np.arraymath" in sys.modules:     # another thread's load imported it meanwhile
            return
        alone = _blas_alone()
        try:
            import numba.np.arraymath  # noqa: F401
        finally:
            if alone:
                sys.modules.pop(_BLAS, None)


_ARRAY_FUNCTIONS = threading.Lock()
_BLAS = "scipy.linalg.cython_blas"


def _blas_alone() -> bool:
    """Load scipy's BLAS module, scipy.linalg.cython_blas (a compiled module that needs nothing of
    its package), into ``sys.modules`` without importing the scipy.linalg package around it; True
    when it did. False where scipy.linalg or that module is imported already, or the module is
    not where this scipy keeps it or fails to load: then it is imported the usual way."""
    import importlib.machinery
    import importlib.util
    if "scipy.linalg" in sys.modules or _BLAS in sys.modules:
        return False
    try:
        import scipy
        where = os.path.join(os.path.dirname(scipy.__file__), "linalg")
        spec = importlib.machinery.PathFinder.find_spec(_BLAS, [where])
        if spec is None or spec.loader is None:
            return False
        module = importlib.util.module_from_spec(spec)
        sys.modules[_BLAS] = module
        spec.loader.exec_module(module)
    except Exception:
        sys.modules.pop(_BLAS, None)
        return False
    return True


def _link_on_demand() -> None:
    """Load a kernel from the disk cache without reading its linking module until something needs
    it.

    numba caches a kernel as its machine code and, beside it, the LLVM bitcode of the same
    functions: what it links into a kernel compiled later that calls this one. A load parses that
    bitcode and walks its functions to list the symbols the process defines; running the loaded
    kernel needs neither. On this project's 2-core machine that is 25 ms of the 48 ms load of the
    swarm filters' kernel, and in one process the first trial of configs/ifa_pf_ungm.yaml (seven
    loads) took 0.155 s instead of 0.205 s (three runs each, the same rows).

    Here a load keeps the bitcode as bytes (``_on_demand_class``). It is parsed, and its symbols
    listed, the first time it is asked for (a kernel compiled later links it in), or when a symbol
    is asked of that library (a model function's address: its own symbols first), or when numba
    asks whether the process defines a symbol it has not listed: every library waiting is read
    then, so the answer is the one numba would have given. The one symbol a load asks for itself,
    the entry point numba makes the kernel's Python function from (``get_executable``), is listed
    at once: a cached kernel defines its own. The seven loads of that first trial then read the
    bitcode of the four small model functions only. With a numba that lacks any of the parts this
    relies on, numba's own load stays."""
    try:
        import llvmlite.binding as ll
        from numba.core import codegen, cpu
        library, engine = codegen.JITCodeLibrary, codegen.JitEngine
        unserialize = codegen.CPUCodeLibrary.__dict__["_unserialize"].__func__
        is_symbol_defined = engine.is_symbol_defined
        get_executable = cpu.CPUContext.get_executable
    except (ImportError, AttributeError, KeyError):
        return
    needed = ((engine, "_load_defined_symbols"), (library, "enable_object_caching"),
              (library, "_set_compiled_object"), (library, "_finalize_final_module"))
    if (getattr(get_executable, "_pfbench_lazy", False)
            or not all(hasattr(owner, name) for owner, name in needed)):
        return
    on_demand = _on_demand_class(library, ll.parse_bitcode)

    def load(cls, cg, state):
        name, kind, data = state
        if kind != "object" or cls is not library or cg._library_class is not library:
            return unserialize(cls, cg, state)
        waiting = _waiting(cg._engine)
        if waiting is None:
            return unserialize(cls, cg, state)
        object_code, bitcode = data
        self = cg.create_library(name)
        self.__class__ = on_demand
        self.__dict__.pop("_shared_module", None)
        self.__dict__["_pfbench_bitcode"] = bitcode
        self.enable_object_caching()
        self._set_compiled_object(object_code)
        self._finalize_final_module()
        with _LINKING:
            waiting.append(self)
        return self

    def defined(self, name):
        if is_symbol_defined(self, name):
            return True
        with _LINKING:
            for lib in list(getattr(self, "_pfbench_waiting", ())):
                lib._shared_module              # parsed, its symbols listed, off the list
        return is_symbol_defined(self, name)

    def executable(self, lib, fndesc, env):
        if isinstance(lib, on_demand) and "_pfbench_bitcode" in lib.__dict__:
            symbols = getattr(lib._codegen._engine, "_defined_symbols", None)
            if isinstance(symbols, set):
                symbols.add(fndesc.llvm_cpython_wrapper_name)
        return get_executable(self, lib, fndesc, env)

    executable._pfbench_lazy = True
    library._unserialize = classmethod(load)
    engine.is_symbol_defined = defined
    cpu.CPUContext.get_executable = executable


def _on_demand_class(library: type, parse) -> type:
    """The subclass of numba's code library ``library`` that a load from the cache makes
    (_link_on_demand): its linking module (``_shared_module``) is its bitcode parsed by ``parse``
    when first asked for, and its symbols are listed then."""

    class LinkOnDemand(library):
        """A code library loaded from the cache whose linking module is parsed, and its symbols
        listed, when first asked for."""

        @property
        def _shared_module(self):
            with _LINKING:
                bitcode = self.__dict__.pop("_pfbench_bitcode", None)
                if bitcode is not None:         # off the waiting list first, whatever follows
                    eng = self._codegen._engine
                    waiting = getattr(eng, "_pfbench_waiting", [])
                    listed = self in waiting
                    if listed:
                        waiting.remove(self)
                    self.__dict__["_pfbench_module"] = parse(bitcode)
                    if listed:
                        eng._load_defined_symbols(self.__dict__["_pfbench_module"])
                return self.__dict__.get("_pfbench_module")

        @_shared_module.setter
        def _shared_module(self, module):
            self.__dict__["_pfbench_module"] = module

        def get_pointer_to_function(self, name):
            # a symbol asked of this library (a model function's address): this library's own
            # symbols are listed first, and the others' only where it lacks the name
            symbols = getattr(self._codegen._engine, "_defined_symbols", ())
            if "_pfbench_bitcode" in self.__dict__ and name not in symbols:
                self._shared_module
            return super().get_pointer_to_function(name)

    return LinkOnDemand


def _waiting(eng) -> list | None:
    """The libraries of numba's engine ``eng`` loaded from the cache whose symbols are not listed
    yet (None where the engine cannot keep the list)."""
    with _LINKING:
        waiting = getattr(eng, "_pfbench_waiting", None)
        if waiting is None:
            try:
                waiting = eng._pfbench_waiting = []
            except AttributeError:
                return None
    return waiting


_LINKING = threading.RLock()


def configure(version: str) -> Path:
    """Set ``numba.config.CACHE_DIR`` to ``<base>/pfbench-<version>-<srchash>`` and return it.

    ``<base>`` is ``$NUMBA_CACHE_DIR`` if the user set one, else ``$XDG_CACHE_HOME`` (or
    ``~/.cache``) ``/pfbench/numba``. When that folder cannot be created or written (a read-only
    home, a file in the way), the cache goes to ``pfbench-<uid>/numba`` in the temporary folder,
    and when that fails too, kernels compile without a disk cache; either way with one warning
    line, never an error. The fallback is handed on to child processes through
    ``NUMBA_CACHE_DIR``.
    """
    global ENABLED
    _guard_caching()
    _load_without_refresh()
    _link_on_demand()
    name = f"pfbench-{version}-{_source_hash()}"
    base = os.environ.get("NUMBA_CACHE_DIR")
    what = "NUMBA_CACHE_DIR" if base else "the kernel cache"
    if not base:
        home = os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache")
        base = os.path.join(home, "pfbench", "numba")
    path = Path(base) / name
    why = _usable(path)
    if why is not None:
        temp = _private_temp()
        if temp is not None and _usable(temp / name) is None:
            warn(f"{what} {path}: {why}; kernels are cached in {temp} instead (set "
                 "NUMBA_CACHE_DIR to choose a folder)")
            os.environ["NUMBA_CACHE_DIR"] = str(temp)
            path = temp / name
        else:
            warn(f"{what} {path}: {why}; kernels compile in each process without a disk cache "
                 "(set NUMBA_CACHE_DIR to a writable folder)")
            ENABLED = False
            numba.config.CACHE_DIR = ""
            return Path("")
    numba.config.CACHE_DIR = str(path)
    _register_locator()
    return path
