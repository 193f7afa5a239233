"""Results read back exactly as written, or refused in one line: the trials file and its
meta.json tied together, a meta.json of a shape or format this pfbench does not read refused, and
the committed tables computed from committed files alone."""
import csv
import io
import json
import os
import shutil
import subprocess
import sys
import zlib

import pandas as pd
import pytest

import pfbench
from pfbench import runner
from pfbench.config import FORMAT_VERSION, load
from pfbench.errors import UserError
from pfbench.store import read_results, read_sweep, read_trials, row_crc, trials_digest

from .conftest import ROOT, TINY


def _one_line(err) -> str:
    text = str(err.value)
    assert "\n" not in text and text
    return text


@pytest.fixture
def folder(tmp_path, monkeypatch):
    """A copy of a committed results folder (sspf_global), read from a folder without its
    config (load_results then reads its table.csv: no recomputation)."""
    dst = tmp_path / "sspf_global"
    shutil.copytree(ROOT / "results" / "sspf_global", dst,
                    ignore=shutil.ignore_patterns("figures", "timings.*", "traces.npz"))
    monkeypatch.chdir(tmp_path)
    return dst


def _lines(path):
    return path.read_text().splitlines(keepends=True)


def _rewrite_row(path, index, column, value):
    """Change one field of row ``index`` and give the row a matching checksum (a row of another
    run, not a damaged one)."""
    rows = list(csv.reader(io.StringIO(path.read_text())))
    head = rows[0]
    row = rows[1 + index]
    row[head.index(column)] = value
    row[-1] = str(row_crc(row[:-1]))
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(rows)
    path.write_text(buf.getvalue())


def test_the_committed_folders_read_back():
    for meta in sorted((ROOT / "results").glob("*/meta.json")):
        m, got = read_results(meta.parent)
        assert len({r["trial"] for r in got.rows}) == m["trials"]
    trials, summary = read_sweep(ROOT / "results" / "ifa_fastslam_speed")
    assert len(trials) and len(summary)


def test_a_folder_reads_back(folder):
    res = pfbench.load_results(folder)
    assert res.trials["trial"].nunique() == res.meta["trials"] == 100


# ---- item: trials tied to their meta.json

def test_another_runs_trials_under_this_meta_are_refused(folder):
    _rewrite_row(folder / "trials.csv", 0, "rmse", "0.125")      # every row checks
    assert not read_trials(folder / "trials.csv").rejected
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    assert "checksum differs" in _one_line(err) and "trials.csv" in str(err.value)


def test_a_legacy_meta_without_the_checksum_still_ties_count_and_runs(folder):
    meta = json.loads((folder / "meta.json").read_text())
    for k in ("trials_sha256", "trials_rows"):
        meta.pop(k, None)
    (folder / "meta.json").write_text(json.dumps(meta))
    assert pfbench.load_results(folder).meta["trials"] == 100
    _rewrite_row(folder / "trials.csv", 0, "filter", "other@5")
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    assert "trial 0 has rows for" in _one_line(err)


