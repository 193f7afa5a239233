"""The results folder's files: the trials file (its columns, its rows' checksums, reading it back
with every row checked) and the writes every command makes into a results folder.

A trials file (``trials.csv``, and ``trials.partial.csv`` while a run is under way) has one row per
trial and filter run: the id columns, the metrics of the scenario's kind (pfbench.kinds) and
``crc``, a crc32 of the row's other fields as written. Floats are written in their shortest exact
form, so they read back bit for bit. A row holds only what the seed determines, so the same
experiment gives the same file on any machine, run in any order. (Files of pfbench before the
timings file, with a ``wall_s`` column before ``crc``, still read: their wall times come back as
timings.)

The timings file (``timings.csv``, ``timings.partial.csv`` while a run is under way) holds what
the machine determines: ``trial``, ``filter`` and ``wall_s``, the seconds the filter run took.
It is not part of the results a project commits (``.gitignore`` leaves it out), and nothing that
``pfbench tables --check`` or ``report --check`` compares reads it; the console tables show the
run times it holds. A damaged or missing timings file costs only the run times.

The traces the figures draw (pfbench.traces) go to ``traces.npz``: one array per member,
``TRIAL/NAME`` for a trial's trace and ``world/NAME`` for the world, written with fixed
timestamps so that the same run gives the same bytes. While a run is under way each trace goes to
``traces.partial/trial-K.npz`` as its trial finishes, so that ``--resume`` keeps it.
"""
from __future__ import annotations

import csv
import hashlib
import io
import json
import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable

import numpy as np

from .config import Experiment
from .errors import UserError
from .fsutil import atomic_write, is_regular, remove_tree, require_regular
from .schema import describe
from .version import __version__
from .diagnostics import reported_metrics
from .kinds import END_COLUMNS, ID_COLUMNS
from .metrics import METRICS, summarize

__all__ = ["META", "check_meta", "check_trials", "read_meta", "read_results", "read_sweep",
           "trials_digest",
           "TIMING_COLUMNS", "TIMINGS", "TIMINGS_PARTIAL", "Traces", "read_timings", "timings_text",
           "with_timings", "TrialsFile", "atomic_write", "clear_staged_traces",
           "complete_trials", "csv_text", "finish_traces", "read_staged_traces", "read_traces", "read_trials",
           "row_crc", "stage_trace", "trial_columns", "write_csv", "write_json"]

TRACES = "traces.npz"
TRACES_PARTIAL = "traces.partial"

TIMINGS = "timings.csv"
TIMINGS_PARTIAL = "timings.partial.csv"
TIMINGS_COLUMNS = ("trial", "filter", "wall_s")

# What a row dict may carry beside the trials file's columns: what the machine determines (it goes
# to the timings file, never to the trials file).
TIMING_COLUMNS = ("wall_s",)
# The end of a trials file written before the timings file had its own file.
_LEGACY_END = ("wall_s", "crc")


# what 'pfbench report' writes into a results folder: no experiment's folder can be one
REPORT_NAMES = ("report", "REPORT.md")


def reserved_name(name: str, config) -> None:
    """Refuse an experiment name whose folder in a results folder would be the report's."""
    if name in REPORT_NAMES:
        raise UserError(f"{config}: name '{name}': results/{name} holds the reproduction report; "
                        "give the experiment another name (or choose its folder with --out)")


def write_json(path: Path, obj, indent: int | None = 2) -> None:
    """``obj`` as JSON into ``path``, through a temporary file (never half written)."""
    atomic_write(Path(path), json.dumps(obj, indent=indent) + "\n")


def write_csv(path: Path, df) -> None:
    """A pandas frame as CSV (no index, \\n line ends) into ``path``, through a temporary file."""
    atomic_write(Path(path), df.to_csv(index=False, lineterminator="\n"))


def trial_columns(exp: Experiment) -> tuple[str, ...]:
    """The columns of ``exp``'s trials file: those of its scenario's kind, with the consistency
    metrics (NEES, NIS) when one of its filters reports them (pfbench.diagnostics.reported_metrics)."""
    return (*ID_COLUMNS, *reported_metrics(exp), *END_COLUMNS)


