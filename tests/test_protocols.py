"""What filters need of a scenario and what scenarios provide (pfbench.protocols.NEEDS): every
built-in declares it; a plug-in scenario declares it or has it read from its model; an
incompatible pair is refused in one line naming the filter, the scenario and what is missing, by
validate, run, sweep (every cell) and the API, before anything is written; `pfbench list` shows
the compatibility matrix."""
from __future__ import annotations

import dataclasses
import math
import types

import numba
import pytest
from typer.testing import CliRunner

from pfbench.cli import app, compatibility_lines
from pfbench.config import validate
from pfbench.errors import UserError
from pfbench.filters import BUILTIN as BUILTIN_FILTERS
from pfbench.filters import FILTERS, FilterType
from pfbench.models.scalar import LIK_SIG
from pfbench.plugins import check_filter, check_scenario
from pfbench.protocols import NEEDS, compatibility, provided
from pfbench.scenarios import BUILTIN as BUILTIN_SCENARIOS
from pfbench.scenarios import SCENARIOS, ungm
from pfbench.schema import REQUIRED, ConfigError, Key

from .conftest import one_line_exit_2, tree

# The filters the measurement of a likelihood-only scenario (y_t = beta exp(x_t / 2) e_t, say)
# refuses, and those that run on it through its likelihood.
GAUSSIAN_ONLY = ("ukf", "ekf", "kf", "upf", "sspf")
LIKELIHOOD_FILTERS = ("pf", "pfmh", "fa", "ifa", "ba", "pso", "afsa")


@numba.njit(LIK_SIG, cache=True)
def _laplace_loglik(x, t, theta, y, out):
    """A log-likelihood of the model's own (Laplace noise of scale 1 about x^2 / 20)."""
    for i in range(x.size):
        out[i] = -abs(y - x[i] * x[i] / 20.0) - math.log(2.0)


def _scenario(name: str, provides=None, build=None, schema=None) -> types.ModuleType:
    """A plug-in scenario module like ungm: PROVIDES as given (None: none declared), its own
    build (default: ungm's model)."""
    mod = types.ModuleType(f"myplugin.{name}")
    mod.NAME, mod.KIND, mod.DESCRIPTION = name, "scalar", f"test scenario {name}"
    mod.SCHEMA = dict(schema or ungm.SCHEMA)
    mod.build = build or ungm.build
    mod.simulate = ungm.simulate
    if provides is not None:
        mod.PROVIDES = provides
    return mod


def _no_jacobians(p):
    return dataclasses.replace(ungm.build(p), transition_jac=None, observe_jac=None)


def _own_likelihood(p):
    return dataclasses.replace(ungm.build(p), loglik=_laplace_loglik)


def _spec(fname: str) -> dict:
    return {"type": fname, **({"particles": 20} if FILTERS[fname].particles else {})}


@pytest.fixture
def plugins(monkeypatch):
    """Plug-in scenarios: 'likonly' declares only a likelihood (as the stochastic-volatility
    model does); 'ownlik' declares nothing and its model brings its own likelihood; 'nojac'
    declares nothing and its model has no Jacobians; 'liar' declares Jacobians its model lacks;
    'oldstyle' declares only its Jacobians (a PROVIDES written before the measurement's needs)."""
    mods = {"likonly": _scenario("likonly", ("likelihood",)),
            "ownlik": _scenario("ownlik", build=_own_likelihood),
            "nojac": _scenario("nojac", build=_no_jacobians),
            "liar": _scenario("liar", ("jacobians", "gaussian_measurement", "likelihood"),
                              build=_no_jacobians),
            "oldstyle": _scenario("oldstyle", ("jacobians",))}
    for name, mod in mods.items():
        monkeypatch.setitem(SCENARIOS, name, mod)
    return mods


def _raw(scenario: str, *fnames: str, **keys) -> dict:
    return {"trials": 2, "scenario": {"name": scenario, "steps": 5, **keys},
            "filters": {f: _spec(f) for f in fnames}}


# --- the vocabulary and the declarations ---------------------------------------------------

