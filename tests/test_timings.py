"""What the machine determines (the run times) lives apart from what the seed determines: a rerun
of an experiment leaves its results folder as it was, byte for byte, and the timings file holds
the run times (issue 17, part 4)."""
import csv
import io
import json
import shutil
import subprocess

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.api import load_results, run_experiment as api_run
from pfbench.cli import app
from pfbench.config import load
from pfbench.runner import keep_provenance, run_experiment
from pfbench.store import read_timings, read_trials, row_crc, trial_columns

from .conftest import ROOT, TINY

runner = CliRunner()
TIMING_FILES = ("timings.csv", "timings.json")


def _committed(folder):
    """The files of a results folder that a project commits, with their bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file() and not p.name.startswith("timings.")}


def test_a_forced_rerun_leaves_the_results_folder_byte_for_byte(tmp_path, write_config):
    cfg = write_config(TINY)
    out = tmp_path / "o"
    first = runner.invoke(app, ["run", str(cfg), "--out", str(out)])
    assert first.exit_code == 0, first.output
    before = _committed(out)
    assert {"trials.csv", "meta.json", "table.csv", "table.md"} <= set(before)
    assert any(k.startswith("figures/") for k in before)
    took = json.loads((out / "timings.json").read_text())
    again = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--force", "--workers", "2"])
    assert again.exit_code == 0, again.output
    assert _committed(out) == before
    # the run times went to the timings file, one per filter run of every trial
    timings = read_timings(out)
    assert len(timings) == 4 * 3 and all(w > 0 for w in timings.values())
    assert json.loads((out / "timings.json").read_text())["workers"] == 2 != took["workers"]
    # and nowhere in what the folder commits
    meta = json.loads((out / "meta.json").read_text())
    assert not {"wall_s", "started", "finished", "workers", "argv"} & set(meta)
    assert "wall_s" not in (out / "trials.csv").read_text().splitlines()[0]


def test_the_console_shows_run_times_and_the_files_leave_them_out(tmp_path):
    out = tmp_path / "u"
    res = runner.invoke(app, ["run", str(ROOT / "configs/ifa_pf_ungm.yaml"), "--trials", "2",
                              "--out", str(out), "--no-figures", "--wide"])
    assert res.exit_code == 0, res.output
    assert "ms/trial" in res.output
    md = (out / "table.md").read_text()
    assert "ms/trial" not in md and "leaves out our value of 'time / PF'" in md
    tab = pd.read_csv(out / "table.csv")
    assert tab["wall_ms_per_trial"].isna().all() and tab["ours_time_ratio"].isna().all()
    # the verdict on cost is judged on the evaluations, so it is there without the run times
    cell = tab.set_index("filter").loc["fa@100", "verdict_time_ratio"]
    assert "judged on evals ratio" in cell
    # the Python API and load_results give the run times beside the trials
    back = load_results(out)
    assert back.trials["wall_s"].notna().all() and back.run["trials_run_now"] == 2
    assert back.comparison.timed and not back.comparison.without_timings().timed
    (out / "timings.csv").unlink()
    (out / "timings.json").unlink()
    bare = load_results(out)
    assert bare.trials["wall_s"].isna().all() and bare.run is None
    assert list(bare.table["verdict_time_ratio"]) == list(back.table["verdict_time_ratio"])


def _legacy(text: str, walls: dict) -> str:
    """A trials file as pfbench wrote it before the timings file: wall_s before crc, which
    covers it."""
    rows = list(csv.reader(io.StringIO(text)))
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(rows[0][:-1] + ["wall_s", "crc"])
    for r in rows[1:]:
        fields = r[:-1] + [repr(walls[(int(r[0]), r[1])])]
        w.writerow(fields + [row_crc(fields)])
    return out.getvalue()


def test_an_older_trials_file_with_wall_times_reads_and_resumes(tmp_path, write_config):
    exp = load(write_config(TINY))
    fresh = tmp_path / "fresh"
    run_experiment(exp, fresh, traces=False)
    walls = {k: 0.5 + 0.001 * i for i, k in enumerate(sorted(read_timings(fresh)))}
    old = tmp_path / "old"
    shutil.copytree(fresh, old)
    for name in ("timings.csv", "timings.json"):
        (old / name).unlink()
    (old / "trials.csv").write_text(_legacy((fresh / "trials.csv").read_text(), walls))
    meta = json.loads((old / "meta.json").read_text())     # the meta.json of that format: no
    for key in ("trials_sha256", "trials_rows"):            # checksum of its trials file
        meta.pop(key, None)
    (old / "meta.json").write_text(json.dumps(meta))
    got = read_trials(old / "trials.csv", trial_columns(exp))
    assert not got.rejected and {(r["trial"], r["filter"]): r["wall_s"] for r in got.rows} == walls
    # an edited wall time still fails the checksum that covered it
    lines = (old / "trials.csv").read_text().splitlines(keepends=True)
    edited = lines[:2] + [lines[2].replace(",0.50", ",0.70", 1)] + lines[3:]
    assert edited != lines
    (tmp_path / "edited.csv").write_text("".join(edited))
    assert set(read_trials(tmp_path / "edited.csv").rejected) == {int(lines[2].split(",")[0])}
    # up to date: the table comes from it, with its wall times
    res = run_experiment(exp, old, traces=False)
    assert res.up_to_date and all(r["wall_s"] == walls[(r["trial"], r["filter"])]
                                  for r in res.rows)
    # resumed into more trials: the old rows move to the new format, their times to timings.csv
    more = load(write_config(TINY.replace("trials: 4", "trials: 5"), "more.yaml"))
    run_experiment(more, old, resume=True, traces=False)
    run_experiment(more, fresh, resume=True, traces=False)
    assert (old / "trials.csv").read_bytes() == (fresh / "trials.csv").read_bytes()
    assert {k: v for k, v in read_timings(old).items() if k[0] < 4} == walls


def test_a_regeneration_keeps_the_provenance_of_unchanged_trials(tmp_path, write_config):
    exp = load(write_config(TINY))
    a, b = tmp_path / "a", tmp_path / "b"
    run_experiment(exp, a, traces=False)
    shutil.copytree(a, b)
    meta = json.loads((a / "meta.json").read_text())
    meta.update(git_commit="0" * 40, host="elsewhere")
    (a / "meta.json").write_text(json.dumps(meta))
    keep_provenance(b, a)        # b replaces a: same trials, so a's provenance stays
    kept = json.loads((b / "meta.json").read_text())
    assert kept["git_commit"] == "0" * 40 and kept["host"] == "elsewhere"
    other = load(write_config(TINY.replace("seed: 0", "seed: 1"), "other.yaml"))
    c = tmp_path / "c"
    run_experiment(other, c, traces=False)
    keep_provenance(c, a)        # other trials: their own provenance
    assert json.loads((c / "meta.json").read_text())["git_commit"] != "0" * 40


def test_the_provenance_is_taken_beside_the_trials(tmp_path, write_config, monkeypatch):
    """The git commit of a run's meta.json is asked for in a thread while its trials run (git's
    commands no longer follow the last trial), and meta.json holds it with the rest of the
    provenance; where the thread fails, it is asked for again after the trials."""
    import threading

    import pfbench.runner as runner_module
    asked = []

    def commit(cwd=None):
        asked.append(threading.current_thread() is threading.main_thread())
        return "c" * 40
    monkeypatch.setattr(runner_module, "git_commit", commit)
    exp = load(write_config(TINY))
    run_experiment(exp, tmp_path / "a", traces=False)
    meta = json.loads((tmp_path / "a" / "meta.json").read_text())
    assert asked == [False] and meta["git_commit"] == "c" * 40
    assert set(runner_module.PROVENANCE) <= set(meta)
    assert meta["versions"] == runner_module.versions()

    def not_in_a_thread(cwd=None):
        if threading.current_thread() is not threading.main_thread():
            raise RuntimeError("not here")
        return "d" * 40
    monkeypatch.setattr(runner_module, "git_commit", not_in_a_thread)
    run_experiment(exp, tmp_path / "b", traces=False)
    assert json.loads((tmp_path / "b" / "meta.json").read_text())["git_commit"] == "d" * 40


def test_a_sweep_keeps_its_run_times_apart(tmp_path, write_config):
    cfg = write_config(TINY)
    out = tmp_path / "s"
    res = runner.invoke(app, ["sweep", str(cfg), "--set", "scenario.steps=5,8", "--out", str(out)])
    assert res.exit_code == 0, res.output
    assert "ms/trial" in res.output
    assert "wall_s" not in pd.read_csv(out / "trials.csv")
    assert not any("wall_s" in c for c in pd.read_csv(out / "summary.csv").columns)
    assert not (out / "figures" / "wall_s.png").exists() and (out / "timings.png").exists()
    timings = pd.read_csv(out / "timings.csv")
    assert len(timings) == 2 * 4 * 3 and (timings["wall_s"] > 0).all()


def test_git_leaves_the_timings_files_out_of_the_results():
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    paths = ["results/x/timings.csv", "results/x/timings.partial.csv", "results/x/timings.json",
             "results/x/timings.png", "results/x/cells/a=1/timings.csv"]
    got = subprocess.run(["git", "check-ignore", *paths], cwd=ROOT, capture_output=True,
                         text=True)
    assert got.stdout.split() == paths
    kept = subprocess.run(["git", "check-ignore", "results/x/trials.csv", "results/x/meta.json"],
                          cwd=ROOT, capture_output=True, text=True)
    assert kept.stdout == ""


def test_in_memory_runs_carry_their_run_times():
    res = api_run(ROOT / "configs/sspf_ungm.yaml", trials=2, overrides=["scenario.steps=8"])
    assert res.trials["wall_s"].notna().all() and res.run["trials_run_now"] == 2
    assert "wall_s" not in res.meta
