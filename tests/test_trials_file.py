"""The trials file: a broken one is one line on resume; every row carries a checksum, and a
resume runs again the trials whose rows were edited or duplicated."""
from __future__ import annotations

from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from pfbench.cli import app
from pfbench.config import load
from pfbench.errors import UserError
from pfbench.runner import run_experiment
from pfbench.store import row_crc

from .conftest import TINY, one_line_exit_2

runner = CliRunner()


@pytest.mark.parametrize("content", [bytes(range(256)) * 8, b"\x00" * 100,
                                     "trial,filter\n1,2\n".encode(), b""])
def test_a_broken_trials_file_on_resume_is_one_line(tmp_path, write_config, content):
    cfg = write_config(TINY)
    out = tmp_path / "o"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"]).exit_code == 0
    (out / "trials.csv").write_bytes(content)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out), "--resume"]))
    assert "trials.csv" in line
    assert (out / "trials.csv").read_bytes() == content        # nothing lost


def _numbers(path):
    return pd.read_csv(path).sort_values(
        ["trial", "filter"]).reset_index(drop=True)


def test_resume_re_runs_trials_whose_rows_were_edited_or_duplicated(tmp_path, write_config):
    cfg = write_config(TINY)
    fresh, out = tmp_path / "fresh", tmp_path / "o"
    for folder in (fresh, out):
        res = runner.invoke(app, ["run", str(cfg), "--out", str(folder), "--no-figures"])
        assert res.exit_code == 0, res.output
    lines = (out / "trials.csv").read_text().splitlines(keepends=True)
    header = lines[0].split(",")
    col = header.index("rmse")
    # trial 1: a value edited; trial 2: a second row for the same filter run with another value
    edited = lines[1 + 3].split(",")
    assert edited[0] == "1"
    edited[col] = "0.001"
    lines[1 + 3] = ",".join(edited)
    dup = lines[1 + 6].rstrip("\n").split(",")
    assert dup[0] == "2"
    dup[col] = "0.002"
    dup[-1] = str(row_crc(dup[:-1]))           # a valid row, but not the one the trial gave
    lines.append(",".join(dup) + "\n")
    (out / "trials.csv").write_text("".join(lines))
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--resume", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "trial 1:" in res.output and "checksum" in res.output
    assert "trial 2:" in res.output and "different values" in res.output
    assert "2 trials in" in res.output and "(2 resumed)" in res.output
    pd.testing.assert_frame_equal(_numbers(out / "trials.csv"), _numbers(fresh / "trials.csv"),
                                  check_exact=True)


def test_rows_carry_a_checksum_and_an_identical_repeat_is_kept_once(tmp_path, write_config):
    from pfbench.store import read_trials
    cfg = write_config(TINY)
    out = tmp_path / "o"
    assert runner.invoke(app, ["run", str(cfg), "--out", str(out), "--no-figures"]).exit_code == 0
    text = (out / "trials.csv").read_text()
    (out / "trials.csv").write_text(text + text.splitlines(keepends=True)[1])
    got = read_trials(out / "trials.csv")
    assert not got.rejected and len(got.rows) == 4 * 3


