"""Usage errors of the command line: one line on stderr and exit status 2."""
from __future__ import annotations

import subprocess
import sys

import pytest
from typer.testing import CliRunner

from pfbench.cli import app

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


@pytest.mark.parametrize("url", ["not a url", "tcp://", "http://[::1", "tcp://256.1.1.1:99999"])
def test_a_scheduler_that_is_not_an_address(tmp_path, write_config, url):
    pytest.importorskip("distributed")
    cfg = write_config(TINY)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--executor", "dask",
                                                "--scheduler", url, "--out",
                                                str(tmp_path / "o")]))
    assert "--scheduler" in line
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("args,words", [
    (["--trials", "0"], ["--trials", ">=", "pfbench run --help"]),   # the bound, as click words it
    (["--workers", "0"], ["--workers"]),
    (["--seed", "-1"], ["--seed"]),
    (["--trials", "1e9"], ["--trials"]),
    (["--no-such-flag"], ["--no-such-flag"]),
])
def test_usage_errors_are_one_line(tmp_path, write_config, args, words):
    cfg = write_config(TINY)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o"),
                                                *args]))
    for w in words:
        assert w in line, line
    assert not (tmp_path / "o").exists()


def test_usage_errors_are_one_line_from_the_console_script(tmp_path):
    res = subprocess.run([sys.executable, "-m", "pfbench.cli", "run", "x.yaml", "--trials", "0"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert res.returncode == 2
    assert res.stderr.strip().count("\n") == 0 and res.stderr.startswith("pfbench: error: ")


@pytest.mark.parametrize("z", ["inf", "nan", "-1", "0"])
def test_tables_check_needs_a_finite_positive_z(tmp_path, z):
    line = one_line_exit_2(runner.invoke(app, ["tables", "--check", "--z", z, "--results",
                                                str(tmp_path)]))
    assert "--z" in line


def test_validate_of_a_sweep_applies_set(write_config):
    cfg = write_config(TINY + "sweep:\n  seed: [1, 2]\n")
    res = runner.invoke(app, ["validate", str(cfg), "--set", "trials=3,4,5"])
    assert res.exit_code == 0, res.output
    assert "6 cells" in res.output and "3 trials each" in res.output
    one_line_exit_2(runner.invoke(app, ["validate", str(cfg), "--set", "trials=0"]))


def test_a_line_number_is_printed_as_written_not_as_an_emoji(write_config):
    # rich turns ':100:' into an emoji unless told not to
    cfg = write_config("#\n" * 99 + "trails: 5\nscenario: {name: ungm}\nfilters: {ukf: {}}\n")
    line = one_line_exit_2(runner.invoke(app, ["validate", str(cfg)]))
    assert f"{cfg}:100: trails: unknown key" in line
