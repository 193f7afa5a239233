"""The Dask executor: the in-process executor's rows bit for bit, re-run chunks of a dead worker
counted once, and a clear message without Dask. Dask is an extra (``pip install ".[dask]"``):
without it the tests that start a cluster are skipped, and those of the message run."""
import importlib.util
import os
import sys

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.runner import DaskExecutor, run_experiment
from pfbench.store import TIMING_COLUMNS

from .conftest import ROOT, SMALL

runner = CliRunner()
needs_dask = pytest.mark.skipif(importlib.util.find_spec("distributed") is None,
                                reason="Dask distributed is not installed (pip install '.[dask]')")


def _numbers(path):
    df = pd.read_csv(path)
    assert not set(TIMING_COLUMNS) & set(df.columns)
    return df


@needs_dask
def test_dask_local_cluster_gives_the_in_process_rows_and_traces(tmp_path, write_config):
    exp = load(write_config(SMALL.replace("trials: 6", "trials: 12")))
    field = load(write_config(f"trials: 5\nscenario: {{name: beacon_field, world: "
                              f"{ROOT / 'configs/worlds/beacon_field.yaml'}, steps: 20}}\n"
                              "filters: {mcl: {particles: 200}}\n", "field.yaml"))
    run_experiment(exp, tmp_path / "local", workers=1)
    run_experiment(field, tmp_path / "field_local", workers=1)
    with DaskExecutor(2) as ex:
        assert "2 Dask worker(s)" in ex.describe()
        res = run_experiment(exp, tmp_path / "dask", executor=ex)
        run_experiment(field, tmp_path / "field_dask", executor=ex)
    assert res.ran == 12 and "Dask" in res.run["executor"]
    pd.testing.assert_frame_equal(_numbers(tmp_path / "local/trials.csv"),
                                  _numbers(tmp_path / "dask/trials.csv"), check_exact=True)
    # what the figures draw comes back from the workers too
    assert (tmp_path / "field_dask/traces.npz").read_bytes() == \
        (tmp_path / "field_local/traces.npz").read_bytes()


@pytest.mark.slow
@needs_dask
def test_a_local_cluster_starts_without_a_word_while_another_holds_the_dashboards_port():
    """The local cluster has no dashboard, and its scheduler's HTTP routes take a free port: with
    8787 held (by another cluster, say) it warns of nothing."""
    import socket
    import warnings
    holder = socket.socket()
    try:
        holder.bind(("", 8787))
        holder.listen()
    except OSError:                 # held already: the case itself
        pass
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            with DaskExecutor(1) as ex:
                assert "1 Dask worker(s)" in ex.describe()
        said = [str(w.message) for w in caught]
        assert not [m for m in said if "8787" in m or "already in use" in m], said
    finally:
        holder.close()


@pytest.mark.slow
@needs_dask
def test_a_worker_that_dies_mid_run_has_its_trials_run_again_once(tmp_path, write_config):
    from distributed.comm.core import CommClosedError

    # trials of a few tens of milliseconds, so that chunks are under way when a worker dies
    cfg = ("name: slow\nseed: 5\ntrials: 40\nscenario: {name: ungm, steps: 100}\n"
           "filters:\n  pf: {particles: 20000}\n")
    exp = load(write_config(cfg))
    run_experiment(exp, tmp_path / "local", workers=1)
    with DaskExecutor(2) as ex:
        inner = ex.run
        killed = []

        def die():          # the worker process exits a moment after answering
            import threading
            threading.Timer(0.05, os._exit, args=(1,)).start()

        def run_and_kill(e, trials, count=None, traces=False):
            for chunk in inner(e, trials, count, traces):
                if not killed:
                    victim = sorted(ex.client.scheduler_info()["workers"])[0]
                    try:
                        ex.client.run(die, workers=[victim])
                    except (OSError, CommClosedError):
                        pass        # it died before its answer arrived
                    killed.append(victim)
                yield chunk

        ex.run = run_and_kill
        res = run_experiment(exp, tmp_path / "dask", executor=ex)
        assert killed and killed[0] not in ex.client.scheduler_info()["workers"]
    assert res.ran == 40
    got = _numbers(tmp_path / "dask/trials.csv")
    assert sorted(got["trial"]) == list(range(40))          # every trial once
    pd.testing.assert_frame_equal(_numbers(tmp_path / "local/trials.csv"), got, check_exact=True)


def test_without_dask_the_executor_says_how_to_install_it(monkeypatch, write_config, tmp_path):
    monkeypatch.setitem(sys.modules, "distributed", None)
    with pytest.raises(UserError, match=r"pip install 'pfbench\[dask\]'"):
        DaskExecutor(2)
    res = runner.invoke(app, ["run", str(write_config(SMALL)), "--executor", "dask", "--out",
                              str(tmp_path / "o")])
    assert res.exit_code == 2 and "pfbench[dask]" in res.output
    assert not (tmp_path / "o").exists()


def test_scheduler_without_the_dask_executor_is_refused(write_config, tmp_path):
    res = runner.invoke(app, ["run", str(write_config(SMALL)), "--scheduler", "tcp://x:1",
                              "--out", str(tmp_path / "o")])
    assert res.exit_code == 2 and "--scheduler needs --executor dask" in res.output


@needs_dask
@pytest.mark.parametrize("exc,name", [(SystemExit(3), "SystemExit: 3"),
                                      (KeyboardInterrupt(), "KeyboardInterrupt"),
                                      (ValueError("bad\nthing"), "ValueError: bad thing")])
def test_an_error_or_exit_inside_a_filter_on_a_dask_worker_is_one_line_naming_it(
        exc, name, monkeypatch, write_config, tmp_path):
    """As on the local workers: a filter's KeyboardInterrupt or SystemExit would end the Dask
    worker's task thread, and its trials wait for ever; it comes back as one line. The cluster
    runs in this process, so that the filter registered here is the workers' too."""
    import distributed

    from pfbench.filters import FILTERS, FilterType

    def run(model, y, params, particles, state, diag=True):
        raise exc
    monkeypatch.setitem(FILTERS, "raiser", FilterType("raiser", "raises", {}, run,
                                                      particles=False))
    exp = load(write_config("seed: 3\ntrials: 3\nscenario: {name: ungm, steps: 25}\n"
                            "filters:\n  r: {type: raiser}\n"))
    ex = DaskExecutor.__new__(DaskExecutor)
    ex.workers, ex.scheduler, ex.cluster = 1, None, None
    ex.client = distributed.Client(processes=False, n_workers=1, threads_per_worker=1,
                                   dashboard_address=None)
    with ex, pytest.raises(UserError) as info:
        run_experiment(exp, tmp_path / "o", executor=ex)
    text = str(info.value)
    assert "filter run 'r' (type raiser)" in text and name in text and "\n" not in text
