"""Each optional output of a filter run is optional on its own, for every kind: every subset of
them is checked, scored, kept for the figures and drawn, and the metrics of the outputs left out
are NaN (a count of events left out, underflow_steps, is 0), never a KeyError."""
from __future__ import annotations

import itertools
import math
import types

import numpy as np
import pandas as pd
import pytest

from pfbench.filters import FILTERS, FilterType
from pfbench.kinds import KINDS, check_outputs

from .conftest import ROOT

# every optional output of each kind, and the metric it gives (None: the figures only)
OPTIONAL = {
    "scalar": {"ess": "mean_ess", "resampled": "resample_count", "div_l1": "diversity_l1",
               "distinct": "distinct_frac", "underflow_steps": "underflow_steps",
               # the consistency outputs: their columns (nees, nis) are the kind's reported ones
               "pvar": None, "innov": None, "innov_var": None},
    "slam": {"ess": "mean_ess", "resampled": "resample_count", "div_l1": "diversity_l1",
             "distinct": "distinct_frac", "lm_trace": None, "underflow_steps": "underflow_steps",
             "association_errors": "association_errors", "dropped_frac": "dropped_frac",
             "map_duplicates": "map_duplicates"},
    "localization": {"ess": "mean_ess", "resampled": "resample_count", "n": "mean_particles",
                     "underflow_steps": "underflow_steps"},
}
T, M, K = 10, 4, 3


def _world(kind):
    """(model, truth, data, required outputs, every optional output) of a small trial."""
    if kind == "scalar":
        x = np.linspace(0.0, 1.0, T + 1)
        n = T + 1
        required = {"xhat": x + 0.5, "lik_evals_per_step": 2.0}
        model, truth, data = None, x, np.zeros(T + 1)
    else:
        pose = np.zeros((T + 1, 3))
        pose[:, 0] = np.linspace(1, 2, T + 1)
        model = types.SimpleNamespace(landmarks=np.ones((M, 2)), bound=1.0,
                                      kidnaps=np.zeros(0, np.int64), score_from=1,
                                      report_step=0, area=np.array([10.0, 10.0]), hold=2)
        truth = types.SimpleNamespace(pose=pose)
        data = types.SimpleNamespace(obs_n=np.zeros(K, np.int64), ctrl=np.zeros((T, 3)))
        required = {"pose": pose + 0.1, "lik_evals_per_step": 3.0}
        if kind == "slam":
            required.update(lm_est=np.ones((M, 2)), lm_seen=np.ones(M, bool))
        n = K if kind == "slam" else T
    full = {"ess": np.full(n, 4.0), "resampled": np.ones(n, np.int64), "n": np.full(n, 7),
            "div_l1": np.full(n, 0.5), "distinct": np.full(n, 0.25), "lm_trace": np.ones(n),
            "underflow_steps": 1, "association_errors": 0.1, "dropped_frac": 0.2,
            "map_duplicates": 2, "pvar": np.full(n, 0.5), "innov": np.full(n, 0.3),
            "innov_var": np.full(n, 0.9)}
    return model, truth, data, required, {o: full[o] for o in OPTIONAL[kind]}


@pytest.mark.parametrize("kind", sorted(OPTIONAL))
def test_the_table_names_every_optional_output_of_the_kind(kind):
    model, truth, data, required, _ = _world(kind)
    spec = KINDS[kind].outputs(model, truth, data)
    assert sorted(o for o, (_, req) in spec.items() if not req) == sorted(OPTIONAL[kind])
    assert sorted(o for o, (_, req) in spec.items() if req) == sorted(required)
    for metric in OPTIONAL[kind].values():
        assert metric is None or metric in KINDS[kind].metrics


@pytest.mark.parametrize("kind", sorted(OPTIONAL))
def test_every_subset_of_the_optional_outputs_is_scored(kind):
    k = KINDS[kind]
    model, truth, data, required, optional = _world(kind)
    names = list(optional)
    for r in range(len(names) + 1):
        for subset in itertools.combinations(names, r):
            out = check_outputs(k, {**required, **{o: optional[o] for o in subset}}, model,
                                truth, data)
            row = k.row(model, truth, out)
            assert set(row) == set(k.metrics)
            assert math.isfinite(row["rmse"]) and row["lik_evals_per_step"] > 0
            for o, metric in OPTIONAL[kind].items():
                if metric is None:
                    continue
                if o in subset:
                    assert math.isfinite(row[metric]), (subset, metric)
                elif metric == "underflow_steps":
                    assert row[metric] == 0.0, subset
                else:
                    assert math.isnan(row[metric]), (subset, metric)


