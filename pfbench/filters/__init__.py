"""Filter registry: each filter type's parameters (schema), kernel runner and compatibility."""
from __future__ import annotations

import time

_t0 = time.perf_counter()

from dataclasses import dataclass
from typing import Callable

from ..resampling import SCHEMES
from ..schema import Key
from . import kalman, pf, ukf

# Seconds spent importing the kernels: numba compiles them here (first run) or loads them from the
# disk cache. Reported in meta.json as kernel_load_s, apart from the trials' wall time.
LOAD_SECONDS = time.perf_counter() - _t0


@dataclass(frozen=True)
class FilterType:
    """A filter family as configs see it.

    run(model, y, params, particles, state, diag) -> dict of traces (at least 'xhat') and
    'lik_evals_per_step'; ``particles`` is None for filters without particles.
    scenarios : names of the scenarios it runs on (None: every scalar scenario)
    """

    name: str
    description: str
    schema: dict
    run: Callable
    particles: bool = True
    scenarios: tuple | None = None


def _pf_schema():
    return {
        "resampling": Key("choice", "systematic", "resampling scheme", choices=tuple(SCHEMES)),
        "resample": Key("choice", "always", "'always': every step; 'neff': when ESS < neff_ratio * N",
                        choices=("always", "neff")),
        "neff_ratio": Key("float", 0.5, "ESS threshold as a fraction of N (resample: neff)",
                          min=0.0, max=1.0, min_exclusive=True),
        "estimate": Key("choice", "before_resampling", "state estimate: weighted mean before "
                        "resampling, or mean of the resampled particles",
                        choices=("before_resampling", "after_resampling")),
    }


def _ukf_schema():
    return {
        "alpha": Key("float", 1.0, "spread of the sigma points", min=0.0, min_exclusive=True),
        "beta": Key("float", 0.0, "prior-knowledge term of the centre weight (2 is optimal for "
                    "Gaussian priors)"),
        "kappa": Key("float", 2.0, "secondary scaling; needs L + kappa > 0 (L = 3 augmented, 1 "
                     "otherwise)"),
        "augmented": Key("bool", True, "augment the state with the process and measurement noise"),
    }


FILTERS = {
    f.name: f
    for f in (
        FilterType("pf", "bootstrap particle filter (SIR)", _pf_schema(), pf.run),
        FilterType("ukf", "unscented Kalman filter (scaled sigma points, optional noise "
                   "augmentation)", _ukf_schema(), ukf.run, particles=False),
        FilterType("kf", "exact Kalman filter (linear_gaussian scenario only)", {}, kalman.run,
                   particles=False, scenarios=("linear_gaussian",)),
    )
}
