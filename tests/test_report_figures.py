"""The HTML report's figures, kept once drawn (pfbench.report_html.figures_key): a report written
again, or checked, from the same results by the same code draws none of them, and any change of
what they are drawn from draws them again."""
from __future__ import annotations

import pytest

from pfbench import report_html, tablecache
from pfbench.config import load
from pfbench.runner import run_experiment

from .conftest import TINY


@pytest.fixture
def setup(tmp_path, monkeypatch):
    """(configs, results) of one tiny experiment, a cache folder of the test's own, and the list
    of the results folders whose figures were drawn."""
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    (configs / "plain.yaml").write_text(TINY)
    monkeypatch.chdir(tmp_path)
    exp = load(configs / "plain.yaml")
    run_experiment(exp, results / exp.name, traces=False)
    where = tmp_path / "cache"
    monkeypatch.setattr(tablecache, "folder", lambda: where)
    drawn = []
    original = report_html._draw_figures

    def draw(e, into):
        drawn.append(e.name)
        return original(e, into)
    monkeypatch.setattr(report_html, "_draw_figures", draw)
    return configs, results, drawn, where


def _figures(results):
    return sorted(p.relative_to(results).as_posix()
                  for p in (results / "report" / "figures").rglob("*.svg"))


def test_a_report_written_again_draws_no_figure_and_holds_the_same_bytes(setup):
    configs, results, drawn, where = setup
    report_html.write(configs, results)
    assert drawn == ["plain"] and len(list(where.glob("*.figures.pkl"))) == 1
    before = {p: p.read_bytes() for p in (results / "report").rglob("*") if p.is_file()}
    assert any(p.suffix == ".svg" for p in before)
    _, differ = report_html.write(configs, results)
    assert drawn == ["plain"] and differ == []
    assert {p: p.read_bytes() for p in (results / "report").rglob("*") if p.is_file()} == before
    assert report_html.write(configs, results, check=True)[1] == [] and drawn == ["plain"]


@pytest.mark.parametrize("change", ["a file of the folder", "matplotlib's version",
                                    "the package's code"])
def test_what_the_figures_are_drawn_from_draws_them_again(setup, monkeypatch, change):
    configs, results, drawn, _ = setup
    report_html.write(configs, results)
    names = _figures(results)
    if change == "a file of the folder":
        (results / "plain" / "notes.txt").write_text("a note")
    elif change == "matplotlib's version":
        original = tablecache.library_version
        monkeypatch.setattr(tablecache, "library_version",
                            lambda p: "0.0" if p == "matplotlib" else original(p))
    else:
        monkeypatch.setattr(tablecache, "code_digest", lambda: "another")
    report_html.write(configs, results)
    assert drawn == ["plain", "plain"] and _figures(results) == names


def test_a_figure_of_the_folder_itself_is_not_an_input(setup):
    configs, results, drawn, _ = setup
    report_html.write(configs, results)
    (results / "plain" / "figures").mkdir(exist_ok=True)
    (results / "plain" / "figures" / "rmse.png").write_bytes(b"another drawing")
    report_html.write(configs, results)
    assert drawn == ["plain"]


@pytest.mark.parametrize("damage", [b"", b"not zlib", b"x\x9c\x03\x00\x00\x00\x00\x01"])
def test_a_damaged_entry_draws_them_again(setup, damage):
    configs, results, drawn, where = setup
    report_html.write(configs, results)
    names = _figures(results)
    (entry,) = where.glob("*.figures.pkl")
    entry.write_bytes(damage)
    report_html.write(configs, results)
    assert drawn == ["plain", "plain"] and _figures(results) == names
    report_html.write(configs, results)             # kept again
    assert drawn == ["plain", "plain"]


def test_a_cache_folder_that_cannot_be_written_draws_every_time(setup, monkeypatch):
    configs, results, drawn, where = setup
    where.parent.mkdir(exist_ok=True)
    blocker = where.parent / "blocker"
    blocker.write_text("a file, not a folder")
    monkeypatch.setattr(tablecache, "folder", lambda: blocker / "cache")
    report_html.write(configs, results)
    report_html.write(configs, results)
    assert drawn == ["plain", "plain"] and _figures(results)


def test_the_same_configs_read_through_another_path_draw_nothing(setup):
    """The key holds what the figures are drawn from, not where the config lies: a report of the
    same results from the configs' absolute path, then their relative one, draws them once."""
    from pathlib import Path
    configs, results, drawn, _ = setup
    report_html.write(configs.resolve(), results)
    report_html.write(Path("configs"), Path("results"))
    assert drawn == ["plain"]


def test_the_status_says_which_figures_are_drawn_and_which_kept(setup, tmp_path):
    configs, results, drawn, _ = setup
    said = []
    report_html.build(configs, results, tmp_path / "a", status=said.append)
    report_html.build(configs, results, tmp_path / "b", status=said.append)
    assert [s for s in said if "figures" in s] == [
        "drawing the figures of plain (1 of 1)",
        "the figures of plain (1 of 1): as drawn before"]
    assert drawn == ["plain"]
