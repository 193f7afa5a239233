"""Filter registry. Each filter family declares its types in its own module, beside its kernel:
name, the scenario kind it runs on, its keys (schema), rules across keys, and ``run``
(``pfbench.filters.FilterType``, defined in pfbench.protocols). pfbench's own register through
the entry-point group ``pfbench.filters``, as a plug-in's do (pyproject.toml)."""
from __future__ import annotations

import time

_t0 = time.perf_counter()

from . import (dead_reckoning, ekf, fastslam, kalman, mcl, mixture_mcl, pf, sspf_field,  # noqa: E402
               swarm_pf, ukf, upf)
from ..plugins import FILTER_GROUP, check_filter, discover  # noqa: E402
from ..protocols import FilterType  # noqa: E402,F401  (part of this package's API)

# Seconds spent importing the kernels: numba compiles them here (first run) or loads them from the
# disk cache. Reported in meta.json as kernel_load_s, apart from the trials' wall time.
LOAD_SECONDS = time.perf_counter() - _t0

# (type a config names, scenario kind) -> the filter type that implements it for that kind
KIND_TYPES = {("sspf", "localization"): "sspf_field"}

# pfbench's own filter types, in the order pfbench list shows them; each is an entry point of
# group pfbench.filters (pyproject.toml).
BUILTIN = {f.name: f for f in (
    pf.PF, ukf.UKF, pf.PFMH, upf.UPF, upf.SSPF, swarm_pf.FA_PF, swarm_pf.IFA_PF, swarm_pf.BA_PF,
    swarm_pf.PSO_PF, swarm_pf.AFSA_PF, fastslam.FASTSLAM, mcl.MCL, mixture_mcl.MIXTURE_MCL,
    sspf_field.SSPF_FIELD, ekf.EKF, kalman.KF, dead_reckoning.DEAD_RECKONING)}

# Every filter type: pfbench's own and the plug-ins', found through entry points.
FILTERS = discover(FILTER_GROUP, check_filter, BUILTIN)
