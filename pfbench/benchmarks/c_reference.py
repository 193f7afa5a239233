"""``pfbench bench --c-ref PROGRAM``: the C reference (bench/ungm_ref.c, built by
scripts/bench_vs_c.sh) timed on the bench's UNGM data in the same run as pfbench's kernel."""
from __future__ import annotations

import struct
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from ..errors import UserError
from .common import BATCH_N, ungm_record


def write_c_data(path: Path, X, Y):
    """The truths and measurements as the C reference reads them: K and T, then X and Y."""
    with open(path, "wb") as fh:
        fh.write(struct.pack("<qq", X.shape[0], X.shape[1] - 1))
        fh.write(np.ascontiguousarray(X, dtype="<f8").tobytes())
        fh.write(np.ascontiguousarray(Y, dtype="<f8").tobytes())


def c_lines(binary: Path, *args) -> list[list[float]]:
    """The numbers of each line the C reference prints when run with ``args``."""
    try:
        res = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True,
                             timeout=600, check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        raise UserError(f"--c-ref {binary}: could not run it: {exc}") from None
    try:
        rows = [list(map(float, line.split())) for line in res.stdout.splitlines()
                if line.strip()]
    except ValueError:
        rows = []
    if not rows:
        raise UserError(f"--c-ref {binary}: printed no timings (a program built from "
                        "bench/ungm_ref.c?)")
    return rows


def c_rows(c_ref: Path, X, Y, sizes, K: int, min_time: float, reps: int,
           threads: int) -> list[dict]:
    """The C reference on the truths X and measurements Y: one trial at each N of ``sizes`` on
    one thread (best of ``reps``, each rep at least ``min_time`` s), and K trials at BATCH_N over
    ``threads`` threads."""
    records = []
    with tempfile.TemporaryDirectory() as tmp:
        data = Path(tmp) / "ungm.bin"
        write_c_data(data, X, Y)
        for N in sizes:
            lines = c_lines(c_ref, data, "single", N, reps, min_time)
            records.append(ungm_record("c", "single", N, 1, min(l[0] for l in lines), 1))
        lines = c_lines(c_ref, data, "batch", BATCH_N, reps, K, threads)
        records.append(ungm_record("c", "batch", BATCH_N, K, min(l[0] for l in lines), threads))
    return records