# the optional outputs the figures of a kind read (traces.py, plots.py)
DRAWN = {"slam": ("ess", "lm_trace"), "localization": ("n", "ess")}
SCENARIO = {
    "slam": f"{{name: waypoint_course, world: {ROOT / 'configs/worlds/ifa_course.yaml'}, "
            "steps: 40}",
    "localization": f"{{name: beacon_field, world: {ROOT / 'configs/worlds/beacon_field.yaml'}, "
                    "steps: 12, initial: known}",
}


def _partial_filter(kind, subset):
    """A plug-in filter of ``kind`` that stands still at the start and returns the optional
    outputs of ``subset`` only."""
    def run(model, data, params, particles, state, diag=0):
        steps, obs = data.ctrl.shape[0], data.obs_n.shape[0]
        out = {"pose": np.tile(np.asarray(model.start, float), (steps + 1, 1)),
               "lik_evals_per_step": float(particles)}
        if kind == "slam":
            out.update(lm_est=np.array(model.landmarks, float),
                       lm_seen=np.ones(len(model.landmarks), bool))
        n = obs if kind == "slam" else steps
        full = {"ess": np.full(n, 3.0), "lm_trace": np.ones(n), "n": np.full(n, particles)}
        out.update({o: full[o] for o in subset})
        return out
    return run


@pytest.mark.slow
@pytest.mark.parametrize("kind", sorted(DRAWN))
def test_every_subset_of_the_drawn_outputs_is_kept_and_drawn(kind, monkeypatch, tmp_path,
                                                             write_config):
    """A run of the kind with a filter that returns each subset of what the figures read: the
    trial keeps its trace and every figure is drawn."""
    from pfbench import plots
    from pfbench.config import load
    from pfbench.runner import run_experiment
    from pfbench.store import read_traces
    for r in range(len(DRAWN[kind]) + 1):
        for subset in itertools.combinations(DRAWN[kind], r):
            name = "partial_" + "_".join(subset)
            monkeypatch.setitem(FILTERS, name, FilterType(
                name, "a filter with some optional outputs", {}, _partial_filter(kind, subset),
                kind=kind))
            exp = load(write_config(f"seed: 1\ntrials: 2\nscenario: {SCENARIO[kind]}\n"
                                    f"filters:\n  p: {{type: {name}, particles: 5}}\n",
                                    f"{name}.yaml"))
            out = tmp_path / name
            run_experiment(exp, out)
            assert read_traces(out).trials, subset
            rows = pd.read_csv(out / "trials.csv")
            paths = plots.write_figures(exp, rows, out, "png")
            assert paths and all(p.exists() for p in paths), subset


@pytest.mark.parametrize("kind", sorted(DRAWN))
def test_outputs_given_in_some_trials_only_are_drawn(kind, monkeypatch, tmp_path, write_config):
    """A filter may give an optional output in one trial and not in the next (an adaptive
    particle count reported only when it changed, say): the figures draw what they have."""
    from pfbench import plots
    from pfbench.config import load
    from pfbench.runner import run_experiment
    calls = [0]

    def run(model, data, params, particles, state, diag=0):
        calls[0] += 1
        subset = DRAWN[kind] if calls[0] % 2 else ()
        return _partial_filter(kind, subset)(model, data, params, particles, state, diag)
    monkeypatch.setitem(FILTERS, "sometimes", FilterType("sometimes", "x", {}, run, kind=kind))
    exp = load(write_config(f"seed: 1\ntrials: 4\nscenario: {SCENARIO[kind]}\n"
                            "filters:\n  p: {type: sometimes, particles: 5}\n"))
    run_experiment(exp, tmp_path / "o")
    rows = pd.read_csv(tmp_path / "o" / "trials.csv")
    assert rows["mean_ess"].isna().any() and rows["mean_ess"].notna().any()
    paths = plots.write_figures(exp, rows, tmp_path / "o", "png")
    assert paths and all(p.exists() for p in paths)
