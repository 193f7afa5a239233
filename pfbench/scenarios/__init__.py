"""Scenario registry: name -> module with NAME, DESCRIPTION, SCHEMA and build(params)."""
from . import linear_gaussian, ungm, upf_gamma

SCENARIOS = {m.NAME: m for m in (ungm, upf_gamma, linear_gaussian)}
