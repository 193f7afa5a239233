"""The per-step diagnostics a filter run can be asked for: ``Diag`` flags, their ``NAMES``
(the metric columns, or SLAM's ``lm_trace``, and the filter output holding each) and ``flags``,
which reads a filter's ``diag`` argument. What an experiment computes, and why, is decided in
pfbench.diagnostics; this module sits below the filters, which read their ``diag`` with it.
"""
from __future__ import annotations

import enum


class Diag(enum.IntFlag):
    """The per-step diagnostics a filter run is asked for (flags; 0: none)."""
    NONE = 0
    DISTINCT = 1        # distinct_frac: output 'distinct'
    DIVERSITY = 2       # diversity_l1: output 'div_l1'
    MAP_TRACE = 4       # lm_trace (SLAM): output 'lm_trace'
    SPREAD = 8          # nees (scalar PFs): output 'pvar', the particles' posterior variance


ALL = Diag.DISTINCT | Diag.DIVERSITY | Diag.MAP_TRACE | Diag.SPREAD

# name (a metric column, or the SLAM output lm_trace) -> (flag, the filter output holding it)
NAMES = {"distinct_frac": (Diag.DISTINCT, "distinct"),
         "diversity_l1": (Diag.DIVERSITY, "div_l1"),
         "lm_trace": (Diag.MAP_TRACE, "lm_trace"),
         "nees": (Diag.SPREAD, "pvar")}

# What the ``diagnostics`` config key takes besides a list of NAMES.
KEY_WORDS = ("auto", "all")


def flags(diag) -> Diag:
    """A filter's ``diag`` argument as flags: True (the older boolean form) asks for every
    diagnostic, False for none, an int for its flags."""
    if isinstance(diag, bool) or diag is None:
        return ALL if diag else Diag.NONE
    return Diag(int(diag) & int(ALL))


def outputs_of(names) -> set[str]:
    """The filter outputs that hold the diagnostics ``names``."""
    return {NAMES[n][1] for n in names}