def test_every_builtin_filter_and_scenario_declares_in_the_vocabulary():
    for name, ft in BUILTIN_FILTERS.items():
        assert isinstance(ft.needs, tuple) and set(ft.needs) <= set(NEEDS), name
        assert check_filter(name, ft) is None
    for name, mod in BUILTIN_SCENARIOS.items():
        assert isinstance(mod.PROVIDES, tuple) and set(mod.PROVIDES) <= set(NEEDS), name
        assert check_scenario(name, mod) is None
    for f in LIKELIHOOD_FILTERS:
        assert BUILTIN_FILTERS[f].needs == ("likelihood",)
    for f in ("ukf", "upf", "sspf", "ekf", "kf"):
        assert "gaussian_measurement" in BUILTIN_FILTERS[f].needs
    assert "jacobians" in BUILTIN_FILTERS["ekf"].needs and "linear" in BUILTIN_FILTERS["kf"].needs
    assert BUILTIN_FILTERS["kf"].scenarios is None       # a need, not a list of scenarios
    # the additive Gaussian measurement, with its derivatives
    for name in ("ungm", "upf_gamma", "linear_gaussian"):
        assert {"gaussian_measurement", "likelihood", "jacobians"} <= set(
            BUILTIN_SCENARIOS[name].PROVIDES)
    # every scalar scenario gives its filters a likelihood; the SLAM scenarios the Gaussian
    # sensor with its Jacobians (FastSLAM's landmark EKFs); the beacon field's is read from its
    # model (its keys decide whether the measurement is Gaussian)
    for name, mod in BUILTIN_SCENARIOS.items():
        if mod.KIND == "scalar":
            assert "likelihood" in mod.PROVIDES
        elif mod.KIND == "slam":
            assert set(mod.PROVIDES) == {"gaussian_measurement", "jacobians", "likelihood"}
        else:
            assert mod.PROVIDES == ()
    assert "linear" in BUILTIN_SCENARIOS["linear_gaussian"].PROVIDES
    assert "linear" not in BUILTIN_SCENARIOS["ungm"].PROVIDES


def test_a_plugin_may_declare_and_need_every_name_of_the_vocabulary_and_nothing_else():
    mod = _scenario("x", tuple(NEEDS))
    assert check_scenario("x", mod) is None
    assert "not a tuple of" in check_scenario("x", _scenario("x", ("closed_form",)))
    ft = FilterType("mine", "d", {}, lambda *a: {}, needs=tuple(NEEDS))
    assert check_filter("mine", ft) is None
    assert "not a tuple of" in check_filter("mine", dataclasses.replace(ft, needs=("magic",)))


def test_what_a_plugin_scenario_without_provides_gives_is_read_from_its_model(plugins):
    every = tuple(NEEDS)
    assert provided(plugins["nojac"], None, every) == {"gaussian_measurement", "likelihood"}
    assert provided(plugins["ownlik"], None, every) == {"jacobians", "likelihood"}
    # a linear model is declared, never guessed from the functions
    assert "linear" not in provided(_scenario("y"), None, every)
    # a PROVIDES that names neither measurement need (written before they existed): read
    assert provided(plugins["oldstyle"], None, every) == {"jacobians", "gaussian_measurement",
                                                          "likelihood"}
    # a PROVIDES that names one is what the scenario gives, whatever the model
    assert provided(plugins["likonly"], None, every) == {"likelihood"}
    # a model that cannot be built, or keys without defaults: nothing is credited
    broken = _scenario("b", build=lambda p: 1 / 0)
    assert provided(broken, None, every) == set()
    required = _scenario("r", schema={"steps": Key("int", 5, "T"),
                                      "beta": Key("float", REQUIRED, "scale")})
    assert provided(required, None, every) == set()


# --- refused in one line, at validation ----------------------------------------------------

@pytest.mark.parametrize("fname", GAUSSIAN_ONLY)
def test_a_likelihood_only_scenario_refuses_the_gaussian_filters(plugins, fname):
    with pytest.raises(ConfigError) as err:
        validate(_raw("likonly", fname))
    text = str(err.value)
    assert "\n" not in text
    assert f"filters.{fname}" in text and f"filter type '{fname}'" in text
    assert "scenario 'likonly'" in text and "['gaussian_measurement']" in text
    # the filters that do run on it are named
    assert "pf, pfmh, fa, ifa, ba, pso, afsa" in text


