"""The trial contract: determinism across workers, resume, and independence of filters."""
import pytest
import shutil

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load
from pfbench.runner import run_experiment, run_trial
from pfbench.store import TIMING_COLUMNS

from .conftest import SMALL

runner = CliRunner()


def _numbers(path):
    df = pd.read_csv(path)
    assert not set(TIMING_COLUMNS) & set(df.columns)     # the machine's share is elsewhere
    return df


def test_trial_is_pure_and_seed_zero_is_a_seed(write_config):
    exp = load(write_config(SMALL))
    a = run_trial(exp, 3)
    b = run_trial(exp, 3)
    for ra, rb in zip(a, b):
        ra.pop("wall_s"), rb.pop("wall_s")
        assert ra == rb
    other = load(write_config(SMALL.replace("seed: 0", "seed: 1"), "other.yaml"))
    assert run_trial(other, 3)[0]["rmse"] != a[0]["rmse"]


def test_workers_do_not_change_results(tmp_path, write_config):
    exp = load(write_config(SMALL.replace("trials: 6", "trials: 9")))
    one = run_experiment(exp, tmp_path / "w1", workers=1)
    two = run_experiment(exp, tmp_path / "w2", workers=2)
    assert one.ran == two.ran == 9
    pd.testing.assert_frame_equal(_numbers(tmp_path / "w1/trials.csv"),
                                  _numbers(tmp_path / "w2/trials.csv"), check_exact=True)


def test_interrupted_then_resumed_equals_uninterrupted(tmp_path, write_config):
    exp = load(write_config(SMALL.replace("trials: 6", "trials: 8")))
    full = tmp_path / "full"
    run_experiment(exp, full)
    # Build the state of a run killed mid-write: 3 finished trials and a torn line.
    part = tmp_path / "part"
    part.mkdir()
    lines = (full / "trials.csv").read_text().splitlines(keepends=True)
    n_runs = len(exp.filters)
    (part / "trials.partial.csv").write_text("".join(lines[: 1 + 3 * n_runs])
                                             + lines[1 + 3 * n_runs][:17])
    (part / "run.json").write_text('{"experiment_hash": "%s"}' % exp.hash)
    res = run_experiment(exp, part, resume=True)
    assert res.ran == 5
    pd.testing.assert_frame_equal(_numbers(full / "trials.csv"), _numbers(part / "trials.csv"),
                                  check_exact=True)
    assert not (part / "trials.partial.csv").exists()


def test_resume_extends_a_finished_run_and_refuses_another_experiment(tmp_path, write_config):
    cfg = write_config(SMALL)
    out = tmp_path / "r"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--trials", "4"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--trials", "6", "--resume"])
    assert res.exit_code == 0, res.output
    assert "2 resumed" not in res.output and "(4 resumed)" in res.output
    ref = tmp_path / "ref"
    runner.invoke(app, ["run", str(cfg), "--out", str(ref)])
    pd.testing.assert_frame_equal(_numbers(out / "trials.csv"), _numbers(ref / "trials.csv"),
                                  check_exact=True)
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--seed", "5", "--resume"])
    assert res.exit_code == 2 and "different experiment" in res.output


def test_adding_a_filter_does_not_change_the_others(tmp_path, write_config):
    base = load(write_config(SMALL))
    more = load(write_config(SMALL.replace("filters:\n", "filters:\n  extra:\n    type: pf\n"
                                           "    label: PF2\n    particles: 7\n"), "more.yaml"))
    a = run_experiment(base, tmp_path / "a")
    b = run_experiment(more, tmp_path / "b")
    da = _numbers(tmp_path / "a/trials.csv")
    db = _numbers(tmp_path / "b/trials.csv")
    db = db[db["filter"] != "extra@7"].reset_index(drop=True)
    pd.testing.assert_frame_equal(da, db, check_exact=True)
    assert a.ran == b.ran


def test_common_random_numbers_every_filter_sees_the_same_truth(write_config):
    # Two PF runs with the same particle count but different keys share the data, not the filter
    # noise: their RMSEs differ, yet both track the same truth closely.
    exp = load(write_config(SMALL.replace("particles: [20, 40]", "particles: [2000]")
                            + "  pf_b:\n    type: pf\n    label: PFb\n    particles: 2000\n"))
    rows = run_trial(exp, 0)
    r = {row["filter"]: row["rmse"] for row in rows}
    assert r["pf@2000"] != r["pf_b@2000"]
    assert abs(r["pf@2000"] - r["pf_b@2000"]) < 0.25 * r["pf@2000"]


def test_files_of_a_run(tmp_path, write_config):
    exp = load(write_config(SMALL))
    out = tmp_path / "x"
    res = runner.invoke(app, ["run", str(write_config(SMALL)), "--out", str(out)])
    assert res.exit_code == 0, res.output
    for name in ("trials.csv", "table.csv", "table.md", "meta.json"):
        assert (out / name).exists()
    assert not list(out.glob(".*tmp*"))
    df = pd.read_csv(out / "trials.csv")
    assert len(df) == exp.trials * len(exp.filters)
    assert np.isfinite(df["rmse"]).all()
    shutil.rmtree(out)


