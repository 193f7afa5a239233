"""Hostile configs: every problem reported at once, --set blamed on itself, a did-you-mean over
every valid key, run keys unique, impossible pairings refused at validation, files that are not
regular files refused without blocking, non-UTF-8 names, extreme numbers."""
from __future__ import annotations

import itertools
import math
import os
import threading

import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load, validate
from pfbench.filters import FILTERS
from pfbench.scenarios import SCENARIOS
from pfbench.schema import ConfigError

from .conftest import SMALL, one_line_exit_2


def test_every_problem_of_a_config_is_reported_at_once_each_with_its_line(write_config):
    cfg = write_config("paper: nopaper\ntrials: 3\nscenario:\n  name: ungm\n  stpes: 5\n"
                       "filters:\n  pf:\n    particles: ['1e3']\n    partcles: 5\n")
    with pytest.raises(ConfigError) as err:
        load(cfg)
    text = str(err.value)
    assert "4 problems" in text
    assert "exp.yaml:5: scenario.stpes" in text and "did you mean 'steps'" in text
    assert "exp.yaml:8: filters.pf.particles[0]" in text
    assert "exp.yaml:9: filters.pf.partcles" in text
    assert "exp.yaml:1: paper" in text
    assert "missing required key" not in text     # a bad value is not also a missing one
    res = CliRunner().invoke(app, ["validate", str(cfg)])
    assert "4 problems" in one_line_exit_2(res)


def test_a_typo_in_a_common_key_gets_a_did_you_mean_and_every_valid_key(write_config):
    cfg = write_config(SMALL.replace("particles: [20, 40]", "partcles: [20, 40]"))
    with pytest.raises(ConfigError) as err:
        load(cfg)
    msg = str(err.value)
    assert "did you mean 'particles'" in msg
    valid = msg.split("valid keys: ")[1]
    for key in ("particles", "label", "type", "resampling"):
        assert key in valid
    for where, text in (("top", "trails: 3\n"), ("check", "check: {trails: 3}\n"),
                        ("compare", "compare: {basline: pf}\n")):
        with pytest.raises(ConfigError, match="did you mean") as err:
            load(write_config(SMALL + text))
        if where == "top":
            assert "scenario" in str(err.value) and "filters" in str(err.value)


def test_a_set_typo_is_blamed_on_the_set_not_on_a_line_of_the_file(write_config):
    cfg = write_config(SMALL)
    with pytest.raises(ConfigError) as err:
        load(cfg, sets=["filters.pf.partcles=10"])
    text = str(err.value)
    assert text.startswith("--set filters.pf.partcles=10: filters.pf.partcles: unknown key")
    assert "did you mean 'particles'" in text and "exp.yaml" not in text
    res = CliRunner().invoke(app, ["validate", str(cfg), "--set", "filters.pf.partcles=10"])
    assert "--set filters.pf.partcles=10" in one_line_exit_2(res)
    with pytest.raises(ConfigError, match="^--set filters.nope.x=1"):
        load(cfg, sets=["filters.nope.x=1"])


@pytest.mark.parametrize("text,sets", [
    (SMALL + "  pf@20:\n    type: ukf\n", ()),
    (SMALL, ("filters.pf@40={type: ukf}",)),
])
def test_run_keys_that_collide_are_refused_naming_both(write_config, text, sets):
    with pytest.raises(ConfigError) as err:
        load(write_config(text), sets=list(sets))
    msg = str(err.value)
    assert "filters.pf" in msg and "filters.pf@" in msg and "rename" in msg


def test_runs_keys_are_unique_after_every_override_through_the_api():
    raw = {"scenario": {"name": "ungm"}, "filters": {"ekf": {}, "x": {"type": "ekf"}}}
    exp = validate(raw)
    assert len({f.key for f in exp.filters}) == len(exp.filters)
    with pytest.raises(ConfigError, match="expected text"):
        validate({"scenario": {"name": "ungm"}, "filters": {1: {"type": "ekf"}}})


def _minimal(ftype) -> dict:
    spec = {"type": ftype.name}
    if ftype.particles:
        spec["particles"] = 20
    return spec


PAIRS = list(itertools.product(FILTERS, SCENARIOS))


@pytest.mark.parametrize("fname,sname", PAIRS)
def test_every_builtin_pairing_is_refused_at_validation_or_declares_it_can_run(fname, sname,
                                                                              monkeypatch):
    from .conftest import ROOT
    monkeypatch.chdir(ROOT / "configs")          # world files resolve against configs/
    ftype, mod = FILTERS[fname], SCENARIOS[sname]
    raw = {"scenario": {"name": sname}, "filters": {"f": _minimal(ftype)}}
    try:
        exp = validate(raw, str(ROOT / "configs" / "x.yaml"))
    except ConfigError as err:
        assert "runs on" in str(err) or "runs only on" in str(err) or "needs" in str(err), err
        assert not ftype.runs_on(sname, mod.KIND)
        return
    ran = FILTERS[exp.filters[0].type]        # 'sspf' on a field: sspf_field
    assert ran.runs_on(sname, mod.KIND)
    assert all(n in getattr(mod, "PROVIDES", ()) for n in ran.needs)


@pytest.mark.slow
@pytest.mark.parametrize("fname,sname", [p for p in PAIRS
                                         if FILTERS[p[0]].kind == SCENARIOS[p[1]].KIND
                                         and SCENARIOS[p[1]].KIND == "scalar"])
