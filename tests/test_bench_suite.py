"""pfbench bench (pfbench.benchmarks.suite): every option is checked before anything is timed,
from the Python API as from the command line; the C reference is run as named."""
import json
import os

import numpy as np
import pytest
from typer.testing import CliRunner

from pfbench.benchmarks import suite
from pfbench.benchmarks.c_reference import c_lines, c_rows
from pfbench.cli import app
from pfbench.errors import UserError

from .conftest import one_line_exit_2, tree

runner = CliRunner()
PART_FUNCTIONS = ("ungm_bench", "costs_bench", "fastslam_bench", "afsa_bench", "mcl_bench",
                  "peers_bench", "run_path_bench", "limit_bench")


@pytest.fixture
def untimed(monkeypatch):
    """Every part replaced by one that fails the test if it is ever called."""
    def never(*args, **kwargs):
        raise AssertionError("a part was timed")
    for name in PART_FUNCTIONS:
        monkeypatch.setattr(suite, name, never)


def _program(folder, name, body, mode=0o755):
    path = folder / name
    path.write_text("#!/bin/sh\n" + body + "\n")
    path.chmod(mode)
    return path


def test_bad_options_are_refused_before_anything_is_timed(untimed, tmp_path):
    plain = tmp_path / "plain"
    plain.write_text("not a program\n")
    plain.chmod(0o644)
    ref = _program(tmp_path, "ref", "echo 0.001 1 0.001")
    cases = [
        (dict(json_path=tmp_path / "missing" / "b.json"), "--json"),
        (dict(json_path=tmp_path), "--json"),
        (dict(only=("ungm", "nosuch")), "--only nosuch"),
        (dict(only=("ungm",), c_ref=tmp_path / "no_ref"), "no such file"),
        (dict(only=("ungm",), c_ref=tmp_path), "not a file"),
        (dict(only=("ungm",), c_ref=plain), "not an executable"),
        (dict(only=("mcl",), c_ref=ref), "--only ungm"),
        (dict(only=("limit",), c_ref=ref), "--only ungm"),
        (dict(compare=tmp_path / "no.json"), "--compare"),
        (dict(compare=tmp_path), "--compare"),
    ]
    before = tree(tmp_path)
    for kwargs, words in cases:
        with pytest.raises(UserError, match=words):
            suite.run_bench(quick=True, **kwargs)
    assert tree(tmp_path) == before             # nothing written


def test_the_command_line_gives_one_line_for_them(untimed, tmp_path):
    plain = tmp_path / "plain"
    plain.write_text("x\n")
    plain.chmod(0o644)
    for args, words in ((["--c-ref", str(plain)], "not an executable"),
                        (["--json", str(tmp_path / "no" / "b.json")], "existing folder"),
                        (["--json", ""], "empty"), (["--c-ref", ""], "empty"),
                        (["--compare", ""], "empty"), (["--c-ref", "a\x00b"], "NUL")):
        line = one_line_exit_2(runner.invoke(app, ["bench", "--quick", "--only", "ungm", *args]))
        assert words in line


def test_a_c_reference_named_by_a_bare_name_is_the_one_in_this_folder(monkeypatch, tmp_path):
    """``--c-ref ungm_ref`` is ./ungm_ref, as its check found it, not a program of that name
    on PATH (nor "could not run it" after minutes of timing)."""
    _program(tmp_path, "fake_ref", 'echo "0.002 1 0.002"\necho "0.001 1 0.001"')
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("PATH", os.defpath)
    X, Y = np.zeros((2, 101)), np.ones((2, 101))

    def ungm_rows(quick, c_ref, K, min_time, reps, threads, say, console):
        return c_rows(c_ref, X, Y, (100,), 2, min_time, reps, threads)

    monkeypatch.setattr(suite, "ungm_bench", ungm_rows)
    recs = suite.run_bench(quick=True, only=("ungm",), c_ref="fake_ref", threads=1,
                           json_path="b.json")
    c = [r for r in recs if r["impl"] == "c"]
    assert [(r["mode"], r["seconds"]) for r in c] == [("single", 0.001), ("batch", 0.001)]
    run = json.loads((tmp_path / "b.json").read_text())[-1]
    assert run["command"] == "pfbench bench --quick --c-ref fake_ref --threads 1 --only ungm"


def test_a_program_that_prints_no_timings_is_one_line(tmp_path):
    data = tmp_path / "d.bin"
    data.write_bytes(b"")
    for body, words in (("echo see header for usage", "printed no timings"),
                        ("true", "printed no timings"),
                        ("exit 2", "could not run it")):
        prog = _program(tmp_path, "p", body)
        with pytest.raises(UserError, match=words):
            c_lines(prog, data, "single", 100, 1, 0.1)


def test_from_another_folder_the_parts_that_read_configs_say_so(monkeypatch, tmp_path, capsys):
    monkeypatch.chdir(tmp_path)
    recs = suite.run_bench(quick=True, only=("fastslam", "afsa", "mcl", "run"))
    assert [r["workload"] for r in recs] == ["run"]
    out = capsys.readouterr().out
    assert out.count("skipped") == 6 and "run from the repository root" in out
