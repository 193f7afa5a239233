"""Names and paths: a config's name is one plain folder name, and nothing outside the folders a
user named is ever removed or replaced."""
from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from pfbench import fsutil
from pfbench.cli import app
from pfbench.errors import UserError

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


@pytest.mark.parametrize("name", ["../../escaped", "/tmp/pfbench-abs-escape", "a/b", "..", ".",
                                  ".hidden", "x\\y", "x\x00y", " spaced "])
def test_a_name_must_be_one_plain_folder_name(tmp_path, write_config, name, monkeypatch):
    monkeypatch.chdir(tmp_path)
    cfg = write_config(f"name: {json.dumps(name)}\n" + TINY)
    before = sorted(p.name for p in tmp_path.parent.iterdir())
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg)]))
    assert "name" in line
    assert not (tmp_path / "results").exists()
    assert sorted(p.name for p in tmp_path.parent.iterdir()) == before
    assert not Path("/tmp/pfbench-abs-escape").exists()
    # the same through --set, and in validate
    cfg = write_config(TINY, "plain.yaml")
    one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--set", f"name={json.dumps(name)}"]))
    one_line_exit_2(runner.invoke(app, ["validate", str(cfg), "--set",
                                         f"name={json.dumps(name)}"]))


def test_tables_never_removes_a_folder_outside_results(tmp_path):
    configs = tmp_path / "configs"
    configs.mkdir()
    outside = tmp_path / "precious"
    outside.mkdir()
    (outside / "keep.txt").write_text("mine")
    (configs / "evil.yaml").write_text("name: ../precious\n" + TINY)
    res = runner.invoke(app, ["tables", "--configs", str(configs), "--results",
                              str(tmp_path / "results")])
    line = one_line_exit_2(res)
    assert "evil.yaml" in line and "name" in line
    assert (outside / "keep.txt").read_text() == "mine"


def test_remove_and_replace_refuse_paths_outside_their_owner_and_links(tmp_path):
    results = tmp_path / "results"
    results.mkdir()
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "f").write_text("x")
    (results / "link").symlink_to(outside)
    for bad in (outside, results / "link", results / ".." / "outside", results):
        with pytest.raises(UserError, match="does not lie inside"):
            fsutil.remove_tree(bad, results)
    stage = results / "stage"
    stage.mkdir()
    with pytest.raises(UserError):
        fsutil.replace_tree(stage, results / "link", results)
    assert (outside / "f").read_text() == "x"
    # inside, it works
    (results / "old").mkdir()
    (results / "old" / "a").write_text("old")
    (stage / "a").write_text("new")
    fsutil.replace_tree(stage, results / "old", results)
    assert (results / "old" / "a").read_text() == "new" and not stage.exists()


def test_sweep_cell_names_stay_plain_folder_names():
    from pfbench.sweep import _cell_name
    for values in ({"name": "../../x"}, {"a.b": "/etc"}, {"k": "." * 300}, {"k": ".."}):
        name = _cell_name(values)
        assert fsutil.name_problem(name) is None, name
