"""Filters that misbehave, as a plug-in's might: one that writes into its inputs changes nothing
another run sees; malformed outputs, errors and exits are one line naming the filter run; each
optional output is optional on its own."""
from __future__ import annotations

import itertools
import re
import math

import numpy as np
import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import plugins
from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.filters import FILTERS, FilterType
from pfbench.runner import run_experiment, run_trial
from pfbench.schema import Key

# what the worker processes do: runs of one worker fork theirs here too (tests/conftest.py)
pytestmark = pytest.mark.worker_processes

cli = CliRunner()

BASE = """\
seed: 3
trials: 3
scenario: {name: ungm, steps: 25}
filters:
"""
PF = "  pf: {label: PF, particles: 40}\n  ukf: {label: UKF}\n"


def _register(monkeypatch, name, run, package=None, schema=None):
    monkeypatch.setitem(FILTERS, name, FilterType(name, "a hostile filter", schema or {}, run,
                                                  particles=False))
    if package:
        monkeypatch.setitem(plugins.ORIGIN, (plugins.FILTER_GROUP, name), package)


def _vandal(model, y, params, particles, state, diag=True):
    """Writes into everything it is given, then returns a fine estimate."""
    xhat = np.full(y.size, model.prior_mean)
    y[:] = 1e6
    model.theta[:] = -7.0
    model.noise[:] = 123.0
    params["box"].append(5.0)
    params["box"][0] = 99.0
    state[:] = 0
    return {"xhat": xhat, "lik_evals_per_step": 1.0}


def test_a_filter_that_writes_into_its_inputs_changes_no_other_run(monkeypatch, write_config,
                                                                   tmp_path):
    _register(monkeypatch, "vandal", _vandal, schema={"box": Key("floats", [1.0], "a list")})
    clean = load(write_config(BASE + PF, "clean.yaml"))
    # the vandal runs first, between the pf and the ukf, and last
    for order in ("  v1: {type: vandal, label: V1}\n" + PF,
                  PF.replace("  ukf", "  v1: {type: vandal, label: V1}\n  ukf"),
                  PF + "  v1: {type: vandal, label: V1}\n"):
        exp = load(write_config(BASE + order, "hostile.yaml"))
        for k in range(exp.trials):
            want = {r["filter"]: r["rmse"] for r in run_trial(clean, k)}
            got = {r["filter"]: r["rmse"] for r in run_trial(exp, k)}
            assert {f: got[f] for f in want} == want, (order, k)
    assert list(exp.filter("v1").params["box"]) == [1.0]     # the experiment's own value stays
    # and through a run's child process, trial after trial
    a = run_experiment(clean, tmp_path / "a")
    b = run_experiment(exp, tmp_path / "b")
    rows = pd.DataFrame(b.rows)
    rows = rows[rows["filter"] != "v1"].reset_index(drop=True)
    pd.testing.assert_frame_equal(pd.DataFrame(a.rows).drop(columns="wall_s"),
                                  rows.drop(columns="wall_s"), check_exact=True)


def _returning(out):
    def run(model, y, params, particles, state, diag=True):
        return out(y.size) if callable(out) else out
    return run


GOOD = lambda n: {"xhat": np.zeros(n), "lik_evals_per_step": 1.0}     # noqa: E731

