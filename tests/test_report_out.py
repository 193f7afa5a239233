"""pfbench report: REPORT.md and the HTML report go where --out says, and only there; a report
that cannot be built right writes nothing; a report of some of a paper's configs reports what
they fill."""
import os
import re
import shutil

import pytest
from typer.testing import CliRunner

import pfbench
from pfbench import report
from pfbench.cli import app
from pfbench.errors import UserError

from .conftest import ROOT, TINY, one_line_exit_2, tree

runner = CliRunner()


def _small(name: str, trials: int) -> str:
    text = (ROOT / "configs" / f"{name}.yaml").read_text()
    return re.sub(r"(?m)^trials: \d+", f"trials: {trials}", text)


def stat_tree(folder):
    """Every path under ``folder`` with its kind, size and modification time (a cheap snapshot
    of a large folder: the repository's results)."""
    out = {}
    for dirpath, dirnames, filenames in os.walk(folder):
        for n in dirnames + filenames:
            p = os.path.join(dirpath, n)
            st = os.lstat(p)
            out[p] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


@pytest.fixture(scope="module")
def mine(tmp_path_factory):
    """A user's folder of configs: one of sspf2008's (Table 1; the paper's Field table has no
    config here) and one that names no paper, regenerated into a results folder."""
    tmp = tmp_path_factory.mktemp("mine")
    configs, results = tmp / "configs", tmp / "results"
    configs.mkdir()
    (configs / "sspf_ungm.yaml").write_text(_small("sspf_ungm", 3))
    (configs / "plain.yaml").write_text(TINY)
    for name in ("sspf_ungm", "plain"):
        pfbench.run_experiment(configs / f"{name}.yaml", out=results / name, figures=False)
    return configs, results


def _copy(results, tmp_path):
    out = tmp_path / "results"
    shutil.copytree(results, out)
    return out


def test_out_is_a_folder_created_with_the_markdown_and_the_html(mine, tmp_path):
    configs, results = mine
    before, repo = tree(results), stat_tree(ROOT / "results")
    out = tmp_path / "else" / "where"            # its parents do not exist
    args = ["report", "--configs", str(configs), "--results", str(results), "--out", str(out)]
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    assert (out / "REPORT.md").is_file() and (out / "report" / "index.html").is_file()
    assert (out / "report" / "sspf2008.html").is_file()
    assert tree(results) == before                # nothing in the results folder
    assert stat_tree(ROOT / "results") == repo    # nor in the repository's
    assert ".tmp" not in r.output
    # --check looks where --out says
    assert runner.invoke(app, args + ["--check"]).exit_code == 0
    (out / "report" / "index.html").write_text("edited")
    r = runner.invoke(app, args + ["--check"])
    assert r.exit_code == 1 and "index.html" in r.output
    assert (out / "report" / "index.html").read_text() == "edited"     # --check wrote nothing
    default = runner.invoke(app, ["report", "--configs", str(configs), "--results",
                                  str(results), "--check"])
    assert default.exit_code == 1 and tree(results) == before


def test_out_ending_in_md_is_the_markdown_file_with_the_html_beside(mine, tmp_path):
    configs, results = mine
    before = tree(results)
    md = tmp_path / "new" / "MINE.md"
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                            "--out", str(md)])
    assert r.exit_code == 0, r.output
    assert md.is_file() and (md.parent / "report" / "index.html").is_file()
    assert sorted(p.name for p in md.parent.iterdir()) == ["MINE.md", "report"]
    assert tree(results) == before
    # the figures it links lie in the results folder, relative to the file
    text = md.read_text()
    link = re.search(r"\]\(([^)]*plain/table\.md)\)", text).group(1)
    assert (md.parent / link).resolve() == (results / "plain" / "table.md").resolve()


def test_the_users_own_files_in_the_out_folder_stay(mine, tmp_path):
    configs, results = mine
    out = tmp_path / "out"
    (out / "report" / "figures").mkdir(parents=True)
    (out / "notes.txt").write_text("mine")
    (out / "report" / "style.css").write_text("mine")
    (out / "report" / "figures" / "sketch.png").write_bytes(b"mine")
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                            "--out", str(out)])
    assert r.exit_code == 0, r.output
    assert (out / "notes.txt").read_text() == "mine"
    assert (out / "report" / "style.css").read_text() == "mine"
    assert (out / "report" / "figures" / "sketch.png").read_bytes() == b"mine"


