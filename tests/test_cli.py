import json

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench import __version__
from pfbench.cli import app

from .conftest import ROOT, SMALL

runner = CliRunner()


def test_version():
    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and __version__ in res.output


def test_the_installed_version_is_the_packages():
    """pyproject.toml reads the version from pfbench/version.py: what pip installed says the
    same as ``pfbench.__version__``, and the file holds it as a literal the build can read."""
    import ast
    from importlib.metadata import version
    assert version("pfbench") == __version__
    tree = ast.parse((ROOT / "pfbench" / "version.py").read_text())
    literal = [n.value.value for n in tree.body if isinstance(n, ast.Assign)
               and [t.id for t in n.targets] == ["__version__"]
               and isinstance(n.value, ast.Constant)]
    assert literal == [__version__]


def test_list_names_every_registry_entry():
    res = runner.invoke(app, ["list", "--configs", str(ROOT / "configs")])
    assert res.exit_code == 0
    for word in ("ungm", "linear_gaussian", "pf", "ukf", "kf", "systematic", "residual",
                 "multinomial", "stratified", "ifa_pf_ungm.yaml", "sspf_ungm.yaml"):
        assert word in res.output


def test_validate_ok(write_config):
    res = runner.invoke(app, ["validate", str(write_config(SMALL))])
    assert res.exit_code == 0 and "ok" in res.output and "pf@20" in res.output


