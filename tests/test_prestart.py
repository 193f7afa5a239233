"""The worker the command line starts before it reads its config (pfbench.runner.prestart): a
run of one worker takes it, with the same trials, bit for bit, as a worker forked later; a run
that needs another count, or none, stops it."""
from __future__ import annotations

import subprocess
import sys

import pytest
from typer.testing import CliRunner

import pfbench
import pfbench.runner as runner_mod
from pfbench.cli import app

from .conftest import TINY

# what the worker processes do: runs of one worker fork theirs here too (tests/conftest.py)
pytestmark = pytest.mark.worker_processes

runner = CliRunner()

# runs pfbench.cli.main in a process of its own with ARGS, noting what the run claimed, and
# prints: whether it took the early worker, the workers left alive, the exit status
_SCRIPT = """
import multiprocessing, sys
import pfbench.runner as R
claims = []
original = R._claim
def claim(exp, workers):
    got = original(exp, workers)
    claims.append(got is not None)
    return got
R._claim = claim
sys.argv = ["pfbench"] + {args!r}
before = []
original_prestart = R.prestart
def prestart():
    before.append("typer" in sys.modules or "rich" in sys.modules)
    original_prestart()
R.prestart = prestart
import pfbench.__main__ as M
M._end = lambda code: sys.exit(M._status(code))     # (it would end the process here)
from pfbench.{entry} import main
try:
    main()
    code = 0
except SystemExit as e:
    code = e.code
print(claims, len(R._EARLY), len(multiprocessing.active_children()), code)
print(before[:1])  # the first start: later ones find it started
"""


def _main(tmp_path, *args, entry="cli"):
    res = subprocess.run([sys.executable, "-c", _SCRIPT.format(args=list(args), entry=entry)],
                         capture_output=True, text=True, cwd=tmp_path, timeout=600)
    lines = res.stdout.strip().splitlines()
    return res, lines[-2] if len(lines) >= 2 else ""


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_the_console_script_starts_it_before_the_command_line_is_imported(tmp_path,
                                                                          write_config):
    """The console script (pfbench.__main__.main) forks a run's worker before it imports typer
    and rich, and the run takes it; pfbench.cli.main starts it after them."""
    import tomllib
    from pathlib import Path
    project = tomllib.loads((Path(__file__).parents[1] / "pyproject.toml").read_text())
    assert project["project"]["scripts"]["pfbench"] == "pfbench.__main__:main"
    cfg = write_config(TINY)
    res, last = _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "o"), "--no-figures",
                      entry="__main__")
    assert last == "[True] 0 0 0", (last, res.stderr)
    assert res.stdout.strip().splitlines()[-1] == "[False]", res.stdout
    res, last = _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "p"), "--no-figures")
    assert last == "[True] 0 0 0", (last, res.stderr)
    assert res.stdout.strip().splitlines()[-1] == "[True]", res.stdout
    version = subprocess.run([sys.executable, "-m", "pfbench", "--version"], capture_output=True,
                             text=True, cwd=tmp_path, timeout=600)
    assert version.returncode == 0 and version.stdout.split()[-1] == pfbench.__version__, \
        version
    bad = subprocess.run([sys.executable, "-m", "pfbench", "run"], capture_output=True,
                         text=True, cwd=tmp_path, timeout=600)
    assert bad.returncode == 2 and bad.stderr == (
        "pfbench: error: Missing argument 'config'. (see 'pfbench run --help')\n"), bad.stderr


def test_a_run_takes_the_early_worker_and_gets_the_same_trials(tmp_path, write_config):
    cfg = write_config(TINY)
    res, last = _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "early"),
                      "--no-figures")
    assert last == "[True] 0 0 0", (last, res.stderr)
    later = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "later"),
                                "--no-figures"])
    assert later.exit_code == 0, later.output
    assert ((tmp_path / "early" / "trials.csv").read_bytes()
            == (tmp_path / "later" / "trials.csv").read_bytes())


@pytest.mark.slow     # the early worker, in a fresh interpreter: a speed feature, checked in CI
def test_a_run_of_two_workers_stops_it_and_forks_its_own(tmp_path, write_config):
    cfg = write_config(TINY)
    res, last = _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "two"),
                      "--no-figures", "--workers", "2")
    assert last == "[False] 0 0 0", (last, res.stderr)


@pytest.mark.slow     # the early worker, in a fresh interpreter: a speed feature, checked in CI
def test_a_command_that_runs_nothing_stops_it(tmp_path, write_config):
    res, last = _main(tmp_path, "run", str(tmp_path / "no-such.yaml"))
    assert last == "[] 0 0 2", (last, res.stderr)
    assert res.stderr.startswith("pfbench: error: ") and res.stderr.count("\n") == 1
    cfg = write_config(TINY)
    _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "o"), "--no-figures")
    res, last = _main(tmp_path, "run", str(cfg), "--out", str(tmp_path / "o"), "--no-figures")
    assert last == "[] 0 0 0" and "is up to date" in res.stderr, (last, res.stderr)


def test_an_experiment_that_cannot_be_sent_gets_a_forked_worker():
    runner_mod.prestart()
    try:
        assert len(runner_mod._EARLY) == 1
        pool = runner_mod._EARLY[0][0]
        assert runner_mod._claim(lambda: None, 1) is None       # no pickle of it
        assert runner_mod._EARLY == [] and all(p.exitcode is not None for p in pool.procs)
    finally:
        runner_mod.discard_prestarted()


_ENDING = """
import atexit, sys, threading, time
import pfbench.__main__ as M
atexit.register(lambda: print("exit function ran", end=" "))
print("buffered", end=" ")
if "thread" in sys.argv:
    def late():
        time.sleep(0.3)
        print("thread done", end=" ")
    threading.Thread(target=late).start()
M._end(int(sys.argv[1]) if sys.argv[1].isdigit() else sys.argv[1])
print("never")
"""


def test_the_console_script_ends_its_process_as_the_interpreter_would():
    """pfbench.__main__._end ends the process once the exit functions have run and the output
    is flushed, with sys.exit's status (a message: 1, on stderr); a thread that is not a daemon
    is waited for, as the interpreter would."""
    def end(*args):
        return subprocess.run([sys.executable, "-c", _ENDING, *args], capture_output=True,
                              text=True, timeout=600)
    res = end("3")
    assert (res.returncode, res.stdout) == (3, "buffered exit function ran "), res
    res = end("0")
    assert (res.returncode, res.stdout, res.stderr) == (0, "buffered exit function ran ", "")
    res = end("no such file")
    assert (res.returncode, res.stderr) == (1, "no such file\n"), res
    res = end("2", "thread")
    assert res.returncode == 2 and "thread done" in res.stdout, res
    assert "exit function ran" in res.stdout and "never" not in res.stdout