def test_a_trials_file_carries_its_kinds_columns(tmp_path, write_config):
    from pfbench.kinds import KINDS
    from pfbench.metrics import METRICS
    from pfbench.store import read_trials
    exp = load(write_config(TINY))
    run_experiment(exp, tmp_path / "a")
    header = (tmp_path / "a/trials.csv").read_text().splitlines()[0].split(",")
    # the kind's columns, with the NEES and NIS its UKF reports (after mse, in METRICS' order)
    scalar = KINDS["scalar"].columns
    assert tuple(header) == scalar[:6] + ("nees", "nis") + scalar[6:]
    assert "landmark_error" not in header and "converge_step" not in header
    metrics = list(KINDS["scalar"].metrics)
    rows = pd.read_csv(tmp_path / "a/trials.csv")
    ukf = rows["filter"] == "ukf"
    assert rows.loc[ukf, ["nees", "nis"]].notna().all().all()
    assert rows.loc[~ukf, ["nees", "nis"]].isna().all().all()     # a PF reports neither
    assert rows["diversity_l1"].isna().all()        # computed only where read (diagnostics)
    assert not rows[[m for m in metrics if m != "diversity_l1"]].isna().all().any()
    run_experiment(load(write_config(TINY + "diagnostics: all\n", "all.yaml")), tmp_path / "b")
    assert not pd.read_csv(tmp_path / "b/trials.csv")[metrics].isna().all().any()
    # every kind: its metrics in METRICS' order, the SLAM kind with the final error too
    for kind in KINDS.values():
        assert list(kind.metrics) == [m for m in METRICS if m in kind.metrics]
    assert "final_error" in KINDS["slam"].metrics
    # a header with a column no kind has, or in another order, is not a trials file
    text = (tmp_path / "a/trials.csv").read_text()
    for bad in (text.replace("rmse,mse", "mse,rmse", 1), text.replace(",mse,", ",msee,", 1)):
        (tmp_path / "bad.csv").write_text(bad)
        with pytest.raises(UserError, match="columns differ"):
            read_trials(tmp_path / "bad.csv")
    # another kind's columns are refused where this experiment's are expected
    with pytest.raises(UserError, match="columns differ"):
        read_trials(tmp_path / "a/trials.csv", KINDS["slam"].columns)


def test_slam_rows_have_the_final_error(tmp_path, write_config):
    from pfbench.kinds import KINDS
    cfg = ("seed: 3\ntrials: 2\nscenario: {name: landmark_world, world: "
           + str(Path(__file__).resolve().parents[1] / "configs/worlds/afsa_world.yaml")
           + ", steps: 40}\nfilters:\n  fastslam: {particles: 10}\n")
    exp = load(write_config(cfg))
    res = run_experiment(exp, tmp_path / "s")
    df = pd.read_csv(tmp_path / "s/trials.csv")
    assert tuple(df.columns) == KINDS["slam"].columns
    assert df["final_error"].notna().all() and (df["final_error"] >= 0).all()
    assert set(res.rows[0]) == set(KINDS["slam"].columns) | {"wall_s"}     # in timings.csv


def test_a_folder_written_without_the_consistency_columns_is_named_and_still_reads(
        tmp_path, write_config):
    """Trials of an experiment with a UKF written before it reported NEES and NIS (no such
    columns): a run into the folder says in one line what the file lacks and what to do, and
    changes nothing; the results still read (without those columns)."""
    import csv
    import io

    from pfbench.store import read_trials

    from .conftest import tree
    cfg = write_config(TINY)
    out = tmp_path / "a"
    run_experiment(load(cfg), out)
    lines = list(csv.reader(io.StringIO((out / "trials.csv").read_text())))
    keep = [i for i, c in enumerate(lines[0]) if c not in ("nees", "nis")]
    assert len(keep) == len(lines[0]) - 2
    old = [[r[i] for i in keep] for r in lines]
    for r in old[1:]:
        r[-1] = str(row_crc(r[:-1]))
    buf = io.StringIO()
    csv.writer(buf, lineterminator="\n").writerows(old)
    (out / "trials.csv").write_text(buf.getvalue())
    before = tree(out)
    line = one_line_exit_2(runner.invoke(app, ["run", str(cfg), "--out", str(out)]))
    assert "columns differ: it lacks nees, nis" in line and "--force" in line, line
    assert tree(out) == before
    got = pd.DataFrame(read_trials(out / "trials.csv").rows)
    assert "nees" not in got and len(got) == 4 * 3
    res = runner.invoke(app, ["run", str(cfg), "--out", str(out), "--force", "--no-figures"])
    assert res.exit_code == 0, res.output
    assert "nees" in pd.read_csv(out / "trials.csv")
