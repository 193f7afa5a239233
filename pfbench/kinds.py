"""Scenario kinds: what a trial of each kind scores, what its rows hold, what it draws.

A scenario declares its kind (``KIND = "scalar"``) and a filter the kind it runs on
(``FilterType.kind``); a filter runs on every scenario of its kind. The kind decides what a
filter's output must hold and how a trial is scored:

- ``scalar``: a one-dimensional state. ``simulate`` gives (x (T+1,), y (T+1,)); a filter returns
  ``xhat`` (T+1,), the posterior mean, and ``lik_evals_per_step``; optionally ``ess``,
  ``resampled``, ``div_l1``, ``distinct`` (T+1,) and ``underflow_steps``; a filter that carries a
  variance ``pvar`` (T+1,), the posterior variance (its NEES), and one that predicts the
  measurement ``innov`` and ``innov_var`` (T+1,), the innovation and its predicted variance (its
  NIS). The NEES and NIS columns are in an experiment's trials file when one of its filters
  declares it reports them (``FilterType.reports``), and the NEES column too when the
  experiment computes the per-step diagnostic ``nees`` (a particle filter's ``pvar``, the
  variance of its particles): pfbench.diagnostics.reported_metrics.
- ``slam``: a robot's pose (x, y, heading) and a landmark map. The truth has ``pose`` (T+1, 3); a
  filter returns ``pose`` (T+1, 3), ``lm_est`` (M, 2), ``lm_seen`` (M,), ``lik_evals_per_step``;
  optionally ``ess``, ``resampled``, ``div_l1``, ``distinct``, ``lm_trace`` per observation (K,)
  and the counts ``underflow_steps``, ``association_errors``, ``dropped_frac``,
  ``map_duplicates``.
- ``localization``: a robot's pose on a known map, with convergence and kidnapping. A filter
  returns ``pose`` (T+1, 3) and ``lik_evals_per_step``; optionally ``ess``, ``resampled``, ``n``
  (T,) and ``underflow_steps``.

Each optional output is optional on its own: a metric whose output is missing is NaN. What a
filter run returns is checked against its kind's ``outputs`` (``check_outputs``) before it is
scored: a mapping, each output of its shape, real numbers, each count a finite number >= 0.

Nothing here branches on a kind's name: the runner, the memory estimate, the figures and the
contract ask the kind.
"""
from __future__ import annotations

import math
import numbers
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .diag import NAMES as DIAGNOSTIC_NAMES
from .metrics import (CONVERGE_HOLD_STEPS, METRICS, localization_metrics, slam_metrics,
                      trial_metrics)
from .protocols import KIND_NAMES
from .traces import LocalizationTracer, SlamTracer

# The columns every trials file starts and ends with; a kind's metrics go between. A trial row
# holds only what the seed determines: the wall time goes to the timings file (pfbench.store).
ID_COLUMNS = ("trial", "filter", "label", "particles")
END_COLUMNS = ("crc",)

# The diagnostics every particle filter's rows carry, whatever the kind.
_DIAGNOSTICS = ("mean_ess", "resample_count", "underflow_steps", "diverged_steps",
                "lik_evals_per_step")


