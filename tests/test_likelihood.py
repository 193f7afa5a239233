"""A scalar model's own log-likelihood and measurement sampler (pfbench.models.scalar LIK_SIG,
SAMPLE_SIG): the particle filters (pf, pfmh and the swarm PFs) weigh through it, and the swarms'
fitness reads it; without one the inline Gaussian stays the path."""
import math
import pickle

import numpy as np
import pytest
from numba import njit, typeof

from pfbench.errors import UserError
from pfbench.filters import FILTERS
from pfbench.models.scalar import (LIK_SIG, MODEL_SIG, SAMPLE_SIG, LikelihoodFunction, LikFn,
                                   SamplerFunction, ScalarModel, simulate)
from pfbench.rng import normal, state_from_seed
from pfbench.scenarios import ungm

from .conftest import default_params, njit_when_used

PF_FAMILY = ("pf", "pfmh", "fa", "ifa", "ba", "pso", "afsa")


@njit_when_used(LIK_SIG)
def gaussian_loglik(x, t, theta, y, out):
    """log N(y; x^2 / 20, R), R = theta[2]: ungm's measurement written as a likelihood."""
    R = theta[2]
    c = -0.5 * math.log(2.0 * math.pi * R)
    for i in range(x.size):
        d = y - x[i] * x[i] / 20.0
        out[i] = c - 0.5 * d * d / R


@njit_when_used(LIK_SIG)
def nothing_at_step_3(x, t, theta, y, out):
    """The Gaussian, except at t = 3, where no state can have produced y."""
    R = theta[2]
    for i in range(x.size):
        d = y - x[i] * x[i] / 20.0
        out[i] = -np.inf if t == 3.0 else -0.5 * d * d / R


@njit_when_used(LIK_SIG)
def unbounded_above_zero_at_step_3(x, t, theta, y, out):
    """The Gaussian, except at t = 3, where the density has no bound at every x > 0 (+inf)."""
    R = theta[2]
    for i in range(x.size):
        d = y - x[i] * x[i] / 20.0
        out[i] = np.inf if t == 3.0 and x[i] > 0.0 else -0.5 * d * d / R


@njit_when_used(SAMPLE_SIG)
def exact(x, t, theta, s, out):
    """y = x (the sampler's draw), and one normal drawn to show it gets the state."""
    for i in range(x.size):
        normal(s)
        out[i] = x[i]


def _ungm(R=1.0, steps=15, **fields):
    base = ungm.build(default_params(ungm.SCHEMA, steps=steps, measurement_noise_var=R))
    theta = np.array([base.theta[0], base.theta[1], R])   # theta[2]: R, for the likelihoods
    return ScalarModel(base.transition, base.observe, theta, base.noise, base.x0,
                       base.prior_mean, base.prior_var, steps, **fields)


def _run(name, model, y, N=40, seed=4, **over):
    ft = FILTERS[name]
    params = default_params(ft.schema, **over)
    return ft.run(model, y, params, N, state_from_seed(np.random.SeedSequence(seed)))


def _data(model, seed=9):
    return simulate(model, state_from_seed(np.random.SeedSequence(seed)))


@pytest.mark.parametrize("name", PF_FAMILY)
def test_the_gaussian_written_as_a_likelihood_gives_the_builtin_estimates(name):
    """ungm (a nonlinear h, resampling by ESS, so that both weights and resampling matter) with
    its Gaussian measurement written as the model's own log-likelihood, constants included: the
    same estimates as the inline Gaussian within floating-point tolerance; the same function with
    another R moves them (the filter does read the model's likelihood)."""
    builtin = _ungm()
    y = _data(builtin)[1]
    over = {"resample": "neff", "neff_ratio": 0.5} if name != "ifa" else {}
    ref = _run(name, builtin, y, **over)["xhat"]
    own = _run(name, _ungm(loglik=gaussian_loglik()), y, **over)
    assert own["underflow_steps"] == 0
    assert np.allclose(own["xhat"], ref, rtol=1e-9, atol=1e-9)
    wide = _ungm(loglik=gaussian_loglik())
    wide.theta[2] = 25.0
    moved = _run(name, wide, y, **over)["xhat"]
    assert np.max(np.abs(moved - ref)) > 1e-3


