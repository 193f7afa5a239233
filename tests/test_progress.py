"""Progress that moves: trials handed out in units sized to their cost, the same trials whatever
the units, progress callbacks that grow to the total, an honest time left, and commands that say
what they do (issue 31, part 4)."""
import math
import re

import pandas as pd
import pytest
from typer.testing import CliRunner

import pfbench
from pfbench import runner as rn
from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.progress import time_left

from .conftest import ROOT, SMALL

# what the worker processes do: runs of one worker fork theirs here too (tests/conftest.py)
pytestmark = pytest.mark.worker_processes

cli = CliRunner()


def _sizes(units: rn.Units) -> list[int]:
    out = []
    while True:
        unit = units.next()
        if not unit:
            return out
        out.append(len(unit))


def test_heavy_trials_go_one_at_a_time_light_ones_in_larger_units(write_config):
    heavy = load(ROOT / "configs" / "ifa_fastslam.yaml")
    light = load(write_config(SMALL.replace("trials: 6", "trials: 400")))
    assert rn.trial_seconds(heavy) > rn.UNIT_SECONDS > 10 * rn.trial_seconds(light)
    # before any trial has finished: from the work of a trial, doubted (the first units small)
    assert rn.Units(heavy, range(100), 100, 2).size() == 1
    units = rn.Units(light, range(400), 400, 2)
    assert 1 <= units.size() <= 3
    tiny = load(write_config("trials: 400\nscenario: {name: ungm, steps: 10}\n"
                             "filters: {pf: {particles: 10}}\n", "tiny.yaml"))
    assert rn.Units(tiny, range(400), 400, 2).size() > 5
    # after trials were measured: a slow first unit (kernels loading) shrinks the next ones,
    # the measures that follow grow them again
    units.measured(10, 20.0)
    assert units.size() == 1
    for _ in range(4):
        units.measured(50, 0.05)
    assert units.size() == math.ceil(400 / 8)           # only a worker's share bounds it
    heavy_units = rn.Units(heavy, range(100), 100, 2)
    heavy_units.measured(1, 3.0)
    assert _sizes(heavy_units) == [1] * 100


def test_units_hand_out_every_trial_once_in_order_and_shrink_toward_the_end(write_config):
    light = load(write_config(SMALL.replace("trials: 6", "trials: 1000")))
    units = rn.Units(light, iter(range(1000)), 1000, 3)
    got, sizes = [], []
    while True:
        unit = units.next()
        if not unit:
            break
        got += unit
        sizes.append(len(unit))
        units.measured(len(unit), 1e-5 * len(unit))       # cheap: bounded by the share left
    assert got == list(range(1000))
    assert sizes[0] <= 3 and sizes[-1] == 1 and sizes[1:] == sorted(sizes[1:], reverse=True)
    assert max(sizes) <= rn.MAX_UNIT
    # count unknown: the measure alone sizes them (no share to bound them)
    unknown = rn.Units(light, iter(range(100)), -1, 2)
    unknown.measured(1, 1e-5)
    assert _sizes(unknown) == [100]


@pytest.mark.parametrize("unit_seconds,workers", [(1e-9, 2), (1e9, 3), (1e9, 1)])
def test_results_do_not_depend_on_the_units_or_the_workers(tmp_path, write_config, monkeypatch,
                                                             unit_seconds, workers):
    exp = load(write_config(SMALL.replace("trials: 6", "trials: 24")))
    ref = rn.run_experiment(exp, tmp_path / "ref", workers=1)
    monkeypatch.setattr(rn, "UNIT_SECONDS", unit_seconds)     # units of one, or of all
    sizes = []
    measured = rn.Units.measured
    monkeypatch.setattr(rn.Units, "measured",
                        lambda self, n, s: (sizes.append(n), measured(self, n, s)))
    got = rn.run_experiment(exp, tmp_path / "got", workers=workers)
    assert (tmp_path / "got/trials.csv").read_bytes() == (tmp_path / "ref/trials.csv").read_bytes()
    assert sorted(r["trial"] for r in got.rows) == sorted(r["trial"] for r in ref.rows)
    assert sum(sizes) == 24
    assert set(sizes) == {1} if unit_seconds < 1 else max(sizes) > 1


def _check_counts(calls, total):
    done = [d for d, _ in calls]
    assert done == sorted(done) and calls[-1] == (total, total)
    assert all(t == total for _, t in calls)
    assert any(0 < d < total for d in done), calls      # it moved before the end


