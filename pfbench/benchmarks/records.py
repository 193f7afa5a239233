"""``pfbench bench --compare OLD.json``: the records of an earlier ``--json`` run read back, each
of this run's records matched to the one that timed the same work, and their throughput ratios
printed."""
from __future__ import annotations

import json
import math
from pathlib import Path

from ..errors import UserError
from ..fsutil import require_regular

# What names a bench record (two runs' records with the same identity timed the same work), and
# the throughput compared, in order of preference.
IDENTITY = ("workload", "impl", "mode", "filter", "particles", "trials", "steps", "threads")
RATES = ("particle_steps_per_s", "steps_per_s")
SLOWER = 0.9        # a row below this ratio to the earlier run is flagged


def record_key(rec: dict) -> tuple:
    return tuple((k, rec[k]) for k in IDENTITY if k in rec)


def record_rate(rec: dict) -> float:
    for k in RATES:
        if isinstance(rec.get(k), (int, float)) and rec[k] > 0:
            return float(rec[k])
    s = rec.get("seconds")
    return 1.0 / s if isinstance(s, (int, float)) and s > 0 else math.nan


def read_records(path: Path) -> list[dict]:
    """The records of an earlier ``pfbench bench --json`` run; a UserError for anything else
    (a FIFO or a device is never read: it could wait or run for ever)."""
    try:
        require_regular(path)
    except UserError as exc:
        raise UserError(f"--compare {exc}") from None
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise UserError(f"--compare {path}: cannot read it ({exc.strerror})") from None
    except (ValueError, UnicodeDecodeError):
        raise UserError(f"--compare {path}: not JSON (a file 'pfbench bench --json' wrote?)") \
            from None
    if (not isinstance(data, list) or not data
            or not all(isinstance(r, dict) and "workload" in r and "impl" in r
                       and all(isinstance(r[k], (str, int, float, bool)) or r[k] is None
                               for k in IDENTITY if k in r) for r in data)):
        raise UserError(f"--compare {path}: not a list of bench records (a file 'pfbench bench "
                        "--json' wrote?)")
    return data


def compare_records(new: list[dict], old: list[dict]) -> list[dict]:
    """Each record of ``new`` beside the record of ``old`` that timed the same work (same
    identity: IDENTITY): {'key', 'new', 'old', 'ratio' (new throughput / old; > 1 faster),
    'slower' (ratio below SLOWER)}; records of only one run have None for the other."""
    before = {record_key(r): r for r in old if r.get("workload") != "run"}
    out = []
    for r in new:
        if r.get("workload") == "run":          # what ran, not a timing
            continue
        k = record_key(r)
        o = before.pop(k, None)
        ratio = record_rate(r) / record_rate(o) if o is not None else math.nan
        out.append({"key": k, "new": r, "old": o, "ratio": ratio,
                    "slower": ratio == ratio and ratio < SLOWER})
    out += [{"key": k, "new": None, "old": o, "ratio": math.nan, "slower": False}
            for k, o in before.items()]
    return out


def _what(key: tuple) -> str:
    d = dict(key)
    parts = [d.get("workload", "?"), d.get("impl", "?")]
    parts += [str(d[k]) for k in ("mode", "filter") if k in d]
    if d.get("particles"):
        parts.append(f"N={d['particles']}")
    if d.get("trials", 1) != 1:
        parts.append(f"x{d['trials']}")
    if "threads" in d and d["threads"] != 1:
        parts.append(f"{d['threads']} threads")
    return " ".join(parts)


def print_comparison(rows: list[dict], path: Path, console) -> None:
    from rich.table import Table as RichTable
    t = RichTable(title=f"this run beside {path} (throughput; ratio > 1: faster now)",
                  title_justify="left", show_edge=False)
    for h in ("record", "earlier", "now", "ratio"):
        t.add_column(h, no_wrap=h != "record")
    for r in rows:
        fmt = lambda rec: ("-" if rec is None or record_rate(rec) != record_rate(rec)
                           else f"{record_rate(rec):.3g}")
        ratio = "-" if r["ratio"] != r["ratio"] else f"{r['ratio']:.2f}"
        t.add_row(_what(r["key"]), fmt(r["old"]), fmt(r["new"]),
                  ratio + ("  SLOWER" if r["slower"] else ""))
    console.print(t)
    slow = [r for r in rows if r["slower"]]
    console.print(f"{len(slow)} of {sum(r['ratio'] == r['ratio'] for r in rows)} records "
                  f"matched are below {SLOWER:g}x the earlier run (on a shared machine a single "
                  "run moves 10-30%: rerun before calling it a slowdown)", markup=False)