def test_every_scalar_pairing_that_validates_runs(fname, sname, tmp_path):
    from pfbench.api import run_experiment
    ftype = FILTERS[fname]
    raw = {"trials": 2, "scenario": {"name": sname, "steps": 5},
           "filters": {"f": _minimal(ftype)}}
    try:
        validate(raw)
    except ConfigError:
        return
    res = run_experiment(raw, out=tmp_path / "out", figures=False)
    assert len(res.trials) == 2


def test_ekf_on_a_scenario_without_jacobians_is_refused_at_validation(monkeypatch):
    import types as _t

    from pfbench.filters.types import provided
    ungm = SCENARIOS["ungm"]
    bare = _t.SimpleNamespace(**{k: getattr(ungm, k) for k in
                                 ("KIND", "DESCRIPTION", "SCHEMA", "simulate")},
                              NAME="nojac", build=lambda p: _t.SimpleNamespace(
                                  transition_jac=None, observe_jac=None))
    monkeypatch.setitem(SCENARIOS, "nojac", bare)
    assert provided(bare, {}, ("jacobians",)) == set()
    raw = {"scenario": {"name": "nojac"}, "filters": {"ekf": {}, "pf": {"particles": 10}}}
    with pytest.raises(ConfigError, match="needs the Jacobians") as err:
        validate(raw)
    assert "filters.ekf" in str(err.value) and "pf" in str(err.value)
    declared = _t.SimpleNamespace(**vars(bare), PROVIDES=())
    monkeypatch.setitem(SCENARIOS, "nojac", declared)
    with pytest.raises(ConfigError, match="needs the Jacobians"):
        validate(raw)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs here")
def test_a_fifo_config_or_world_file_is_refused_without_blocking(tmp_path, write_config):
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    out = {}

    def go():
        try:
            load(fifo)
        except ConfigError as err:
            out["err"] = str(err)
    t = threading.Thread(target=go, daemon=True)
    t.start()
    t.join(20)
    assert "FIFO" in out.get("err", ""), out
    res = CliRunner().invoke(app, ["validate", "/dev/zero"])
    assert "device" in one_line_exit_2(res)
    world = write_config("scenario:\n  name: beacon_field\n  world: fifo.yaml\n"
                         "filters:\n  mcl: {particles: 50}\n")
    with pytest.raises(ConfigError, match="FIFO"):
        load(world)


def test_a_paper_file_that_is_a_fifo_is_refused(tmp_path, write_config):
    (tmp_path / "papers").mkdir()
    os.mkfifo(tmp_path / "papers" / "mine.yaml")
    with pytest.raises(ConfigError, match="FIFO"):
        load(write_config(SMALL + "paper: mine\n"))


def test_a_config_path_that_is_not_utf8_validates_or_refuses_in_one_line(tmp_path):
    name = os.fsdecode(os.fsencode(str(tmp_path)) + b"/exp\xff.yaml")
    with open(os.fsencode(name), "w") as fh:
        fh.write(SMALL)
    with pytest.raises(ConfigError) as err:
        load(name)
    msg = str(err.value)
    msg.encode("utf-8")
    assert "set 'name'" in msg and "\\xff" in msg
    with open(os.fsencode(name), "w") as fh:
        fh.write("name: fine\n" + SMALL)
    exp = load(name)
    exp.source.encode("utf-8")
    res = CliRunner().invoke(app, ["validate", name, "--set", "name=null"])
    one_line_exit_2(res)


@pytest.mark.parametrize("value", ["1e308", "-1e308", "1e19", "99999999999999999999"])
def test_integer_keys_past_int64_are_refused(write_config, value):
    for key in ("trials", "seed", "filters.pf.particles", "scenario.steps"):
        with pytest.raises(ConfigError, match="2\\^63|>= "):
            load(write_config(SMALL), sets=[f"{key}={value}"])


def test_verdicts_survive_extreme_paper_values():
    from pfbench.verdicts import Claim, Estimate, Margin, decide, decide_family
    vals = [1e308, -1e308, 1e-320, 0.0, 1.0, 1.7976931348623157e308]
    for p, v, se in itertools.product(vals, [1.0, 1e308, 1e-320], [0.1, 1e308, 1e-320, 0.0]):
        for m in (None, Margin(0.1, None, "x"), Margin(None, 1e308, "x")):
            for meth in ("t", "cs"):
                for paper in (p, (min(p, -p), max(p, -p))):
                    e = Estimate(v, se, 20, meth, rho2=0.1 if meth == "cs" else None)
                    out = decide(paper, e, margin=m, paper_runs=5)
                    assert isinstance(out.text, str)
                    decide_family([Claim(paper, e, m, 5)])
    assert math.isfinite(1.0)


def test_kld_keys_have_limits_where_the_math_stops(write_config):
    from .conftest import ROOT
    base = (ROOT / "configs" / "kidnap.yaml")
    for s in ("filters.*.kld_epsilon=1e-40", "filters.*.kld_delta=3e-18",
              "filters.*.kld_bin_deg=1e-9"):
        with pytest.raises(ConfigError, match=">= "):
            load(base, sets=[s])
    with pytest.raises(ConfigError, match="bins"):
        load(base, sets=["filters.*.sampling=kld", "filters.*.reset=none",
                         "filters.*.kld_bin_m=0.001"])
