"""The trap suite (pfbench.traps): each trap fails on a plug-in filter broken the way it looks for,
says when it does not apply, and runs on pfbench's own filters; ``pfbench check`` runs from a
folder with no configs/."""
from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from pfbench import traps
from pfbench.cli import app
from pfbench.filters import FILTERS, FilterType
from pfbench.filters.keys import pf_keys
from pfbench.filters.mcl import MCL
from pfbench.traps import BROKEN, KEPT, NOT_APPLICABLE


def numpy_pf(overwrite=False, naive=False, reset=True):
    """A bootstrap PF in numpy for scalar models with Gaussian noise (f, h through the model's
    functions, the noise of ScalarModel.noise). ``overwrite``: the weights are set to the
    step's likelihood instead of multiplied by it when the step does not resample; ``naive``:
    exp of the log-weights without subtracting the largest; ``reset``: an all -inf step resets
    the weights to uniform and is counted (else the NaN goes on)."""
    def run(model, y, params, particles, state, diag=True):
        rng = np.random.default_rng(np.asarray(state, dtype=np.uint64))
        N, T = particles, y.size - 1
        _, q, _, R = model.noise            # kind 0: N(0, q) process noise
        x = model.prior_mean + np.sqrt(model.prior_var) * rng.standard_normal(N)
        lw = np.zeros(N)
        xhat = np.empty(T + 1)
        xhat[0] = x.mean()
        hx, fx = np.empty(N), np.empty(N)
        under = 0
        thr = np.inf if params["resample"] == "always" else params["neff_ratio"] * N
        for t in range(1, T + 1):
            model.transition(x, float(t), model.theta, fx)
            x = fx + np.sqrt(q) * rng.standard_normal(N)
            model.observe(x, float(t), model.theta, hx)
            ll = -0.5 * (y[t] - hx) ** 2 / R
            lw = ll if overwrite else lw + ll
            m = lw.max()
            if not np.isfinite(m) and reset:
                under += 1
                lw = np.zeros(N)
                m = 0.0
            w = np.exp(lw) if naive else np.exp(lw - m)
            w = w / w.sum()
            xhat[t] = np.sum(w * x)
            if 1.0 / np.sum(w * w) < thr:
                x = x[rng.choice(N, N, p=w)]
                lw = np.zeros(N)
            else:
                lw = np.log(w)
        return {"xhat": xhat, "lik_evals_per_step": float(N), "underflow_steps": under}
    return run


def _register(monkeypatch, name, run, schema=None, **kw):
    monkeypatch.setitem(FILTERS, name, FilterType(name, "a plug-in of the tests",
                                                  pf_keys() if schema is None else schema,
                                                  run, **kw))
    return name


def test_a_sound_plugin_filter_keeps_every_trap_that_applies(monkeypatch):
    name = _register(monkeypatch, "sound", numpy_pf())
    found = {t: traps.run_trap(t, name) for t in traps.TRAPS}
    for t in ("resampling-ulp", "resampling-one-hot", "particles-1-2", "log-weights-all-inf",
              "log-weights-far-below-0", "resample-every-ess-never"):
        assert found[t].status == KEPT, found[t].line()
    for t in ("rotated-world", "kld-bound"):     # a scalar filter without KLD-sampling
        assert found[t].status == NOT_APPLICABLE and found[t].detail, found[t].line()


def test_weights_overwritten_between_resamplings_break_the_kalman_trap(monkeypatch):
    name = _register(monkeypatch, "overwriter", numpy_pf(overwrite=True))
    f = traps.run_trap("resample-every-ess-never", name)
    assert f.status == BROKEN and "overwritten instead of multiplied" in f.detail, f.line()
    assert f.line().startswith("trap resample-every-ess-never: filter overwriter: BROKEN: ")


def test_nan_on_underflow_breaks_the_all_inf_trap(monkeypatch):
    name = _register(monkeypatch, "nanny", numpy_pf(reset=False))
    f = traps.run_trap("log-weights-all-inf", name)
    assert f.status == BROKEN and "moved to 1e200" in f.detail and "nan" in f.detail, f.line()


def test_exp_without_the_largest_breaks_the_far_below_trap(monkeypatch):
    # log-weights like [-1000, -1001]: exp gives 0 / 0 unless the largest is subtracted first
    name = _register(monkeypatch, "naive", numpy_pf(naive=True))
    f = traps.run_trap("log-weights-far-below-0", name)
    assert f.status == BROKEN and "moved by" in f.detail, f.line()


def test_a_filter_that_fails_on_two_particles_breaks_the_count_trap(monkeypatch):
    sound = numpy_pf()

    def run(model, y, params, particles, state, diag=True):
        if particles < 3:
            raise IndexError("index 2 is out of bounds for axis 0 with size 2")
        return sound(model, y, params, particles, state, diag)
    name = _register(monkeypatch, "threeplus", run)
    f = traps.run_trap("particles-1-2", name)
    assert f.status == BROKEN and "N = 2" in f.detail and "IndexError" in f.detail, f.line()


def test_a_scheme_that_indexes_past_the_end_breaks_the_resampling_traps(monkeypatch):
    from pfbench import resampling

    def broken(scheme, w, S, s, idx):       # positions against a sum taken as exactly 1
        c = np.cumsum(w)
        u = (np.arange(w.size) + 0.999999) / w.size
        idx[:] = np.searchsorted(c, u * S / c[-1] * 1.0000001)
    monkeypatch.setattr(resampling, "resample", broken)
    name = _register(monkeypatch, "sound", numpy_pf())
    f = traps.run_trap("resampling-ulp", name)
    assert f.status == BROKEN and "ulp" in f.detail and "outside [0," in f.detail, f.line()

    def always_first(scheme, w, S, s, idx):
        idx[:] = 0
    monkeypatch.setattr(resampling, "resample", always_first)
    f = traps.run_trap("resampling-one-hot", name)
    assert f.status == BROKEN and "weight 1 at particle" in f.detail, f.line()


