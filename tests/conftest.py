import os
import sys
from pathlib import Path

import pytest

from pfbench.config import Params

ROOT = Path(__file__).resolve().parents[1]
os.environ.setdefault("COLUMNS", "200")


@pytest.fixture
def write_config(tmp_path):
    """Write YAML text to a file under tmp_path and return its path."""
    def _write(text: str, name: str = "exp.yaml") -> Path:
        p = tmp_path / name
        p.write_text(text)
        return p
    return _write


SMALL = """\
seed: 0
trials: 6
scenario:
  name: ungm
  steps: 30
  process_noise_var: 1.0
filters:
  pf:
    label: PF
    particles: [20, 40]
  ukf:
    label: UKF
"""


def default_params(schema: dict, **over) -> Params:
    """A schema's defaults with some keys overridden, as validated parameters."""
    p = {k: key.default for k, key in schema.items()}
    p.update(over)
    return Params(p)


TINY = SMALL.replace("trials: 6", "trials: 4").replace("steps: 30", "steps: 10")


def one_line_exit_2(res) -> str:
    """The one line a CLI run gave for bad input (exit status 2, no traceback)."""
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    lines = [l for l in res.output.strip().splitlines() if l.strip()]
    assert len(lines) == 1, res.output
    assert lines[0].startswith("pfbench: error: ")
    return lines[0]


def tree(folder: Path) -> dict:
    """Every file under folder with its bytes (to show nothing changed)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


def _say(config):
    """A function that writes a line to the terminal even while a test's output is captured."""
    def say(text: str) -> None:
        tr = config.pluginmanager.getplugin("terminalreporter")
        cap = config.pluginmanager.getplugin("capturemanager")
        if tr is None:
            return
        if cap is None:
            tr.write_line(text)
            return
        # pytest's capture, suspended and resumed, sets sys.stdout and sys.stderr to its own:
        # a test that swapped them (typer's CliRunner) gets its own back
        out, err = sys.stdout, sys.stderr
        try:
            with cap.global_and_fixture_disabled():
                tr.write_line(text)
        finally:
            sys.stdout, sys.stderr = out, err
    return say


def pytest_configure(config):
    from numba.core import event

    from ._kernels import CompileReporter
    event.register("numba:compile", CompileReporter(_say(config)).listener())


def pytest_collection_finish(session):
    """Before the first test of a run of the suite (tests from more than ten files): the kernels
    of the committed configs the numba cache lacks compile on every core, visibly
    (tests/_kernels.py). A run of a few files compiles only what its tests use."""
    if (session.config.option.collectonly
            or len({item.path for item in session.items}) <= 10):
        return
    from ._kernels import warm
    tr = session.config.pluginmanager.getplugin("terminalreporter")
    if tr is not None:
        tr.write_line("")
    warm(_say(session.config))
