"""'Did we implement it as the paper says?': each paper file's algorithms step by step (the text
quoted in the original and translated, the functions of pfbench that do each step, and whether
they follow it), read strictly, every named function importable, and rendered in the report
right after the findings, with a place for the readings' outcome."""
import re
import sys
import types

import pytest
import yaml
from typer.testing import CliRunner

from pfbench import papers
from pfbench import report_data as rp
from pfbench import report_html
from pfbench.cli import app
from pfbench.schema import ConfigError

from .conftest import ROOT, one_line_exit_2

runner = CliRunner()
PAPERS = ROOT / "configs" / "papers"
# the papers whose algorithms pfbench runs (review2007 is a survey whose MCL family runs as the
# baselines of the others)
WITH_ALGORITHMS = ("afsa2014", "asrl2008", "ifa2021", "sspf2008")
# the ids of the open choices the steps name (the paper files' choices)
CJK = re.compile(r"[\u4e00-\u9fff]")

GOOD = """\
paper: smith2024
citation: Smith and Lee, 2024
implementation:
- algorithm: stepwise EWA resampling
  where: section 1.2
  steps:
  - step: sort the weights
    text: 1) 计算粒子权重并按降序排列.
    english: 1) Compute the particles' weights and sort them in descending order.
    pfbench: pfbench.resampling.stepwise_ewa_plan
    status: follows
  - step: bias correction
    text: 1 - β^i 为偏差修正项
    english: 1 - β^i is the bias-correction term
    pfbench: [pfbench.resampling.stepwise_ewa_plan, pfbench.resampling.ewa_mutant]
    status: open
    choice: ewa_correction
    note: as printed or the standard form; pfbench's default is the standard form.
"""


def test_every_algorithm_paper_says_how_pfbench_does_each_step():
    for key in WITH_ALGORITHMS:
        paper = papers.read(PAPERS / f"{key}.yaml")
        assert paper.implementation, key
        raw = yaml.safe_load((PAPERS / f"{key}.yaml").read_text())
        ids = {c["id"] for c in raw.get("choices") or [] if isinstance(c, dict) and "id" in c}
        for a in paper.implementation:
            assert a.steps and a.where, (key, a.name)
            for s in a.steps:
                where = (key, a.name, s.name)
                # quoted in the original (Chinese), translated into English
                assert CJK.search(s.text), where
                assert not CJK.search(s.english), where
                assert s.status in papers.STATUSES, where
                for f in s.functions:       # every named function exists
                    assert f.startswith("pfbench.") and papers.function_problem(f) is None, \
                        (where, f)
                if s.status != "follows":
                    assert s.note.strip(), where
                if s.choice is not None:
                    # a choice the paper file declares (its readings name the same ids)
                    assert s.choice in ids, (where, sorted(ids))
    # the algorithms the project reproduces are all there
    names = {a.name for k in WITH_ALGORITHMS for a in papers.read(PAPERS / f"{k}.yaml")
             .implementation}
    for name in ("IFA-PF", "FA-PF", "BA-PF", "stepwise EWA resampling",
                 "IFA-FastSLAM's refinement", "AFSA-FastSLAM", "directional resampling",
                 "ASRL", "SRL", "SSPF"):
        assert name in names, name


def test_a_function_path_is_checked_down_to_its_attribute():
    assert papers.function_problem("pfbench.filters.swarm.ifa_move") is None
    assert papers.function_problem("pfbench.filters.fastslam.refine_poses") is None
    assert "has no ifa_mov" in papers.function_problem("pfbench.filters.swarm.ifa_mov")
    assert "has no nowhere.f" in papers.function_problem("pfbench.nowhere.f")
    assert "no module nosuchpkg" in papers.function_problem("nosuchpkg.f")
    assert "not a dotted path" in papers.function_problem("ifa_move")
    assert "not a dotted path" in papers.function_problem("pfbench.filters.swarm.ifa-move")


@pytest.mark.parametrize("edit, message", [
    (("    text: 1) 计算粒子权重并按降序排列.\n", ""),
     r"implementation\[0\]\.steps\[0\]\.text: a step needs the text's words"),
    (("    english: 1) Compute", "    english: ''\n    x: 1) Compute"),
     r"steps\[0\]\.english: a step needs"),
    (("pfbench.resampling.stepwise_ewa_plan\n    status: follows",
      "pfbench.resampling.stepwise_ewa_plam\n    status: follows"),
     r"steps\[0\]\.pfbench: 'pfbench\.resampling\.stepwise_ewa_plam': pfbench\.resampling has "
     r"no stepwise_ewa_plam"),
    (("pfbench.resampling.ewa_mutant]", "pfbench.nope.ewa_mutant]"),
     r"steps\[1\]\.pfbench\[1\]: 'pfbench\.nope\.ewa_mutant'"),
    (("    pfbench: pfbench.resampling.stepwise_ewa_plan\n", ""),
     r"steps\[0\]\.pfbench: missing"),
    (("status: follows", "status: follow"), r"steps\[0\]\.status: expected one of"),
    (("    note: as printed", "    nota: as printed"), r"steps\[1\]\.nota: unknown key"),
    (("    note: as printed or the standard form; pfbench's default is the standard form.\n", ""),
     r"steps\[1\]\.note: a step with status open needs a note"),
    (("choice: ewa_correction", "choice: EWA correction"), r"is not a choice id"),
    (("  where: section 1.2\n", ""), r"implementation\[0\]\.where: missing"),
])
def test_a_broken_implementation_is_named_with_its_line_and_key(tmp_path, edit, message):
    path = tmp_path / "smith2024.yaml"
    assert edit[0] in GOOD
    path.write_text(GOOD.replace(*edit))
    with pytest.raises(ConfigError, match=message) as exc:
        papers.read(path)
    assert str(exc.value).startswith(f"{path}:"), str(exc.value)
    assert "\n" not in str(exc.value)