@dataclass(frozen=True)
class Kind:
    """A kind of scenario.

    metrics : the metric columns its trials fill (the others are NaN)
    headline : the metrics every filter run must give as finite numbers on the kind's scenarios
        with their default settings (the plug-in contract checks it)
    score(model, truth, out) -> the row of metrics of one filter run
    unit : the unit of its errors, for axis labels ('' for a scalar state)
    particle_floats(params, scenario_params) : float64s a particle holds while its filter runs
    step_floats(scenario_params) : float64s a step of the scenario's truth and data take
    figures : the name of the function of pfbench.plots that draws an experiment of this kind
        (exp, rows, traces, folder) -> paths, or None
    tracer : what a trial keeps for those figures while it runs (pfbench.traces), or None
    outputs(model, truth, data) -> {name: (shape, required)}: what a filter run returns; shape
        a tuple of sizes (None: any size) for an array, COUNT for a number (check_outputs)
    diagnostics : the per-step diagnostics its filter runs can compute, names of
        pfbench.diagnostics.NAMES (which of them a run computes: pfbench.diagnostics.plan)
    figure_diagnostics : those its figures read, from the trials whose trace ``tracer`` keeps
    reported : metrics of pfbench.metrics.METRICS its trials have only in an experiment with a
        filter that reports them (``FilterType.reports``) or that computes them as a per-step
        diagnostic (the particle filters' nees): the consistency metrics

    A trials file of the kind has the columns ``columns``: the trial, the filter run, its
    ``metrics`` (in the order of pfbench.metrics.METRICS) and the row's checksum.
    """

    name: str
    description: str
    metrics: tuple[str, ...]
    headline: tuple[str, ...]
    score: Callable
    unit: str
    particle_floats: Callable
    step_floats: Callable
    figures: str | None = None
    tracer: object | None = None
    outputs: Callable | None = None
    diagnostics: tuple[str, ...] = ()
    figure_diagnostics: tuple[str, ...] = ()
    reported: tuple[str, ...] = ()

    def __post_init__(self):
        unknown = [m for m in self.metrics + self.reported if m not in METRICS]
        if unknown:
            raise ValueError(f"kind {self.name}: no metric {unknown[0]}")
        unknown = [d for d in self.diagnostics + self.figure_diagnostics
                   if d not in DIAGNOSTIC_NAMES or d not in self.diagnostics]
        if unknown:
            raise ValueError(f"kind {self.name}: no diagnostic {unknown[0]}")
        # the metrics in METRICS' order, so that every file of a kind has one column order
        object.__setattr__(self, "metrics", tuple(m for m in METRICS if m in self.metrics))

    @property
    def columns(self) -> tuple[str, ...]:
        return (*ID_COLUMNS, *self.metrics, *END_COLUMNS)

    def row(self, model, truth, out, metrics: tuple[str, ...] | None = None) -> dict:
        """The kind's metrics of one filter run (``score``'s row, the kind's columns only, or
        ``metrics``: an experiment's, ``experiment_metrics``)."""
        row = self.score(model, truth, out)
        return {m: row.get(m, math.nan) for m in (self.metrics if metrics is None else metrics)}

    def experiment_metrics(self, reports) -> tuple[str, ...]:
        """The metric columns of an experiment of this kind whose filters report ``reports``
        (FilterType.reports, over its filters): the kind's metrics and those of ``reported``
        that a filter reports, in METRICS' order."""
        extra = set(self.reported) & set(reports)
        return tuple(m for m in METRICS if m in self.metrics or m in extra)


def _slam_particle_floats(params, scen: dict) -> int:
    m = (params.get("max_landmarks") if params else None) or 3 * len(scen.get("landmarks", ()))
    return 16 + 12 * max(int(m), 1) * 2


# An output that is one number (a count or a fraction): finite and >= 0.
COUNT = "count"


def _size(obj, name: str, axis: int = 0):
    """The size of axis ``axis`` of the array ``obj.name`` (None when it has none)."""
    a = getattr(obj, name, None)
    shape = getattr(a, "shape", None)
    return shape[axis] if shape is not None and len(shape) > axis else None


def _scalar_outputs(model, truth, data) -> dict:
    T1 = len(truth)
    return {"xhat": ((T1,), True), "lik_evals_per_step": (COUNT, True),
            "ess": ((T1,), False), "resampled": ((T1,), False), "div_l1": ((T1,), False),
            "distinct": ((T1,), False), "underflow_steps": (COUNT, False),
            "pvar": ((T1,), False), "innov": ((T1,), False), "innov_var": ((T1,), False)}


def _slam_outputs(model, truth, data) -> dict:
    T1, M, K = _size(truth, "pose"), _size(model, "landmarks"), _size(data, "obs_n")
    out = {"pose": ((T1, 3), True), "lm_est": ((M, 2), True), "lm_seen": ((M,), True),
           "lik_evals_per_step": (COUNT, True)}
    out.update({k: ((K,), False) for k in ("ess", "resampled", "div_l1", "distinct",
                                           "lm_trace")})
    out.update({k: (COUNT, False) for k in ("underflow_steps", "association_errors",
                                            "dropped_frac", "map_duplicates")})
    return out


def _localization_outputs(model, truth, data) -> dict:
    T1 = _size(truth, "pose")
    T = None if T1 is None else T1 - 1
    return {"pose": ((T1, 3), True), "lik_evals_per_step": (COUNT, True),
            "ess": ((T,), False), "resampled": ((T,), False), "n": ((T,), False),
            "underflow_steps": (COUNT, False)}


def _shape_text(shape) -> str:
    return "(" + ", ".join("any" if n is None else str(n) for n in shape) + ("," if len(shape) == 1
                                                                          else "") + ")"


def _what(v) -> str:
    """A short description of a value that is not what was expected."""
    if isinstance(v, np.ndarray):
        return f"an array of shape {v.shape} and dtype {v.dtype}"
    text = repr(v)
    return f"{type(v).__name__} {text if len(text) <= 40 else text[:37] + '...'}"


