"""Paper files: read strictly, found beside a config or with --papers, the package holds no
paper's values, and the docs' example paper (docs/how-to/papers.md) is judged by pfbench run."""
import re

import pytest
import yaml
from typer.testing import CliRunner

from pfbench import papers
from pfbench.cli import app
from pfbench.config import load
from pfbench.regen import config_files, is_sweep
from pfbench.schema import ConfigError

from .conftest import ROOT, one_line_exit_2

runner = CliRunner()
PAPERS = ROOT / "configs" / "papers"

GOOD = """\
paper: smith2024
citation: Smith and Lee, 2024
tables:
  table2:
    caption: UNGM, RMSE
    quantities:
      rmse_mean: {title: RMSE, metric: rmse, stat: mean}
    values:
      - {label: PF, particles: 100, rmse_mean: 4.9}
      - {label: UKF, rmse_mean: 7.5}
    ranking: [rmse_mean]
findings:
  - "PF: {smith_ungm:pf@100:rmse_mean:ci}"
"""


@pytest.fixture(autouse=True)
def _no_search_folders():
    yield
    papers.search_folders([])


def test_every_paper_file_reads_and_every_config_finds_its_table():
    keys = sorted(p.stem for p in PAPERS.glob("*.yaml"))
    assert keys == ["afsa2014", "asrl2008", "ifa2021", "plaza2009", "review2007", "sspf2008"]
    for key in keys:
        paper = papers.read(PAPERS / f"{key}.yaml")
        assert paper.key == key and paper.citation and paper.about
    named = set()
    for path in config_files(ROOT / "configs"):
        if not is_sweep(path):
            exp = load(path)
            if exp.paper:
                named.add(exp.paper)
                assert exp.reference.key == exp.paper
                assert (exp.reported is not None) == (exp.table is not None)
    assert named == {"afsa2014", "asrl2008", "ifa2021", "plaza2009", "review2007", "sspf2008"}
    # the runs behind the values, where the paper states them
    ifa = papers.read(PAPERS / "ifa2021.yaml").tables
    assert (ifa["table1"].runs, ifa["table3"].runs) == (None, 20)


def _numbers(node, out):
    if isinstance(node, dict):
        for v in node.values():
            _numbers(v, out)
    elif isinstance(node, list):
        for v in node:
            _numbers(v, out)
    elif isinstance(node, float) and not isinstance(node, bool):
        out.add(node)
    return out


def test_the_package_holds_no_paper_values_and_points_outside_nowhere():
    values = set()
    for p in PAPERS.glob("*.yaml"):
        values |= _numbers(yaml.safe_load(p.read_text()), set())
    # the printed values with four or more significant digits are specific enough to search for
    specific = {f"{v:.4g}" for v in values if not v.is_integer()
                and len(f"{v:.4g}".replace(".", "").lstrip("0")) >= 4}
    assert len(specific) >= 30
    sources = {p: p.read_text() for p in (ROOT / "pfbench").rglob("*.py")}
    # one pattern for every value (a regex per value and file took seconds)
    anyone = re.compile(rf"(?<![\d.])(?:{'|'.join(map(re.escape, specific))})(?!\d)")
    hits = [(m.group(), str(p)) for p, src in sources.items() for m in anyone.finditer(src)]
    assert not hits, hits
    docs = {p: p.read_text() for p in [ROOT / "README.md", *(ROOT / "docs").rglob("*.md")]}
    for p, src in {**sources, **docs}.items():
        for word in ("PAPERS.md", "DESIGN.md", "../shared"):
            assert word not in src, (p, word)


