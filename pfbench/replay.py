"""What an up-to-date ``pfbench run`` (or ``pfbench sweep``) prints, without computing it again.

A run that finds its results folder up to date (every trial of its experiment already there)
runs nothing and writes the same bytes again: what it spends its second on is importing pandas,
scipy and the tables to compute the comparison it printed last time. After each run into a
folder, ``record`` keeps what the console showed of that comparison (strings:
``pfbench.tables.console_parts``) and the SHA-256 of the files the run left (table.csv,
table.md, trials.parquet), under a key made of everything the comparison depends on:

- the SHA-256 of every source file of pfbench, and the versions of Python, numpy, scipy, pandas
  and pyarrow (an edit or an upgrade is a new key);
- the experiment (its settings and its paper's table);
- the bytes of the folder's meta.json, trials.csv and timings.csv (the rows, their run times,
  and what meta.json says of the run).

``replay`` gives those strings back only when the key finds an entry and the folder still holds
the files it names with the same bytes (and, where the run draws figures, every figure an
up-to-date run checks for, with no half-written figure left). Anything else (an entry missing
or unreadable, a file changed or gone, another figure format) returns None, and the run takes
its ordinary path, which computes, writes and records again. The entries are JSON files beside
the table cache's (pfbench.tablecache), the newest ``tablecache.KEEP`` kept; a folder that
cannot be written records nothing.

The results folder keeps one entry of its own, ``console.json`` (FOLDER_RECORD), for where the
run times are not there: a fresh clone of a repository that commits its results (the timings
file is the machine's, never committed). It holds what the console prints of the comparison
without the run times (what a folder without a timings file prints), under a key of the code,
the experiment, meta.json and trials.csv, with the SHA-256 of table.csv and table.md. A run
that ran trials writes it (and a regeneration of committed results, and an up-to-date run into
a folder that has none); an up-to-date run never replaces one, so a folder whose record an
edit of the code has made stale stays as it is (the run computes, as without one). ``replay``
reads it only in a folder without a timings file, when its key is the current one and the two
tables have its bytes, and trials.parquet (ignored where results are committed) is absent or has
the bytes it had.

A sweep folder keeps one too (``record_sweep_in_folder``): the sweep's table without its run
times and its curves' verdicts, under a key of the code, the paper's curves and each cell's
name, experiment, meta.json and trials.csv, with the digests of the files and figures an
up-to-date sweep leaves; it is read only where neither the folder nor a cell has a timings file.

A sweep's entry (``record_sweep``, ``replay_sweep``) keeps its table and its curves' verdicts,
with every file an up-to-date sweep writes (SWEEP_FILES, and CELL_FILES in each cell's folder)
and every figure it drew, under a key of the code, the paper's curves, and each cell's name,
experiment and INPUTS.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Callable

from .fsutil import atomic_write, file_digest, left_by_a_kill
from .tablecache import code_digest, folder, store

FORMAT = 1
FILES = ("table.csv", "table.md", "trials.parquet")   # what an up-to-date run (re)writes
INPUTS = ("meta.json", "trials.csv", "timings.csv")     # what its comparison is computed from
FOLDER_RECORD = "console.json"      # the folder's own entry, for a folder without run times
UNTIMED_INPUTS = ("meta.json", "trials.csv")
UNTIMED_FILES = ("table.csv", "table.md")


def _digest(path: Path) -> str | None:
    """SHA-256 of a regular file's bytes; None when it is absent or not a regular file."""
    try:
        if not path.is_file() or path.is_symlink():
            return None
        return file_digest(path).hex()
    except OSError:
        return None


def _run_key(exp, folder: Path, untimed: bool) -> str:
    h = hashlib.sha256(code_digest().encode())
    if untimed:
        h.update(b"|untimed|")
    h.update(repr(exp).encode())
    h.update(repr(exp.reported).encode())
    for name in UNTIMED_INPUTS if untimed else INPUTS:
        h.update(f"|{name}={_digest(Path(folder) / name)}".encode())
    return h.hexdigest()


def key(exp, folder: Path) -> str:
    """The entry's key for ``exp``'s results in ``folder`` (see the module)."""
    return _run_key(exp, folder, False)


def untimed_key(exp, folder: Path) -> str:
    """The key of the folder's own entry (FOLDER_RECORD): as ``key``, without the timings file."""
    return _run_key(exp, folder, True)


def _where() -> Path | None:
    return folder()


