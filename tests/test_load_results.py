"""Results as a dataset (pfbench.dataset): trials.parquet with its metadata beside trials.csv,
and pfbench.load_trials over many folders."""
import json
import shutil

import pandas as pd
import pyarrow.parquet as pq
import pytest

import pfbench
from pfbench import dataset
from pfbench.errors import UserError

from .conftest import ROOT

FOLDERS = (ROOT / "results" / "ifa_pf_ungm", ROOT / "results" / "sspf_ungm")


def test_load_trials_reads_two_committed_folders_into_one_frame():
    df = pfbench.load_trials(*FOLDERS)
    assert list(df.columns[:4]) == ["folder", "experiment", "trial", "filter"]
    for f in FOLDERS:
        csv = pd.read_csv(f / "trials.csv")
        part = df[df["folder"] == str(f)]
        assert len(part) == len(csv) and set(part["experiment"]) == {f.name}
        assert part["rmse"].tolist() == csv["rmse"].tolist()
    assert df.attrs["meta"][str(FOLDERS[0])]["seed"] == 2021
    # sspf_ungm's NEES column is NaN for ifa_pf_ungm's rows, which have none
    assert df.loc[df["experiment"] == "ifa_pf_ungm", "nees"].isna().all()


def test_parquet_holds_the_csv_and_the_metadata_and_is_read_only_while_fresh(tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(FOLDERS[1], folder, ignore=shutil.ignore_patterns("trials.parquet"))
    from_csv = pfbench.load_trials(folder)
    path = dataset.write_parquet(folder)
    kv = pq.read_schema(path).metadata
    meta = json.loads(kv[b"pfbench.meta"])
    assert meta == json.loads((folder / "meta.json").read_text())
    assert meta["experiment"] == "sspf_ungm" and "versions" in meta and "seed" in meta
    from_parquet = pfbench.load_trials(folder)
    pd.testing.assert_frame_equal(from_parquet, from_csv)
    # a stale parquet (another file's checksum) is passed over for the CSV
    table = pq.read_table(path)
    pq.write_table(table.slice(0, 3).replace_schema_metadata(
        {**kv, b"pfbench.trials_sha256": b"0" * 64}), path)
    assert len(pfbench.load_trials(folder)) == len(from_csv)


def test_a_sweep_writes_its_parquet_with_every_cells_metadata(tmp_path):
    folder = tmp_path / "sweep"
    shutil.copytree(ROOT / "results" / "ifa_fastslam_speed", folder,
                    ignore=shutil.ignore_patterns("trials.parquet", "figures"))
    dataset.write_parquet(folder)
    meta = dataset.parquet_metadata(folder / "trials.parquet")["meta"]
    assert meta["sweep"] == ["scenario.speed_mps"] and len(meta["cells"]) == 5
    df = pfbench.load_trials(folder)
    assert df["scenario.speed_mps"].nunique() == 5


def test_load_trials_refuses_what_is_no_results_folder(tmp_path):
    with pytest.raises(UserError, match="no such results folder"):
        pfbench.load_trials(tmp_path / "none")
    with pytest.raises(UserError, match="no trials.csv"):
        pfbench.load_trials(tmp_path)
    with pytest.raises(UserError, match="expected a path"):
        pfbench.load_trials(3)


def test_a_fresh_parquet_is_kept_and_a_stale_one_written_again(tmp_path):
    """write_parquet leaves a trials.parquet written from the same trials file with the same
    metadata as it is (an up-to-date run), and writes it again when either changed."""
    folder = tmp_path / "run"
    shutil.copytree(FOLDERS[1], folder, ignore=shutil.ignore_patterns("trials.parquet"))
    path = dataset.write_parquet(folder)
    stamp = (path.stat().st_ino, path.stat().st_mtime_ns)      # a rewrite replaces the file
    assert dataset.write_parquet(folder) == path
    assert (path.stat().st_ino, path.stat().st_mtime_ns) == stamp
    meta = json.loads((folder / "meta.json").read_text())
    meta["host"] = "another"                       # the metadata changed: written again
    (folder / "meta.json").write_text(json.dumps(meta))
    dataset.write_parquet(folder)
    assert json.loads(pq.read_schema(path).metadata[b"pfbench.meta"])["host"] == "another"
    rows = (folder / "trials.csv").read_text().splitlines(keepends=True)
    (folder / "trials.csv").write_text("".join(rows[:5]))      # the trials changed
    dataset.write_parquet(folder)
    assert pq.read_metadata(path).num_rows == 4
