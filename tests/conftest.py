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