MALFORMED = {
    "a tuple": (lambda n: (np.zeros(n), 1.0), "expected a dict of outputs"),
    "a list": (lambda n: [np.zeros(n)], "expected a dict of outputs"),
    "None": (lambda n: None, "expected a dict of outputs"),
    "no xhat": (lambda n: {"lik_evals_per_step": 1.0}, "no 'xhat'"),
    "no count": (lambda n: {"xhat": np.zeros(n)}, "no 'lik_evals_per_step'"),
    "short xhat": (lambda n: {"xhat": np.zeros(n - 1), "lik_evals_per_step": 1.0},
                   "'xhat' has shape (25,), expected (26,)"),
    "2-d xhat": (lambda n: {"xhat": np.zeros((n, 1)), "lik_evals_per_step": 1.0},
                 "expected (26,)"),
    "scalar xhat": (lambda n: {"xhat": 0.0, "lik_evals_per_step": 1.0}, "expected (26,)"),
    "string xhat": (lambda n: {"xhat": np.array(["a"] * n), "lik_evals_per_step": 1.0},
                    "expected an array of real numbers"),
    "complex xhat": (lambda n: {"xhat": np.zeros(n, complex), "lik_evals_per_step": 1.0},
                     "expected an array of real numbers"),
    "object xhat": (lambda n: {"xhat": [object()] * n, "lik_evals_per_step": 1.0},
                    "expected an array of real numbers"),
    "ragged xhat": (lambda n: {"xhat": [[1.0], [1.0, 2.0]], "lik_evals_per_step": 1.0},
                    "expected an array of real numbers"),
    "NaN count": (lambda n: {**GOOD(n), "lik_evals_per_step": math.nan},
                  "'lik_evals_per_step' is float nan, expected a finite number >= 0"),
    "inf count": (lambda n: {**GOOD(n), "underflow_steps": math.inf}, "'underflow_steps'"),
    "negative count": (lambda n: {**GOOD(n), "underflow_steps": -1}, "finite number >= 0"),
    "string count": (lambda n: {**GOOD(n), "lik_evals_per_step": "1"}, "str '1'"),
    "array count": (lambda n: {**GOOD(n), "lik_evals_per_step": np.ones(3)}, "shape (3,)"),
    "huge count": (lambda n: {**GOOD(n), "lik_evals_per_step": 10 ** 400}, "finite number"),
    "short ess": (lambda n: {**GOOD(n), "ess": np.ones(n + 2)}, "'ess' has shape (28,)"),
    "string resampled": (lambda n: {**GOOD(n), "resampled": "yes"}, "'resampled'"),
    "short pvar": (lambda n: {**GOOD(n), "pvar": np.ones(n - 1)}, "'pvar' has shape (25,)"),
    "string innov": (lambda n: {**GOOD(n), "innov": "big", "innov_var": np.ones(n)},
                     "'innov' is str"),
    "2-d innov_var": (lambda n: {**GOOD(n), "innov": np.ones(n), "innov_var": np.ones((n, 2))},
                      "'innov_var' has shape (26, 2)"),
}


@pytest.mark.parametrize("case", list(MALFORMED))
def test_a_malformed_output_is_one_line_naming_the_filter(case, monkeypatch, write_config):
    out, expected = MALFORMED[case]
    _register(monkeypatch, "shabby", _returning(out), package="pfbench-shabby")
    # a filter's 'pvar' unasked, without reports=('nees',), is dropped unread: the experiment
    # asks for it (the per-step diagnostic nees) for its shape to be checked
    asks = "diagnostics: [nees]\n" if case == "short pvar" else ""
    exp = load(write_config(asks + BASE + PF + "  odd: {type: shabby, label: Odd}\n"))
    with pytest.raises(UserError) as info:
        run_trial(exp, 1)
    text = str(info.value)
    assert "\n" not in text
    assert "filter run 'odd' (type shabby) (plug-in package pfbench-shabby), trial 1" in text
    assert expected in text, text


def test_a_malformed_output_through_the_cli_is_one_line_and_exit_2(monkeypatch, write_config,
                                                                   tmp_path):
    _register(monkeypatch, "shabby", _returning(lambda n: (np.zeros(n), 1.0)))
    cfg = write_config(BASE + "  odd: {type: shabby, label: Odd}\n")
    res = cli.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    errors = [line for line in res.output.splitlines() if "error" in line]
    assert len(errors) == 1 and errors[0].startswith("pfbench: error: "), res.output
    assert "filter run 'odd' (type shabby), trial 0: returned tuple" in errors[0]


def _raising(exc):
    def run(model, y, params, particles, state, diag=True):
        raise exc
    return run


@pytest.mark.parametrize("exc,name", [(KeyError("div_l1"), "KeyError: 'div_l1'"),
                                      (ValueError("bad\nthing"), "ValueError: bad thing"),
                                      (SystemExit(3), "SystemExit: 3"),
                                      (KeyboardInterrupt(), "KeyboardInterrupt")])
