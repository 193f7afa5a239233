"""Scenario registry: name -> module with NAME, DESCRIPTION, SCHEMA and build(params)."""
from . import linear_gaussian, ungm

SCENARIOS = {m.NAME: m for m in (ungm, linear_gaussian)}