@pytest.mark.parametrize("fname", LIKELIHOOD_FILTERS)
def test_a_likelihood_only_scenario_takes_the_particle_filters(plugins, fname):
    exp = validate(_raw("likonly", fname))
    assert exp.filters[0].type == fname
    exp = validate(_raw("ownlik", fname))
    assert exp.filters[0].type == fname


def test_each_missing_need_is_named_with_the_filter_and_the_scenario(plugins):
    cases = {("nojac", "ekf"): ["['jacobians']", "declares no PROVIDES"],
             ("ownlik", "ukf"): ["['gaussian_measurement']", "declares no PROVIDES"],
             ("ownlik", "upf"): ["['gaussian_measurement']"],
             ("likonly", "ekf"): ["['jacobians'] and", "['gaussian_measurement']",
                                  "its PROVIDES: likelihood"],
             ("likonly", "kf"): ["['linear'] and", "['gaussian_measurement']"],
             ("ungm", "kf"): ["['linear']", "scenario 'ungm'"],
             ("upf_gamma", "kf"): ["['linear']"],
             ("liar", "ekf"): ["['jacobians']", "declares in its PROVIDES but its model lacks"]}
    for (scen, fname), parts in cases.items():
        with pytest.raises(ConfigError) as err:
            validate(_raw(scen, fname))
        text = str(err.value)
        assert "\n" not in text and f"filter type '{fname}'" in text, text
        assert f"scenario '{scen}'" in text, text
        for part in parts:
            assert part in text, (scen, fname, text)
    # what they do provide runs
    validate(_raw("nojac", "ukf", "pf"))
    validate(_raw("oldstyle", "ukf", "ekf", "pf", "upf"))
    validate(_raw("linear_gaussian", "kf"))


def test_what_a_plugin_without_provides_gives_follows_its_keys(monkeypatch):
    """The model is built from the config's keys (a --set or a sweep cell's value)."""
    schema = {**ungm.SCHEMA, "multiplicative": Key("bool", False, "own likelihood")}

    def build(p):
        base = ungm.build({k: v for k, v in p.items() if k != "multiplicative"})
        return _own_likelihood_of(base) if p["multiplicative"] else base
    monkeypatch.setitem(SCENARIOS, "switch", _scenario("switch", build=build, schema=schema))
    validate(_raw("switch", "ukf"))
    with pytest.raises(ConfigError, match="gaussian_measurement"):
        validate(_raw("switch", "ukf", multiplicative=True))
    validate(_raw("switch", "pf", multiplicative=True))


def _own_likelihood_of(model):
    return dataclasses.replace(model, loglik=_laplace_loglik)


# --- refused by every command and the API, before anything is written ----------------------

def _write(tmp_path, scenario: str, fname: str, extra: str = "") -> str:
    cfg = tmp_path / "exp.yaml"
    cfg.write_text(f"trials: 2\nscenario:\n  name: {scenario}\n  steps: 5\n"
                   f"filters:\n  {fname}:\n" + "".join(f"    {k}: {v}\n" for k, v in
                                                      _spec(fname).items()) + extra)
    return str(cfg)


@pytest.mark.parametrize("scen,fname", [("likonly", "ukf"), ("nojac", "ekf"), ("liar", "ekf"),
                                        ("likonly", "sspf"), ("ungm", "kf")])
def test_validate_and_run_refuse_in_one_line_and_write_nothing(plugins, tmp_path, scen, fname):
    cfg = _write(tmp_path, scen, fname)
    runner = CliRunner()
    line = one_line_exit_2(runner.invoke(app, ["validate", cfg]))
    assert f"filter type '{fname}'" in line and f"scenario '{scen}'" in line
    out = tmp_path / "out"
    line = one_line_exit_2(runner.invoke(app, ["run", cfg, "--out", str(out), "--no-figures"]))
    assert f"filter type '{fname}'" in line and f"scenario '{scen}'" in line
    assert not out.exists()
    # a folder the user had is left as it was
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    before = tree(out)
    one_line_exit_2(runner.invoke(app, ["run", cfg, "--out", str(out), "--no-figures"]))
    one_line_exit_2(runner.invoke(app, ["run", cfg, "--out", str(out), "--resume"]))
    assert tree(out) == before and sorted(p.name for p in out.iterdir()) == ["notes.txt"]