def _write_folder_entry(folder: Path, replace: bool, make: Callable[[], dict]) -> None:
    """Write ``folder``'s own entry (FOLDER_RECORD): what ``make()`` gives (its key, parts, files
    and figures), with the format and the digest of trials.parquet; ``replace``: also where the
    folder has one, else only where it has none (``make`` is then not called). Never an error:
    a folder that cannot take it has none."""
    path = folder / FOLDER_RECORD
    try:
        if not replace and (path.exists() or path.is_symlink()):
            return
        entry = {"format": FORMAT, "parquet": _digest(folder / "trials.parquet"), **make()}
        atomic_write(path, json.dumps(entry, sort_keys=True, indent=1) + "\n")
    except Exception:
        pass


def _read_folder_entry(folder: Path, timed: list[Path], key: Callable[[], str],
                       files: Callable[[], dict]) -> dict | None:
    """``folder``'s own entry when none of the folders ``timed`` has a timings file, the entry's
    key is ``key()``, its files' digests are ``files()`` and trials.parquet is absent (a fresh
    clone: left so) or has the bytes it had; else None."""
    if any((f / "timings.csv").exists() or (f / "timings.csv").is_symlink() for f in timed):
        return None
    path = folder / FOLDER_RECORD
    try:
        if path.is_symlink() or not path.is_file():
            return None
        entry = json.loads(path.read_text("utf-8"))
    except (OSError, ValueError):
        return None
    if not (isinstance(entry, dict) and entry.get("format") == FORMAT
            and entry.get("key") == key() and entry.get("files") == files()):
        return None
    parquet = _digest(folder / "trials.parquet")
    return entry if parquet is None or parquet == entry.get("parquet") else None


def _untimed_files(folder: Path) -> dict:
    return {name: _digest(folder / name) for name in UNTIMED_FILES}


def record_in_folder(exp, folder: Path, parts: Callable[[], dict], figures: list[str] | None,
                     fmt: str, replace: bool) -> None:
    """Write the folder's own entry (FOLDER_RECORD): ``parts()``, what the console prints of the
    comparison without the run times, with the tables' digests and ``figures`` (as ``record``);
    ``replace``: also where the folder has one (a run that ran trials, a regeneration), else only
    where it has none. Never an error: a folder that cannot take it has none."""
    folder = Path(folder)
    _write_folder_entry(folder, replace, lambda: {
        "key": untimed_key(exp, folder), "parts": parts(), "files": _untimed_files(folder),
        "figures": None if figures is None else {"format": fmt, "names": list(figures)}})


def _folder_entry(exp, folder: Path) -> dict | None:
    """The folder's own entry where it still holds (_read_folder_entry): both tables there."""
    files = _untimed_files(folder)
    if None in files.values():
        return None
    return _read_folder_entry(folder, [folder], lambda: untimed_key(exp, folder),
                              lambda: files)


def record(exp, folder: Path, parts: dict, figures: list[str] | None, fmt: str) -> None:
    """Keep what the console printed (``parts``) of ``exp``'s run into ``folder``, with the files
    the run left there and ``figures`` (the names an up-to-date run checks for in format
    ``fmt``; None: the run was asked for none). Never an error: a cache that cannot be written
    is no cache."""
    where = _where()
    if where is None:
        return
    try:
        folder = Path(folder)
        files = {name: _digest(folder / name) for name in FILES}
        entry = {"format": FORMAT, "parts": parts, "files": files,
                 "figures": None if figures is None else {"format": fmt,
                                                          "names": list(figures)}}
        data = json.dumps(entry, sort_keys=True).encode()
        store(where, where / f"{key(exp, folder)}.replay.json", data, "*.replay.json")
    except Exception:
        pass


def _entry(name) -> dict | None:
    """The entry of the cache's file ``name()`` (called only when there is a cache folder), or
    None: no cache, no such entry, or one unreadable or of another format."""
    where = _where()
    if where is None:
        return None
    try:
        entry = json.loads((where / name()).read_text("utf-8"))
    except (OSError, ValueError):
        return None
    return entry if isinstance(entry, dict) and entry.get("format") == FORMAT else None


def _half_drawn(figs: Path) -> bool:
    """Whether the folder ``figs`` holds what a drawing killed half-way left (the ordinary path
    removes it, then draws)."""
    return any(left_by_a_kill(p.name) for p in figs.iterdir())


