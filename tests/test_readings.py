"""Readings of a paper's open choices (pfbench.readings): the paper file's section checked, the
key paths expanded against a config, a reading's trials equal to a full run of it bit for bit
while the filter runs it leaves alone keep the config's rows, one Holm family across readings,
the robustness lines, and ``pfbench run --readings`` end to end."""
from __future__ import annotations

import copy
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from pfbench import papers
from pfbench import readings as rd
from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.runner import LocalExecutor, run_experiment, trial_data, trial_result
from pfbench.schema import ConfigError
from pfbench.verdicts import Claim, Estimate, Margin

from .conftest import ROOT, one_line_exit_2, tree

runner = CliRunner()

CONFIG = """\
paper: tiny
table: t1
seed: 7
trials: 5
scenario:
  name: ungm
  steps: 15
filters:
  pf:
    label: PF
    particles: [20, 40]
    resample: always
  ifa:
    label: IFA-PF
    particles: [20, 40]
"""

PAPER = {
    "paper": "tiny",
    "citation": "A paper of two filters",
    "tables": {"t1": {
        "caption": "UNGM: PF and IFA-PF",
        "quantities": {"rmse_mean": {"title": "RMSE", "metric": "rmse", "stat": "mean",
                                     "margin": {"relative": 0.1, "why": "a tenth"}}},
        "values": [{"label": "PF", "particles": 20, "rmse_mean": 4.0},
                   {"label": "IFA-PF", "particles": 20, "rmse_mean": 3.0},
                   {"label": "PF", "particles": 40, "rmse_mean": 3.5},
                   {"label": "IFA-PF", "particles": 40, "rmse_mean": 2.5}],
        "ranking": ["rmse_mean"]}},
    "choices": [
        {"id": "ifa_brightness", "what": "the brightness", "keys": ["filters.ifa.brightness"]},
        {"id": "resample_trigger", "what": "when to resample", "keys": ["filters.pf.resample"]},
    ],
    "readings": {"t1": [
        {"name": "brightness_inverse", "title": "brightness 1 / (1 + d)",
         "choice": "ifa_brightness", "set": {"filters.ifa.brightness": "inverse"},
         "why": "no formula in the text"},
        {"name": "all_neff", "title": "every filter when ESS < N/2",
         "choice": ["resample_trigger"], "set": {"filters.*.resample": "neff"},
         "why": "the text never says when"},
    ]},
}


def _setup(tmp_path: Path, paper: dict | None = None, config: str = CONFIG) -> Path:
    (tmp_path / "papers").mkdir(exist_ok=True)
    (tmp_path / "papers" / "tiny.yaml").write_text(yaml.safe_dump(paper or PAPER))
    path = tmp_path / "tiny.yaml"
    path.write_text(config)
    return path


def _paper_with(**reading) -> dict:
    p = copy.deepcopy(PAPER)
    p["readings"]["t1"][0].update(reading)
    return p


# ---------------------------------------------------------------- the paper file's section

@pytest.mark.parametrize("change, words", [
    ({"choice": "brightnes"}, "no choice with the id 'brightnes'"),
    ({"name": "all_neff"}, "a second reading named 'all_neff'"),
    ({"name": "pfbench"}, "the config as it is"),
    ({"name": "Bad-Name"}, "lowercase letters"),
    ({"set": {"trials": 5}}, "not the scenario's name, trials or seed"),
    ({"set": {"filters.ifa": 1}}, "filters.NAME.KEY"),
    ({"set": {}}, "at least one key path"),
    ({"title": "x" * 45}, "under 40"),
])
def test_a_malformed_reading_is_one_line_naming_it(change, words):
    with pytest.raises(ConfigError) as exc:
        papers.parse(_paper_with(**change), "tiny.yaml")
    text = str(exc.value)
    assert words in text and "readings.t1[" in text and "\n" not in text


def test_choice_ids_are_checked():
    p = copy.deepcopy(PAPER)
    p["choices"][1]["id"] = "ifa_brightness"
    with pytest.raises(ConfigError, match="also the id of choices"):
        papers.parse(p, "tiny.yaml")
    p["choices"][1]["id"] = "Has Space"
    with pytest.raises(ConfigError, match="lowercase"):
        papers.parse(p, "tiny.yaml")