def _fields(r: dict, columns: tuple[str, ...]) -> list[str]:
    return ["" if r[c] is None else str(r[c]) for c in columns[:-1]]


def row_crc(fields: list[str]) -> int:
    """The checksum of a trial row: crc32 of its fields as written (every column but ``crc``)."""
    return zlib.crc32("\x1f".join(fields).encode("utf-8", "surrogatepass"))


def csv_text(rows: Iterable[dict], header: bool, columns: tuple[str, ...]) -> str:
    """CSV text of ``rows`` in ``columns``; each row gets its checksum (``crc``), in the file and
    in the dict."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    if header:
        w.writerow(columns)
    for r in rows:
        fields = _fields(r, columns)
        r["crc"] = row_crc(fields)
        w.writerow(fields + [r["crc"]])
    return buf.getvalue()


def _parse_row(fields: list[str], columns: tuple[str, ...]) -> dict:
    row = dict(zip(columns, fields))
    row["trial"] = int(row["trial"])
    row["particles"] = int(row["particles"]) if row["particles"] else None
    for c in columns[len(ID_COLUMNS):-1]:
        row[c] = float(row[c])
    row["crc"] = int(row["crc"])
    return row


def _values(row: dict) -> tuple:
    """A row's values without its timing and checksum (two runs of a trial agree on these)."""
    return tuple(repr(v) for c, v in row.items() if c not in TIMING_COLUMNS + ("crc",))


def _end(header: tuple) -> tuple:
    """The end columns of a trials file's header: END_COLUMNS, or _LEGACY_END (an older file)."""
    return _LEGACY_END if header[-len(_LEGACY_END):] == _LEGACY_END else END_COLUMNS


def _header_ok(header: tuple) -> bool:
    """A trials file's header: the id columns, metrics in METRICS' order, and crc (an older
    file: wall_s and crc)."""
    n, end = len(ID_COLUMNS), _end(header)
    middle = header[n:-len(end)]
    order = [m for m in METRICS if m in middle]
    return (header[:n] == ID_COLUMNS and header[-len(end):] == end
            and len(header) > n + len(end) and list(middle) == order)


def _column_difference(header: tuple, columns) -> str:
    """': it lacks nees, nis' (and/or 'it has X, which this experiment's trials do not'): how a
    trials file's header differs from the columns expected ('' when only their order does, or
    nothing is expected)."""
    if columns is None:
        return ""
    lacks = [c for c in columns if c not in header]
    extra = [c for c in header if c not in columns]
    parts = ([f"it lacks {', '.join(lacks)}"] if lacks else []) + (
        [f"it has {', '.join(extra)}, which this experiment's trials do not"] if extra else [])
    return f": {'; '.join(parts)}" if parts else ""


@dataclass
class TrialsFile:
    """What a trials file holds: the rows that check, and the trials that must run again."""
    rows: list[dict]
    rejected: dict[int, str]      # trial -> why its rows cannot be kept


