"""Scenario registry: name -> module with NAME, KIND ('scalar', 'slam' or 'localization'), DESCRIPTION, SCHEMA,
build(params) -> model, simulate(model, state) -> (truth, data), and optionally
resolve(params, base_dir) -> params (load files the scenario names, at validation)."""
from . import beacon_field, landmark_world, linear_gaussian, ungm, upf_gamma, waypoint_course

SCENARIOS = {m.NAME: m for m in (ungm, upf_gamma, linear_gaussian, waypoint_course, landmark_world,
                                 beacon_field)}