def test_a_valid_section_is_read():
    paper = papers.parse(PAPER, "tiny.yaml")
    assert paper.choice_ids == {"ifa_brightness": 0, "resample_trigger": 1}
    names = [r.name for r in paper.readings["t1"]]
    assert names == ["brightness_inverse", "all_neff"]
    assert paper.readings["t1"][1].set == (("filters.*.resample", "neff"),)


def test_the_committed_readings_apply_to_their_config():
    """Every reading ifa2021 declares is valid on configs/ifa_pf_ungm.yaml and changes only the
    filters it names."""
    exp = load(ROOT / "configs" / "ifa_pf_ungm.yaml")
    runs = rd.plan(exp)
    assert runs[0].name == "pfbench" and len(runs) == 1 + len(rd.declared(exp))
    by = {r.name: r for r in runs}
    assert set(by["brightness_inverse"].changed) == {"ifa@50", "ifa@100", "ifa@150"}
    assert len(by["resample_when_ess_low_all"].changed) == len(exp.filters)


# ---------------------------------------------------------------- key paths on a config

def test_wildcards_expand_to_the_filters_that_declare_the_key(tmp_path):
    exp = load(_setup(tmp_path))
    neff = papers.Reading("r", "r", ("x",), (("filters.*.resample", "neff"),), "")
    assert [p for p, _ in rd.targets(exp, neff)] == [("filters", "pf", "resample"),
                                                      ("filters", "ifa", "resample")]
    bright = papers.Reading("r", "r", ("x",), (("filters.*.brightness", "inverse"),), "")
    assert [p for p, _ in rd.targets(exp, bright)] == [("filters", "ifa", "brightness")]
    for bad, words in ((("filters.*.nokey", 1), "no filter of"),
                       (("filters.ukf.resample", "neff"), "no filter 'ukf'"),
                       (("filters.pf.brightness", "inverse"), "has no key 'brightness'"),
                       (("filters.pf.particles", 30), "cannot change a filter's particles"),
                       (("scenario.nokey", 1), "has no key 'nokey'")):
        with pytest.raises(UserError, match=words):
            rd.targets(exp, papers.Reading("r", "r", ("x",), (bad,), ""))


def test_a_reading_is_validated_as_a_config_and_must_change_something(tmp_path):
    exp = load(_setup(tmp_path))
    bad = papers.Reading("bad", "b", ("x",), (("filters.ifa.brightness", "sideways"),), "")
    with pytest.raises(UserError, match="reading 'bad'.*filters.ifa.brightness"):
        rd.apply(exp, bad)
    same = papers.Reading("same", "s", ("x",), (("filters.pf.resample", "always"),), "")
    with pytest.raises(UserError, match="changes nothing"):
        rd.apply(exp, same)


# ---------------------------------------------------------------- common random numbers

def _strip(rows):
    return [{k: v for k, v in r.items() if k != "wall_s"} for r in rows]


def test_a_filters_rows_do_not_depend_on_the_other_filters(tmp_path):
    """The premise of reusing rows: a filter run's rows are the same run alone or with others
    (its stream: seed, trial and key; its data: seed and trial)."""
    exp = load(_setup(tmp_path))
    alone = replace(exp, filters=tuple(f for f in exp.filters if f.name == "ifa"))
    for k in range(3):
        both = [r for r in trial_result(exp, k, True).rows if r["filter"].startswith("ifa")]
        assert _strip(trial_result(alone, k, True).rows) == _strip(both)


def test_every_reading_sees_the_same_truth(tmp_path):
    exp = load(_setup(tmp_path))
    for run in rd.plan(exp)[1:]:
        for k in range(3):
            a, b = trial_data(exp, k), trial_data(run.exp, k)
            assert np.array_equal(np.asarray(a[1]), np.asarray(b[1]))
            assert np.array_equal(np.asarray(a[2]), np.asarray(b[2]))