def _figures_there(folder: Path, want: dict | None, fmt: str) -> bool:
    """Whether ``folder/figures`` holds every figure of the entry's list for format ``fmt``, and
    no temporary file a killed drawing left (the ordinary path removes those)."""
    if not isinstance(want, dict) or want.get("format") != fmt:
        return False
    figs = folder / "figures"
    names = want.get("names")
    if not isinstance(names, list) or (names and (figs.is_symlink() or not figs.is_dir())):
        return False
    if figs.is_dir() and _half_drawn(figs):
        return False
    return all(isinstance(n, str) and (figs / n).is_file() for n in names)


def replay(exp, folder: Path, figures: bool, fmt: str) -> dict | None:
    """What the console printed of ``exp``'s comparison when ``folder`` last got its files
    (pfbench.tables.console_parts), if the folder still holds them with the same bytes (and,
    with ``figures``, every figure in format ``fmt``); else None. Call it only for a folder
    the runner found up to date, holding its lock."""
    folder = Path(folder)
    entry = _entry(lambda: f"{key(exp, folder)}.replay.json")
    if entry is None:
        entry = _folder_entry(exp, folder)
        if entry is None:
            return None
    else:
        files = entry.get("files")
        if not isinstance(files, dict) or set(files) != set(FILES) or any(
                sha is None or _digest(folder / name) != sha for name, sha in files.items()):
            return None
    if figures and not _figures_there(folder, entry.get("figures"), fmt):
        return None
    parts = entry.get("parts")
    return parts if _parts_ok(parts) else None


def _parts_ok(parts) -> bool:
    """Whether an entry's ``parts`` have the shape pfbench.tables.console_parts gives."""
    def tables_ok(tables):
        return isinstance(tables, list) and all(
            isinstance(t, list) and len(t) == 3 and isinstance(t[0], str)
            and isinstance(t[1], list) and all(isinstance(h, str) for h in t[1])
            and isinstance(t[2], list) and all(isinstance(r, list) and all(
                isinstance(c, str) for c in r) for r in t[2]) for t in tables)
    return (isinstance(parts, dict) and isinstance(parts.get("title"), str)
            and type(parts.get("trials")) is int and tables_ok(parts.get("headline"))
            and tables_ok(parts.get("wide")) and isinstance(parts.get("footnotes"), list)
            and all(isinstance(n, str) for n in parts["footnotes"])
            and isinstance(parts.get("counts"), str))


# ---- a sweep's (pfbench sweep): the same, for every cell and the sweep's own files

SWEEP_FILES = ("trials.csv", "timings.csv", "summary.csv", "trials.parquet", "curves.csv",
               "curves.md")                     # what an up-to-date sweep (re)writes
CELL_FILES = ("table.csv", "table.md")           # and in each cell's folder
UNTIMED_SWEEP_FILES = ("trials.csv", "summary.csv", "curves.csv", "curves.md")  # folder entry's


def _sweep_key(cells, folder: Path, untimed: bool) -> str:
    folder = Path(folder)
    h = hashlib.sha256(code_digest().encode())
    if untimed:
        h.update(b"|untimed|")
    h.update(repr(cells[0].curves if cells else ()).encode())
    for cell in cells:
        h.update(f"|cell {cell.name}|{cell.exp!r}|{cell.exp.reported!r}".encode())
        for name in UNTIMED_INPUTS if untimed else INPUTS:
            h.update(f"|{name}={_digest(folder / 'cells' / cell.name / name)}".encode())
    return h.hexdigest()


def sweep_key(cells, folder: Path) -> str:
    """The entry's key for the sweep of ``cells`` (pfbench.sweep.Cell) in ``folder``: the code
    (as ``key``), the paper's curves the sweep names, and per cell its name, its experiment and
    the bytes of its INPUTS."""
    return _sweep_key(cells, folder, False)


def _sweep_files(cells, folder: Path, names=SWEEP_FILES) -> dict:
    """The SHA-256 of every file an up-to-date sweep of ``cells`` writes in ``folder`` (None:
    absent), by its path in the folder: ``names`` of the folder's own, and each cell's
    CELL_FILES."""
    out = {name: _digest(folder / name) for name in names}
    for cell in cells:
        for name in CELL_FILES:
            out[f"cells/{cell.name}/{name}"] = _digest(folder / "cells" / cell.name / name)
    return out


def untimed_sweep_key(cells, folder: Path) -> str:
    """The key of a sweep folder's own entry (FOLDER_RECORD): as ``sweep_key``, without the
    cells' timings files."""
    return _sweep_key(cells, folder, True)