def read_trials(path: Path, columns: tuple[str, ...] | None = None) -> TrialsFile:
    """The rows of a trials file, each checked against its checksum.

    A row of an older file with a ``wall_s`` column keeps it (the runner moves it to the timings
    file). A torn last line (an interrupted write) is dropped. A trial with a row whose checksum does
    not match its values (an edited file), a malformed row, or two different rows for one filter
    run is rejected as a whole (it runs again); a row written twice with the same values is kept
    once. A file that is not a trials file at all, or (with ``columns``) whose columns are not
    those, is a UserError.
    """
    path = Path(path)
    require_regular(path)
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise UserError(f"{path}: not a pfbench trials file (not UTF-8 text)") from None
    if "\x00" in text:
        raise UserError(f"{path}: not a pfbench trials file (binary data in it)")
    if text and not text.endswith("\n"):
        text = text[: text.rfind("\n") + 1]
    try:
        lines = list(csv.reader(io.StringIO(text)))
    except csv.Error as exc:
        raise UserError(f"{path}: not a pfbench trials file ({exc})") from None
    header = tuple(lines[0]) if lines else ()
    if columns is not None and _end(header) == _LEGACY_END:
        columns = tuple(columns)[:-len(END_COLUMNS)] + _LEGACY_END
    if not _header_ok(header) or (columns is not None and header != tuple(columns)):
        raise UserError(f"{path}: not a pfbench trials file of this version (columns differ"
                        f"{_column_difference(header, columns)})")
    columns = header
    rows: dict[tuple[int, str], dict] = {}
    rejected: dict[int, str] = {}
    for n, fields in enumerate(lines[1:], start=2):
        try:
            trial = int(fields[0])
        except (ValueError, IndexError):
            continue                     # no trial to re-run: the row is ignored
        if len(fields) != len(columns):
            rejected.setdefault(trial, f"line {n} has {len(fields)} fields")
            continue
        try:
            row = _parse_row(fields, columns)
        except ValueError:
            rejected.setdefault(trial, f"line {n} is malformed")
            continue
        if row["crc"] != row_crc(fields[:-1]):
            rejected.setdefault(trial, f"line {n} ({row['filter']}): its checksum does not match "
                                "its values")
            continue
        key = (trial, row["filter"])
        if key in rows and _values(rows[key]) != _values(row):
            rejected.setdefault(trial, f"line {n} ({row['filter']}): a second row for it with "
                                "different values")
            continue
        rows.setdefault(key, row)
    return TrialsFile([r for r in rows.values() if r["trial"] not in rejected], rejected)


def complete_trials(rows: list[dict], exp: Experiment) -> dict[int, list[dict]]:
    """Rows grouped by trial, keeping only trials with a row for every filter run of ``exp``."""
    order = {f.key: i for i, f in enumerate(exp.filters)}
    by_trial: dict[int, dict[str, dict]] = {}
    for r in rows:
        if r["filter"] in order and 0 <= r["trial"]:
            by_trial.setdefault(r["trial"], {})[r["filter"]] = r
    return {k: sorted(v.values(), key=lambda r: order[r["filter"]])
            for k, v in by_trial.items() if len(v) == len(order)}


# ---------------------------------------------------------------- timings

def timings_text(rows: Iterable[dict], header: bool) -> str:
    """CSV text of the timings of ``rows`` (those that carry ``wall_s``)."""
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    if header:
        w.writerow(TIMINGS_COLUMNS)
    for r in rows:
        if r.get("wall_s") is not None:
            w.writerow([r["trial"], r["filter"], repr(float(r["wall_s"]))])
    return buf.getvalue()


def read_timings(out_dir: Path, partial: bool = False) -> dict[tuple[int, str], float]:
    """{(trial, filter run): wall seconds} from a folder's timings file (``partial``: the
    unfinished run's); rows it cannot read are left out, and a missing or damaged file gives
    what it can (timings are never worth refusing a run over)."""
    path = Path(out_dir) / (TIMINGS_PARTIAL if partial else TIMINGS)
    if path.exists() and not is_regular(path):
        return {}
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError):
        return {}
    out = {}
    for fields in csv.reader(io.StringIO(text.replace("\x00", ""))):
        try:
            trial, key, wall = int(fields[0]), fields[1], float(fields[2])
        except (ValueError, IndexError):
            continue
        if len(fields) == 3 and wall >= 0:
            out[(trial, key)] = wall
    return out


def with_timings(rows: list[dict], timings: dict[tuple[int, str], float]) -> list[dict]:
    """``rows`` with the wall time each has in ``timings`` (None where it has none)."""
    for r in rows:
        if r.get("wall_s") is None:
            r["wall_s"] = timings.get((r["trial"], r["filter"]))
    return rows


# ---------------------------------------------------------------- traces

