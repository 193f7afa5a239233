"""World files: a broken one is named in one line."""
from __future__ import annotations

import pytest
from typer.testing import CliRunner

from pfbench.cli import app

from .conftest import one_line_exit_2
from .test_yaml import BOMB

runner = CliRunner()


WORLD = """\
area: [40.0, 40.0]
start: [5.0, 5.0, 0.0]
waypoints: [[5, 5], [35, 5], [35, 35], [5, 35]]
beacons: [[0, 0], [40, 0], [40, 40], [0, 40], [20, 20], [20, 0]]
"""
FIELD = """\
trials: 2
scenario:
  name: beacon_field
  world: world.yaml
  steps: 10
filters:
  mcl:
    particles: 50
"""


@pytest.mark.parametrize("world,words", [
    (b"area: [40.0, 40.0]\nname: \xff\xfe\n", ["world", "not UTF-8"]),
    (WORLD.replace("[40.0, 40.0]", "[forty, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "[.inf, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "[.nan, 40.0]").encode(), ["area", "finite"]),
    (WORLD.replace("[40.0, 40.0]", "{w: 1}").encode(), ["area"]),
    (BOMB.encode() + WORLD.encode(), ["world", "aliases"]),
])
def test_bad_world_files(tmp_path, world, words):
    (tmp_path / "world.yaml").write_bytes(world)
    (tmp_path / "exp.yaml").write_text(FIELD)
    for cmd in (["run", str(tmp_path / "exp.yaml"), "--out", str(tmp_path / "o")],
                ["validate", str(tmp_path / "exp.yaml")]):
        line = one_line_exit_2(runner.invoke(app, cmd))
        for w in words:
            assert w in line, line
    assert not (tmp_path / "o").exists()