def test_reused_rows_equal_a_full_run_of_the_reading_bit_for_bit(tmp_path):
    exp = load(_setup(tmp_path))
    out = tmp_path / "out"
    run_experiment(exp, out)
    runs = rd.plan(exp)
    inverse = next(r for r in runs if r.name == "brightness_inverse")
    assert set(inverse.changed) == {"ifa@20", "ifa@40"}
    ex = LocalExecutor(1)
    got = rd.run_reading(inverse, out, ex)
    full = tmp_path / "full"
    run_experiment(inverse.exp, full)
    assert (got / "trials.csv").read_bytes() == (full / "trials.csv").read_bytes()
    # and the rows of the filter it leaves alone are the config's
    pf = [l for l in (out / "trials.csv").read_text().splitlines() if ",pf@" in l]
    assert pf and all(l in (got / "trials.csv").read_text().splitlines() for l in pf)
    assert rd.up_to_date(inverse, out)


# ---------------------------------------------------------------- robustness and multiplicity

@pytest.mark.parametrize("outcomes, pair, line", [
    ([("a", "differs")] * 1 + [("b", "differs"), ("c", "differs")], False,
     "differs under all 3 readings"),
    ([("pfbench", "differs"), ("a", "reproduced"), ("b", "differs"), ("c", "reproduced")],
     False, "reproduced only under: a, c; differs under the rest"),
    ([("pfbench", "differs"), ("a", "inconclusive"), ("b", "differs"), ("c", "inconclusive"),
      ("d", "differs")], False, "inconclusive under 2 of 5 (a, c); differs under the rest"),
    ([("pfbench", "reproduced"), ("a", "reproduced"), ("b", "reproduced"), ("c", "differs")],
     False, "differs under 1 of 4 (c); reproduced under the rest"),
    ([("pfbench", "same"), ("a", "unresolved")], True,
     "in the paper's order only under: pfbench; unresolved under the rest"),
    ([("pfbench", "inconclusive")], False, "inconclusive under the one reading"),
])
def test_the_robustness_wording(outcomes, pair, line):
    assert rd.summary(outcomes, pair) == line


def _claim(value, se, paper=3.0, n=200):
    est = Estimate(value, se, n)
    return rd.JudgedClaim(f"cell:x:{value}:{se}", "cell", "X", 50, "RMSE", paper, value,
                          value - 2 * se, value + 2 * se, Claim(paper, est, Margin(0.1, None, "")))


def test_more_readings_never_make_a_verdict_less_cautious():
    """One Holm family over claims x readings: a claim judged beside more readings is never
    'reproduced' where beside fewer it was not, and 'differs' only where beside fewer its
    difference was shown too ('differs', or 'reproduced', which a verdict says first when both
    hold: ours within the margin yet apart from the paper's value)."""
    rng = np.random.default_rng(3)
    strength = {"reproduced": 2, "differs": 1, "inconclusive": 0}
    checked = 0
    for _ in range(30):
        base = [_claim(3.0 + rng.normal(0, 0.25), abs(rng.normal(0.08, 0.04)) + 1e-3)
                for _ in range(6)]
        few = rd.judge({"pfbench": base})
        more = {"pfbench": base}
        for j in range(int(rng.integers(1, 8))):
            more[f"r{j}"] = [_claim(3.0 + rng.normal(0, 0.3), abs(rng.normal(0.08, 0.04)) + 1e-3)
                             for _ in range(6)]
        many = [r for r in rd.judge(more) if r["reading"] == "pfbench"]
        for a, b in zip(few, many):
            assert a["claim"] == b["claim"]
            if b["verdict"] == "reproduced":
                assert a["verdict"] == "reproduced", (a, b)
            if b["verdict"] == "differs":
                assert a["verdict"] in ("differs", "reproduced"), (a, b)
            checked += strength[a["verdict"]] > strength[b["verdict"]]
    assert checked > 0          # some verdicts did become more cautious


def test_a_claim_the_readings_leave_alone_counts_once():
    base = [_claim(3.02, 0.05)]
    one = rd.judge({"pfbench": base})
    same = rd.judge({"pfbench": base, "a": list(base), "b": list(base)})
    assert {r["level"] for r in same} == {one[0]["level"]}
    assert {r["verdict"] for r in same} == {one[0]["verdict"]}


