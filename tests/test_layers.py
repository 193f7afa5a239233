"""The layers of pfbench (docs/internals/layers.md): every import of every module, at module level
and inside functions, parsed with ast; no import circle, and no import against the layer order
or against one of the "never" rules."""
from __future__ import annotations

import ast
import functools
from pathlib import Path

import pytest

from .conftest import ROOT, parsed

# The packages checked: pfbench, and any top-level package of the repository that joins it (a
# benchmarks/ package of performance tooling, say) once it is named here.
PACKAGES = ("pfbench",)

# The layers, lowest first: a module may import its own layer and those below, never one above.
# A name stands for that module, or for a package and everything in it ("pfbench.models").
LAYERS = {
    "base": ("pfbench.errors", "pfbench.angles", "pfbench._lazy", "pfbench._cache",
             "pfbench.version", "pfbench.fsutil", "pfbench.yamlio", "pfbench.schema",
             "pfbench.seeding", "pfbench.rng", "pfbench.vecmath", "pfbench.progress",
             "pfbench.figstyle", "pfbench.metrics", "pfbench.diag", "pfbench.protocols",
             "pfbench.codes", "pfbench._special"),
    "models": ("pfbench.models", "pfbench.datasets"),
    "kernels and worlds": ("pfbench.resampling", "pfbench.filters.*", "pfbench.scenarios.*"),
    "registry": ("pfbench.plugins", "pfbench.filters", "pfbench.scenarios", "pfbench.kernels"),
    "experiment": ("pfbench.kinds", "pfbench.traces", "pfbench.diagnostics", "pfbench.resources",
                   "pfbench.papers", "pfbench.verdicts", "pfbench.compare", "pfbench.config"),
    "running": ("pfbench.workers", "pfbench.store", "pfbench.runner", "pfbench.precompile",
                "pfbench.sweep", "pfbench.curves", "pfbench.rank", "pfbench.dataset", "pfbench.tables", "pfbench.tablecache", "pfbench.replay", "pfbench.plots",
                "pfbench.contract", "pfbench.traps"),
    "outputs": ("pfbench.outputs", "pfbench.api", "pfbench.readings", "pfbench.runs_compare",
                "pfbench.regen",
                "pfbench.report_data",
                "pfbench.report_html", "pfbench.report"),
    "tooling": ("pfbench.benchmarks",),
    "entry": ("pfbench.cli", "pfbench", "pfbench.__main__"),
}

# Modules whose own imports are not checked yet (they are still imported-from like any other):
# none (the performance tooling has left the library for pfbench.benchmarks, checked as any).
PENDING: set[str] = set()

# Imports that still close a circle, (importer, imported): why each is left. The check of
# circles leaves them out; a listed import that is gone fails the test (drop it from here).
CIRCLES_LEFT: dict[tuple[str, str], str] = {}

# (importer, imported, why): what no layer order says by itself. A name as in LAYERS.
NEVER = (
    ("pfbench.filters.*", "pfbench.scenarios", "filters read models; they never import a world"),
    ("pfbench.filters.*", "pfbench.scenarios.*", "filters never import a world"),
    ("pfbench.scenarios.*", "pfbench.filters", "worlds build models; they never import a filter"),
    ("pfbench.scenarios.*", "pfbench.filters.*", "worlds never import a filter"),
    ("pfbench.models", "pfbench.filters.*", "models never import a filter"),
    ("pfbench.models", "pfbench.scenarios.*", "models never import a world"),
    ("*", "pfbench.cli", "nothing imports the command line but the console script"),
    ("*", "pfbench", "nothing below the command line imports the package's own namespace, whose "
     "API it imports (pfbench.version holds the version and the cache folder)"),
)

# Modules that cost nothing to import once pfbench is (they import no library, or are loaded with
# the package): importing one inside a function defers nothing, so it is imported at the top.
LIGHT = ("pfbench.errors", "pfbench.version", "pfbench._cache", "pfbench.fsutil", "pfbench.schema",
         "pfbench.progress", "pfbench.figstyle", "pfbench.diag", "pfbench.protocols", "pfbench.codes",
         "pfbench.workers", "pfbench._special")
# The command line defers even those: ``import pfbench.cli`` loads nothing a command does not
# need (the startup of every command).
DEFER_ALL = {"pfbench.cli", "pfbench.__main__"}