@pytest.mark.parametrize("name", PF_FAMILY)
def test_a_likelihood_that_is_minus_inf_everywhere_at_a_step_is_one_underflow_step(name):
    model = _ungm(loglik=nothing_at_step_3(), steps=8)
    y = _data(_ungm(steps=8))[1]
    out = _run(name, model, y, N=30)
    assert out["underflow_steps"] == 1
    assert np.all(np.isfinite(out["xhat"]))
    assert np.all(np.isfinite(out["ess"]))


@pytest.mark.parametrize("name", PF_FAMILY)
def test_a_likelihood_of_plus_inf_gives_those_particles_the_weight_never_nan(name):
    """+inf (a density without bound at y) at some particles of a step: they share the weight
    (the estimate is positive, one of them), the others none; no NaN, no underflow."""
    model = _ungm(loglik=unbounded_above_zero_at_step_3(), steps=6)
    y = _data(_ungm(steps=6))[1]
    out = _run(name, model, y, N=60, estimate="before_resampling")
    assert np.all(np.isfinite(out["xhat"])) and np.all(np.isfinite(out["ess"]))
    assert out["underflow_steps"] == 0
    assert out["xhat"][3] > 0.0 and out["ess"][3] < 60


def test_a_model_function_of_the_wrong_kind_is_refused_in_one_line():
    """A likelihood of MODEL_SIG (not LIK_SIG), a plain Python function, a transition of
    LIK_SIG: TypeError naming the signature, one line, when the model is built."""
    @njit(MODEL_SIG)
    def as_model(x, t, theta, out):
        out[:] = 0.0

    def plain(x, t, theta, y, out):
        out[:] = 0.0

    base = _ungm()
    for kw, sig in (({"loglik": as_model}, "LIK_SIG"), ({"loglik": plain}, "LIK_SIG"),
                    ({"sample": gaussian_loglik()}, "SAMPLE_SIG")):
        with pytest.raises(TypeError) as e:
            ScalarModel(base.transition, base.observe, base.theta, base.noise, 0.0, 0.0, 1.0, 3,
                        **kw)
        assert sig in str(e.value) and "\n" not in str(e.value)
        assert isinstance(e.value, UserError)   # one line and exit status 2 from the CLI
    with pytest.raises(TypeError, match="MODEL_SIG"):
        ScalarModel(gaussian_loglik(), base.observe, base.theta, base.noise, 0.0, 0.0, 1.0, 3)


def test_the_likelihood_and_sampler_are_handed_over_by_address_and_pickle():
    """As the model functions: typed by their signature, called from Python, pickled back to
    the function (the Dask engine ships models); a model without them says so."""
    model = _ungm(loglik=gaussian_loglik(), sample=exact())
    assert isinstance(model.loglik, LikelihoodFunction) and typeof(model.loglik) == LikFn
    assert isinstance(model.sample, SamplerFunction)
    assert model.has_likelihood and not _ungm().has_likelihood
    assert model.likelihood() == (model.loglik, 1) and _ungm().likelihood()[1] == 0
    again = pickle.loads(pickle.dumps(model))
    assert again.loglik.address == model.loglik.address
    assert type(again.sample) is SamplerFunction
    out = np.empty(1)
    model.loglik(np.array([2.0]), 1.0, model.theta, 0.2, out)
    assert out[0] == pytest.approx(-0.5 * math.log(2 * math.pi))