def _npz_bytes(arrays: dict[str, np.ndarray]) -> bytes:
    """A .npz archive of ``arrays`` (compressed; fixed member timestamps: the same arrays give
    the same bytes; numpy.load reads it)."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        for name, a in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, np.asarray(a), allow_pickle=False)
            info = zipfile.ZipInfo(f"{name}.npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_DEFLATED
            z.writestr(info, member.getvalue())
    return buf.getvalue()


def _read_npz(path: Path) -> dict[str, np.ndarray] | None:
    """The arrays of a .npz file; None when it is missing or damaged."""
    if not is_regular(path):
        return None
    try:
        with np.load(path, allow_pickle=False) as f:
            return {name: f[name] for name in f.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, KeyError):
        return None


def stage_trace(out_dir: Path, trial: int, trace: dict) -> None:
    """Keep one finished trial's trace while the run goes on."""
    folder = Path(out_dir) / TRACES_PARTIAL
    folder.mkdir(exist_ok=True)
    atomic_write(folder / f"trial-{trial}.npz", _npz_bytes(trace))


def read_staged_traces(out_dir: Path) -> dict[int, dict]:
    """The traces an unfinished run staged (damaged ones left out: their trials run again)."""
    folder = Path(out_dir) / TRACES_PARTIAL
    found = {}
    for p in sorted(folder.glob("trial-*.npz")) if folder.is_dir() else ():
        k = p.stem.removeprefix("trial-")
        trace = _read_npz(p) if k.isdigit() else None
        if trace is not None:
            found[int(k)] = trace
    return found


def clear_staged_traces(out_dir: Path) -> None:
    remove_tree(Path(out_dir) / TRACES_PARTIAL, Path(out_dir))


def finish_traces(out_dir: Path, world: dict, traces: dict[int, dict]) -> None:
    """Write ``traces.npz`` (the world, then each trial's trace in trial order) and remove the
    staged ones; without traces, remove an old ``traces.npz``."""
    path = Path(out_dir) / TRACES
    if traces:
        arrays = {f"world/{n}": a for n, a in world.items()}
        for k in sorted(traces):
            arrays.update({f"{k}/{n}": a for n, a in traces[k].items()})
        atomic_write(path, _npz_bytes(arrays))
    else:
        path.unlink(missing_ok=True)
    clear_staged_traces(out_dir)


@dataclass
class Traces:
    """What ``traces.npz`` holds: the world's arrays and each kept trial's trace."""
    world: dict[str, np.ndarray]
    trials: dict[int, dict[str, np.ndarray]]


def read_traces(out_dir: Path) -> Traces | None:
    """The traces of a finished run (None when it kept none, or the file is damaged)."""
    arrays = _read_npz(Path(out_dir) / TRACES)
    if arrays is None:
        return None
    world, trials = {}, {}
    for name, a in arrays.items():
        head, _, rest = name.partition("/")
        if head == "world":
            world[rest] = a
        elif head.isdigit():
            trials.setdefault(int(head), {})[rest] = a
    return Traces(world, trials)


# ---------------------------------------------------------------- reading a results folder back

META = "meta.json"

_NONE = type(None)
# meta.json's keys a reader relies on: (the types it may have, whether every meta.json has it)
META_KEYS = {
    "experiment": ((str,), True), "experiment_hash": ((str,), True), "seed": ((int,), True),
    "trials": ((int,), True), "format": ((int,), False), "config": ((str, _NONE), False),
    "paper": ((str, _NONE), False), "table": ((str, _NONE), False),
    "versions": ((dict,), False), "identity": ((dict,), False),
    "until_decided": ((dict, _NONE), False), "git_commit": ((str, _NONE), False),
    "trials_sha256": ((str,), False), "trials_rows": ((int,), False),
}
_UNTIL_KEYS = {"max_trials": int, "batch": int, "looks": list, "stopped": str}


