"""The stochastic volatility scenario `sv` (Kim, Shephard and Chib 1998): its own likelihood and
sampler, the PF family on it, its keys at validation and an end-to-end run."""
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.filters import FILTERS
from pfbench.rng import state_from_seed
from pfbench.scenarios import SCENARIOS, sv

from .conftest import default_params, one_line_exit_2, tree

runner = CliRunner()


def _model(**over):
    return sv.build(default_params(sv.SCHEMA, **over))


def _data(model, seed):
    return sv.simulate(model, state_from_seed(np.random.SeedSequence(seed)))


def test_sv_is_registered_and_declares_its_likelihood():
    assert SCENARIOS["sv"] is sv
    assert sv.KIND == "scalar" and sv.PROVIDES == ("likelihood",)
    m = _model()
    assert m.has_likelihood and m.sample is not None
    assert m.transition_jac is None and m.observe_jac is None
    assert m.prior_mean == 0.0
    assert m.prior_var == pytest.approx(0.16 ** 2 / (1 - 0.98 ** 2))


def test_its_likelihood_is_the_normal_density_of_the_return():
    m = _model(beta=0.7)
    x = np.array([-3.0, -0.5, 0.0, 1.2, 4.0])
    out = np.empty(x.size)
    for y in (0.0, -0.3, 2.5):
        m.loglik(x, 1.0, m.theta, y, out)
        var = 0.7 ** 2 * np.exp(x)
        ref = -0.5 * np.log(2 * np.pi * var) - 0.5 * y * y / var
        assert np.allclose(out, ref, rtol=1e-13, atol=1e-13)


def test_simulation_follows_the_model():
    """Over many steps: the log-volatility's stationary variance, and returns whose scaled
    values y exp(-x/2) / beta are standard normal."""
    m = _model(steps=20000, phi=0.9, sigma=0.5, beta=0.8)
    x, y = _data(m, 3)
    var0 = 0.25 / (1 - 0.81)
    assert np.var(x) == pytest.approx(var0, rel=0.1)
    e = y[1:] * np.exp(-x[1:] / 2) / 0.8
    assert abs(e.mean()) < 0.03 and np.var(e) == pytest.approx(1.0, rel=0.05)
    # the true x_0 is drawn from the stationary distribution, not fixed
    starts = [_data(_model(steps=1), s)[0][0] for s in range(200)]
    assert np.std(starts) == pytest.approx(math.sqrt(0.16 ** 2 / (1 - 0.98 ** 2)), rel=0.15)


@pytest.mark.parametrize("name,over", [("pf", {}), ("pfmh", {}), ("fa", {}), ("ifa", {}),
                                       ("ifa", {"brightness": "inverse"}), ("ba", {}),
                                       ("pso", {}), ("afsa", {}),
                                       ("pf", {"likelihood_floor": 1e-3})])
def test_every_particle_filter_of_the_family_runs_on_sv(name, over):
    m = _model(steps=25)
    x, y = _data(m, 1)
    ft = FILTERS[name]
    out = ft.run(m, y, default_params(ft.schema, **over), 30,
                 state_from_seed(np.random.SeedSequence(2)))
    assert out["xhat"].shape == x.shape and np.all(np.isfinite(out["xhat"]))
    assert out["underflow_steps"] == 0


def test_the_pf_beats_the_prior_on_sv():
    """300 particles, 20 trials of 100 steps (fixed seeds): the PF's mean RMSE is below 0.8 times
    the prior's (its stationary standard deviation, about 0.80: the RMSE of estimating 0); the
    likelihood carries information, each return about its volatility."""
    m = _model()
    ft = FILTERS["pf"]
    params = default_params(ft.schema)
    rmse, prior = [], []
    for k in range(20):
        x, y = _data(m, 100 + k)
        out = ft.run(m, y, params, 300, state_from_seed(np.random.SeedSequence(500 + k)))
        rmse.append(np.sqrt(np.mean((out["xhat"][1:] - x[1:]) ** 2)))
        prior.append(np.sqrt(np.mean(x[1:] ** 2)))
    assert np.mean(rmse) < 0.8 * math.sqrt(m.prior_var)
    assert np.mean(rmse) < 0.8 * np.mean(prior)


def test_phi_of_one_is_refused_in_one_line_before_anything_is_written(tmp_path):
    cfg = tmp_path / "sv.yaml"
    cfg.write_text("seed: 0\ntrials: 2\nscenario:\n  name: sv\n  phi: 1.0\n"
                   "filters:\n  pf:\n    particles: [20]\n")
    out = tmp_path / "out"
    for cmd in (["validate", str(cfg)], ["run", str(cfg), "--out", str(out)]):
        line = one_line_exit_2(runner.invoke(app, cmd))
        assert "phi" in line
    assert not out.exists()


def test_a_small_sv_experiment_runs_end_to_end(tmp_path):
    cfg = tmp_path / "sv.yaml"
    cfg.write_text("seed: 0\ntrials: 3\nscenario:\n  name: sv\n  steps: 30\n"
                   "filters:\n  pf:\n    particles: [50]\n  pfmh:\n    particles: [20]\n")
    out = tmp_path / "out"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(out / "table.csv")
    assert len(table) == 2 and np.all(np.isfinite(table["rmse_mean"]))
    assert tree(out)


def test_a_built_in_scenario_the_installed_metadata_lacks_is_still_registered(monkeypatch):
    """pfbench installed before a scenario was added (its entry points list the others): the
    source tree's built-ins are all registered, in their declared order, pfbench's own."""
    from pfbench import plugins, scenarios

    class Dist:
        name = "pfbench"

    class EP:
        def __init__(self, name):
            self.name, self.value, self.dist = name, f"pfbench.scenarios.{name}", Dist()

        def load(self):
            return scenarios.BUILTIN[self.name]

    stale = [EP(n) for n in scenarios.BUILTIN if n != "sv"]
    monkeypatch.setattr(plugins, "entry_points", lambda group: stale)
    found = plugins.discover("pfbench.scenarios", plugins.check_scenario, scenarios.BUILTIN)
    assert list(found) == list(scenarios.BUILTIN) and found["sv"] is sv
    assert plugins.ORIGIN[("pfbench.scenarios", "sv")] == "pfbench"


def test_the_gaussian_filters_do_not_crash_on_sv(tmp_path):
    """The UKF runs on sv (h = 0: it learns nothing, its estimates finite); the EKF, which needs
    Jacobians sv does not have, is refused at validation in one line."""
    m = _model(steps=20)
    _, y = _data(m, 4)
    ukf = FILTERS["ukf"].run(m, y, default_params(FILTERS["ukf"].schema), None, None)
    assert np.all(np.isfinite(ukf["xhat"]))
    cfg = tmp_path / "sv.yaml"
    cfg.write_text("seed: 0\ntrials: 2\nscenario:\n  name: sv\nfilters:\n  ekf: {}\n")
    one_line_exit_2(runner.invoke(app, ["validate", str(cfg)]))