@pytest.mark.parametrize("edit, where, message", [
    (("  table2:\n    caption", "  table2:\n    captoin: x\n    caption"), 5,
     r"tables\.table2\.captoin: unknown key \(did you mean 'caption'\?\)"),
    (("rmse_mean: 4.9}", "rmse_men: 4.9}"), 9,
     r"rmse_men: no quantity 'rmse_men' \(did you mean 'rmse_mean'\?\)"),
    (("metric: rmse,", "metric: rmes,"), 7, r"metric: expected one of .* \(did you mean 'rmse'"),
    (("rmse_mean: 7.5}", "rmse_mean: [9, 2]}"), 10, r"a range is \[low, high\]"),
    (("ranking: [rmse_mean]", "ranking: [rmse]"), 11, r"ranking\[0\]: no quantity 'rmse'"),
    (("paper: smith2024", "paper: smith2025"), 1, r"the key is the file's name"),
    (("{smith_ungm:pf@100:rmse_mean:ci}", "{smith_ungm:pf@100}"), 13, r"is not a reference"),
    (("caption: UNGM, RMSE", "caption: UNGM, RMSE\n    runs: 0"), 6,
     r"tables\.table2\.runs: expected an integer >= 1, got 0"),
    (("- {label: UKF, rmse_mean: 7.5}", "- {label: PF, particles: 100, rmse_mean: 7.5}"), 10,
     r"a second row for PF at 100 particles"),
])
def test_a_broken_paper_file_is_named_with_its_line_and_key(tmp_path, edit, where, message):
    path = tmp_path / "smith2024.yaml"
    assert edit[0] in GOOD
    path.write_text(GOOD.replace(*edit))
    with pytest.raises(ConfigError, match=message) as exc:
        papers.read(path)
    assert str(exc.value).startswith(f"{path}:{where}: "), str(exc.value)


def test_a_factor_or_cell_note_names_rows_and_columns_that_exist(tmp_path):
    path = tmp_path / "smith2024.yaml"
    path.write_text(GOOD.replace("    ranking:", "    factors:\n      - {quantity: rmse_mean, "
                                 "from: PF, to: UFK}\n    ranking:"))
    with pytest.raises(ConfigError, match=r"factors\[0\]\.to: no row label 'UFK' \(did you "
                                          "mean 'UKF'"):
        papers.read(path)


def test_a_config_finds_its_paper_beside_it_or_in_a_papers_folder(tmp_path):
    cfg = tmp_path / "work" / "smith_ungm.yaml"
    cfg.parent.mkdir()
    cfg.write_text("paper: smith2024\ntable: table2\ntrials: 2\nscenario: {name: ungm}\n"
                   "filters:\n  pf: {label: PF, particles: 100}\n")
    with pytest.raises(ConfigError, match="no paper file smith2024.yaml in .*--papers"):
        load(cfg)
    elsewhere = tmp_path / "mine"
    elsewhere.mkdir()
    (elsewhere / "smith2024.yaml").write_text(GOOD)
    papers.search_folders([elsewhere])
    assert load(cfg).reported.caption == "UNGM, RMSE"
    papers.search_folders([])
    (cfg.parent / "papers").mkdir()
    (cfg.parent / "papers" / "smith2024.yaml").write_text(GOOD.replace("UNGM, RMSE", "beside"))
    assert load(cfg).reported.caption == "beside"
    # a table the paper does not have
    cfg.write_text(cfg.read_text().replace("table: table2", "table: table3"))
    with pytest.raises(ConfigError, match="has no table 'table3' .did you mean 'table2'"):
        load(cfg)
    # the command line: one line, exit 2, for a missing folder or a broken paper file
    line = one_line_exit_2(runner.invoke(app, ["validate", str(cfg), "--papers",
                                               str(tmp_path / "nope")]))
    assert "--papers" in line and "no such folder" in line
    (cfg.parent / "papers" / "smith2024.yaml").write_text(GOOD.replace("caption:", "captoin:"))
    line = one_line_exit_2(runner.invoke(app, ["validate", str(cfg)]))
    assert "smith2024.yaml:5: tables.table2.captoin: unknown key" in line


def _readme_example() -> tuple[str, str]:
    """The paper file and config of the docs' page on paper files."""
    section = (ROOT / "docs/how-to/papers.md").read_text()
    blocks = re.findall(r"```yaml\n(.*?)```", section, re.S)
    paper = next(b for b in blocks if b.startswith("# papers/"))
    config = next(b for b in blocks if not b.startswith("# papers/"))
    return paper, config