def trials_digest(text: str | bytes) -> str:
    """The checksum meta.json records of the trials file it describes: sha256 of its bytes,
    line ends read as \n (a checkout that writes \r\n holds the same file)."""
    data = text.encode("utf-8") if isinstance(text, str) else text
    return hashlib.sha256(data.replace(b"\r\n", b"\n")).hexdigest()


def _type_ok(v, types: tuple) -> bool:
    if isinstance(v, bool):
        return bool in types
    return isinstance(v, types)


def _names(types: tuple) -> str:
    words = {str: "a string", int: "an integer", dict: "a mapping", list: "a list",
             _NONE: "null"}
    return " or ".join(words[t] for t in types)


def check_meta(meta, path: Path) -> dict:
    """``meta`` (meta.json of a results folder, read from ``path``) when its shape is one this
    pfbench reads; a one-line UserError naming the file and the key otherwise. A folder of a
    newer results format than this pfbench's is refused, with the version that wrote it."""
    from .config import FORMAT_VERSION
    if not isinstance(meta, dict):
        raise UserError(f"{path}: expected a mapping of keys, got {describe(meta)}")
    fmt = meta.get("format")
    if _type_ok(fmt, (int,)) and fmt > FORMAT_VERSION:
        v = meta.get("versions")
        who = v.get("pfbench") if isinstance(v, dict) else None
        by = f"pfbench {who}" if isinstance(who, str) else "a newer pfbench"
        raise UserError(f"{path}: written by {by} in results format {fmt}; this pfbench "
                        f"({__version__}) reads formats up to {FORMAT_VERSION}: upgrade pfbench "
                        "to read it")
    for key, (types, required) in META_KEYS.items():
        if key not in meta:
            if required:
                raise UserError(f"{path}: no key '{key}' (expected {_names(types)})")
            continue
        if not _type_ok(meta[key], types):
            raise UserError(f"{path}: key '{key}': expected {_names(types)}, got "
                            f"{describe(meta[key])}")
    for key, least in (("trials", 1), ("trials_rows", 0), ("format", 1), ("seed", 0)):
        if key in meta and meta[key] < least:
            raise UserError(f"{path}: key '{key}': expected an integer >= {least}, got "
                            f"{meta[key]}")
    versions = meta.get("versions")
    if versions is not None and not all(isinstance(x, str) for x in versions.values()):
        raise UserError(f"{path}: key 'versions': expected a mapping of strings")
    if versions is not None and "pfbench" not in versions:
        raise UserError(f"{path}: key 'versions.pfbench': missing")
    until = meta.get("until_decided")
    if until is not None:
        for key, t in _UNTIL_KEYS.items():
            if not _type_ok(until.get(key), (t,)):
                raise UserError(f"{path}: key 'until_decided.{key}': expected {_names((t,))}, "
                                f"got {describe(until.get(key))}")
        for look in until["looks"]:
            if not (isinstance(look, dict) and _type_ok(look.get("trials"), (int,))
                    and _type_ok(look.get("undecided"), (int,))):
                raise UserError(f"{path}: key 'until_decided.looks': expected mappings of "
                                "'trials' and 'undecided' (integers)")
    filters = (meta.get("identity") or {}).get("filters")
    if filters is not None and not (isinstance(filters, list) and all(
            isinstance(f, list) and f and isinstance(f[0], str) for f in filters)):
        raise UserError(f"{path}: key 'identity.filters': expected a list of filter runs, each "
                        "a list that starts with its key")
    return meta


def _read_text(path: Path, what: str) -> str:
    """The UTF-8 text of the regular file ``path`` of ``what`` (a finished run, a sweep); a
    one-line UserError when it is missing, not a regular file or unreadable."""
    require_regular(path)
    try:
        return path.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise UserError(f"{path}: missing (not {what})") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise UserError(f"{path}: unreadable ({getattr(exc, 'strerror', None) or exc})") \
            from None


def read_meta(folder: Path) -> dict:
    """A results folder's meta.json, its shape checked (check_meta): a one-line UserError when it
    is missing, not JSON, or not a meta.json this pfbench reads."""
    path = Path(folder) / META
    text = _read_text(path, "a finished pfbench run")
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError) as exc:
        raise UserError(f"{path}: not JSON ({exc})") from None
    return check_meta(meta, path)


