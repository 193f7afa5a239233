"""The bench tooling lives apart from the library: pfbench.benchmarks, which no module of the
library imports (the command line only inside its ``bench`` command), and whose modules import
each other without a circle. The imports are read from the source (ast), those inside functions
included, so that a function-local import cannot hide one."""
import ast
import importlib.util

from .conftest import ROOT, parsed

PKG = ROOT / "pfbench"
BENCH = "pfbench.benchmarks"


def _module_name(path):
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules():
    """{module name: (path, is a package)} of every source file of pfbench."""
    return {_module_name(p): (p, p.name == "__init__.py") for p in sorted(PKG.rglob("*.py"))}


def _imports(name, path, is_pkg, known):
    """(imported module, the function it is imported in or None) for every import statement of
    the module, relative ones resolved; ``from X import y`` counts X.y when that is a module."""
    tree = parsed(path.read_text(encoding="utf-8"))
    out = []

    def visit(node, func):
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, (ast.FunctionDef,
                                                     ast.AsyncFunctionDef)) else func
            if isinstance(child, ast.Import):
                out.extend((a.name, func) for a in child.names)
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = name.split(".") if is_pkg else name.split(".")[:-1]
                    base = base[:len(base) - (child.level - 1)]
                    target = ".".join(base + ([child.module] if child.module else []))
                else:
                    target = child.module
                out.append((target, func))
                out.extend((f"{target}.{a.name}", func) for a in child.names
                           if f"{target}.{a.name}" in known)
            visit(child, inner)

    visit(tree, None)
    return out


def _in_bench(module):
    return module == BENCH or module.startswith(BENCH + ".")


def test_the_tooling_is_a_package_of_its_own():
    mods = _modules()
    assert mods[BENCH][1]                       # a package
    for gone in ("pfbench.bench", "pfbench.limits"):
        assert gone not in mods, gone
    # in the package a wheel installs (pyproject's packages: pfbench*), not only in a checkout
    assert importlib.util.find_spec(BENCH + ".suite").origin == str(PKG / "benchmarks" / "suite.py")


def test_no_library_module_imports_the_benchmarks():
    mods = _modules()
    found = []
    for name, (path, is_pkg) in mods.items():
        if _in_bench(name):
            continue
        for target, func in _imports(name, path, is_pkg, mods):
            if not _in_bench(target):
                continue
            if name == "pfbench.cli" and func == "bench":
                continue            # the command's entry point, imported when it runs
            found.append(f"{name} imports {target}" + (f" in {func}" if func else ""))
    assert found == []
    # and the command does import it
    cli = _imports("pfbench.cli", *mods["pfbench.cli"], mods)
    assert any(_in_bench(t) and f == "bench" for t, f in cli)


def test_the_bench_modules_form_no_import_circle():
    """No circle through a module of the bench tooling (bench <-> limits was one)."""
    mods = _modules()
    graph = {name: {t for t, _ in _imports(name, *mods[name], mods) if t in mods and t != name}
             for name in mods}

    def circle_from(start):
        stack, seen = [(start, [start])], set()
        while stack:
            node, trail = stack.pop()
            for nxt in graph[node]:
                if nxt == start:
                    return trail + [start]
                if nxt not in seen:
                    seen.add(nxt)
                    stack.append((nxt, trail + [nxt]))
        return None

    starts = [m for m in mods if _in_bench(m) or m in ("pfbench.bench", "pfbench.limits")]
    assert starts
    circles = [c for c in map(circle_from, starts) if c]
    assert circles == []


def test_the_layout_check_sees_a_hidden_import(tmp_path):
    """The import reader finds a function-local relative import of the package."""
    src = tmp_path / "m.py"
    src.write_text("def f():\n    from .benchmarks import suite\n    from . import benchmarks\n")
    known = {"pfbench.benchmarks", "pfbench.benchmarks.suite"}
    got = _imports("pfbench.m", src, False, known)
    assert ("pfbench.benchmarks.suite", "f") in got and ("pfbench.benchmarks", "f") in got