def test_a_set_that_changes_the_scenario_is_refused_in_one_line(plugins, tmp_path):
    cfg = _write(tmp_path, "ungm", "ukf")
    runner = CliRunner()
    for cmd in (["validate", cfg], ["run", cfg, "--out", str(tmp_path / "o")]):
        line = one_line_exit_2(runner.invoke(app, [*cmd, "--set", "scenario.name=likonly"]))
        assert "filter type 'ukf'" in line and "scenario 'likonly'" in line
    assert not (tmp_path / "o").exists()


def test_a_sweep_refuses_a_cell_whose_scenario_lacks_a_need_before_any_cell_runs(plugins,
                                                                               tmp_path):
    cfg = _write(tmp_path, "ungm", "ukf")
    runner = CliRunner()
    out = tmp_path / "sw"
    line = one_line_exit_2(runner.invoke(app, ["sweep", cfg, "--out", str(out), "--set",
                                               "scenario.name=ungm,likonly"]))
    assert "filter type 'ukf'" in line and "scenario 'likonly'" in line
    assert "sweep cell scenario.name=likonly" in line
    assert not out.exists()
    # a sweep file's own values too, by validate and sweep
    sweep_cfg = tmp_path / "s.yaml"
    sweep_cfg.write_text(open(cfg).read() + "sweep:\n  scenario.name: [ungm, nojac]\n"
                         "  filters.ukf.type: [ukf, ekf]\n")
    for cmd in (["validate", str(sweep_cfg)], ["sweep", str(sweep_cfg), "--out", str(out)]):
        line = one_line_exit_2(runner.invoke(app, cmd))
        assert "filter type 'ekf'" in line and "scenario 'nojac'" in line
        assert "['jacobians']" in line and "filters.ukf.type=ekf" in line
    assert not out.exists()


def test_the_api_refuses_a_mapping_a_file_and_an_experiment_built_by_hand(plugins, tmp_path):
    from pfbench.api import run_experiment, run_until_decided
    out = tmp_path / "api"
    with pytest.raises(ConfigError, match="scenario 'likonly'"):
        run_experiment(_raw("likonly", "ukf"), out=out, figures=False)
    with pytest.raises(ConfigError, match="scenario 'nojac'"):
        run_experiment(_write(tmp_path, "nojac", "ekf"), out=out, figures=False)
    with pytest.raises(ConfigError, match="scenario 'likonly'"):
        run_experiment(_write(tmp_path, "ungm", "upf"), out=out, figures=False,
                       overrides=["scenario.name=likonly"])
    good = validate(_raw("ungm", "ukf", "pf"))
    moved = dataclasses.replace(good, scenario="likonly")
    for call in (lambda: run_experiment(moved, out=out, figures=False),
                 lambda: run_experiment(moved, figures=False),
                 lambda: run_until_decided(moved, out=out, figures=False)):
        with pytest.raises(UserError) as err:
            call()
        text = str(err.value)
        assert "\n" not in text and "filters.ukf" in text and "filter type 'ukf'" in text
        assert "scenario 'likonly'" in text and "['gaussian_measurement']" in text
    assert not out.exists()


# --- the matrix -----------------------------------------------------------------------------

def test_the_matrix_pairs_every_filter_with_every_scenario_of_its_kind(plugins):
    blocks = compatibility(FILTERS, SCENARIOS)
    assert set(blocks) == {"scalar", "slam", "localization"}
    scens, filts, cells = blocks["scalar"]
    assert {"ungm", "likonly", "ownlik"} <= set(scens) and {"pf", "ukf", "kf"} <= set(filts)
    assert cells["likonly", "pf"] == () and cells["ungm", "ekf"] == ()
    assert cells["likonly", "ekf"] == ("jacobians", "gaussian_measurement")
    assert cells["ungm", "kf"] == ("linear",) and cells["linear_gaussian", "kf"] == ()
    assert cells["ownlik", "ukf"] == ("gaussian_measurement",)
    assert cells["nojac", "ekf"] == ("jacobians",)
    for kind, (scens, filts, cells) in blocks.items():
        assert set(cells) == {(s, f) for s in scens for f in filts}
        for s in scens:
            for f in filts:
                runs = FILTERS[f].runs_on(s, kind, SCENARIOS[s])
                assert runs == (cells[s, f] == ()), (s, f)
    assert blocks["localization"][2]["beacon_field", "mcl"] == ()