# What the command line may do that no other module may: read the package's namespace; and the
# console script (pfbench.__main__, which starts a run's worker first) imports the command line.
ALLOWED = {("pfbench.cli", "pfbench"), ("pfbench.__main__", "pfbench.cli")}


def _modules() -> dict[str, tuple[Path, bool]]:
    """Module name -> (file, whether it is a package's __init__)."""
    found = {}
    for package in PACKAGES:
        base = ROOT / package
        if not base.is_dir():
            continue
        for path in sorted(base.rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            is_pkg = parts[-1] == "__init__"
            found[".".join(parts[:-1] if is_pkg else parts)] = (path, is_pkg)
    return found


MODULES = _modules()


def _in(name: str, pattern: str) -> bool:
    """Whether module ``name`` is what ``pattern`` names: '*' any module, 'a.b.*' a module
    inside package a.b (not a.b itself), 'a.b' a.b and (when a.b is a package other than
    pfbench itself, whose namespace is a module of its own layer) everything in it."""
    if pattern == "*":
        return True
    if pattern.endswith(".*"):
        return name.startswith(pattern[:-1])
    if name == pattern:
        return True
    return (pattern != "pfbench" and MODULES.get(pattern, (None, False))[1]
            and name.startswith(pattern + "."))


def layer_of(name: str) -> int | None:
    """The index of the layer of ``name`` in LAYERS (the most specific pattern wins)."""
    best, rank = None, -1
    for i, patterns in enumerate(LAYERS.values()):
        for p in patterns:
            if _in(name, p):
                r = 0 if p == "*" else len(p) + (0 if p.endswith(".*") else 1)
                if r > rank:
                    best, rank = i, r
    return best


def _type_checking(node: ast.If) -> bool:
    t = node.test
    return (isinstance(t, ast.Name) and t.id == "TYPE_CHECKING") or (
        isinstance(t, ast.Attribute) and t.attr == "TYPE_CHECKING")


def _imports(tree: ast.AST):
    """(node, at module level) of every import outside an ``if TYPE_CHECKING:`` block."""
    def walk(node, top):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and _type_checking(child):
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, top
            inner = top and not isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef,
                                                   ast.Lambda, ast.ClassDef))
            yield from walk(child, inner)
    yield from walk(tree, True)