# ---------------------------------------------------------------- the command line

def test_run_readings_end_to_end(tmp_path):
    config = _setup(tmp_path)
    out = tmp_path / "res"
    r = runner.invoke(app, ["run", str(config), "--out", str(out), "--no-figures",
                            "--readings"])
    assert r.exit_code == 0, r.output
    lines = rd.robustness_lines(out)
    # 4 cells, 2 pairs (one per N)
    assert len(lines) == 6 and all(f"- {line}" in " ".join(r.output.split()) or
                                   line.split(":")[0] in r.output for line in lines)
    assert lines[0].startswith("PF N=20 RMSE (paper 4.00): ")
    rows = rd.read_csv(out)
    assert {r["reading"] for r in rows} == {"pfbench", "brightness_inverse", "all_neff"}
    assert len(rows) == 3 * 6
    for name in ("brightness_inverse", "all_neff"):
        assert (out / "readings" / name / "trials.csv").is_file()
    md = (out / "readings.md").read_text()
    assert "## Robustness" in md and "Holm" in md and "`all_neff`" in md
    # the PF's rows under the reading that leaves the PF alone are the config's: its cells agree
    pf = [r for r in rows if r["claim"] == "cell:pf@20:rmse_mean"]
    assert len({r["ours"] for r in pf if r["reading"] != "all_neff"}) == 1
    # the report: the robustness lines first, the readings table on demand
    from types import SimpleNamespace
    from pfbench import report_html
    shown = rd.report_lines(out, "res/readings.md")
    assert [f"- {line}" for line in lines] == shown[2:2 + len(lines)]
    assert "<details><summary>Every claim under every reading</summary>" in shown
    html = report_html._readings(SimpleNamespace(folder=out))
    assert html["lines"] == lines and len(html["rows"]) == len(lines)
    # again: every reading is up to date, nothing runs
    before = tree(out / "readings")
    r = runner.invoke(app, ["run", str(config), "--out", str(out), "--no-figures",
                            "--readings", "brightness_inverse"])
    assert r.exit_code == 0, r.output
    assert "up to date" in r.output and tree(out / "readings") == before


@pytest.mark.parametrize("paper, flag, words", [
    (_paper_with(set={"filters.nope.brightness": "inverse"}), [], "no filter 'nope'"),
    (_paper_with(set={"filters.ifa.brightness": "sideways"}), [], "filters.ifa.brightness"),
    (_paper_with(set={"filters.*.nokey": 1}), [], "no filter of"),
    (PAPER, ["--readings", "nope"], "no reading 'nope'"),
    (_paper_with(choice="nope"), [], "no choice with the id 'nope'"),
])
def test_bad_readings_are_one_line_exit_2_and_nothing_is_written(tmp_path, paper, flag, words):
    config = _setup(tmp_path, paper)
    out = tmp_path / "res"
    r = runner.invoke(app, ["run", str(config), "--out", str(out), "--no-figures"]
                      + (flag or ["--readings"]))
    assert words in one_line_exit_2(r)
    assert not out.exists()


def test_tables_regenerates_keeps_and_checks_the_readings(tmp_path):
    from pfbench import regen
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    _setup(configs)
    args = ["tables", "--configs", str(configs), "--results", str(results), "--no-figures"]
    r = runner.invoke(app, args + ["--readings"])
    assert r.exit_code == 0, r.output
    folder = results / "tiny"
    assert len(rd.robustness_lines(folder)) == 6
    held = tree(folder / "readings")
    # a regeneration without --readings keeps them: the config's trials are the same
    r = runner.invoke(app, args)
    assert r.exit_code == 0, r.output
    assert tree(folder / "readings") == held and (folder / "readings.md").is_file()
    # the check re-runs each committed reading's trials and compares them too
    ex = LocalExecutor(1)
    with_readings = regen.check_config(configs / "tiny.yaml", results, ex)
    assert with_readings.ok and with_readings.identical
    import shutil
    shutil.rmtree(folder / "readings")
    alone = regen.check_config(configs / "tiny.yaml", results, ex)
    assert with_readings.compared == 3 * alone.compared