def test_a_run_killed_between_the_trials_and_the_meta_leaves_no_mismatched_pair(
        tmp_path, write_config, monkeypatch):
    """Experiment a finished; b (another seed) replaces it with --force and is killed right
    after its trials file is written: the folder never reads back as b's trials under a's meta."""
    a = write_config(TINY)
    b = write_config(TINY.replace("seed: 0", "seed: 1"), "b.yaml")
    out = tmp_path / "out"
    pfbench.run_experiment(a, out=out, figures=False)
    real = runner.atomic_write

    def killed(path, text):
        real(path, text)
        if path.name == "trials.csv":
            raise KeyboardInterrupt
    monkeypatch.setattr(runner, "atomic_write", killed)
    with pytest.raises(KeyboardInterrupt):
        pfbench.run_experiment(b, out=out, figures=False, force=True)
    monkeypatch.setattr(runner, "atomic_write", real)
    with pytest.raises(UserError) as err:
        pfbench.load_results(out)
    assert "meta.json" in _one_line(err)
    # and a meta.json put back from a's run does not pass for b's trials
    meta = pfbench.run_experiment(a, figures=False).meta
    meta.update(format=FORMAT_VERSION, trials_sha256="0" * 64, trials_rows=12, identity={})
    (out / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(UserError) as err:
        pfbench.load_results(out)
    assert "checksum differs" in _one_line(err)


def test_every_finished_run_records_its_trials_checksum(tmp_path, write_config):
    out = tmp_path / "out"
    pfbench.run_experiment(write_config(TINY), out=out, figures=False)
    meta = json.loads((out / "meta.json").read_text())
    assert meta["trials_sha256"] == trials_digest((out / "trials.csv").read_bytes())
    assert meta["trials_rows"] == 4 * 3


# ---- item: the trials file must hold what meta.json records

@pytest.mark.parametrize("cut", ["truncated", "rows deleted", "header only", "torn line",
                                 "extra trial", "empty"])
def test_trials_that_do_not_match_the_meta_are_refused(folder, cut):
    path = folder / "trials.csv"
    lines = _lines(path)
    if cut == "truncated":
        path.write_text("".join(lines[:7]))
    elif cut == "rows deleted":
        path.write_text("".join(lines[:1] + lines[3:]))
    elif cut == "header only":
        path.write_text(lines[0])
    elif cut == "torn line":
        path.write_text("".join(lines)[:-10])
    elif cut == "extra trial":
        path.write_text("".join(lines))
        meta = json.loads((folder / "meta.json").read_text())
        meta["trials"] = 99
        meta.pop("trials_sha256")
        (folder / "meta.json").write_text(json.dumps(meta))
    else:
        path.write_text("")
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    assert "trials.csv" in _one_line(err)


def test_the_report_refuses_a_truncated_trials_file(tmp_path):
    """`pfbench report` reads the same checked files: a trials file cut short is named, not
    reported as the config's trials."""
    from pfbench import report
    configs = tmp_path / "configs"
    configs.mkdir()
    shutil.copy(ROOT / "configs" / "sspf_global.yaml", configs)
    shutil.copytree(ROOT / "configs" / "worlds", configs / "worlds")
    results = tmp_path / "results"
    shutil.copytree(ROOT / "results" / "sspf_global", results / "sspf_global",
                    ignore=shutil.ignore_patterns("figures", "timings.*", "traces.npz"))
    path = results / "sspf_global" / "trials.csv"
    path.write_text("".join(_lines(path)[:7]))
    with pytest.raises(UserError) as err:
        report.collect(configs, results)
    assert "holds 3 of the 100 trials" in _one_line(err)


def test_tables_check_refuses_committed_trials_that_do_not_match(folder):
    from pfbench.regen import _committed
    exp = load(ROOT / "configs" / "sspf_global.yaml")
    path = folder / "trials.csv"
    path.write_text("".join(_lines(path)[:1] + _lines(path)[3:]))
    with pytest.raises(UserError) as err:
        _committed(folder, exp)
    assert "trial 0 missing" in _one_line(err)


@pytest.fixture
def sweep(tmp_path, monkeypatch):
    dst = tmp_path / "sweep"
    shutil.copytree(ROOT / "results" / "ifa_fastslam_speed", dst,
                    ignore=shutil.ignore_patterns("figures", "timings.*"))
    monkeypatch.chdir(tmp_path)
    return dst


def test_a_sweep_reads_back(sweep):
    res = pfbench.load_results(sweep)
    assert len(res.trials) == 400 and len(res.table) == 20


@pytest.mark.parametrize("edit", ["trials row", "summary value", "cell trials"])
def test_an_edited_sweep_is_refused(sweep, edit):
    if edit == "trials row":
        text = (sweep / "trials.csv").read_text()
        head, first, rest = text.split("\n", 2)
        fields = first.split(",")
        fields[5] = "0.5"                   # rmse of the first row
        (sweep / "trials.csv").write_text("\n".join([head, ",".join(fields), rest]))
    elif edit == "summary value":
        s = pd.read_csv(sweep / "summary.csv")
        s.loc[0, "rmse_mean"] = 0.5
        s.to_csv(sweep / "summary.csv", index=False, lineterminator="\n")
    else:
        cell = sorted((sweep / "cells").iterdir())[0] / "trials.csv"
        cell.write_text("".join(_lines(cell)[:5]))
    with pytest.raises(UserError) as err:
        pfbench.load_results(sweep)
    _one_line(err)


# ---- items: a meta.json of a newer format, or of a shape this pfbench does not read

@pytest.mark.parametrize("fmt", [FORMAT_VERSION + 1, 1000])
def test_a_newer_format_is_refused_naming_its_writer(folder, fmt):
    meta = json.loads((folder / "meta.json").read_text())
    meta["format"] = fmt
    meta["versions"]["pfbench"] = "9.9.0"
    (folder / "meta.json").write_text(json.dumps(meta))
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    line = _one_line(err)
    assert f"format {fmt}" in line and "9.9.0" in line and "upgrade" in line


def test_an_older_format_still_reads(folder):
    meta = json.loads((folder / "meta.json").read_text())
    meta["format"] = 5
    (folder / "meta.json").write_text(json.dumps(meta))
    assert pfbench.load_results(folder).meta["format"] == 5


def _edits():
    return [
        ("a list", lambda m: [m], None),
        ("null", lambda m: None, None),
        ("a number", lambda m: 3, None),
        ("no hash", lambda m: {k: v for k, v in m.items() if k != "experiment_hash"},
         "experiment_hash"),
        ("no trials", lambda m: {k: v for k, v in m.items() if k != "trials"}, "trials"),
        ("config a number", lambda m: {**m, "config": 5}, "config"),
        ("config a list", lambda m: {**m, "config": ["a"]}, "config"),
        ("trials a string", lambda m: {**m, "trials": "100"}, "trials"),
        ("trials a bool", lambda m: {**m, "trials": True}, "trials"),
        ("trials negative", lambda m: {**m, "trials": -1}, "trials"),
        ("seed a float", lambda m: {**m, "seed": 1.5}, "seed"),
        ("format a string", lambda m: {**m, "format": "7"}, "format"),
        ("versions a list", lambda m: {**m, "versions": []}, "versions"),
        ("versions without pfbench", lambda m: {**m, "versions": {}}, "versions.pfbench"),
        ("identity filters a string", lambda m: {**m, "identity": {"filters": "x"}},
         "identity.filters"),
        ("until_decided a list", lambda m: {**m, "until_decided": [1]}, "until_decided"),
        ("until_decided without looks", lambda m: {**m, "until_decided": {
            "max_trials": 5, "batch": 1, "stopped": "x"}}, "until_decided.looks"),
    ]


@pytest.mark.parametrize("what,edit,key", _edits(), ids=[e[0] for e in _edits()])
def test_a_hand_edited_meta_is_refused_naming_the_file_and_key(folder, what, edit, key):
    meta = json.loads((folder / "meta.json").read_text())
    (folder / "meta.json").write_text(json.dumps(edit(meta)))
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    line = _one_line(err)
    assert "meta.json" in line
    if key:
        assert f"'{key}'" in line


def test_meta_not_json_is_one_line(folder):
    (folder / "meta.json").write_text("{not json")
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    assert "meta.json" in _one_line(err)


# ---- item: the committed tables depend on no file git ignores

@pytest.mark.parametrize("ranked", [False, True])
def test_a_table_written_with_timings_is_the_table_written_without(tmp_path, ranked):
    """table.csv and table.md are the same bytes whether or not the trials came with their
    timings (a run-time quantity's n counts its paired trials either way; a paper's order of
    its rows by run time is left out)."""
    from dataclasses import replace
    from pfbench import tables
    from pfbench.compare import compare
    exp = load(ROOT / "configs" / "ifa_pf_ungm.yaml", {"trials": 5})
    if ranked:
        table = replace(exp.reported, ranking=("time_ratio", "rmse_mean"))
        exp = replace(exp, reference=replace(
            exp.reference, tables={**exp.reference.tables, exp.table: table}))
    rows = [r for r in read_trials(ROOT / "results" / "ifa_pf_ungm" / "trials.csv").rows
            if r["trial"] < 5]
    plain = [dict(r) for r in rows]
    # run times that order the rows otherwise than the table does
    timed = [{**r, "wall_s": 1e-3 * (1 + r["trial"]) * (1 + zlib.crc32(r["filter"].encode()) % 7)}
             for r in rows]
    for name, rs in (("plain", plain), ("timed", timed)):
        (tmp_path / name).mkdir()
        tables.write(compare(exp, rs), tmp_path / name, {"versions": {"pfbench": "x"}})
    for f in ("table.csv", "table.md"):
        assert (tmp_path / "plain" / f).read_bytes() == (tmp_path / "timed" / f).read_bytes()
    assert compare(exp, timed).timed and not compare(exp, plain).timed


@pytest.mark.slow
def test_every_committed_config_leaves_a_fresh_clone_clean(tmp_path):
    """The README's commands on every committed config in a fresh clone: up to date, nothing
    runs, and git status stays empty (the timings files are not in a clone)."""
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "--quiet", str(ROOT), str(clone)], check=True)
    if subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", "pfbench",
                       "configs", "results"], capture_output=True, text=True).stdout.strip():
        pytest.skip("the checkout has uncommitted changes: a clone would not test them")
    env = {**os.environ, "PYTHONPATH": str(clone)}
    for cfg in sorted((clone / "configs").glob("*.yaml")):
        cmd = "sweep" if "\nsweep:" in "\n" + cfg.read_text() else "run"
        res = subprocess.run([sys.executable, "-m", "pfbench.cli", cmd, f"configs/{cfg.name}"],
                             cwd=clone, env=env, capture_output=True, text=True)
        assert res.returncode == 0, res.stderr[-2000:]
        status = subprocess.run(["git", "status", "--porcelain"], cwd=clone,
                                capture_output=True, text=True).stdout
        assert status == "", f"{cmd} {cfg.name}: {status}"