def _run_keys(meta: dict) -> list[str] | None:
    filters = (meta.get("identity") or {}).get("filters")
    return [f[0] for f in filters] if filters else None


def check_trials(got: TrialsFile, meta: dict, path: Path, meta_path: Path,
                 data: bytes | None = None) -> None:
    """A one-line UserError unless the trials file at ``path`` (read: ``got``; its bytes:
    ``data``) holds exactly what its meta.json (``meta``, at ``meta_path``) records: every row's
    checksum, the file's checksum where meta.json records one, every trial 0 .. trials - 1 with
    one row for each filter run, and nothing else."""
    if got.rejected:
        k, why = next(iter(sorted(got.rejected.items())))
        raise UserError(f"{path}: {len(got.rejected)} trial(s) fail their checksum or are "
                        f"malformed (trial {k}: {why})")
    want = meta["trials"]
    by_trial: dict[int, list[str]] = {}
    for r in got.rows:
        by_trial.setdefault(r["trial"], []).append(r["filter"])
    missing = [k for k in range(want) if k not in by_trial]
    extra = sorted(k for k in by_trial if not 0 <= k < want)
    hint = "the file was cut short or edited: run the experiment into this folder again"
    if missing:
        raise UserError(f"{path}: holds {want - len(missing)} of the {want} trials "
                        f"{meta_path.name} records (trial {missing[0]} missing"
                        f"{f' and {len(missing) - 1} more' if len(missing) > 1 else ''}); {hint}")
    if extra:
        raise UserError(f"{path}: trial {extra[0]} is beyond the {want} trials "
                        f"{meta_path.name} records; {hint}")
    keys = _run_keys(meta)
    if keys is None:
        counts = {len(v) for v in by_trial.values()}
        keys_ok = len(counts) <= 1
    else:
        keys_ok = all(sorted(v) == sorted(keys) for v in by_trial.values())
    if not keys_ok:
        k = next(k for k, v in sorted(by_trial.items())
                 if (keys is not None and sorted(v) != sorted(keys))
                 or (keys is None and len(v) != len(by_trial[0])))
        raise UserError(f"{path}: trial {k} has rows for {', '.join(sorted(by_trial[k]))}, not "
                        f"the filter runs {meta_path.name} records; {hint}")
    rows = meta.get("trials_rows")
    if rows is not None and rows != len(got.rows):
        raise UserError(f"{path}: holds {len(got.rows)} rows, {meta_path.name} records {rows}; "
                        f"{hint}")
    digest = meta.get("trials_sha256")
    if digest is not None and data is not None and trials_digest(data) != digest:
        raise UserError(f"{path}: not the trials file {meta_path.name} describes (its checksum "
                        "differs: another run's trials, an interrupted write or an edit); run "
                        "the experiment into this folder again")


def read_results(folder: Path) -> tuple[dict, TrialsFile]:
    """(meta.json, trials file) of a finished run's folder, each checked against the other
    (read_meta, check_trials): a one-line UserError when they do not agree."""
    folder = Path(folder)
    path = folder / "trials.csv"
    meta = read_meta(folder)
    require_regular(path)
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise UserError(f"{path}: missing (not a finished pfbench run)") from None
    except OSError as exc:
        raise UserError(f"{path}: unreadable ({exc.strerror or exc})") from None
    got = read_trials(path)
    check_trials(got, meta, path, folder / META, data)
    return meta, got


def _sweep_fields(fields: list[str]) -> list[str]:
    """A row of a sweep's trials.csv (past its swept values), as the cell's trials file wrote
    it: the combined file is written by pandas (an empty field for NaN, 100.0 for 100)."""
    trial, key, label, n = fields[:4]
    n = "" if n == "" else str(int(float(n)))
    return [str(int(trial)), key, label, n] + [
        "nan" if v == "" else repr(float(v)) for v in fields[4:-1]]


