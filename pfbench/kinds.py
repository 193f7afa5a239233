"""Scenario kinds: what a trial of each kind scores, what its rows hold, what it draws.

A scenario declares its kind (``KIND = "scalar"``) and a filter the kind it runs on
(``FilterType.kind``); a filter runs on every scenario of its kind. The kind decides what a
filter's output must hold and how a trial is scored:

- ``scalar``: a one-dimensional state. ``simulate`` gives (x (T+1,), y (T+1,)); a filter returns
  ``xhat`` (T+1,), the posterior mean, and ``lik_evals_per_step``.
- ``slam``: a robot's pose (x, y, heading) and a landmark map. The truth has ``pose`` (T+1, 3); a
  filter returns ``pose`` (T+1, 3), ``lm_est`` (M, 2), ``lm_seen`` (M,), ``ess`` and
  ``resampled`` per observation.
- ``localization``: a robot's pose on a known map, with convergence and kidnapping. A filter
  returns ``pose`` (T+1, 3), ``ess`` (T,), ``resampled`` (T,), optionally ``n`` (T,).

Nothing here branches on a kind's name: the runner, the memory estimate, the figures and the
contract ask the kind.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .metrics import (CONVERGE_HOLD_STEPS, METRICS, localization_metrics, slam_metrics,
                      trial_metrics)
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

    def __post_init__(self):
        unknown = [m for m in self.metrics if m not in METRICS]
        if unknown:
            raise ValueError(f"kind {self.name}: no metric {unknown[0]}")
        # the metrics in METRICS' order, so that every file of a kind has one column order
        object.__setattr__(self, "metrics", tuple(m for m in METRICS if m in self.metrics))

    @property
    def columns(self) -> tuple[str, ...]:
        return (*ID_COLUMNS, *self.metrics, *END_COLUMNS)

    def row(self, model, truth, out) -> dict:
        """The kind's metrics of one filter run (``score``'s row, the kind's columns only)."""
        row = self.score(model, truth, out)
        return {m: row[m] for m in self.metrics}


def _slam_particle_floats(params, scen: dict) -> int:
    m = (params.get("max_landmarks") if params else None) or 3 * len(scen.get("landmarks", ()))
    return 16 + 12 * max(int(m), 1) * 2


SCALAR = Kind(
    "scalar", "a one-dimensional state-space model x_t = f(x_{t-1}, t) + w_t, y_t = h(x_t, t) + v_t",
    metrics=("rmse", "mse", "diversity_l1", "distinct_frac") + _DIAGNOSTICS,
    headline=("rmse", "mse", "diverged_steps", "lik_evals_per_step"),
    score=lambda model, truth, out: trial_metrics(truth, out),
    unit="",
    particle_floats=lambda params, scen: 24,
    step_floats=lambda scen: 8)

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
    figures="slam_figures", tracer=SlamTracer())

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
    figures="localization_figures", tracer=LocalizationTracer())

KINDS = {k.name: k for k in (SCALAR, SLAM, LOCALIZATION)}


def kind_of(scenario: str) -> Kind:
    """The kind of the registered scenario ``scenario``."""
    from .scenarios import SCENARIOS
    return KINDS[SCENARIOS[scenario].KIND]
