"""Ctrl-C is seen at once, even while a kernel holds the interpreter: a run's trials go to a child
process (one worker included); the message names the filter runs that were running."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import numpy as np
import pandas as pd
import pytest

from .conftest import ROOT

# what the worker processes do: runs of one worker fork theirs here too (tests/conftest.py)
pytestmark = pytest.mark.worker_processes

# A `pfbench run` whose filter 'stuck' spins in a numba loop (holding the interpreter) from its
# third call on, that is from trial 2 of a one-worker run.
SCRIPT = """
import sys
import numba
import numpy as np
from pfbench.filters import FILTERS, FilterType

@numba.njit
def spin(x):
    while x >= 0.0:         # never false: x grows to inf
        x = x * 1.0000001 + 1.0
    return x

CALLS = [0]

def run(model, y, params, particles, state, diag=True):
    CALLS[0] += 1
    if CALLS[0] >= 3:
        spin(1.0)
    return {"xhat": np.zeros(y.size), "lik_evals_per_step": 1.0}

spin(-1.0)      # compiled here, before the run
FILTERS["stuck"] = FilterType("stuck", "spins from its third run on", {}, run, particles=False)
from pfbench.cli import main
sys.argv = ["pfbench", *sys.argv[1:]]
main()
"""

CONFIG = """\
seed: 1
trials: 5
scenario: {name: ungm, steps: 20}
filters:
  ukf: {label: UKF}
  stuck: {label: Stuck}
"""


def test_ctrl_c_in_a_long_kernel_stops_the_run_at_once_naming_what_ran(tmp_path):
    script = tmp_path / "stuck_run.py"
    script.write_text(SCRIPT)
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(CONFIG)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    # a shell's background job starts with SIGINT ignored, which Python keeps: give the run the
    # default disposition a terminal would
    proc = subprocess.Popen([sys.executable, str(script), "run", str(cfg), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    partial = out / "trials.partial.csv"
    deadline = time.monotonic() + 300
    try:
        while time.monotonic() < deadline and proc.poll() is None:
            if partial.exists() and len(partial.read_text().splitlines()) == 1 + 2 * 2:
                break
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()[0]
        time.sleep(1.0)                          # trial 2 is spinning now
        assert proc.poll() is None
        os.killpg(proc.pid, signal.SIGINT)      # what Ctrl-C in a terminal sends
        output, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, output
    assert "Traceback" not in output
    assert "(it was running: filter run 'stuck' (type stuck), trial 2)" in output, output
    assert "2 of 5 trials saved" in output and "--resume" in output, output
    kept = pd.read_csv(partial)
    assert sorted(set(kept["trial"])) == [0, 1]


def _sleeper(model, y, params, particles, state, diag=True):
    time.sleep(3600)


def _prompt(model, y, params, particles, state, diag=True):
    return {"xhat": np.zeros(y.size), "lik_evals_per_step": 1.0}


def test_a_contract_probe_that_never_finishes_is_stopped_and_named(monkeypatch):
    from pfbench import contract
    from pfbench.filters import FILTERS, FilterType
    configs = ROOT / "configs"
    monkeypatch.setitem(FILTERS, "sleeper", FilterType("sleeper", "never returns", {}, _sleeper,
                                                       particles=False))
    monkeypatch.setitem(FILTERS, "prompt", FilterType("prompt", "returns at once", {}, _prompt,
                                                      particles=False))
    stuck = contract.Probe("sleeper", "ungm", ["filter sleeper"])
    fine = contract.Probe("prompt", "ungm", ["filter prompt"])
    monkeypatch.setattr(contract, "probes", lambda: ([stuck, fine], []))
    n, problems = contract.check_all(configs, timeout=3.0)      # the prompt probe: well within
    assert n == 2
    assert problems == ["filter sleeper: sleeper on ungm did not finish within 3 s "
                        "(--probe-timeout); stopped"]


def test_list_check_refuses_a_bad_probe_timeout():
    from typer.testing import CliRunner

    from pfbench.cli import app

    from .conftest import one_line_exit_2
    for bad in ("0", "-1", "nan", "inf"):
        line = one_line_exit_2(CliRunner().invoke(app, ["list", "--check", "--probe-timeout",
                                                        bad]))
        assert "--probe-timeout" in line


CHECK_SCRIPT = """
import os, sys, time
import numpy as np
from pfbench import contract
from pfbench.filters import FILTERS, FilterType

def run(model, y, params, particles, state, diag=True):
    open(os.environ["MARK"], "w").close()
    time.sleep(3600)

FILTERS["sleeper"] = FilterType("sleeper", "never returns", {}, run, particles=False)
contract.probes = lambda: ([contract.Probe("sleeper", "ungm", ["filter sleeper"])], [])
from pfbench.cli import main
sys.argv = ["pfbench", *sys.argv[1:]]
main()
"""


def test_ctrl_c_in_list_check_names_the_probe_and_exits_130(tmp_path):
    script = tmp_path / "check.py"
    script.write_text(CHECK_SCRIPT)
    proc = subprocess.Popen([sys.executable, str(script), "list", "--check", "--configs",
                             str(ROOT / "configs")], stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True,
                            env={**os.environ, "PYTHONPATH": str(ROOT),
                                 "MARK": str(tmp_path / "sleeping")},
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        deadline = time.monotonic() + 300
        while not (tmp_path / "sleeping").exists() and time.monotonic() < deadline:
            assert proc.poll() is None, proc.communicate()[0]
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()[0]
        os.killpg(proc.pid, signal.SIGINT)
        output, _ = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, output
    assert "Traceback" not in output
    assert ("pfbench: interrupted in the probe sleeper on ungm (filter sleeper); 0 of 1 probes "
            "done") in output, output