def test_an_error_or_exit_inside_a_filter_is_one_line_naming_it(exc, name, monkeypatch,
                                                                 write_config, tmp_path):
    """In a run's worker process (where a KeyboardInterrupt is the filter's own: Ctrl-C goes to
    the parent) and, but for KeyboardInterrupt, in this process."""
    _register(monkeypatch, "raiser", _raising(exc), package="pfbench-raiser")
    exp = load(write_config(BASE + "  r: {type: raiser}\n"))
    with pytest.raises(UserError) as info:
        run_experiment(exp, tmp_path / "o")
    text = str(info.value)
    assert "filter run 'r' (type raiser) (plug-in package pfbench-raiser), trial" in text
    assert name in text and "\n" not in text
    if not isinstance(exc, KeyboardInterrupt):
        with pytest.raises(UserError, match="filter run 'r'"):
            run_trial(exp, 0)


OPTIONAL = ("ess", "resampled", "div_l1", "distinct", "underflow_steps")
COLUMNS = {"ess": "mean_ess", "resampled": "resample_count", "div_l1": "diversity_l1",
           "distinct": "distinct_frac"}


@pytest.mark.parametrize("subset", [s for n in range(len(OPTIONAL) + 1)
                                    for s in itertools.combinations(OPTIONAL, n)],
                         ids=lambda s: "+".join(s) or "none")
def test_each_optional_output_is_optional_on_its_own(subset, monkeypatch, write_config):
    def run(model, y, params, particles, state, diag=True):
        n = y.size
        out = {"xhat": np.zeros(n), "lik_evals_per_step": 2.0}
        full = {"ess": np.full(n, 5.0), "resampled": np.ones(n, dtype=bool),
                "div_l1": np.full(n, 0.5), "distinct": np.full(n, 0.25), "underflow_steps": 4}
        out.update({k: full[k] for k in subset})
        return out
    _register(monkeypatch, "partial", run)
    # every diagnostic asked for: one not asked is dropped whatever the filter returns
    exp = load(write_config("diagnostics: all\n" + BASE + "  p: {type: partial}\n"))
    (row,) = run_trial(exp, 0)
    want = {"mean_ess": 5.0, "resample_count": 25.0, "diversity_l1": 0.5, "distinct_frac": 0.25}
    for out, col in COLUMNS.items():
        assert (row[col] == want[col]) if out in subset else math.isnan(row[col]), (out, row)
    assert row["underflow_steps"] == (4.0 if "underflow_steps" in subset else 0.0)
    assert row["lik_evals_per_step"] == 2.0


def _dies(how):
    calls = [0]

    def run(model, y, params, particles, state, diag=True):
        import os
        import signal
        calls[0] += 1
        if calls[0] == 2:           # in trial 1 of a one-worker run
            if how == "exit":
                os._exit(7)
            import faulthandler
            faulthandler.disable()          # pytest's: no dump of this deliberate crash
            os.kill(os.getpid(), signal.SIGSEGV)
        return {"xhat": np.zeros(y.size), "lik_evals_per_step": 1.0}
    return run


@pytest.mark.parametrize("how,said", [("exit", "exit status 7"), ("crash", "killed by SIGSEGV")])
def test_a_filter_that_ends_its_process_is_named_and_the_finished_trials_kept(
        how, said, monkeypatch, write_config, tmp_path):
    _register(monkeypatch, "doomed", _dies(how))
    exp = load(write_config(BASE + "  d: {type: doomed}\n"))
    with pytest.raises(UserError) as info:
        run_experiment(exp, tmp_path / "o")
    text = str(info.value)
    assert f"a worker process ended ({said}) while running filter run 'd' (type doomed), " \
           "trial 1" in text, text
    kept = set(pd.read_csv(tmp_path / "o" / "trials.partial.csv")["trial"])
    assert 0 in kept and 1 not in kept


def test_a_runs_copy_shares_no_array_whatever_holds_them():
    """Plug-in models and data come in many shapes: plain objects, named tuples, nested
    containers, objects that refer to themselves."""
    import types
    from collections import namedtuple

    from pfbench.runner import fresh

    Data = namedtuple("Data", "y extra")
    model = types.SimpleNamespace(theta=np.arange(3.0), parts={"a": [np.ones(2)]},
                                  f=np.cumsum)
    model.me = model                                    # a cycle
    data = Data(np.zeros(4), (np.ones(1), "text"))
    m2, d2 = fresh(model), fresh(data)
    m2.theta[:] = 9
    m2.parts["a"][0][:] = 9
    d2.y[:] = 9
    d2.extra[0][:] = 9
    assert model.theta.tolist() == [0.0, 1.0, 2.0] and model.parts["a"][0].tolist() == [1, 1]
    assert data.y.tolist() == [0, 0, 0, 0] and data.extra[0].tolist() == [1.0]
    assert m2.me is m2 and m2.f is np.cumsum and isinstance(d2, Data)