def _figure_digests(fmt: str, figures: list[Path]) -> dict:
    return {"format": fmt, "files": {Path(p).name: _digest(Path(p)) for p in figures}}


def record_sweep_in_folder(cells, folder: Path, parts: Callable[[], dict], figures: list[Path],
                           fmt: str, replace: bool) -> None:
    """A sweep folder's own entry (FOLDER_RECORD): ``parts()``, what the console prints of the
    sweep without the run times, with the digests of the files (those of ``sweep_key``'s
    without the timings file and trials.parquet: UNTIMED_SWEEP_FILES) and figures an
    up-to-date sweep leaves; ``replace`` as ``record_in_folder``. Never an error."""
    folder = Path(folder)
    if cells:
        _write_folder_entry(folder, replace, lambda: {
            "key": untimed_sweep_key(cells, folder), "parts": parts(),
            "files": _sweep_files(cells, folder, UNTIMED_SWEEP_FILES),
            "figures": _figure_digests(fmt, figures)})


def _sweep_folder_entry(cells, folder: Path) -> dict | None:
    """A sweep folder's own entry where it still holds (_read_folder_entry), no cell having a
    timings file either."""
    return _read_folder_entry(folder, [folder] + [folder / "cells" / c.name for c in cells],
                              lambda: untimed_sweep_key(cells, folder),
                              lambda: _sweep_files(cells, folder, UNTIMED_SWEEP_FILES))


def record_sweep(cells, folder: Path, parts: dict, figures: list[Path], fmt: str) -> None:
    """Keep what the console printed (``parts``: the sweep's table and its curves' blocks) of
    the sweep of ``cells`` into ``folder``, with the files it left there and its ``figures`` (in
    format ``fmt``). Never an error: a cache that cannot be written is no cache."""
    where = _where()
    if where is None or not cells:
        return
    try:
        folder = Path(folder)
        entry = {"format": FORMAT, "parts": parts, "files": _sweep_files(cells, folder),
                 "figures": _figure_digests(fmt, figures)}
        data = json.dumps(entry, sort_keys=True).encode()
        store(where, where / f"{sweep_key(cells, folder)}.sweep.json", data, "*.sweep.json")
    except Exception:
        pass


def replay_sweep(cells, folder: Path, fmt: str, figures: bool = True) -> dict | None:
    """What the console printed of the sweep of ``cells`` when ``folder`` last got its files,
    if it still holds every one with the same bytes (absent where it was), and (with
    ``figures``) every figure in format ``fmt`` with no half-written one beside them; else None.
    Call it only for a sweep whose every cell the runner found up to date, holding the folders'
    locks."""
    folder = Path(folder)
    entry = _entry(lambda: f"{sweep_key(cells, folder)}.sweep.json") if cells else None
    if entry is None and cells:
        entry = _sweep_folder_entry(cells, folder)
    elif entry is not None and entry.get("files") != _sweep_files(cells, folder):
        return None
    if entry is None or (figures and not _sweep_figures_there(entry, folder, fmt)):
        return None
    parts = entry.get("parts")
    return parts if _sweep_parts_ok(parts) else None


def _sweep_figures_there(entry: dict, folder: Path, fmt: str) -> bool:
    """Whether ``folder/figures`` holds every figure of a sweep entry, in format ``fmt`` and
    with the bytes the entry names, and no half-written one beside them."""
    figures = entry.get("figures")
    if not isinstance(figures, dict) or figures.get("format") != fmt:
        return False
    kept = figures.get("files")
    figs = folder / "figures"
    if not isinstance(kept, dict) or not kept or figs.is_symlink() or not figs.is_dir():
        return False
    return not _half_drawn(figs) and all(
        sha is not None and _digest(figs / name) == sha for name, sha in kept.items())


def _sweep_parts_ok(parts) -> bool:
    """Whether an entry's ``parts`` have the shape pfbench.cli's sweep tables give."""
    def strings(v):
        return isinstance(v, list) and all(isinstance(x, str) for x in v)

    def table_ok(t):
        return (isinstance(t, dict) and strings(t.get("head")) and isinstance(t.get("rows"), list)
                and all(strings(r) for r in t["rows"]))
    return (isinstance(parts, dict) and table_ok(parts.get("table"))
            and isinstance(parts.get("curves"), list)
            and all(table_ok(b) and isinstance(b.get("title"), str)
                    and isinstance(b.get("description"), str) for b in parts["curves"]))
