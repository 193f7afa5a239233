"""The CI script (.ci/run) names only test files and configs that exist: a file moved or renamed
elsewhere would otherwise turn a CI step into 'no tests ran' (pytest's exit status 5)."""
import re

from .conftest import ROOT


def test_every_path_the_ci_script_names_exists():
    text = (ROOT / ".ci" / "run").read_text()
    paths = set(re.findall(r"\b((?:tests|configs|scripts|bench)/[\w./-]+\.(?:py|yaml|c|sh))\b",
                           text))
    assert paths, "the CI script names no file: the pattern no longer reads it"
    missing = sorted(p for p in paths if not (ROOT / p).exists())
    assert not missing, f".ci/run names files that do not exist: {missing}"


def empty_selections(root) -> list[str]:
    """What each `pytest FILE ... -k WORD` line of root/.ci/run would select nothing of: a file
    with no test, or no test of the file whose name holds WORD."""
    out = []
    for line in (root / ".ci" / "run").read_text().splitlines():
        if not line.lstrip().startswith("pytest"):
            continue
        word = re.search(r"-k\s+(\w+)", line)
        for f in re.findall(r"(tests/[\w/]+\.py)", line):
            names = re.findall(r"^def (test_\w+)", (root / f).read_text(), flags=re.M)
            if not names:
                out.append(f"{line!r}: {f} has no test")
            elif word and not any(word.group(1) in n for n in names):
                out.append(f"{line!r}: no test of {f} matches -k {word.group(1)}")
    return out


def test_every_test_selection_of_the_ci_script_selects_a_test():
    assert not empty_selections(ROOT)


def test_the_selection_check_catches_a_selection_that_selects_nothing(tmp_path):
    (tmp_path / ".ci").mkdir()
    (tmp_path / ".ci" / "run").write_text("pytest -q tests/test_ci_script.py -k nosuchword\n"
                                          "pytest -q tests/test_empty.py\n")
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_ci_script.py").write_text("def test_a():\n    pass\n")
    (tmp_path / "tests" / "test_empty.py").write_text("X = 1\n")
    found = empty_selections(tmp_path)
    assert len(found) == 2 and "nosuchword" in found[0] and "has no test" in found[1]