def check_outputs(kind: Kind, out, model, truth, data) -> dict:
    """``out``, a filter run's outputs, checked against ``kind.outputs``: the outputs it names as
    numpy arrays (or floats, for counts), the others as they came. A ValueError says in one line
    what was expected and what came."""
    spec = kind.outputs(model, truth, data)
    if not isinstance(out, Mapping):
        needed = ", ".join(k for k, (_, required) in spec.items() if required)
        raise ValueError(f"returned {_what(out)}, expected a dict of outputs ({needed}, ...)")
    clean = dict(out)
    for name, (shape, required) in spec.items():
        if name not in out:
            if required:
                raise ValueError(f"returned no '{name}' (its outputs: "
                                 f"{', '.join(map(str, out)) or 'none'})")
            continue
        v = out[name]
        if shape == COUNT:
            if isinstance(v, np.ndarray) and v.shape == ():
                v = v[()]
            try:
                ok = (isinstance(v, numbers.Real) and not isinstance(v, (bool, np.bool_))
                      and math.isfinite(float(v)) and float(v) >= 0)
            except (TypeError, ValueError, OverflowError):
                ok = False
            if not ok:
                raise ValueError(f"'{name}' is {_what(v)}, expected a finite number >= 0")
            clean[name] = float(v)
            continue
        try:
            a = np.asarray(v)
        except Exception:       # a ragged list, an object that is no array
            a = None
        if a is None or a.dtype.kind not in "biuf":
            raise ValueError(f"'{name}' is {_what(v)}, expected an array of real numbers of "
                             f"shape {_shape_text(shape)}")
        if a.ndim != len(shape) or any(n is not None and n != m for n, m in zip(shape, a.shape)):
            raise ValueError(f"'{name}' has shape {a.shape}, expected {_shape_text(shape)}")
        clean[name] = a
    return clean


SCALAR = Kind(
    "scalar", "a one-dimensional state-space model x_t = f(x_{t-1}, t) + w_t, y_t = h(x_t, t) + v_t",
    metrics=("rmse", "mse", "diversity_l1", "distinct_frac") + _DIAGNOSTICS,
    headline=("rmse", "mse", "diverged_steps", "lik_evals_per_step"),
    score=lambda model, truth, out: trial_metrics(truth, out),
    unit="",
    particle_floats=lambda params, scen: 24,
    step_floats=lambda scen: 8,
    outputs=_scalar_outputs, diagnostics=("distinct_frac", "diversity_l1", "nees"),
    reported=("nees", "nis"))

SLAM = Kind(
    "slam", "a robot's pose and a map of point landmarks, estimated together",
    metrics=("rmse", "mse", "heading_rmse", "position_error", "heading_error", "final_error",
             "landmark_error", "association_errors", "dropped_frac", "map_duplicates",
             "diversity_l1", "distinct_frac") + _DIAGNOSTICS,
    headline=("rmse", "position_error", "heading_rmse", "diverged_steps"),
    score=lambda model, truth, out: slam_metrics(truth.pose, model.landmarks, out),
    unit="m",
    particle_floats=_slam_particle_floats,
    step_floats=lambda scen: 16 + 3 * len(scen.get("landmarks", ())),
    figures="slam_figures", tracer=SlamTracer(), outputs=_slam_outputs,
    diagnostics=("distinct_frac", "diversity_l1", "lm_trace"), figure_diagnostics=("lm_trace",))

LOCALIZATION = Kind(
    "localization", "a robot's pose on a known map: global localization, tracking and kidnapping",
    metrics=("rmse", "mse", "heading_rmse", "position_error", "heading_error", "x_error",
             "y_error", "final_error", "error_at_step", "converged", "converge_step",
             "recovery_steps", "recovery_failures", "mean_particles") + _DIAGNOSTICS,
    headline=("rmse", "x_error", "y_error", "final_error", "diverged_steps"),
    score=lambda model, truth, out: localization_metrics(
        truth.pose, out, model.bound, model.kidnaps, model.score_from, model.report_step,
        model.area, getattr(model, "hold", CONVERGE_HOLD_STEPS)),
    unit="m",
    particle_floats=lambda params, scen: 64,
    step_floats=lambda scen: 16 + 3 * len(scen.get("beacons", ())),
    figures="localization_figures", tracer=LocalizationTracer(),
    outputs=_localization_outputs)

KINDS = {k.name: k for k in (SCALAR, SLAM, LOCALIZATION)}
# the names the plug-in checks know (pfbench.protocols, below the registries this module reads)
assert tuple(KINDS) == KIND_NAMES, "pfbench.protocols.KIND_NAMES must name every kind"


def kind_of(scenario: str) -> Kind:
    """The kind of the registered scenario ``scenario``."""
    from .scenarios import SCENARIOS    # the registry: every scenario and filter, numba's types
    return KINDS[SCENARIOS[scenario].KIND]