def _pose_world(T=10, M=4, K=3):
    import types
    pose = np.zeros((T + 1, 3))
    pose[:, 0] = np.linspace(1, 2, T + 1)
    model = types.SimpleNamespace(landmarks=np.ones((M, 2)), bound=1.0,
                                  kidnaps=np.zeros(0, np.int64), score_from=1, report_step=0,
                                  area=np.array([10.0, 10.0]), hold=2)
    truth = types.SimpleNamespace(pose=pose)
    data = types.SimpleNamespace(obs_n=np.zeros(K, np.int64), ctrl=np.zeros((T, 3)))
    return model, truth, data


SLAM_OPTIONAL = ("ess", "resampled", "div_l1", "distinct", "lm_trace", "underflow_steps",
                 "association_errors", "dropped_frac", "map_duplicates")


@pytest.mark.parametrize("kind", ["slam", "localization"])
def test_pose_kinds_check_outputs_and_take_each_optional_one_alone(kind):
    from pfbench.kinds import KINDS, check_outputs
    k = KINDS[kind]
    model, truth, data = _pose_world()
    T1, K = truth.pose.shape[0], data.obs_n.shape[0]
    base = {"pose": truth.pose + 0.1, "lik_evals_per_step": 3.0}
    n = K if kind == "slam" else T1 - 1
    full = {"ess": np.full(n, 4.0), "resampled": np.ones(n, np.int64), "n": np.full(n, 7),
            "div_l1": np.full(n, 0.5), "distinct": np.full(n, 0.5), "lm_trace": np.ones(n),
            "underflow_steps": 1, "association_errors": 0.1, "dropped_frac": 0.2,
            "map_duplicates": 2}
    if kind == "slam":
        base.update(lm_est=np.ones((4, 2)), lm_seen=np.ones(4, bool))
        optional = SLAM_OPTIONAL
    else:
        optional = ("ess", "resampled", "n", "underflow_steps")
    for r in range(len(optional) + 1):
        for subset in itertools.combinations(optional, r):
            out = check_outputs(k, {**base, **{o: full[o] for o in subset}}, model, truth, data)
            row = k.row(model, truth, out)
            assert math.isnan(row["mean_ess"]) == ("ess" not in subset), subset
            assert math.isnan(row["resample_count"]) == ("resampled" not in subset), subset
            assert math.isfinite(row["rmse"])
    for bad, said in ((("pose", np.zeros((T1, 2))), f"expected ({T1}, 3)"),
                      (("ess", np.ones(n + 1)), f"expected ({n},)"),
                      (("lik_evals_per_step", math.nan), "finite number"),
                      (("underflow_steps", None), "finite number")):
        with pytest.raises(ValueError, match=re.escape(said)):
            check_outputs(k, {**base, bad[0]: bad[1]}, model, truth, data)
    with pytest.raises(ValueError, match="no 'pose'"):
        check_outputs(k, {"lik_evals_per_step": 1.0}, model, truth, data)
    if kind == "slam":
        said = "'lm_est' has shape (3, 2), expected (4, 2)"
        with pytest.raises(ValueError, match=re.escape(said)):
            check_outputs(k, {**base, "lm_est": np.ones((3, 2))}, model, truth, data)


class _Unpicklable(Exception):
    def __init__(self):
        super().__init__("a lock inside")
        import threading
        self.lock = threading.Lock()


class _Unprintable(Exception):
    def __str__(self):
        raise RuntimeError("no")


@pytest.mark.parametrize("exc,said", [(_Unpicklable(), "_Unpicklable: a lock inside"),
                                      (_Unprintable(), "_Unprintable: (its message cannot")])
def test_an_odd_exception_from_a_filter_is_still_one_line(exc, said, monkeypatch, write_config,
                                                          tmp_path):
    _register(monkeypatch, "odd", _raising(exc))
    exp = load(write_config(BASE + "  o: {type: odd}\n"))
    with pytest.raises(UserError) as info:
        run_experiment(exp, tmp_path / "o")         # raised in a worker, sent back
    assert "filter run 'o' (type odd), trial 0 raised " + said in str(info.value)