def _matrix(output: str) -> dict:
    """{(scenario, filter): cell} of the scalar block of list's matrix."""
    lines = output.splitlines()
    i = next(k for k, l in enumerate(lines) if l.startswith("compatibility"))
    cells, filts = {}, []
    for line in lines[i + 1:]:
        words = line.split()
        if not line.startswith("  ") or not words:
            break
        if words[0] in ("scalar", "slam", "localization"):
            filts = words[1:] if words[0] == "scalar" else []
            continue
        if filts and words[0] in SCENARIOS and SCENARIOS[words[0]].KIND == "scalar":
            cells.update({(words[0], f): c for f, c in zip(filts, words[1:])})
    return cells


def test_list_shows_the_matrix_with_what_is_missing_in_100_columns(plugins):
    res = CliRunner().invoke(app, ["list"], env={"COLUMNS": "100"})
    assert res.exit_code == 0, res.output
    block = res.output.split("compatibility")[1].split("resampling:")[0]
    assert all(len(l) <= 100 for l in block.splitlines()), block
    m = _matrix(res.output)
    assert m["likonly", "pf"] == "ok" and m["ungm", "ukf"] == "ok"
    assert m["likonly", "ukf"] == "G" and m["likonly", "ekf"] == "JG"
    assert m["ungm", "kf"] == "I" and m["linear_gaussian", "kf"] == "ok"
    assert m["nojac", "ekf"] == "J" and m["oldstyle", "ekf"] == "ok"
    for need, letter in (("jacobians", "J"), ("gaussian_measurement", "G"),
                         ("likelihood", "L"), ("linear", "I")):
        assert f"{letter} {need}" in block


def test_the_matrix_wraps_its_columns_to_100_with_many_plugin_filters(plugins, monkeypatch):
    base = FILTERS["pf"]
    names = [f"plugin_filter_number_{i}" for i in range(9)]
    for n in names:
        monkeypatch.setitem(FILTERS, n, dataclasses.replace(base, name=n, needs=(
            "gaussian_measurement",), scenarios=("ungm", "likonly")))
    lines = compatibility_lines(FILTERS, SCENARIOS)
    assert all(len(l) <= 100 for l in lines), [l for l in lines if len(l) > 100]
    text = "\n".join(lines)
    for n in names:
        assert n in text
    assert "x: the filter runs only on scenarios it names" in text
    row = [l for l in lines if l.split()[:1] == ["likonly"]]
    assert any("G" in l.split() for l in row)


def test_a_plugin_model_that_cannot_be_asked_is_unknown_in_the_matrix(monkeypatch):
    """Keys without defaults, or a build that raises (even SystemExit): '?' in the matrix, no
    traceback; a config's keys decide at validation."""
    def leaves(p):
        raise SystemExit("bye")
    required = _scenario("needskeys", schema={**ungm.SCHEMA,
                                               "beta": Key("float", REQUIRED, "scale")},
                         build=lambda p: ungm.build({k: v for k, v in p.items() if k != "beta"}))
    monkeypatch.setitem(SCENARIOS, "needskeys", required)
    monkeypatch.setitem(SCENARIOS, "leaves", _scenario("leaves", build=leaves))
    res = CliRunner().invoke(app, ["list"])
    assert res.exit_code == 0 and "Traceback" not in res.output, res.output
    m = _matrix(res.output)
    assert m["needskeys", "pf"] == "?" and m["leaves", "ekf"] == "?"
    assert "?: its model" in res.output
    # the config's keys build it: it provides what its model shows
    validate(_raw("needskeys", "pf", "ekf", beta=2.0))
    with pytest.raises(ConfigError, match="scenario 'leaves' does not provide"):
        validate(_raw("leaves", "pf"))
