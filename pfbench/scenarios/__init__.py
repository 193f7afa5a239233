"""Scenario registry: name -> module with NAME, KIND ('scalar', 'slam' or 'localization'), DESCRIPTION, SCHEMA,
build(params) -> model, simulate(model, state) -> (truth, data), and optionally
resolve(params, base_dir) -> params (load files the scenario names, at validation)."""
from . import (beacon_field, landmark_world, linear_gaussian, plaza, sv, ungm, upf_gamma,
               waypoint_course)

from ..plugins import SCENARIO_GROUP, check_scenario, discover
from ..protocols import register_scenarios

# pfbench's own scenarios: each module is an entry point of group pfbench.scenarios
# (pyproject.toml), as a plug-in's scenario is.
BUILTIN = {m.NAME: m for m in (ungm, upf_gamma, linear_gaussian, waypoint_course, landmark_world,
                               beacon_field, sv, plaza)}

# Every scenario: pfbench's own and the plug-ins', found through entry points.
SCENARIOS = discover(SCENARIO_GROUP, check_scenario, BUILTIN)
register_scenarios(SCENARIOS)