def test_end_to_end_paper_config_with_few_trials(tmp_path):
    out = tmp_path / "ifa"
    res = runner.invoke(app, ["run", str(ROOT / "configs/ifa_pf_ungm.yaml"), "--trials", "4",
                              "--set", "filters.pf_floor.particles=300",
                              "--set", "compare.floor=pf_floor@300", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "PF" in res.output and "4.2216" in res.output
    tab = pd.read_csv(out / "table.csv")
    pf50 = tab[(tab["label"] == "PF") & (tab["particles"] == 50)].iloc[0]
    assert pf50["paper_rmse_mean"] == 4.2216
    assert abs(pf50["ratio_rmse_mean"] - pf50["rmse_mean"] / 4.2216) < 1e-12
    assert isinstance(pf50["verdict_rmse_mean"], str) and pf50["verdict_rmse_mean"]
    meta = json.loads((out / "meta.json").read_text())
    assert meta["trials"] == 4 and meta["seed"] == 2021 and meta["experiment_hash"]
    assert "Paper: `ifa2021`" in (out / "table.md").read_text()


@pytest.mark.slow
def test_bench_quick_writes_records(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)          # the FastSLAM row reads configs/worlds/ifa_course.yaml
    path = tmp_path / "b.json"
    res = runner.invoke(app, ["bench", "--quick", "--json", str(path)])
    assert res.exit_code == 0, res.output
    recs = json.loads(path.read_text())
    run = [r for r in recs if r["workload"] == "run"]        # what ran: command, cores, versions
    assert len(run) == 1 and run[0]["command"] == "pfbench bench --quick"
    recs = [r for r in recs if r["workload"] != "run"]
    # what `pfbench run` runs beside the bare kernel, per family, with its ratio and target
    path_recs = [r for r in recs if r["workload"] == "run-path"]
    assert {r["impl"] for r in path_recs} == {"kernel", "run"}
    assert {r["filter"] for r in path_recs if "run_over_kernel" in r} == {"ungm", "mcl",
                                                                          "fastslam"}
    recs = [r for r in recs if r["workload"] != "run-path"]
    keys = {"workload", "impl", "particles", "trials", "steps", "particle_steps_per_s"}
    assert all(keys <= set(r) for r in recs)
    assert {r["impl"] for r in recs} == {"pfbench", "numpy"}
    assert {r["workload"] for r in recs} == {"ungm", "ungm-filters", "fastslam-course",
                                             "afsa-world", "mcl-beacon-field", "kld-mcl-global",
                                             "sspf-field"}
    # KLD-MCL and the field SSPF: the particles each step drew, at most the N allowed
    for r in recs:
        if r["workload"] in ("kld-mcl-global", "sspf-field"):
            assert 0 < r["mean_particles"] <= r["particles"]
            assert r["particle_steps_per_s"] == pytest.approx(
                r["mean_particles"] * r["steps_per_s"])
    mcl = {(r["impl"], r["particles"]): r for r in recs if r["workload"] == "mcl-beacon-field"}
    assert set(mcl) == {(i, n) for i in ("pfbench", "numpy") for n in (1000, 10_000)}
    # the same filter tracking the same 2 trials (--quick): mean position errors ~0.13 m with a
    # standard error ~0.01 each
    for n in (1000, 10_000):
        a, b = (mcl[(i, n)]["mean_position_error"] for i in ("pfbench", "numpy"))
        assert a < 0.5 and b < 0.5 and abs(a - b) < 0.06
    afsa = [r for r in recs if r["workload"] == "afsa-world"]
    assert {r["particles"] for r in afsa} == {10, 100}
    by = {(r["filter"], r["particles"]): r for r in afsa}
    assert by[("FastSLAM", 10)]["relative_to_fastslam"] == 1.0
    assert by[("AFSA-FastSLAM", 10)]["evals_per_step"] == 6 * 10     # N + 4N + N
    assert by[("PSO-FastSLAM", 100)]["evals_per_step"] == 3 * 100
    fs = {r["impl"]: r["steps_per_s"] for r in recs if r["workload"] == "fastslam-course"}
    assert set(fs) == {"pfbench", "numpy"} and min(fs.values()) > 0
    assert all(r["particle_steps_per_s"] > 0 for r in recs)
    from pfbench.filters import FILTERS
    costs = {r["filter"] for r in recs if r["workload"] == "ungm-filters"}
    assert costs == {n for n, f in FILTERS.items() if f.scenarios is None and f.kind == "scalar"}
    assert "pf" in costs
    batch = {r["impl"]: r["mean_rmse"] for r in recs if r.get("mode") == "batch"}
    # same filter on the same data: mean RMSEs agree within Monte Carlo error (spread ~1 / sqrt(100))
    assert abs(batch["pfbench"] - batch["numpy"]) < 0.5


def test_bench_only_runs_the_parts_named(tmp_path, monkeypatch):
    monkeypatch.chdir(ROOT)
    path = tmp_path / "b.json"
    res = runner.invoke(app, ["bench", "--quick", "--only", "mcl", "--json", str(path)])
    assert res.exit_code == 0, res.output
    recs = json.loads(path.read_text())
    assert {r["workload"] for r in recs} == {"mcl-beacon-field", "kld-mcl-global", "sspf-field",
                                           "run"}
    run = next(r for r in recs if r["workload"] == "run")     # what ran, without --json
    assert run["command"] == "pfbench bench --quick --only mcl"
    assert "UNGM" not in res.output
    res = runner.invoke(app, ["bench", "--only", "nosuch"])
    assert res.exit_code == 2 and "parts: ungm, costs, fastslam, afsa, mcl" in res.output
    res = runner.invoke(app, ["bench", "--only", "mcl", "--c-ref", str(path)])
    assert res.exit_code == 2 and "--only ungm" in res.output


def test_run_writes_figures_unless_told_not_to(tmp_path, write_config):
    out = tmp_path / "f"
    res = runner.invoke(app, ["run", str(write_config(SMALL)), "--out", str(out)])
    assert res.exit_code == 0, res.output
    png = (out / "figures" / "rmse.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    res = runner.invoke(app, ["run", str(write_config(SMALL)), "--out", str(tmp_path / "g"),
                              "--no-figures"])
    assert res.exit_code == 0 and not (tmp_path / "g" / "figures").exists()


def test_slam_run_draws_the_course_and_the_error_over_time(tmp_path):
    world = ROOT / "configs/worlds/ifa_course.yaml"
    cfg = tmp_path / "fs.yaml"
    cfg.write_text(f"seed: 1\ntrials: 2\nscenario: {{name: waypoint_course, world: {world}, "
                   "steps: 300}\nfilters: {fastslam: {label: FastSLAM, particles: 10}}\n")
    out = tmp_path / "fs"
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert res.exit_code == 0, res.output
    for name in ("rmse.png", "course.png", "errors.png", "ess.png"):
        assert (out / "figures" / name).read_bytes()[:4] == b"\x89PNG"


def test_the_shipped_afsa_config_runs_small_and_prints_its_tables(tmp_path):
    out = tmp_path / "afsa"
    res = runner.invoke(app, ["run", str(ROOT / "configs/afsa_fastslam.yaml"), "--trials", "2",
                              "--set", "scenario.steps=150", "--out", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "AFSA-FastSLAM / PSO-FastSLAM" in res.output and "0.0829" in res.output
    wide = runner.invoke(app, ["run", str(ROOT / "configs/afsa_fastslam.yaml"), "--trials", "2",
                               "--set", "scenario.steps=150", "--out", str(out), "--wide",
                               "--no-figures"])
    assert "AFSA-FastSLAM / PSO-FastSLAM: paper 0.0829" in wide.output
    assert "paper: directional" in wide.output
    md = (out / "table.md").read_text()
    assert "| paper: traditional | 0.42 |" in md and "not comparable: 0.336 as printed" in md
    trials = pd.read_csv(out / "trials.csv")
    fs = trials[trials["filter"].str.startswith("afsa@")]
    assert (fs["lik_evals_per_step"] == 60).all() and fs["distinct_frac"].notna().all()


UNTIL = """\
paper: ifa2021
table: table1
seed: 4
trials: 6
scenario: {name: ungm, steps: 30}
filters:
  pf: {label: PF, particles: 50}
  ba: {label: BA-PF, particles: 50, iterations: 1}
"""


def test_run_until_decided_adds_batches_and_keeps_its_intervals(tmp_path, write_config):
    from pfbench.api import load_results
    out = tmp_path / "u"
    cfg = write_config(UNTIL)
    res = runner.invoke(app, ["run", str(cfg), "--until-decided", "--max-trials", "18",
                              "--out", str(out), "--no-figures"])
    assert res.exit_code == 0, res.output
    meta = json.loads((out / "meta.json").read_text())
    until = meta["until_decided"]
    assert until["max_trials"] == 18 and until["batch"] == 6
    looks = [k["trials"] for k in until["looks"]]
    assert looks == list(range(6, looks[-1] + 1, 6)) and looks[-1] <= 18
    trials = pd.read_csv(out / "trials.csv")
    assert trials["trial"].nunique() == looks[-1] == meta["trials"]
    assert "until decided:" in res.output and until["stopped"] in res.output.replace("\n", " ")
    # every verdict on a confidence sequence for 18 trials, and recomputed the same from the folder
    tab = pd.read_csv(out / "table.csv")
    assert set(tab["kind_rmse_mean"].dropna()) <= {"reproduced", "differs", "inconclusive"}
    again = load_results(out)
    assert list(again.table["verdict_rmse_mean"]) == list(tab["verdict_rmse_mean"])
    assert again.comparison.anytime == 18
    md = (out / "table.md").read_text()
    assert "confidence sequence" in md and "Run until decided: batches of 6 trials" in md
    # the trials are those of a plain run of the same count, bit for bit
    plain = tmp_path / "p"
    res = runner.invoke(app, ["run", str(cfg), "--trials", str(looks[-1]), "--out", str(plain),
                              "--no-figures"])
    assert res.exit_code == 0, res.output
    a = trials.sort_values(["trial", "filter"]).reset_index(drop=True)
    b = pd.read_csv(plain / "trials.csv").sort_values(["trial", "filter"]).reset_index(drop=True)
    pd.testing.assert_frame_equal(a, b)


def test_until_decided_refuses_what_it_cannot_do(tmp_path, write_config):
    cfg = write_config(UNTIL)
    for args, words in ((["--max-trials", "10"], "--max-trials goes with --until-decided"),
                        (["--until-decided", "--max-trials", "3"], "below the first batch"),):
        res = runner.invoke(app, ["run", str(cfg), "--out", str(tmp_path / "x"), *args])
        assert res.exit_code == 2 and words in res.output, res.output
    res = runner.invoke(app, ["run", str(write_config(SMALL, "s.yaml")), "--until-decided",
                              "--out", str(tmp_path / "y")])
    assert res.exit_code == 2 and "needs a paper's table" in res.output, res.output
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_a_folder_of_another_experiment_is_refused_and_the_same_one_is_up_to_date(
        tmp_path, write_config):
    """run into a results folder: another experiment's (or more of this one's) trials are
    refused with what differs, untouched; the same trials say 'up to date' and change no byte;
    more trials keep the ones there; --force replaces."""
    from .conftest import one_line_exit_2, tree
    cfg = write_config(SMALL)
    out = tmp_path / "o"
    args = ["run", str(cfg), "--out", str(out), "--no-figures"]
    assert runner.invoke(app, args).exit_code == 0
    before = tree(out)
    res = runner.invoke(app, args)
    assert res.exit_code == 0 and "is up to date" in res.output, res.output
    assert tree(out) == before                                  # not a byte changed
    line = one_line_exit_2(runner.invoke(app, args + ["--seed", "5", "--set",
                                                      "scenario.steps=20"]))
    assert "another experiment" in line and "seed 0 -> 5" in line \
        and "scenario.steps 30 -> 20" in line and "--force" in line
    line = one_line_exit_2(runner.invoke(app, args + ["--set", "filters.pf.particles=[20]"]))
    assert "filter runs pf@40 not in this config" in line
    line = one_line_exit_2(runner.invoke(app, args + ["--trials", "3"]))
    assert "holds 6 trials of this experiment" in line and "--trials 6 keeps them" in line
    assert tree(out) == before
    # more trials: the six there are kept (not run again), two more run
    res = runner.invoke(app, args + ["--trials", "8"])
    assert res.exit_code == 0 and "2 trials" in res.output and "(6 resumed)" in res.output
    assert json.loads((out / "meta.json").read_text())["trials"] == 8
    # --force replaces another experiment's folder
    res = runner.invoke(app, args + ["--seed", "5", "--force"])
    assert res.exit_code == 0, res.output
    assert json.loads((out / "meta.json").read_text())["seed"] == 5


def test_an_unfinished_run_of_another_experiment_is_refused(tmp_path, write_config):
    from .conftest import one_line_exit_2, tree
    out = tmp_path / "o"
    out.mkdir()
    (out / "run.json").write_text(json.dumps({"experiment": "x", "experiment_hash": "abc",
                                              "trials": 9}))
    (out / "trials.partial.csv").write_text("trial,filter\n")
    before = tree(out)
    line = one_line_exit_2(runner.invoke(app, ["run", str(write_config(SMALL)), "--out",
                                               str(out), "--no-figures"]))
    assert "unfinished trials of another experiment" in line and "'x'" in line
    assert tree(out) == before
    for stamp in ("{not json", '{"experiment_hash": "abc", "trials": "many"}',
                  '{"experiment_hash": 7}', '[1, 2]'):
        (out / "run.json").write_text(stamp)
        line = one_line_exit_2(runner.invoke(app, ["run", str(write_config(SMALL)), "--out",
                                                   str(out), "--no-figures"]))
        assert "unreadable" in line and "--force" in line, stamp
    # an identity edited by hand still gets a one-line answer (from the hashes)
    (out / "run.json").write_text(json.dumps({"experiment": "x", "experiment_hash": "abc",
                                              "identity": {"filters": [1, 2]}}))
    line = one_line_exit_2(runner.invoke(app, ["run", str(write_config(SMALL)), "--out",
                                               str(out), "--no-figures"]))
    assert "another experiment" in line


def test_loading_the_kernels_is_never_silent_when_it_takes_long(tmp_path, monkeypatch, capsys):
    """Before any config is read, a first run (no compiled kernel in the cache) says it is
    compiling; in a log one line, where loading from a warm cache says nothing."""
    import sys

    import pfbench
    from pfbench import cli
    monkeypatch.delitem(sys.modules, "pfbench.filters")
    monkeypatch.setattr(pfbench, "CACHE_DIR", tmp_path)
    with cli._kernels():
        pass
    assert "compiling the filters' numba kernels (first run only" in capsys.readouterr().err
    (tmp_path / "k.nbi").write_bytes(b"")
    with cli._kernels():
        pass
    assert capsys.readouterr().err == ""


def test_a_run_and_a_sweep_do_not_take_each_others_folder(tmp_path, write_config):
    from .conftest import one_line_exit_2, tree
    cfg = write_config(SMALL)
    out = tmp_path / "s"
    res = runner.invoke(app, ["sweep", str(cfg), "--out", str(out), "--trials", "2",
                              "--set", "scenario.steps=10,20", "--no-figures"])
    assert res.exit_code == 0, res.output
    before = tree(out)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out),
                                               "--no-figures"]))
    assert "holds a sweep's results" in line and tree(out) == before
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures", "--force"])
    assert res.exit_code == 0, res.output
    assert not (out / "cells").exists() and not (out / "summary.csv").exists()
    before = tree(out)
    line = one_line_exit_2(runner.invoke(app, ["sweep", str(cfg), "--out", str(out),
                                               "--trials", "2", "--set", "scenario.steps=10,20"]))
    assert "holds the results of a run" in line and tree(out) == before
    # trials without a stamp that says whose they are
    lone = tmp_path / "lone"
    lone.mkdir()
    (lone / "trials.csv").write_text("trial,filter\n")
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(lone)]))
    assert "no meta.json or run.json describes" in line


def test_every_help_text_shows_its_brackets():
    # rich reads "[peers]" in a help text as markup and drops it; a literal bracket must be
    # escaped, and every command's --help must show the brackets its options' help texts hold
    import re

    import typer.main
    group = typer.main.get_command(app)
    for name, cmd in group.commands.items():
        res = runner.invoke(app, [name, "--help"], env={"COLUMNS": "400"}, terminal_width=400)
        assert res.exit_code == 0, name
        shown = " ".join(res.output.split())
        for param in cmd.params:
            text = " ".join((getattr(param, "help", None) or "").split()).replace("\\[", "[")
            for bracket in re.findall(r"\[[^\]]*\]", text):
                assert bracket in shown, (name, param.name, bracket)
