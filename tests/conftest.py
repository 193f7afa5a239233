import os
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
