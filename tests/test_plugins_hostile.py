"""Hostile plug-ins cannot take pfbench down: an import that exits or raises KeyboardInterrupt,
a scenario named like a built-in, a schema that redeclares a common key: each is left out and
named, and the rest keeps working."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from .test_plugins import _dist

ROOT = Path(__file__).resolve().parents[1]

CONFIG = """\
trials: 2
scenario:
  name: ungm
  steps: 5
filters:
  pf:
    particles: 20
"""


@pytest.fixture
def hostile(tmp_path):
    site = tmp_path / "site"
    site.mkdir()
    _dist(site, "exits", "[pfbench.filters]\nexits = exits_mod:F\n",
          {"exits_mod.py": "import sys\nsys.exit(3)\n"})
    _dist(site, "interrupts", "[pfbench.scenarios]\ninterrupts = interrupts_mod\n",
          {"interrupts_mod.py": "raise KeyboardInterrupt\n"})
    _dist(site, "thief", "[pfbench.scenarios]\nungm = thief_mod\n",
          {"thief_mod.py": "from pfbench.scenarios.ungm import *\nNAME = 'ungm'\n"})
    _dist(site, "redeclares", "[pfbench.filters]\nmypf = redeclares_mod:MYPF\n",
          {"redeclares_mod.py": "from pfbench.filters.types import FilterType\n"
           "from pfbench.filters.pf import PF\n"
           "from pfbench.schema import Key\n"
           "MYPF = FilterType('mypf', 'a pf', {**PF.schema, 'particles': Key('int', 7, 'n')},"
           " PF.run)\n"})
    return site


def _pfbench(site, *args, cwd):
    env = dict(os.environ, PYTHONPATH=f"{site}{os.pathsep}{ROOT}", COLUMNS="200")
    return subprocess.run([sys.executable, "-m", "pfbench.cli", *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=600)


def test_hostile_plugins_are_left_out_and_named_and_the_built_ins_keep_working(hostile,
                                                                             tmp_path):
    (tmp_path / "exp.yaml").write_text(CONFIG)
    res = _pfbench(hostile, "list", cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    text = res.stdout + res.stderr
    assert "plug-in 'exits'" in text and "SystemExit" in text
    assert "plug-in 'interrupts'" in text and "KeyboardInterrupt" in text
    assert "plug-in 'ungm'" in text and "taken" in text
    assert "plug-in 'mypf'" in text and "'particles'" in text
    res = _pfbench(hostile, "validate", "exp.yaml", cwd=tmp_path)
    assert res.returncode == 0, res.stderr          # the built-in ungm is still usable
    res = _pfbench(hostile, "validate", "exp.yaml", "--set", "filters.pf.type=mypf",
                   cwd=tmp_path)
    assert res.returncode == 2 and "'particles'" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