def _mcl_with(change):
    def run(model, data, params, particles, state, diag=True):
        return change(MCL.run(model, data, params, particles, state, diag), params)
    return run


def test_a_heading_not_wrapped_breaks_the_rotated_world_trap(monkeypatch):
    def biased(out, params):            # a filter whose estimate slips where |heading| is near pi
        pose = np.array(out["pose"], dtype=float)
        pose[:, 0] += 3.0 * (np.abs(pose[:, 2]) > np.pi / 2)
        return {**out, "pose": pose}
    name = _register(monkeypatch, "unwrapped", _mcl_with(biased), MCL.schema,
                     kind="localization")
    f = traps.run_trap("rotated-world", name)
    assert f.status == BROKEN and "turned by pi" in f.detail, f.line()
    name = _register(monkeypatch, "wrapped", _mcl_with(lambda out, p: out), MCL.schema,
                     kind="localization")
    assert traps.run_trap("rotated-world", name).status == KEPT


def test_a_kld_bound_that_divides_by_k_minus_1_breaks_the_kld_trap(monkeypatch):
    def one_bin_fails(out, params):
        if params["sampling"] == "kld" and params["kld_bin_deg"] >= 360.0:    # k = 1
            traps.kld_closed_form(2, 0.05, 2.3)        # (a sound call) then the plug-in's own
            k = 1
            return {**out, "lik_evals_per_step": (k - 1) / (2 * 0.05) / (2.0 / (9 * (k - 1)))}
        return out
    name = _register(monkeypatch, "kldbug", _mcl_with(one_bin_fails), MCL.schema,
                     kind="localization")
    f = traps.run_trap("kld-bound", name)
    assert f.status == BROKEN and "one bin" in f.detail and "ZeroDivisionError" in f.detail, \
        f.line()


def test_the_closed_form_of_the_kld_bound():
    from scipy.stats import chi2
    assert traps.kld_closed_form(1, 0.05, 2.33) == 0.0
    k, eps, delta = 10 ** 5, 0.05, 0.01
    from pfbench.filters.mcl import kld_quantile
    exact = chi2.ppf(1 - delta, k - 1) / (2 * eps)
    assert abs(traps.kld_closed_form(k, eps, kld_quantile(delta)) / exact - 1) < 1e-4


@pytest.mark.parametrize("name", list(FILTERS))
def test_pfbench_own_filters_against_the_traps(name):
    for trap in traps.TRAPS:
        if trap == "resample-every-ess-never" and FILTERS[name].cost != "N":
            continue        # the swarm PFs: seconds each (pfbench check runs them)
        f = traps.run_trap(trap, name)
        assert f.detail, f.line()
        assert f.status in (KEPT, NOT_APPLICABLE), f.line()


def test_check_runs_from_a_folder_with_no_configs(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    res = CliRunner().invoke(app, ["check", "--only", "linear_gaussian", "--no-traps"])
    assert res.exit_code == 0, res.output
    assert "probes of linear_gaussian: all kept" in res.output, res.output
    assert list(tmp_path.iterdir()) == []           # nothing written where it ran
    res = CliRunner().invoke(app, ["check", "--only", "pf"])
    assert res.exit_code == 0, res.output
    for trap in traps.TRAPS:
        assert f"trap {trap}: " in res.output
    assert "does not apply to pf (a filter of no localization or SLAM scenario)" in res.output


def test_check_names_each_broken_trap_in_one_line(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _register(monkeypatch, "nanny", numpy_pf(reset=False))
    res = CliRunner().invoke(app, ["check", "--only", "nanny"])
    assert res.exit_code == 1
    lines = [ln for ln in res.output.splitlines() if ln.startswith("pfbench: contract: trap ")]
    assert lines == [ln for ln in lines if "filter nanny: BROKEN: " in ln]
    assert any(ln.startswith("pfbench: contract: trap log-weights-all-inf: filter nanny")
               for ln in lines), res.output


def test_check_refuses_an_unknown_only_in_one_line():
    from .conftest import one_line_exit_2
    line = one_line_exit_2(CliRunner().invoke(app, ["check", "--only", "nosuch"]))
    assert "--only" in line and "nosuch" in line


def test_a_filter_that_never_returns_is_stopped_and_named(monkeypatch):
    import time

    def run(model, y, params, particles, state, diag=True):
        time.sleep(3600)
    name = _register(monkeypatch, "sleeper", run)
    found = traps.filter_traps(name, ["particles-1-2"], timeout=1.0)
    assert [f.status for f in found] == [BROKEN]
    assert "did not finish within 1 s" in found[0].detail, found[0].line()


def test_list_check_is_the_same_check_from_a_folder_with_no_configs(tmp_path, monkeypatch):
    from pfbench import contract
    monkeypatch.chdir(tmp_path)        # 'list' defaults --configs to configs/, which is not here
    monkeypatch.setattr(contract, "probes", lambda: ([contract.Probe(
        "kf", "linear_gaussian", ["filter kf on scenario linear_gaussian"])], []))
    monkeypatch.setattr(traps, "TRAPS", {"particles-1-2": traps.trap_particles_1_2})
    res = CliRunner().invoke(app, ["list", "--check"])
    assert res.exit_code == 0, res.output
    assert "contract: 1 probes cover every filter and scenario: all kept" in res.output
    assert "trap particles-1-2: kept by pf" in res.output
    assert list(tmp_path.iterdir()) == []