def test_the_progress_callback_grows_to_the_total_with_two_workers(tmp_path, write_config):
    cfg = write_config(SMALL.replace("trials: 6", "trials: 12"))
    calls = []
    pfbench.run_experiment(cfg, workers=2, progress=lambda d, t: calls.append((d, t)))
    _check_counts(calls, 12)
    calls.clear()
    pfbench.run_experiment(cfg, workers=2, out=tmp_path / "o", figures=False,
                           progress=lambda d, t: calls.append((d, t)))
    assert calls[0] == (0, 12)
    _check_counts(calls, 12)


def test_run_until_decided_and_a_sweep_call_progress_as_trials_finish(tmp_path, write_config):
    from pfbench import sweep as sw
    cfg = write_config(SMALL.replace("trials: 6", "trials: 4"))
    _, cells = sw.expand(cfg, sw.parse_sets(["scenario.steps=10,20"]), {})
    calls, said = [], []
    sw.run_sweep(cells, tmp_path / "sweep", workers=2, status=said.append,
                 progress=lambda d, t: calls.append((d, t)))
    _check_counts(calls, 8)
    assert said == ["cell steps=10 (1 of 2)", "cell steps=20 (2 of 2)"]
    calls.clear()
    pfbench.run_until_decided(ROOT / "configs" / "sspf_ungm.yaml", out=tmp_path / "u",
                              trials=4, max_trials=8, figures=False,
                              overrides=["scenario.steps=10"],
                              progress=lambda d, t: calls.append((d, t)))
    done = [d for d, _ in calls]
    assert done == sorted(done) and calls[-1][0] == calls[-1][1] >= 4


def test_progress_true_draws_a_bar_and_anything_else_is_refused(tmp_path, write_config):
    cfg = write_config(SMALL)
    res = pfbench.run_experiment(cfg, progress=True)
    assert len(res.trials) == 6 * 3
    with pytest.raises(UserError, match=r"^run_experiment: progress: expected a function of "
                                        r"\(done, total\), True \(a progress bar\) or None"):
        pfbench.run_experiment(cfg, progress="yes")
    again = pfbench.run_experiment(cfg, progress=False).trials
    assert again.drop(columns="wall_s").equals(res.trials.drop(columns="wall_s"))


def test_the_time_left_is_blank_until_a_trial_finished_and_grows_while_none_does():
    assert time_left(since=0.0, base=0, done=0, total=10, now=30.0) == ""
    assert time_left(since=None, base=0, done=0, total=10, now=30.0) == ""
    assert time_left(since=0.0, base=0, done=1, total=10, now=10.0) == "0:01:30 left"
    assert time_left(since=0.0, base=0, done=1, total=10, now=20.0) == "0:03:00 left"
    # resumed trials are not this run's pace
    assert time_left(since=0.0, base=5, done=6, total=10, now=10.0) == "0:00:40 left"
    assert time_left(since=0.0, base=0, done=10, total=10, now=10.0) == ""


def test_underway_counts_the_filter_runs_finished_of_the_trials_running(write_config):
    exp = load(write_config(SMALL))          # three filter runs
    ex = rn.LocalExecutor(2)
    assert ex.underway() == 0.0
    ex._exp, ex._running = exp, [lambda: [(4, 2), (-1, -1), (7, -1), (9, 0), (3, 99)]]
    assert ex.underway() == pytest.approx(2 / 3 + 0 + 0 + 2 / 3)
    ex._running = [lambda: 1 / 0]            # a pool torn down
    assert ex.underway() == 0.0


@pytest.fixture
def folders(tmp_path):
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    (configs / "one.yaml").write_text(SMALL.replace("trials: 6", "name: one\ntrials: 3"))
    (configs / "two.yaml").write_text(SMALL.replace("trials: 6", "name: two\ntrials: 2"))
    return configs, results


@pytest.fixture
def on_terminal(monkeypatch):
    """The CLI's stderr as a terminal, the words of its spinner recorded (a spinner draws them
    only now and then)."""
    from pfbench import cli as c
    said = []

    class Status:
        def __init__(self, text):
            said.append(text)

        def __enter__(self):
            return self

        def __exit__(self, *exc):
            return None

        def update(self, text):
            said.append(text)
    monkeypatch.setattr(c.err, "_force_terminal", True)
    monkeypatch.setattr(c.err, "status", lambda text, **kw: Status(text))
    return said


