"""The contract every registered filter and scenario keeps (pfbench.contract): run over
pfbench's own here, over the example plug-in in test_plugins; and each clause can fail."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from pfbench import contract
from pfbench.filters import FILTERS, FilterType
from pfbench.scenarios import SCENARIOS, ungm
from pfbench.schema import Key

CONFIGS = Path(__file__).resolve().parents[1] / "configs"
PROBES, EARLY = contract.probes()


def test_every_filter_has_a_probe_on_every_scenario_it_runs_on():
    pairs = {(p.filter, p.scenario) for p in PROBES}
    # a recorded-data scenario whose data are not installed has no probe (pfbench.scenarios.plaza)
    here = {s: mod for s, mod in SCENARIOS.items()
            if getattr(mod, "unavailable", None) is None or mod.unavailable({}) is None}
    assert pairs == {(f, s) for f, ft in FILTERS.items() for s, mod in here.items()
                     if ft.cannot_run_on(s, mod.KIND, mod) is None}
    assert {f for f, _ in pairs} == set(FILTERS) and {s for _, s in pairs} == set(here)
    assert EARLY == []


def test_the_probes_need_no_file_of_the_repository(tmp_path, monkeypatch):
    # the scenarios that read a world file get a generated one: no configs/ anywhere
    monkeypatch.chdir(tmp_path)
    for p in PROBES:
        if "world" in SCENARIOS[p.scenario].SCHEMA:
            exp = contract.experiment(p)
            assert Path(exp.scenario_params["world"]).parent == contract.scratch()


def test_a_filter_that_differs_across_worker_counts_breaks_the_contract(monkeypatch):
    import os
    main = os.getpid()
    bad = FilterType("pidful", "depends on its process", {}, _mean_run(
        lambda state: float(os.getpid() != main)), particles=False)
    monkeypatch.setitem(FILTERS, "pidful", bad)
    monkeypatch.setattr(contract, "probes", lambda: ([contract.Probe(
        "pidful", "ungm", ["filter pidful on scenario ungm"])], []))
    n, problems = contract.check_all(timeout=None)
    assert n == 1 and problems == ["filter pidful on scenario ungm: pidful on ungm gave other "
                                   "numbers under 2 worker(s) than in this process"], problems


@pytest.mark.parametrize("probe", PROBES, ids=[f"{p.filter}-{p.scenario}" for p in PROBES])
def test_each_probe_keeps_the_contract(probe):
    problems, exp, rows = contract.check_probe(probe, CONFIGS)
    assert problems == []
    assert len(rows) == len(contract.TRIALS) and exp.seed == contract.SEED


def _run_with(monkeypatch, ftype: FilterType):
    monkeypatch.setitem(FILTERS, ftype.name, ftype)
    probe = contract.Probe(ftype.name, "ungm", [f"filter {ftype.name}"])
    return contract.check_probe(probe, CONFIGS)[0]


def _mean_run(noise):
    """A toy filter: the prior mean, plus whatever ``noise(state)`` adds."""
    def run(model, y, params, particles, state, diag=True):
        return {"xhat": np.full(y.size, model.prior_mean) + noise(state),
                "lik_evals_per_step": 1.0}
    return run


def test_a_filter_that_ignores_its_seed_breaks_the_contract(monkeypatch):
    rng = np.random.default_rng()      # not from the state it is given
    bad = FilterType("unseeded", "draws from its own generator", {}, _mean_run(
        lambda state: rng.normal()), particles=False)
    problems = _run_with(monkeypatch, bad)
    assert any("the same seed gave different numbers" in p for p in problems), problems
    good = FilterType("seeded", "draws from its state", {}, _mean_run(
        lambda state: np.random.default_rng(np.asarray(state)).normal()), particles=False)
    assert _run_with(monkeypatch, good) == []


def test_a_filter_that_returns_nan_breaks_the_contract(monkeypatch):
    bad = FilterType("nanny", "returns NaN", {}, _mean_run(lambda state: math.nan),
                     particles=False)
    problems = _run_with(monkeypatch, bad)
    assert any("rmse is nan, expected a finite number on a scalar scenario" in p
               for p in problems), problems


def test_a_filter_that_raises_is_named_not_raised(monkeypatch):
    def run(*args, **kw):
        raise ZeroDivisionError("oops")
    problems = _run_with(monkeypatch, FilterType("raiser", "raises", {}, run, particles=False))
    assert problems == ["filter raiser: raiser on ungm raised ZeroDivisionError: oops"]


def test_undocumented_keys_and_bad_defaults_are_found(monkeypatch):
    monkeypatch.setitem(FILTERS, "nodoc", FilterType(
        "nodoc", "a key without a doc line", {"gain": Key("float", 1.0, ""),
                                              "rate": Key("float", -1.0, "a rate", min=0.0)},
        _mean_run(lambda s: 0.0), particles=False))
    _, problems = contract.probes()
    assert "filter nodoc: key 'gain' has no doc line" in problems
    assert any(p.startswith("filter nodoc: its defaults do not pass its own schema") and "rate"
               in p for p in problems), problems


def test_a_scenario_that_ignores_its_seed_breaks_the_contract(monkeypatch):
    class Unseeded:
        NAME, KIND, DESCRIPTION, SCHEMA = "unseeded", "scalar", "ignores its state", ungm.SCHEMA
        build = staticmethod(ungm.build)

        @staticmethod
        def simulate(model, state):
            return ungm.simulate(model, np.random.default_rng().integers(
                0, 2**63, 4, dtype=np.uint64))
    monkeypatch.setitem(SCENARIOS, "unseeded", Unseeded)
    problems = contract.check_probe(contract.Probe("pf", "unseeded", ["scenario unseeded"]),
                                    CONFIGS)[0]
    assert any("the same seed simulated trial 0 twice differently" in p for p in problems), problems


def test_a_filter_kind_without_a_scenario_is_named(monkeypatch):
    monkeypatch.setitem(FILTERS, "lonely", FilterType(
        "lonely", "runs only on a scenario nobody registered", {}, _mean_run(lambda s: 0.0),
        particles=False, scenarios=("nowhere",)))
    _, problems = contract.probes()
    assert "filter lonely: no registered scenario of kind 'scalar' it runs on" in problems


@pytest.mark.slow     # the whole contract on a Dask cluster: 20 s
def test_the_contract_holds_under_the_dask_executor():
    pytest.importorskip("distributed")
    from pfbench.runner import DaskExecutor
    with DaskExecutor(2) as ex:
        n, problems = contract.check_all(CONFIGS, ex)
    assert n == len(PROBES) and problems == []


def test_a_filter_that_claims_snapshots_it_does_not_take_breaks_the_contract(monkeypatch):
    # what the figures draw is kept in the probe's first trial, as in a results folder's run
    from pfbench.filters.mcl import MCL

    def run(model, data, params, particles, state, diag=True):    # takes no snapshots
        return MCL.run(model, data, params, particles, state, diag)

    def probe(ftype):
        monkeypatch.setitem(FILTERS, ftype.name, ftype)
        return contract.check_probe(contract.Probe(ftype.name, "beacon_field",
                                                   [f"filter {ftype.name}"]), CONFIGS)[0]

    claims = FilterType("claims", "says it keeps snapshots", MCL.schema, run,
                        kind="localization", snapshots=True)
    problems = probe(claims)
    assert len(problems) == 1 and "raised TypeError" in problems[0] and "snapshots" in \
        problems[0], problems
    honest = FilterType("honest", "keeps none", MCL.schema, run, kind="localization")
    assert probe(honest) == []
