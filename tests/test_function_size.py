"""No function in pfbench/ is longer than 80 lines: a longer one is split into named steps (for a
kernel: the steps of its algorithm, see docs/internals/kernels.md)."""
from __future__ import annotations

import ast
from pathlib import Path

import pytest

from .conftest import parsed

ROOT = Path(__file__).resolve().parent.parent / "pfbench"
MOST_LINES = 80


def long_functions(root: Path, most: int = MOST_LINES) -> list[str]:
    """'path:line name (n lines)' for every function, method or nested function under root
    whose definition (decorators excluded, docstring included) spans more than ``most`` lines."""
    found = []
    for path in sorted(root.rglob("*.py")):
        tree = parsed(path.read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                lines = node.end_lineno - node.lineno + 1
                if lines > most:
                    found.append(f"{path.relative_to(root.parent).as_posix()}:{node.lineno} "
                                 f"{node.name} ({lines} lines)")
    return found


def test_no_function_in_pfbench_is_over_80_lines():
    long = long_functions(ROOT)
    assert not long, (f"functions over {MOST_LINES} lines (split them into named steps): "
                      + "; ".join(long))


@pytest.mark.parametrize("body_lines, expected", [(MOST_LINES - 1, 0), (MOST_LINES, 1)])
def test_the_count_names_a_function_one_line_past_the_limit(tmp_path, body_lines, expected):
    """The counter itself: def line + body; a nested function and a method are found too."""
    body = "".join(f"    x{i} = {i}\n" for i in range(body_lines))
    (tmp_path / "pkg").mkdir()
    (tmp_path / "pkg" / "a.py").write_text(f"def top():\n{body}")
    nested = "".join(f"            y{i} = {i}\n" for i in range(MOST_LINES))
    (tmp_path / "pkg" / "b.py").write_text(
        f"class C:\n    def method(self):\n        def inner():\n{nested}        return inner\n")
    found = long_functions(tmp_path / "pkg")
    assert sum("top" in f for f in found) == expected
    assert any("method" in f for f in found) and any("inner" in f for f in found)
    if expected:
        assert f"pkg/a.py:1 top ({MOST_LINES + 1} lines)" in found