def read_sweep(folder: Path):
    """(trials, summary) of a finished sweep's folder as DataFrames, checked: every row of
    ``trials.csv`` against its checksum, ``summary.csv`` against the summary of those trials,
    and each cell's folder (read_results). A one-line UserError when anything disagrees."""
    import pandas as pd
    folder = Path(folder)
    path, spath = folder / "trials.csv", folder / "summary.csv"
    require_regular(path)
    require_regular(spath)
    text = _read_text(path, "a finished pfbench sweep")
    lines = list(csv.reader(io.StringIO(text.replace("\x00", ""))))
    header = tuple(lines[0]) if lines else ()
    k = header.index("trial") if "trial" in header else -1
    if k < 1 or not _header_ok(header[k:]):
        raise UserError(f"{path}: not a pfbench sweep's trials file (columns differ)")
    if len(lines) < 2:
        raise UserError(f"{path}: holds no trials")
    for n, fields in enumerate(lines[1:], start=2):
        try:
            ok = (len(fields) == len(header)
                  and row_crc(_sweep_fields(fields[k:])) == int(fields[-1]))
        except ValueError:
            ok = False
        if not ok:
            raise UserError(f"{path}: line {n}: its checksum does not match its values (an "
                            "edited or damaged row); run the sweep again")
    try:
        trials = pd.read_csv(path)
        summary = pd.read_csv(spath)
    except FileNotFoundError:
        raise UserError(f"{spath}: missing (not a finished pfbench sweep)") from None
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise UserError(f"{spath}: unreadable ({str(exc).splitlines()[0]})") from None
    keys = list(header[:k])
    again = sweep_summary(trials.drop(columns=["crc"]), keys)
    if not _same_frame(summary, again):
        raise UserError(f"{spath}: does not match the summary of {path.name} (an edited or "
                        "stale file); run the sweep again")
    cells = folder / "cells"
    for cell in sorted(cells.iterdir()) if cells.is_dir() else ():
        if cell.is_dir() and not cell.name.startswith("."):
            read_results(cell)
    return trials, summary


def _same_frame(a, b) -> bool:
    """Whether two summaries agree: the same columns and rows, numbers to 1e-12 relative."""
    import pandas as pd
    if list(a.columns) != list(b.columns) or len(a) != len(b):
        return False
    for c in a.columns:
        x, y = a[c], b[c]
        xn, yn = pd.to_numeric(x, errors="coerce"), pd.to_numeric(y, errors="coerce")
        if xn.notna().sum() == x.notna().sum() and yn.notna().sum() == y.notna().sum():
            if not np.allclose(xn.to_numpy(float), yn.to_numpy(float), rtol=1e-12, atol=0,
                               equal_nan=True):
                return False
        elif list(x.astype(str)) != list(y.astype(str)):
            return False
    return True


def sweep_summary(trials, keys: list[str],
                  metrics: tuple[str, ...] | None = None):
    """Mean, its Monte Carlo standard error and 95% interval of each of ``metrics`` (default:
    every metric of pfbench.metrics the trials hold) per cell and filter run (the run time ``wall_s`` only when asked: summary.csv
    holds what the seed determines). A pandas DataFrame: summary.csv, which pfbench.sweep
    writes and read_sweep checks."""
    import pandas as pd
    if metrics is None:
        metrics = tuple(m for m in METRICS if m in trials)
    out = []
    for vals, g in trials.groupby(keys + ["filter", "label"], sort=False, dropna=False):
        r = dict(zip(keys + ["filter", "label"], vals))
        r["particles"] = g["particles"].iloc[0]
        r["trials"] = len(g)
        for m in metrics:
            if m in g and pd.to_numeric(g[m], errors="coerce").notna().any():
                s = summarize(g[m])
                r.update({f"{m}_{k}": s[k] for k in ("mean", "se", "ci_lo", "ci_hi")})
        out.append(r)
    return pd.DataFrame(out)
