"""The docs site: it builds with mkdocs in strict mode (a broken link or anchor fails it), and
every Python example in it runs."""
import os
import re
import shutil
import subprocess
import sys

import pytest

from .conftest import ROOT

DOCS = ROOT / "docs"
SLOW = "<!-- test: slow -->"


def _examples():
    """(page, [code blocks]) for each page with ```python blocks; a page whose block follows a
    `<!-- test: slow -->` line runs with the slow tests."""
    out = []
    for page in [ROOT / "README.md", *sorted(DOCS.rglob("*.md"))]:
        text = page.read_text()
        blocks = re.findall(r"^(<!-- test: slow -->\n)?```python\n(.*?)^```", text, re.S | re.M)
        if blocks:
            marks = [pytest.mark.slow] if any(b[0] for b in blocks) else []
            out.append(pytest.param(page, [b[1] for b in blocks],
                                    id=page.relative_to(ROOT).as_posix(), marks=marks))
    return out


def test_the_docs_have_examples_to_run():
    assert len(_examples()) >= 3


@pytest.mark.parametrize("page, blocks", _examples())
def test_every_python_example_of_the_docs_runs(page, blocks, monkeypatch, tmp_path):
    """A page's blocks run in order in one namespace, as a reader would run them, from the
    repository root (where configs/ is)."""
    import matplotlib
    matplotlib.use("Agg")
    monkeypatch.chdir(ROOT)
    scope: dict = {"__name__": "__docs__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{page.name} (python block {i + 1})", "exec"), scope)


def test_every_relative_link_of_the_docs_resolves_in_the_repository_too():
    """The pages read on GitHub as well: each relative link or image, taken from the page's
    file in the repository, names a file there (the site's hook maps links into results/)."""
    bad, n = [], 0
    for page in sorted(DOCS.rglob("*.md")):
        text = re.sub(r"```.*?```", "", page.read_text(), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            path = target.split("#", 1)[0]
            if not path or "://" in path:
                continue
            n += 1
            if not (page.parent / path).resolve().exists():
                bad.append(f"{page.relative_to(ROOT)}: {target}")
    assert n > 100
    assert not bad, bad


def _mkdocs(cwd, out, env=None):
    return subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-d",
                           str(out)], cwd=cwd, capture_output=True, text=True,
                          env={**os.environ, "PYTHONDONTWRITEBYTECODE": "1",
                               "NO_MKDOCS_2_WARNING": "1", **(env or {})})


def test_the_site_builds_strictly_without_touching_the_checkout(tmp_path):
    pytest.importorskip("mkdocs")
    pytest.importorskip("material")
    before = _status()
    res = _mkdocs(ROOT, tmp_path / "site")
    assert res.returncode == 0, res.stdout + res.stderr
    assert (tmp_path / "site/index.html").is_file()
    assert (tmp_path / "site/results/REPORT/index.html").is_file()
    assert _status() == before


def _status() -> list[str]:
    """The checkout's changed and ignored files, less the test tools' own folders (which the
    suite's other workers may create meanwhile)."""
    out = subprocess.run(["git", "status", "--porcelain", "--ignored"], cwd=ROOT,
                         capture_output=True, text=True).stdout
    return [l for l in out.splitlines()
            if not any(t in l for t in (".hypothesis/", ".pytest_cache/", "__pycache__/"))]


@pytest.fixture(scope="module")
def docs_copy(tmp_path_factory):
    """A copy of the site's sources that builds strictly (built once for the edits below)."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("material")
    top = tmp_path_factory.mktemp("docs-copy")
    shutil.copy(ROOT / "mkdocs.yml", top / "mkdocs.yml")
    shutil.copytree(DOCS, top / "docs")
    (top / "results").symlink_to(ROOT / "results")
    res = _mkdocs(top, top / "ok")
    assert res.returncode == 0, res.stdout + res.stderr
    return top


@pytest.mark.parametrize("edit", [
    "[a page that is not there](nowhere.md)",
    "[an anchor that is not there](glossary.md#no-such-term)",
    "[an anchor of this page that is not there](#no-such-section)",
    "![a figure that is not there](../results/ifa_pf_ungm/figures/nope.png)",
    "[a link that leaves the docs](../README.md)",
    None,                                   # a page that the nav leaves out
])
def test_a_broken_link_or_anchor_fails_the_build(docs_copy, tmp_path, edit):
    shutil.copy(docs_copy / "mkdocs.yml", tmp_path / "mkdocs.yml")
    shutil.copytree(docs_copy / "docs", tmp_path / "docs")
    (tmp_path / "results").symlink_to(ROOT / "results")
    page = tmp_path / ("docs/index.md" if edit else "docs/orphan.md")
    page.write_text(page.read_text() + f"\n{edit}\n" if edit else "# Orphan\n")
    res = _mkdocs(tmp_path, tmp_path / "broken")
    assert res.returncode != 0
    assert page.name in res.stdout + res.stderr
