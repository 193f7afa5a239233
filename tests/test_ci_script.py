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


def test_every_test_selection_of_the_ci_script_selects_a_test():
    text = (ROOT / ".ci" / "run").read_text()
    lines = [ln for ln in text.splitlines() if ln.lstrip().startswith("pytest")]
    for line in lines:
        files = re.findall(r"(tests/[\w/]+\.py)", line)
        word = re.search(r"-k\s+(\w+)", line)
        for f in files:
            names = re.findall(r"^def (test_\w+)", (ROOT / f).read_text(), flags=re.M)
            assert names, f"{line!r}: {f} has no test"
            if word:
                assert any(word.group(1) in n for n in names), \
                    f"{line!r}: no test of {f} matches -k {word.group(1)}"


def test_the_selection_check_catches_a_selection_that_selects_nothing(tmp_path, monkeypatch):
    fake = tmp_path / ".ci"
    fake.mkdir()
    (fake / "run").write_text("pytest -q tests/test_ci_script.py -k nosuchword\n")
    monkeypatch.setattr(__import__(__name__, fromlist=["ROOT"]), "ROOT", tmp_path)
    (tmp_path / "tests").mkdir()
    (tmp_path / "tests" / "test_ci_script.py").write_text("def test_a():\n    pass\n")
    try:
        test_every_test_selection_of_the_ci_script_selects_a_test()
    except AssertionError as exc:
        assert "nosuchword" in str(exc)
    else:
        raise AssertionError("a selection of no test passed the check")