def test_simulation_draws_the_measurements_from_the_models_sampler():
    x, y = _data(_ungm(sample=exact(), steps=20))
    assert np.array_equal(y[1:], x[1:])
    xg, yg = _data(_ungm(steps=20))
    assert np.array_equal(xg, x)   # this sampler draws one normal a step, as h(x) + v does
    assert not np.array_equal(yg[1:], xg[1:])


def _guide_blocks() -> dict:
    """The code blocks of the plug-in guide's section on a model with its own likelihood, by
    language."""
    import re

    from .conftest import ROOT
    text = (ROOT / "docs/how-to/plugins.md").read_text()
    section = text.split("## A model with its own likelihood\n", 1)[1].split("\n## ", 1)[0]
    return {lang: body for lang, body in re.findall(r"```(\w+)\n(.*?)```", section, re.DOTALL)}


def _guide_plugin(tmp_path, monkeypatch, edit=lambda text: text):
    """The guide's scenario module (``edit``ed) importable from tmp_path and registered, and
    its experiment file (3 trials)."""
    import importlib
    import sys
    import tomllib

    from pfbench.protocols import register_scenarios
    from pfbench.scenarios import SCENARIOS

    blocks = _guide_blocks()
    project = tomllib.loads(blocks["toml"])
    module = project["project"]["entry-points"]["pfbench.scenarios"]["t_noise"]
    (tmp_path / f"{module}.py").write_text(edit(blocks["python"]))
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, module, raising=False)
    mod = importlib.import_module(module)
    monkeypatch.setitem(SCENARIOS, "t_noise", mod)
    register_scenarios({"t_noise": mod})
    cfg = tmp_path / "t_noise.yaml"
    cfg.write_text(blocks["yaml"].replace("trials: 20", "trials: 3"))
    return mod, cfg


@pytest.fixture
def forget_t_noise():
    yield
    import sys

    from pfbench import protocols
    protocols._SCENARIO_MODULES.pop("t_noise", None)
    sys.modules.pop("pfbench_tnoise", None)


def test_the_guides_plugin_with_its_own_likelihood_runs(tmp_path, monkeypatch, forget_t_noise):
    """The guide's scenario module, as written there: it passes the plug-in checks, builds its
    model with its likelihood and sampler, and the guide's experiment validates and runs."""
    import pandas as pd
    from typer.testing import CliRunner

    from pfbench.cli import app
    from pfbench.plugins import check_scenario

    mod, cfg = _guide_plugin(tmp_path, monkeypatch)
    assert check_scenario("t_noise", mod) is None
    model = mod.build(default_params(mod.SCHEMA))
    assert model.has_likelihood and model.sample is not None
    runner = CliRunner()
    assert runner.invoke(app, ["validate", str(cfg)]).exit_code == 0
    res = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "out"), "--no-figures"])
    assert res.exit_code == 0, res.output
    table = pd.read_csv(tmp_path / "out" / "table.csv")
    assert len(table) == 3 and np.all(np.isfinite(table["rmse_mean"]))


def test_a_plugin_likelihood_of_the_wrong_signature_stops_the_run_in_one_line(
        tmp_path, monkeypatch, forget_t_noise):
    """The guide's plug-in with its log-likelihood declared as a model function (no y): the run
    stops (exit status 2, no traceback) with one error line naming the function and the
    signature it needs; nothing is written."""
    from typer.testing import CliRunner

    from pfbench.cli import app

    def as_model_function(text):
        return (text.replace("@njit(LIK_SIG, cache=True)\ndef loglik(x, t, theta, y, out)",
                             "@njit(MODEL_SIG, cache=True)\ndef loglik(x, t, theta, out)")
                .replace("z = (y - x[i])", "z = (0.0 - x[i])"))

    _, cfg = _guide_plugin(tmp_path, monkeypatch, as_model_function)
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    errors = [line for line in res.output.splitlines() if line.startswith("pfbench: error: ")]
    assert len(errors) == 1 and "loglik" in errors[0] and "LIK_SIG" in errors[0]
    assert not out.exists()