def test_a_checkout_with_crlf_line_ends_reads_back(folder):
    path = folder / "trials.csv"
    path.write_bytes(path.read_bytes().replace(b"\n", b"\r\n"))
    assert pfbench.load_results(folder).meta["trials"] == 100


def test_a_meta_nested_too_deep_is_one_line(folder):
    (folder / "meta.json").write_text("[" * 100000 + "]" * 100000)
    with pytest.raises(UserError) as err:
        pfbench.load_results(folder)
    assert "meta.json: not JSON" in _one_line(err)


def test_a_run_into_a_folder_whose_trials_do_not_match_its_meta_runs_them_again(
        tmp_path, write_config):
    """Rows that check one by one but are not the file meta.json describes are not kept as
    this experiment's trials (neither as up to date nor by --resume)."""
    cfg = write_config(TINY)
    out = tmp_path / "out"
    pfbench.run_experiment(cfg, out=out, figures=False)
    original = (out / "trials.csv").read_bytes()
    _rewrite_row(out / "trials.csv", 0, "rmse", "0.125")
    told = []
    res = pfbench.run_experiment(cfg, out=out, figures=False, warn=told.append)
    assert not res.up_to_date and res.run["trials_run_now"] == 4
    assert (out / "trials.csv").read_bytes() == original
    assert any("checksum differs" in t for t in told)
