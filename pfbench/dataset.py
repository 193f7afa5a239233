"""Results as a dataset: ``trials.parquet`` beside each results folder's ``trials.csv``, and
``load_trials``, which reads many results folders into one DataFrame.

``trials.csv`` stays the committed, diffable form (every row carries its checksum, meta.json the
file's). ``trials.parquet`` holds the same table, typed, with the folder's metadata in the
parquet file's key-value metadata:

    pfbench.meta           meta.json (a run), or for a sweep its name, swept keys and each
                           cell's meta.json: experiment, seed, trials, versions, provenance
    pfbench.trials_sha256  the sha256 of the trials.csv it was written from (store.trials_digest)

It is written from the trials file by every run and sweep (and ``pfbench tables``), never
committed (.gitignore: it is what trials.csv already holds), and read only while its checksum
matches the trials.csv beside it: a stale one (the trials file changed since) is passed over for
the CSV.
"""
from __future__ import annotations

import json
from pathlib import Path
from typing import TYPE_CHECKING

from .errors import UserError
from .fsutil import require_regular, write_through_temp

if TYPE_CHECKING:
    import pandas as pd

PARQUET = "trials.parquet"
META_KEY = b"pfbench.meta"
DIGEST_KEY = b"pfbench.trials_sha256"
# the columns load_trials puts first: which folder and experiment a row comes from
SOURCE_COLUMNS = ("folder", "experiment")


def is_sweep(folder: Path) -> bool:
    """Whether a results folder holds a sweep (summary.csv, no table.csv)."""
    folder = Path(folder)
    return not (folder / "table.csv").is_file() and (folder / "summary.csv").is_file()


def folder_meta(folder: Path) -> dict:
    """The metadata of a results folder: its meta.json (a run), or for a sweep ``experiment``
    (the sweep's name, the folder's), ``sweep`` (the swept keys, trials.csv's first columns),
    ``seed`` and ``trials`` (its first cell's) and ``cells`` (each cell's meta.json by cell
    name)."""
    from .store import read_meta
    folder = Path(folder)
    if not is_sweep(folder):
        return read_meta(folder)
    cells = {}
    for cell in sorted((folder / "cells").iterdir()) if (folder / "cells").is_dir() else ():
        if cell.is_dir() and not cell.name.startswith("."):
            cells[cell.name] = read_meta(cell)
    with open(folder / "trials.csv", encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
    keys = header[:header.index("trial")] if "trial" in header else []
    first = next(iter(cells.values()), {})
    return {"experiment": first.get("experiment", folder.name), "sweep": keys,
            "seed": first.get("seed"), "trials": first.get("trials"), "cells": cells}


def write_parquet(folder: Path, meta: dict | None = None) -> Path:
    """Write ``folder/trials.parquet`` from ``folder/trials.csv`` (atomically), with ``meta``
    (default: folder_meta) and the trials file's checksum in its key-value metadata; returns its
    path. A trials.parquet already written from the same trials file with the same metadata is
    kept as it is (an up-to-date run writes nothing again)."""
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq
    from .store import trials_digest
    folder = Path(folder)
    data = (folder / "trials.csv").read_bytes()
    digest = trials_digest(data)
    meta = folder_meta(folder) if meta is None else meta
    fresh = _fresh_parquet(folder, digest)
    if fresh is not None and fresh["meta"] == json.loads(json.dumps(meta, sort_keys=True)):
        return folder / PARQUET
    frame = pd.read_csv(folder / "trials.csv")
    table = pa.Table.from_pandas(frame, preserve_index=False)
    kv = dict(table.schema.metadata or {})
    kv[META_KEY] = json.dumps(meta, sort_keys=True).encode()
    kv[DIGEST_KEY] = digest.encode()
    table = table.replace_schema_metadata(kv)
    path = folder / PARQUET
    write_through_temp(path, lambda tmp: pq.write_table(table, tmp), ".parquet")
    return path


def parquet_metadata(path: Path) -> dict:
    """The pfbench metadata of a trials.parquet: ``meta`` (what folder_meta gave when it was
    written) and ``trials_sha256``; a UserError for a file that is no pfbench trials.parquet."""
    import pyarrow.parquet as pq
    try:
        kv = pq.read_schema(path).metadata or {}
        return {"meta": json.loads(kv[META_KEY]), "trials_sha256": kv[DIGEST_KEY].decode()}
    except (OSError, KeyError, ValueError) as exc:
        raise UserError(f"{path}: not a pfbench trials.parquet ({exc})") from None


def _fresh_parquet(folder: Path, digest: str) -> dict | None:
    """The parquet's metadata when ``folder`` holds a trials.parquet written from the trials
    file of checksum ``digest``; None when it has none or a stale or unreadable one."""
    path = folder / PARQUET
    if not path.is_file() or path.is_symlink():
        return None
    try:
        got = parquet_metadata(path)
    except UserError:
        return None
    return got if got["trials_sha256"] == digest else None


def read_folder(folder: str | Path) -> tuple[pd.DataFrame, dict]:
    """(trials, meta) of one results folder (a run's or a sweep's): the trials.parquet when it
    matches trials.csv (its checksum), else trials.csv, checked row by row against its
    checksums and meta.json (pfbench.store); the same frame either way, one row per trial
    and filter run."""
    import pandas as pd
    from .store import read_results, read_sweep, trials_digest
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"{folder}: no such results folder")
    path = folder / "trials.csv"
    require_regular(path)
    if not path.is_file():
        raise UserError(f"{folder}: no trials.csv: not the results of 'pfbench run' or "
                        "'pfbench sweep'")
    data = path.read_bytes()
    got = _fresh_parquet(folder, trials_digest(data))
    if got is not None:
        try:
            return pd.read_parquet(folder / PARQUET), got["meta"]
        except (OSError, ValueError):
            pass        # damaged after its metadata: the CSV below
    if is_sweep(folder):
        read_sweep(folder)
    else:
        read_results(folder)
    return pd.read_csv(path), folder_meta(folder)


def load_trials(*folders: str | Path) -> pd.DataFrame:
    """The trials of many results folders (of ``pfbench run`` or ``pfbench sweep``) as one
    DataFrame: one row per trial and filter run, its columns those of the folders' trials files
    (``trial``, ``filter``, ``label``, ``particles``, the metrics, ``crc``; a sweep's swept
    keys, NaN for rows of a run) after two that say where a row comes from: ``folder`` (the
    path as given) and ``experiment`` (the experiment's name, from meta.json).

    Each folder is read from its trials.parquet when that matches its trials.csv, else from the
    CSV, checked against its checksums and meta.json; a folder that is no finished results
    folder, or whose files disagree, is refused with a one-line UserError. The folders'
    metadata (seed, versions, provenance): ``frame.attrs["meta"]``, by folder as given."""
    import pandas as pd
    if not folders:
        raise UserError("load_trials: name at least one results folder")
    frames, metas = [], {}
    for f in folders:
        if not isinstance(f, (str, Path)):
            raise UserError(f"load_trials: a results folder is a path, got {type(f).__name__}")
        df, meta = read_folder(f)
        df.insert(0, "experiment", str(meta.get("experiment", Path(f).name)))
        df.insert(0, "folder", str(f))
        frames.append(df)
        metas[str(f)] = meta
    out = pd.concat(frames, ignore_index=True) if len(frames) > 1 else frames[0]
    out.attrs["meta"] = metas
    return out