def test_tables_and_report_say_what_they_do_on_a_terminal(folders, tmp_path, on_terminal):
    configs, results = folders
    r = cli.invoke(app, ["tables", "--configs", str(configs), "--results", str(results),
                         "--no-figures"])
    assert r.exit_code == 0, r.output
    assert r.stdout == ""
    for line in (f"report: reading {results / 'one'} (1 of 2)",
                 f"report: reading {results / 'two'} (2 of 2)",
                 "report: drawing the figures of one (1 of 2)",
                 f"report: writing {results / 'REPORT.md'}"):
        assert any(line in s for s in on_terminal), on_terminal
    on_terminal.clear()
    r = cli.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                         "--out", str(tmp_path / "rep")])
    assert r.exit_code == 0, r.output
    assert r.stdout == ""
    assert len([s for s in on_terminal if s.startswith("report: ")]) >= 6
    # the last message says what was written (wrapped over lines where its paths are long)
    lines = r.stderr.splitlines()
    last = max(k for k, line in enumerate(lines) if line.startswith("wrote "))
    assert not any(line.startswith("report: ") for line in lines[last:]), lines
    on_terminal.clear()
    r = cli.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                         "--out", str(tmp_path / "rep"), "--check"])
    assert r.exit_code == 0 and any("report: comparing with" in s for s in on_terminal)


def test_in_a_log_report_says_only_its_result_or_its_one_line_error(folders, tmp_path):
    configs, results = folders
    r = cli.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                         "--out", str(tmp_path / "rep")])
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1, r.output
    assert cli.invoke(app, ["tables", "--configs", str(configs), "--results", str(results),
                            "--no-figures"]).exit_code == 0
    r = cli.invoke(app, ["report", "--configs", str(configs), "--results", str(results),
                         "--out", str(tmp_path / "rep")])
    assert r.exit_code == 0 and "report: " not in r.stderr, r.stderr


def test_report_from_python_tells_its_status(folders, tmp_path):
    from pfbench import report
    configs, results = folders
    assert cli.invoke(app, ["tables", "--configs", str(configs), "--results", str(results),
                            "--no-figures"]).exit_code == 0
    said = []
    report.write_report(configs, results, tmp_path / "rep", status=said.append)
    assert [s for s in said if s.startswith("reading")] == [
        f"reading {results / 'one'} (1 of 2)", f"reading {results / 'two'} (2 of 2)"]
    assert re.match(r"writing .*REPORT\.md and .*report$", said[-1])


def test_sweep_says_it_writes_its_figures(write_config, tmp_path, on_terminal):
    cfg = write_config(SMALL.replace("trials: 6", "trials: 2"))
    r = cli.invoke(app, ["sweep", str(cfg), "--set", "scenario.steps=10,20", "--out",
                         str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    assert any(f"sweep: writing {tmp_path / 's'}/summary.csv and the figures" in t
               for t in on_terminal), on_terminal
    assert "sweep:" not in r.stdout
    assert pd.read_csv(tmp_path / "s" / "summary.csv")["trials"].tolist() == [2] * 6


def test_a_progress_callback_that_raises_stops_the_run_and_its_workers(tmp_path, write_config):
    import multiprocessing as mp
    cfg = write_config(SMALL.replace("trials: 6", "trials: 40"))

    def stop(done, total):
        if done:
            raise RuntimeError("enough")
    with pytest.raises(RuntimeError, match="enough"):
        pfbench.run_experiment(cfg, workers=2, out=tmp_path / "o", progress=stop)
    assert not mp.active_children()
    # the trials saved before it are kept: a resume runs the rest, the same trials
    res = pfbench.run_experiment(cfg, workers=2, out=tmp_path / "o", resume=True)
    ref = pfbench.run_experiment(cfg, workers=1, out=tmp_path / "ref")
    assert res.run["trials_run_now"] < 40
    assert (tmp_path / "o/trials.csv").read_bytes() == (tmp_path / "ref/trials.csv").read_bytes()
    assert ref.run["trials_run_now"] == 40


def test_trials_of_unknown_count_are_handed_out_too(write_config):
    exp = load(write_config(SMALL))
    got = [t.index for chunk in rn.execute(exp, iter(range(6)), 2) for t in chunk]
    assert sorted(got) == list(range(6))


def test_a_run_whose_kernels_compile_says_so_in_a_log(write_config, tmp_path, monkeypatch):
    monkeypatch.setattr(rn, "uncompiled", lambda exp: ["pf", "ungm"])
    r = cli.invoke(app, ["run", str(write_config(SMALL)), "--out", str(tmp_path / "o"),
                         "--no-figures"])
    assert r.exit_code == 0, r.output
    lines = r.stderr.splitlines()
    at = lines.index("pfbench: compiling the pf, ungm kernels (first run only) ...")
    assert lines[at - 1].startswith("exp: 6 trials of ungm")      # after the run's header
    monkeypatch.setattr(rn, "uncompiled", lambda exp: [])
    r = cli.invoke(app, ["run", str(write_config(SMALL)), "--out", str(tmp_path / "o"),
                         "--no-figures", "--force"])
    assert r.exit_code == 0 and "compiling" not in r.stderr