@pytest.mark.slow
def test_ctrl_c_keeps_finished_trials_and_resume_completes_them(tmp_path, write_config):
    """A real SIGINT to a running `pfbench run --workers 2`: exit 130, one message, no traceback,
    finished trials kept; --resume then gives the uninterrupted result bit for bit."""
    import os
    import signal
    import subprocess
    import sys
    import time

    text = SMALL.replace("trials: 6", "trials: 400").replace("steps: 30", "steps: 100") \
                .replace("[20, 40]", "[20, 3000]")
    cfg = write_config(text)
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "pfbench.cli", "run", str(cfg), "--workers", "2", "--out", str(out)]
    # a shell's background job (`pytest &`, some CI runners) starts with SIGINT ignored, which
    # Python then keeps; give the run the default disposition a terminal would
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    partial = out / "trials.partial.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline and proc.poll() is None:
        if partial.exists() and len(partial.read_text().splitlines()) > 1 + 3 * 20:
            break
        time.sleep(0.1)
    assert proc.poll() is None, "the run ended before it could be interrupted"
    os.killpg(proc.pid, signal.SIGINT)          # what Ctrl-C in a terminal sends
    output, _ = proc.communicate(timeout=60)
    assert proc.returncode == 130, output
    assert "interrupted:" in output and "--resume" in output
    assert "Traceback" not in output and "Exception" not in output
    kept = len(pd.read_csv(partial)) // 3
    assert 20 <= kept < 400
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--resume", "--workers", "2"])
    assert res.exit_code == 0, res.output
    assert f"({kept} resumed)" in res.output
    ref = tmp_path / "ref"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(ref), "--workers", "2"]).exit_code == 0
    pd.testing.assert_frame_equal(_numbers(out / "trials.csv"), _numbers(ref / "trials.csv"),
                                  check_exact=True)


def test_git_commit_is_dirty_for_the_code_not_for_the_results(tmp_path):
    import subprocess

    from pfbench.runner import git_commit

    def git(*args):
        subprocess.run(["git", *args], cwd=tmp_path, check=True, capture_output=True)
    git("init", "-q")
    for name in ("pfbench/x.py", "results/r/trials.csv", "configs/c.yaml"):
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text("0\n")
    git("add", "-A")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "x")
    clean = git_commit(tmp_path)
    assert clean and not clean.endswith("-dirty")
    (tmp_path / "results/r/trials.csv").write_text("1\n")       # a run rewriting its results
    assert git_commit(tmp_path) == clean
    (tmp_path / "configs/c.yaml").write_text("1\n")
    assert git_commit(tmp_path) == clean + "-dirty"


def _python(code: str, cwd=None, **env) -> str:
    import os
    import subprocess
    import sys
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, **env}, timeout=600, cwd=cwd)
    assert res.returncode == 0, res.stderr
    return res.stdout


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
def test_importing_the_package_builds_no_kernel_and_a_run_builds_only_its_own():
    """Kernels compile (or load from the cache) on first use: importing every filter and
    scenario builds none, and a UNGM run of the PF builds no SLAM or localization kernel."""
    out = _python(
        "import gc\n"
        "import pfbench.filters, pfbench.scenarios, pfbench.config\n"
        "from pfbench._lazy import LazyKernel\n"
        "ks = [o for o in gc.get_objects() if isinstance(o, LazyKernel)]\n"
        "print(len(ks), sum(k.built for k in ks))\n"
        "from pfbench.config import validate\n"
        "from pfbench.runner import run_trial\n"       # in this process (a run's go to a child)
        "run_trial(validate({'seed': 1, 'trials': 2, 'scenario': {'name': 'ungm', "
        "'steps': 10}, 'filters': {'pf': {'particles': 20}}}, 'x.yaml'), 0)\n"
        "built = {k.__module__ for k in ks if k.built}\n"
        "print(sorted(built))\n")
    first, second = out.strip().splitlines()
    total, built = map(int, first.split())
    assert total > 100 and built == 0
    for module in ("fastslam", "mcl", "sspf_field", "swarm", "upf"):
        assert f"pfbench.filters.{module}" not in second, second
    assert "pfbench.filters.pf" in second


@pytest.mark.slow     # what a fresh interpreter loads: a speed property, checked in CI
def test_every_copy_of_the_package_shares_one_kernel_cache(tmp_path):
    """The installed copy and a checkout's file their kernels under the same cache folder (by
    the path inside the package), so the test suite reuses what a run compiled."""
    import shutil
    from pathlib import Path

    import pfbench
    root = Path(pfbench.__file__).parent
    shutil.copytree(root, tmp_path / "pfbench", ignore=shutil.ignore_patterns("__pycache__"))
    code = ("import pfbench, numba\n"
            "from pfbench.filters import pf\n"
            "from pfbench._cache import _package_locator\n"
            "loc = _package_locator().from_function(pf.pf_kernel._func, pf.__file__)\n"
            "print(pfbench.__file__); print(loc.get_cache_path())\n")
    here = _python(code, cwd=root.parent).splitlines()
    there = _python(code, cwd=tmp_path).splitlines()
    assert here[0] != there[0] and str(tmp_path) in there[0]       # two copies
    assert here[1] == there[1] and here[1].endswith("pfbench/filters")


def test_an_interruption_before_the_first_trial_says_nothing_was_saved(tmp_path):
    from pfbench.runner import Interrupted
    none = str(Interrupted(0, 5, tmp_path / "trials.partial.csv", "filter run 'pf' (type pf)"))
    assert none == ("interrupted before any of the 5 trials finished: nothing was saved (it was "
                    "running: filter run 'pf' (type pf))")
    some = str(Interrupted(2, 5, tmp_path / "trials.partial.csv"))
    assert some.startswith("interrupted: 2 of 5 trials saved in ") and "--resume" in some
