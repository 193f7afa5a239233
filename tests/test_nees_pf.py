"""The particle filters' NEES (issue 33, item 5): their posterior variance, the variance of the
cloud their estimate is the mean of, computed as the per-step diagnostic ``nees`` (output
'pvar') only where asked, checked against the Kalman filter on linear_gaussian."""
import math

import numpy as np
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import Params, load
from pfbench.diagnostics import Diag, plan
from pfbench.filters import FILTERS
from pfbench.rng import state_from_seed
from pfbench.scenarios import SCENARIOS
from pfbench.store import trial_columns

cli = CliRunner()

# The PF family's members that sample from the posterior's neighbourhood without a swarm's move
# (a swarm move pulls the particles together: their variance is no posterior's, see the docs)
POSTERIOR_PFS = (("pf", {}), ("pf", {"estimate": "after_resampling"}), ("pfmh", {}),
                 ("upf", {}), ("sspf", {}))
SCALAR_PFS = ("pf", "pfmh", "upf", "sspf", "fa", "ifa", "ba", "pso", "afsa")


def _linear(steps: int = 100):
    mod = SCENARIOS["linear_gaussian"]
    return mod, mod.build({k: key.default for k, key in mod.SCHEMA.items()} | {"steps": steps})


def _params(name: str, **extra) -> Params:
    return Params({k: key.default for k, key in FILTERS[name].schema.items()} | extra)


def _within(pvar, P, ess, k: float = 5.0) -> bool:
    """Whether pvar (T,) is within k Monte Carlo standard deviations of the exact posterior
    variance P (T,) at every step: a variance estimated from ESS independent draws of a normal
    has a relative standard deviation sqrt(2 / ESS)."""
    return bool(np.all(np.abs(pvar / P - 1.0) <= k * np.sqrt(2.0 / ess)))


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_particles_variance_follows_the_kalman_filters_at_every_step(seed):
    """linear_gaussian (T = 100), N = 2000: each PF's posterior variance lies within 5 Monte
    Carlo standard deviations sqrt(2 / ESS_t) of the Kalman filter's P_t at every step (ESS_t
    the step's effective sample size before resampling: the draws the weighted variance rests
    on; 5 of them over 100 steps: a false failure has a chance below 1e-4 for independent
    errors), and its mean over the steps within 5% of P's (the particles' bias: a variance of
    the wrong cloud, the predicted particles' a^2 P + Q, is 2.5 P). The criterion rejects a
    variance 1.5 times too large. Fixed seeds: the outcome is the same on every run."""
    mod, model = _linear()
    _, y = mod.simulate(model, state_from_seed(np.random.SeedSequence(seed)))
    kf = FILTERS["kf"].run(model, y, _params("kf"), None, None, Diag.NONE)
    P = kf["pvar"][1:]
    for name, extra in POSTERIOR_PFS:
        out = FILTERS[name].run(model, y, _params(name, **extra), 2000,
                                state_from_seed(np.random.SeedSequence(seed + 10)), Diag.SPREAD)
        pvar, ess = out["pvar"][1:], out["ess"][1:]
        assert _within(pvar, P, ess), (name, extra, np.max(np.abs(pvar / P - 1)))
        assert abs(np.mean(pvar / P) - 1.0) <= 0.05, (name, extra)
        assert not _within(1.5 * pvar, P, ess), (name, extra)
        assert out["pvar"][0] == model.prior_var


def test_the_mean_nees_of_the_pf_lies_within_the_chi_square_bounds_and_too_few_particles_fail():
    """50 trials of 50 steps on linear_gaussian (the truth starts at the prior mean, so a prior
    variance near zero is the exact one), with the key ``diagnostics: [nees]``: the bootstrap PF
    with N = 2000 has its mean NEES within the 95% chi-square bounds of the mean of K = 2500
    squares, as the Kalman filter has, and within 4 Monte Carlo standard errors of 1; with
    N = 5 its few particles understate their spread, and its NEES lies above the bound
    ('overconfident'): the check can fail. Fixed seed."""
    from pfbench.api import run_experiment
    cfg = {"seed": 33, "trials": 50, "diagnostics": ["nees"],
           "scenario": {"name": "linear_gaussian", "steps": 50, "prior_var": 1e-12},
           "filters": {"kf": {}, "pf": {"particles": [2000, 5]}}}
    res = run_experiment(cfg)
    assert "nees" in res.trials.columns and "nis" in res.trials.columns
    tab = res.table.set_index("filter")
    for key in ("kf", "pf@2000"):
        row = tab.loc[key]
        assert row["nees_check"] == "consistent", (key, row["nees_mean"])
        assert row["nees_bound_lo"] <= row["nees_mean"] <= row["nees_bound_hi"]
        assert abs(row["nees_mean"] - 1.0) <= 4 * row["nees_se"], key
    few = tab.loc["pf@5"]
    assert few["nees_check"] == "overconfident" and few["nees_mean"] > few["nees_bound_hi"]
    assert np.isnan(tab.loc["pf@2000", "nis_mean"])     # a PF predicts no measurement