def test_the_command_line_refuses_a_step_without_text_in_one_line(tmp_path):
    work = tmp_path / "work"
    (work / "papers").mkdir(parents=True)
    cfg = work / "smith_ungm.yaml"
    cfg.write_text("paper: smith2024\ntrials: 2\nscenario: {name: ungm}\n"
                   "filters:\n  pf: {label: PF, particles: 100}\n")
    paper = work / "papers" / "smith2024.yaml"
    paper.write_text(GOOD)
    assert runner.invoke(app, ["validate", str(cfg)]).exit_code == 0
    paper.write_text(GOOD.replace("    text: 1) 计算粒子权重并按降序排列.\n", ""))
    before = sorted(p.name for p in tmp_path.rglob("*"))
    line = one_line_exit_2(runner.invoke(app, ["validate", str(cfg)]))
    assert "smith2024.yaml:7: implementation[0].steps[0].text: a step needs" in line, line
    paper.write_text(GOOD.replace("ewa_mutant]", "ewa_mutnt]"))
    line = one_line_exit_2(runner.invoke(app, ["validate", str(cfg)]))
    assert "pfbench.resampling has no ewa_mutnt" in line, line
    assert sorted(p.name for p in tmp_path.rglob("*")) == before     # nothing written


def _paper(tmp_path):
    path = tmp_path / "smith2024.yaml"
    path.write_text(GOOD.replace("1 - β^i 为偏差修正项", "δ_i = [β δ_{i-1} + (1 - β) w_i](1 - β^i) | x*"))
    return papers.read(path)


def test_the_markdown_gives_a_table_per_algorithm_with_formulas_as_written(tmp_path):
    lines = rp.implementation_md(_paper(tmp_path))
    assert lines[0] == "### Did we implement it as the paper says?"
    assert "#### stepwise EWA resampling (section 1.2)" in lines
    rows = [x for x in lines if x.startswith("| ") and not x.startswith(("| Step", "| ---"))]
    assert len(rows) == 2
    first, second = rows
    assert first.count(" | ") == 2           # three cells: no bar of the text splits a cell
    assert "`pfbench.resampling.stepwise_ewa_plan`: follows the text" in first
    # brackets, bars, stars and underscores escaped: no link, no cell's end, no emphasis
    assert r"δ\_i = \[β δ\_{i-1} + (1 - β) w\_i\](1 - β^i) \| x\*" in second
    assert second.count(" | ") == 2
    assert "open choice `ewa_correction`: as printed or the standard form" in second
    assert rp.implementation_md(papers.Paper("x", "y")) == []


def _fake_readings(monkeypatch, lines):
    mod = types.ModuleType("pfbench.readings")
    mod.robustness_lines = lambda folder: list(lines)
    monkeypatch.setitem(sys.modules, "pfbench.readings", mod)


class _Entry:
    status = "ok"
    folder = "results/x"


def test_the_readings_outcome_is_shown_only_where_readings_give_lines(tmp_path, monkeypatch):
    monkeypatch.setitem(sys.modules, "pfbench.readings", None)     # import fails
    assert rp.readings_outcome([_Entry()]) == [] and rp.readings_outcome_md([_Entry()]) == []
    _fake_readings(monkeypatch, [])
    assert rp.readings_outcome_md([_Entry()]) == []
    _fake_readings(monkeypatch, ["IFA-PF N=50 RMSE: differs under all 14 readings"])
    md = rp.readings_outcome_md([_Entry()])
    assert md[0] == "#### The readings' outcome"
    assert "- IFA-PF N=50 RMSE: differs under all 14 readings" in md
    html = _page(tmp_path, rp.readings_outcome([_Entry()]))
    outcome = html.index("The readings&#39; outcome")
    assert html.index("</table>") < outcome < html.index("differs under all 14 readings")


def _page(tmp_path, outcome) -> str:
    p = _paper(tmp_path)
    return report_html._env().get_template("paper.html").render(
        title="t", css="", papers=[], version="0", paper=p, sections=[], choices=[],
        findings=["a finding"], elsewhere=[], implementation=p.implementation, lang="zh",
        implementation_title=rp.IMPLEMENTATION_TITLE, implementation_intro=rp.IMPLEMENTATION_INTRO,
        status_words=rp.STATUS_WORDS, readings_outcome=outcome, readings_title=rp.READINGS_TITLE,
        readings_intro=rp.READINGS_INTRO)


def test_the_html_page_puts_the_steps_after_the_findings(tmp_path):
    html = _page(tmp_path, [])
    found, section = html.index("a finding"), html.index('id="implementation"')
    assert found < section
    assert '<span lang="zh">1) 计算粒子权重并按降序排列.</span>' in html
    assert "<code>ewa_correction</code>" in html and "open choice" in html
    assert "outcome" not in html                 # no readings: no heading for them


def test_the_committed_report_answers_for_every_paper_after_its_findings():
    text = (ROOT / "results" / "REPORT.md").read_text()
    for key in WITH_ALGORITHMS:
        sec = re.search(rf"^## `{key}`.*?(?=^## |\Z)", text, re.S | re.M).group(0)
        found = sec.index("What reproduced and what did not:")
        answer = sec.index("### Did we implement it as the paper says?")
        assert found < answer, key
        for a in papers.read(PAPERS / f"{key}.yaml").implementation:
            assert f"#### {a.name} ({a.where})" in sec, (key, a.name)
        page = (ROOT / "docs" / "papers" / f"{key}.md").read_text()
        assert f"<!-- implementation:{key}:begin -->" in page
