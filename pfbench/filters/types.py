"""What a filter type declares: its name, the kind of scenario it runs on, its keys and its run.
The record itself lives in pfbench.protocols (below the filters and the registries); it is
importable from here, where a filter module or a plug-in looks for it."""
from __future__ import annotations

from ..protocols import (FILTER_COMMON, NEEDS, FilterType, _model_has,  # noqa: F401
                         declared, provided)

__all__ = ["FILTER_COMMON", "NEEDS", "FilterType", "declared", "provided"]