def test_nees_is_computed_only_where_asked_and_then_is_a_column(tmp_path):
    """Without the key (and no paper reading nees) a PF experiment has no nees column and its
    runs are not asked for the variance; with it, the column, and validate says why."""
    path = tmp_path / "exp.yaml"
    body = ("seed: 1\ntrials: 2\n{extra}scenario:\n  name: ungm\n  steps: 10\nfilters:\n"
            "  pf:\n    particles: 50\n  ukf: {{}}\n")
    path.write_text(body.format(extra=""))
    exp = load(path)
    assert not plan(exp).every & Diag.SPREAD and "nees" in trial_columns(exp)     # ukf's
    res = cli.invoke(app, ["validate", str(path)])
    line = next(l for l in res.output.splitlines() if "per-step diagnostics" in l)
    assert "not computed: diversity_l1, nees" in line
    path.write_text(body.format(extra="").replace("  ukf: {}\n", ""))
    assert "nees" not in trial_columns(load(path))
    path.write_text(body.format(extra="diagnostics: [nees]\n").replace("  ukf: {}\n", ""))
    exp = load(path)
    assert plan(exp).every & Diag.SPREAD and "nees" in trial_columns(exp)
    assert "nis" not in trial_columns(exp)
    res = cli.invoke(app, ["validate", str(path)])
    assert "nees (the config's diagnostics key)" in res.output
    from pfbench.runner import trial_result
    row = trial_result(exp, 0).rows[0]
    assert math.isfinite(row["nees"]) and row["nees"] > 0


def test_a_paper_that_reads_nees_computes_it(tmp_path):
    (tmp_path / "papers").mkdir()
    (tmp_path / "papers" / "tiny2024.yaml").write_text(
        "paper: tiny2024\ncitation: Tiny, 2024\ntables:\n  t1:\n    caption: NEES\n"
        "    quantities:\n      nees_mean: {title: NEES, metric: nees, stat: mean}\n"
        "    values:\n      - {label: PF, particles: 50, nees_mean: 1.0}\n")
    path = tmp_path / "exp.yaml"
    path.write_text("seed: 1\ntrials: 2\npaper: tiny2024\ntable: t1\nscenario:\n  name: ungm\n"
                    "  steps: 10\nfilters:\n  pf:\n    label: PF\n    particles: 50\n")
    p = plan(load(path))
    assert p.every & Diag.SPREAD and any("quantity nees_mean" in w for w in p.why["nees"])


def test_every_scalar_pf_gives_its_variance_when_asked_and_the_same_filter_either_way():
    """Every scalar PF, both estimates (and both move orders of the swarm PFs): asked, 'pvar'
    is finite and >= 0 at every step (0 where one particle holds all the weight, as a swarm's
    move can leave it); not asked, it is absent; the estimates and the other
    diagnostics are the same bit for bit (no draw, no arithmetic of the filter moved)."""
    mod = SCENARIOS["ungm"]
    model = mod.build({k: key.default for k, key in mod.SCHEMA.items()} | {"steps": 15})
    _, y = mod.simulate(model, state_from_seed(np.random.SeedSequence(1)))
    for name in SCALAR_PFS:
        variants = [{}, {"estimate": "after_resampling"}]
        if name in ("fa", "ifa", "ba", "pso", "afsa"):
            variants.append({"move_order": "resample_then_move"})
        for extra in variants:
            p = _params(name, resample="always", **extra)
            on, off = (FILTERS[name].run(model, y, p, 30,
                                         state_from_seed(np.random.SeedSequence(2)), d)
                       for d in (Diag.SPREAD | Diag.DISTINCT, Diag.DISTINCT))
            assert "pvar" not in off, name
            assert np.isfinite(on["pvar"]).all() and (on["pvar"] >= 0).all(), (name, extra)
            assert (on["pvar"] > 0).mean() > 0.5, (name, extra)
            for k in ("xhat", "ess", "distinct"):
                np.testing.assert_array_equal(on[k], off[k], err_msg=f"{name} {extra} {k}")


def test_the_variance_is_of_the_cloud_the_estimate_is_the_mean_of():
    """pf with estimate after_resampling: pvar is the variance of the resampled set about its
    plain mean, which differs from the weighted variance before resampling by the resampling's
    noise alone; with no resampling at all both estimates read the weighted cloud (the same
    variance bit for bit)."""
    mod, model = _linear(30)
    _, y = mod.simulate(model, state_from_seed(np.random.SeedSequence(4)))

    def run(**extra):
        return FILTERS["pf"].run(model, y, _params("pf", **extra), 500,
                                 state_from_seed(np.random.SeedSequence(5)), Diag.SPREAD)
    before, after = run(), run(estimate="after_resampling")
    assert not np.array_equal(before["pvar"], after["pvar"])
    np.testing.assert_allclose(after["pvar"], before["pvar"], rtol=0.5)
    never = [run(resample="neff", neff_ratio=1e-9, **e)
             for e in ({}, {"estimate": "after_resampling"})]
    assert not never[0]["resampled"][1:].any()
    np.testing.assert_array_equal(never[0]["pvar"], never[1]["pvar"])