def test_the_readmes_paper_is_judged_by_run_and_report(tmp_path):
    paper, config = _readme_example()
    name = re.match(r"# papers/(\w+)\.yaml", paper).group(1)
    stem = re.match(r"# (\w+)\.yaml", config).group(1)
    (tmp_path / "papers").mkdir()
    (tmp_path / "papers" / f"{name}.yaml").write_text(paper)
    cfg = tmp_path / f"{stem}.yaml"
    cfg.write_text(config)
    results = tmp_path / "results"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(results / stem), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert name in res.output
    table = (results / stem / "table.csv").read_text()
    assert "verdict_rmse_mean" in table
    assert any(word in table for word in ("reproduced", "differs", "inconclusive"))
    res = runner.invoke(app, ["report", "--configs", str(tmp_path), "--results", str(results)])
    assert res.exit_code == 0, res.output
    report = (results / "REPORT.md").read_text()
    mine = report.split(f"## `{name}`")[1]
    finding = next(line for line in mine.splitlines() if line.startswith("- The PF at N = 100"))
    assert re.fullmatch(r"- The PF at N = 100 averages [\d.]+ \[[\d.]+, [\d.]+\] against the "
                        r"paper's 4\.9\.", finding), finding
    # a finding that names a run the config does not have: the report cannot be built, so it
    # fails in one line naming the paper file's line, and writes nothing
    before = (results / "REPORT.md").read_bytes()
    (tmp_path / "papers" / f"{name}.yaml").write_text(paper.replace("pf@100", "pf@101"))
    res = runner.invoke(app, ["report", "--configs", str(tmp_path), "--results", str(results)])
    line = one_line_exit_2(res)
    n = paper.splitlines().index(next(l for l in paper.splitlines() if "pf@100" in l)) + 1
    assert f"{name}.yaml:{n}: findings[0]: " in line
    assert "no filter run 'pf@101' in smith_ungm (did you mean 'pf@100'?)" in line
    assert (results / "REPORT.md").read_bytes() == before


def test_a_paper_file_too_large_is_refused_without_being_read_whole(tmp_path, monkeypatch):
    import pathlib

    from pfbench.errors import UserError
    from pfbench.yamlio import MAX_YAML_BYTES
    whole = pathlib.Path.read_bytes

    def read_bytes(self):
        assert self.name != "smith2024.yaml", "the oversized paper file was read whole"
        return whole(self)
    monkeypatch.setattr(pathlib.Path, "read_bytes", read_bytes)
    (tmp_path / "papers").mkdir()
    big = tmp_path / "papers" / "smith2024.yaml"
    with open(big, "wb") as fh:           # sparse: no disk, and never read into memory
        fh.truncate(MAX_YAML_BYTES + 1)
    cfg = tmp_path / "c.yaml"
    cfg.write_text("paper: smith2024\nscenario: {name: ungm}\nfilters: {ukf: {}}\n")
    with pytest.raises(UserError, match="larger than"):
        load(cfg)


def test_a_table_headline_is_read_and_a_bad_one_named(tmp_path):
    """A table's headline: one sentence whose references are parsed as a finding's; a brace that
    is not a reference, or a headline that is not text, is named with its key."""
    from pfbench.papers import _parse_bytes
    base = ("paper: p\ncitation: c\ntables:\n  t1:\n    caption: x\n    quantities:\n"
            "      q: {title: RMSE, metric: rmse}\n")
    p = _parse_bytes((base + "    headline: PF {a:pf@1:rmse_mean:ci} as said\n").encode(),
                     tmp_path / "p.yaml")
    h = p.tables["t1"].headline
    assert h.text == "PF {a:pf@1:rmse_mean:ci} as said" and h.refs[0].ci
    assert _parse_bytes(base.encode(), tmp_path / "p.yaml").tables["t1"].headline is None
    for bad, says in (("headline: PF {a:pf}", "is not a reference"),
                      ("headline: [1, 2]", "expected a sentence")):
        with pytest.raises(ConfigError, match=says) as exc:
            _parse_bytes((base + f"    {bad}\n").encode(), tmp_path / "p.yaml")
        assert "tables.t1.headline" in str(exc.value)