def test_out_that_cannot_be_a_folder_is_one_line_naming_it(mine, tmp_path):
    configs, results = mine
    (tmp_path / "file").write_text("x")
    for out in (tmp_path / "file" / "below", tmp_path / ("é" * 200) / "r"):
        r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                                "--out", str(out)])
        line = one_line_exit_2(r)
        assert str(out) in line and ".tmp" not in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_a_report_of_some_of_a_papers_configs_reports_what_they_fill(mine, tmp_path):
    configs, results = mine
    out = tmp_path / "r"
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                            "--out", str(out)])
    assert r.exit_code == 0 and "warning" not in r.output, r.output
    text = (out / "REPORT.md").read_text()
    assert "not among these configs)" not in text and "broken reference" not in text
    assert text.count("Not among these configs:") == 1
    assert "Not among these configs: Field of this paper." in text
    # a survey whose findings are all about configs not here has no section
    assert "review2007" not in text
    html = (out / "report" / "sspf2008.html").read_text()
    assert "Not among these configs: Field of this paper." in html


def _broken_paper(tmp_path, ref: str):
    papers = tmp_path / "papers"
    papers.mkdir(exist_ok=True)
    text = (ROOT / "configs" / "papers" / "sspf2008.yaml").read_text()
    text = text.replace("findings:\n", f"findings:\n- \"A broken one: {ref}.\"\n", 1)
    assert ref in text
    (papers / "sspf2008.yaml").write_text(text)
    return papers


@pytest.mark.parametrize("ref", ["{sspf_ungm:pf@999:rmse_mean}", "{sspf_ungm:pf@200:rmse_men}",
                                 "{sspf_ungmm:pf@200:rmse_mean}"])
def test_a_broken_reference_fails_and_writes_nothing(mine, tmp_path, ref):
    configs, results = mine
    papers = _broken_paper(tmp_path, ref)
    results = _copy(results, tmp_path)
    runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results)])
    before = tree(results)
    out = tmp_path / "out"
    for extra in ([], ["--out", str(out)], ["--check"]):
        r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                                "--papers", str(papers), *extra])
        line = one_line_exit_2(r)
        assert "sspf2008.yaml:" in line and ref in line
        assert tree(results) == before and not out.exists()


def test_a_folder_a_killed_regeneration_left_aside_is_restored_not_omitted(mine, tmp_path):
    configs, results = mine
    results = _copy(results, tmp_path)
    runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results)])
    before = tree(results)
    (results / "plain").rename(results / ".plain.old4242")
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                            "--check"])
    line = one_line_exit_2(r)
    assert ".plain.old4242" in line
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                            "--out", str(tmp_path / "elsewhere")])
    one_line_exit_2(r)
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results)])
    assert r.exit_code == 0 and "restored" in r.output, r.output
    assert tree(results) == before


def test_a_report_into_a_folder_a_tables_run_holds_is_refused(mine, tmp_path):
    from pfbench.fsutil import FolderLock
    configs, results = mine
    results = _copy(results, tmp_path)
    with FolderLock(results):
        r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                                "--out", str(tmp_path / "o")])
        assert "in use by another pfbench run" in one_line_exit_2(r)
    assert not (tmp_path / "o").exists()


def test_findings_about_configs_elsewhere_are_left_out_typos_are_errors(mine):
    configs, results = mine
    entries = {e.name: e for e in report.collect(configs, results)}
    from pfbench import papers
    paper = papers.read(ROOT / "configs" / "papers" / "sspf2008.yaml")
    filled = report.findings(paper, entries)
    assert filled and all("sspf_global" not in f for f in filled)
    bad = papers.Paper(paper.key, paper.citation, paper.tables, (), (
        papers.Finding("x {sspf_globl:pf:rmse_mean}", (papers.Ref(
            "{sspf_globl:pf:rmse_mean}", "sspf_globl", "pf", "rmse_mean", False),), 3),),
        paper.source)
    with pytest.raises(UserError, match="sspf2008.yaml:3: .*no experiment 'sspf_globl'.*"
                                        "did you mean 'sspf_global'"):
        report.findings(bad, entries)


@pytest.mark.parametrize("damage", ["meta", "trials"])
def test_results_that_cannot_be_read_fail_the_report_and_write_nothing(mine, tmp_path, damage):
    configs, results = mine
    results = _copy(results, tmp_path)
    if damage == "meta":
        (results / "plain" / "meta.json").write_text("[1, 2")
    else:
        (results / "plain" / "trials.csv").write_bytes(b"\xff\xfe\x00garbage\x00\n\x01")
    before = tree(results)
    r = runner.invoke(app, ["report", "--configs", str(configs), "--results", str(results)])
    assert "plain" in one_line_exit_2(r)
    assert tree(results) == before
