"""The models layer (pfbench.models): the model types every kind's filters read, built by the
scenarios; a new beacon world is a world file and a few lines of a scenario module."""
from __future__ import annotations

import math
import textwrap
import types

import numpy as np
import pytest

HALL = """\
# a 20 m x 12 m hall with four beacons, one in each corner
area: [20.0, 12.0]
start: [3.0, 3.0, 0.0]
beacons:
  - [1.0, 1.0]
  - [19.0, 1.0]
  - [19.0, 11.0]
  - [1.0, 11.0]
waypoints:
  - [16.0, 3.0]
  - [16.0, 9.0]
  - [4.0, 9.0]
  - [3.0, 3.0]
"""

# The whole scenario module of a second beacon world: its name, kind, description and the
# defaults that differ from beacon_field's; beacon_field's resolve, build and simulate.
HALL_MODULE = """\
from pfbench.scenarios.beacon_field import build, resolve, schema, simulate
NAME = "beacon_hall"
KIND = "localization"
DESCRIPTION = "a 20 m x 12 m hall with four beacons"
SCHEMA = schema(world="hall.yaml", steps=40, sensor="range_bearing", max_range_m=15.0,
                initial="known")
"""


def _hall_module():
    mod = types.ModuleType("beacon_hall")
    exec(textwrap.dedent(HALL_MODULE), mod.__dict__)
    return mod


def test_a_second_beacon_world_is_a_world_file_and_a_few_lines(tmp_path, monkeypatch):
    import pfbench.api as api
    from pfbench.models.field import FieldModel
    from pfbench.plugins import check_scenario
    from pfbench.rng import state_from_seed
    from pfbench.scenarios import SCENARIOS

    (tmp_path / "hall.yaml").write_text(HALL)
    hall = _hall_module()
    assert len(HALL_MODULE.splitlines()) <= 8
    assert check_scenario("beacon_hall", hall) is None
    monkeypatch.setitem(SCENARIOS, "beacon_hall", hall)
    monkeypatch.chdir(tmp_path)
    res = api.run_experiment({"name": "hall", "seed": 3, "trials": 2,
                              "scenario": {"name": "beacon_hall"},
                              "filters": {"mcl": {"particles": 300}}}, figures=False)
    model = hall.build(res.experiment.scenario_params)
    assert isinstance(model, FieldModel)
    assert model.beacons.tolist() == [[1.0, 1.0], [19.0, 1.0], [19.0, 11.0], [1.0, 11.0]]
    assert model.area.tolist() == [20.0, 12.0] and model.steps == 40
    assert model.sensor == 1 and model.sense[0] == 15.0        # range_bearing, 15 m
    truth, _ = hall.simulate(model, state_from_seed(np.random.SeedSequence(5)))
    assert truth.pose.shape == (41, 3) and truth.pose[0].tolist() == [3.0, 3.0, 0.0]
    assert len(res.trials) == 2
    assert all(math.isfinite(v) for v in res.trials["position_error"])


@pytest.mark.parametrize("defaults,words", [
    ({"steps": 0}, "steps"),
    ({"sensor": "sonar"}, "sensor"),
    ({"no_such_key": 1}, "no key 'no_such_key'"),
])
def test_a_beacon_world_with_a_default_its_key_refuses_is_refused(defaults, words):
    from pfbench.scenarios.beacon_field import schema
    with pytest.raises(ValueError, match=words):
        schema(**defaults)


def test_the_models_are_where_the_filters_read_them():
    """The SLAM and localization model types live in pfbench.models; the scenarios that build
    them and the old names there are the same objects."""
    from pfbench.models.field import FieldData, FieldModel
    from pfbench.models.slam import CourseData, SlamModel
    from pfbench.scenarios import beacon_field, landmark_world, waypoint_course
    assert beacon_field.FieldModel is FieldModel and beacon_field.FieldData is FieldData
    assert waypoint_course.SlamModel is SlamModel and landmark_world.CourseData is CourseData
    for cls in (FieldModel, FieldData, SlamModel, CourseData):
        assert cls.__module__.startswith("pfbench.models.")