def _known(name: str) -> str | None:
    """``name``, or the nearest package above it that is a module of ours (None: not ours)."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def _targets(module: str, is_pkg: bool, node) -> list[str]:
    """The modules of ours an import statement loads (its package's __init__s included)."""
    names = []
    if isinstance(node, ast.Import):
        names = [a.name for a in node.names]
    else:
        if node.level:
            base = module.split(".") if is_pkg else module.split(".")[:-1]
            base = base[:len(base) - (node.level - 1)]
            full = ".".join(base + ([node.module] if node.module else []))
        else:
            full = node.module or ""
        for a in node.names:
            sub = f"{full}.{a.name}"
            names.append(sub if sub in MODULES else full)
    out = []
    for name in names:
        target = _known(name)
        if target is None:
            continue
        # importing a.b.c runs the __init__ of a.b first, unless the importer is inside a.b
        parts = target.split(".")
        for k in range(2, len(parts)):
            pkg = ".".join(parts[:k])
            if module != pkg and not module.startswith(pkg + "."):
                out.append(pkg)
        out.append(target)
    return out


@functools.cache
def import_graph() -> dict[str, dict[str, list[tuple[int, bool]]]]:
    """importer -> imported -> [(line, at module level)] over MODULES (parsed when a test first
    asks, not at collection in every pytest-xdist worker)."""
    graph: dict[str, dict[str, list]] = {m: {} for m in MODULES}
    for module, (path, is_pkg) in MODULES.items():
        tree = parsed(path.read_text(encoding="utf-8"))
        for node, top in _imports(tree):
            for target in _targets(module, is_pkg, node):
                if target != module:
                    graph[module].setdefault(target, []).append((node.lineno, top))
    return graph


def _where(a: str, b: str, graph) -> str:
    line, top = graph[a][b][0]
    return f"{a} -> {b} ({MODULES[a][0].relative_to(ROOT)}:{line}" + (
        ")" if top else ", inside a function)")


def find_cycle(graph) -> list[str] | None:
    """One import circle of ``graph`` (its modules in order, the first repeated at the end), or
    None."""
    state: dict[str, int] = {}
    for start in sorted(graph):
        if state.get(start):
            continue
        stack = [(start, iter(sorted(graph[start])))]
        path = [start]
        state[start] = 1
        while stack:
            node, it = stack[-1]
            nxt = next(it, None)
            if nxt is None:
                state[node] = 2
                stack.pop()
                path.pop()
                continue
            if state.get(nxt) == 1:
                return path[path.index(nxt):] + [nxt]
            if not state.get(nxt):
                state[nxt] = 1
                stack.append((nxt, iter(sorted(graph.get(nxt, ())))))
                path.append(nxt)
    return None


def _checked(graph, circles_left: bool = False):
    """The imports the layers govern: those of the modules not PENDING (and, for the check of
    circles, not those of CIRCLES_LEFT)."""
    return {a: {b: w for b, w in targets.items()
                if not (circles_left and (a, b) in CIRCLES_LEFT)}
            for a, targets in graph.items() if a not in PENDING}


def test_every_module_has_a_layer():
    assert MODULES, "no module found"
    lost = [m for m in MODULES if layer_of(m) is None]
    assert not lost, f"modules in no layer of LAYERS (and docs/internals/layers.md): {lost}"


def test_no_import_circle():
    graph = _checked(import_graph(), circles_left=True)
    cycle = find_cycle(graph)
    assert cycle is None, "import circle:\n  " + "\n  ".join(
        _where(a, b, graph) for a, b in zip(cycle, cycle[1:]))


def test_the_circles_left_are_still_there():
    graph = import_graph()
    gone = [f"{a} -> {b}" for a, b in CIRCLES_LEFT if b not in graph.get(a, {})]
    assert not gone, f"no longer imported (drop them from CIRCLES_LEFT): {gone}"


def test_no_import_against_the_layers():
    names = list(LAYERS)
    bad, graph = [], import_graph()
    for a, targets in _checked(graph).items():
        for b in targets:
            la, lb = layer_of(a), layer_of(b)
            if lb > la:
                bad.append(f"{_where(a, b, graph)}: layer '{names[la]}' imports layer "
                           f"'{names[lb]}' above it")
    assert not bad, "\n".join(bad)


@pytest.mark.parametrize("importer,imported,why", NEVER)
def test_never(importer, imported, why):
    graph = import_graph()
    bad = [_where(a, b, graph) for a, targets in _checked(graph).items() if _in(a, importer)
           for b in targets if _in(b, imported) and (a, b) not in ALLOWED]
    assert not bad, f"{why}:\n  " + "\n  ".join(bad)


def test_imports_inside_functions_defer_something():
    """An import inside a function defers an expensive module (numba's kernels and the
    registries, pandas, matplotlib, scipy, jinja2); a LIGHT one goes at the top."""
    bad = [f"{MODULES[a][0].relative_to(ROOT)}:{line} imports {b} inside a function"
           for a, targets in _checked(import_graph()).items() if a not in DEFER_ALL
           for b, where in targets.items() if b in LIGHT
           for line, top in where if not top]
    assert not bad, "\n".join(bad)


def test_the_layers_are_written_down():
    text = (ROOT / "docs" / "internals" / "layers.md").read_text(encoding="utf-8")
    for layer, patterns in LAYERS.items():
        assert layer in text, f"docs/internals/layers.md does not name the layer '{layer}'"
        for p in patterns:
            assert f"`{p}`" in text or f"`{p.removeprefix('pfbench.')}`" in text, (
                f"docs/internals/layers.md does not name {p} (layer '{layer}')")


def test_the_checker_finds_a_circle_and_a_layer_break():
    """The checker itself: a circle hidden in a function, and an import upward, are found."""
    graph = {"a": {"b": [(1, True)]}, "b": {"c": [(2, False)]}, "c": {"a": [(3, False)]}}
    assert find_cycle(graph) == ["a", "b", "c", "a"]
    assert find_cycle({"a": {"b": [(1, True)]}, "b": {}}) is None
    module = "pfbench.filters.pf"
    tree = ast.parse("def f():\n    from ..scenarios import beacon_field\n")
    (node, top), = list(_imports(tree))
    assert not top
    assert _targets(module, False, node) == ["pfbench.scenarios",
                                             "pfbench.scenarios.beacon_field"]
    assert layer_of("pfbench.scenarios") > layer_of(module)
    assert layer_of("pfbench.models.slam") < layer_of("pfbench.scenarios.beacon_field")
