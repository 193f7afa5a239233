"""Sweeps: one experiment run over the cartesian product of values of some of its keys.

Each cell is an ordinary experiment (same base seed, so cells differ only in the swept values,
with common random numbers) written to ``<out>/cells/<cell>/`` with its table (table.csv, table.md:
the cell against its paper's table, as a run's) and resumable like ``run``; the
sweep folder gets a long-form ``trials.csv`` with a column per swept key, ``summary.csv`` (mean,
its standard error and 95% interval of each metric per cell and filter run) and a figure per
metric against the first swept key, one line per filter run with its 95% band. A sweep config
may name curves of its paper (``curves: [NAME, ...]``): the sweep is then judged against each
point by point (pfbench.curves: ``curves.csv``, ``curves.md``, the paper's points on the
figure).
"""
from __future__ import annotations

import copy
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

from .config import Experiment, apply_override, locate, read_yaml, validate
from .curves import resolve as resolve_curves
from .errors import UserError
from .figstyle import label
from .fsutil import FolderLock, own_folder
from .runner import run_experiment
from .store import TIMINGS, write_csv
from .store import sweep_summary as summary  # noqa: F401  (this module's API)
from .schema import ConfigError
from .yamlio import parse_yaml

if TYPE_CHECKING:     # pandas loads where a sweep runs: an up-to-date one replays without it
    import pandas as pd

CONFIRM_ABOVE = 50       # cells; more need --yes
MAX_CELLS = 10_000       # cells; more are refused (each is a folder of results)


def split_values(text: str) -> list[str]:
    """'1,2,[3, 4]' -> ['1', '2', '[3, 4]']: commas inside brackets or quotes do not split."""
    out, depth, cur, quote = [], 0, "", None
    for ch in text:
        if quote:
            cur += ch
            if ch == quote:
                quote = None
            continue
        if ch in "'\"":
            quote = ch
        elif ch in "[{":
            depth += 1
        elif ch in "]}":
            depth -= 1
        elif ch == "," and depth == 0:
            out.append(cur.strip())
            cur = ""
            continue
        cur += ch
    out.append(cur.strip())
    return [v for v in out if v]


def parse_sets(sets: list[str] | tuple[str, ...]) -> dict[str, list[Any]]:
    """--set KEY=V1,V2 ... -> {KEY: [values as YAML]} (keys in order)."""
    out: dict[str, list[Any]] = {}
    for s in sets:
        key, sep, text = s.partition("=")
        if not sep or not key.strip() or not text.strip():
            raise ConfigError(f"--set {s}", "expected KEY=V1,V2,..., e.g. scenario.speed_mps=1,2,3")
        try:
            values = [parse_yaml(v, "--set")[0] for v in split_values(text)]
        except ConfigError as err:
            raise ConfigError(f"--set {key}", f"cannot read the values {text!r}: {err.message}") \
                from None
        out[key.strip()] = values
    return out


@dataclass
class Cell:
    values: dict[str, Any]
    exp: Experiment
    name: str
    # the paper's curves the sweep is judged against, ((name, papers.Curve), ...): the same for
    # every cell of a sweep (pfbench.curves)
    curves: tuple = ()


def _cell_name(values: dict[str, Any]) -> str:
    """A plain folder name for a cell ('particles=50,steps=100'): never a path, at most 100
    characters (a long one ends in a hash of the whole)."""
    parts = [f"{k.split('.')[-1].replace('*', 'all')}={v}" for k, v in values.items()]
    name = re.sub(r"[^A-Za-z0-9_.=,-]+", "_", ",".join(parts)).lstrip(".") or "cell"
    if len(name) > 100:
        digest = hashlib.sha256(json.dumps(values, sort_keys=True, default=str).encode())
        name = f"{name[:83]}-{digest.hexdigest()[:16]}"
    return name


def _spec(config: Path, sets: dict[str, list[Any]]) -> tuple[dict, dict, dict]:
    """(raw config without 'sweep', line numbers, swept key -> values): the file's own ``sweep:``
    section, then --set (which wins)."""
    raw, lines = read_yaml(config)
    if not isinstance(raw, dict):
        raise ConfigError("", "expected a mapping of keys at the top", source=str(config))
    spec = raw.pop("sweep", None) or {}
    if not isinstance(spec, dict) or not all(isinstance(v, list) and v for v in spec.values()):
        raise ConfigError("sweep", "expected a mapping of key path -> non-empty list of values",
                          source=str(config), line=lines.get("sweep"))
    spec = {**spec, **sets}
    if not spec:
        raise UserError(f"{config}: nothing to sweep: give --set KEY=V1,V2,... or a 'sweep:' "
                        "section")
    return raw, lines, spec


def expand(config: Path, sets: dict[str, list[Any]], overrides: dict[str, Any], *,
           confirm_above: int | None = None) -> tuple[str, list[Cell]]:
    """The sweep's name and cells: the config's own ``sweep:`` section, then --set (which wins).

    The cells are counted before any is built: more than ``confirm_above`` (when given: the
    caller has no --yes) or than MAX_CELLS are refused."""
    raw, lines, spec = _spec(config, sets)
    curve_names = raw.pop("curves", None)
    n = math.prod(len(v) for v in spec.values())
    if confirm_above is not None and n > confirm_above:
        raise UserError(f"{n} cells is more than {confirm_above}: add --yes to run them")
    if n > MAX_CELLS:
        raise UserError(f"{config}: {n:,} sweep cells is more than {MAX_CELLS:,}: sweep fewer "
                        "values, or split the sweep")
    keys = list(spec)
    cells = []
    for combo in itertools.product(*(spec[k] for k in keys)):
        values = dict(zip(keys, combo))
        cell_raw = copy.deepcopy(raw)
        try:
            for k, v in values.items():
                apply_override(cell_raw, f"{k}={json.dumps(v)}")
            for k, v in overrides.items():
                if v is not None:
                    cell_raw[k] = v
            exp = validate(cell_raw, str(config))
        except ConfigError as err:
            where = ", ".join(f"{k}={v}" for k, v in values.items())
            if len(err.problems) > 1:       # every problem, each on its line
                raise UserError(f"{locate(err, str(config), lines)} (sweep cell {where})") \
                    from None
            # a problem of another file (the paper's) names that file and its line
            raise ConfigError(err.path, f"{err.message} (sweep cell {where})",
                              source=err.source or str(config),
                              line=err.line if err.source else lines.get(err.path)) from None
        cells.append(Cell(values, exp, _cell_name(values)))
    names = [c.name for c in cells]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise UserError(f"{config}: two sweep cells would share the folder '{dup}': make the "
                        "swept values distinct")
    if cells and curve_names is not None:
        try:
            judged = resolve_curves(curve_names, keys, cells)
        except ConfigError as err:
            raise err.located(str(config), lines) from None
        for cell in cells:
            cell.curves = judged
    return (cells[0].exp.name if cells else config.stem), cells


def run_sweep(cells: list[Cell], out_dir: Path, *, workers: int = 1, resume: bool = False,
              progress: Callable[[int, int], None] | None = None,
              executor=None, warn: Callable[[str], None] | None = None,
              force: bool = False, status: Callable[[str], None] | None = None
              ) -> pd.DataFrame:
    """Run every cell (resumable) on one executor, then write the combined trials. A cell's
    folder that holds its trials keeps them; one that holds another experiment's is refused
    without ``force`` (pfbench.runner.run_experiment). The trials' ``attrs["up_to_date"]``:
    every cell was up to date (nothing ran). Every cell's folder lies inside ``out_dir``, no
    link on the way (refused before any cell runs).

    ``progress(done, total)`` is called as trials finish, over every cell's (done counts the
    trials of the cells before, so it only grows, and reaches the total); ``status(line)`` as
    each cell begins ('cell particles=100 (2 of 8)')."""
    import pandas as pd
    total = sum(c.exp.trials for c in cells)
    if not force and (Path(out_dir) / "meta.json").exists():
        raise UserError(f"{out_dir} holds the results of a run, not of a sweep: --force "
                        "replaces them, or --out names another folder")
    out_dir = Path(out_dir)
    own_folder(out_dir / "cells", out_dir, "sweep cells folder")
    for cell in cells:          # every cell's folder is its own and free before any cell runs
        with FolderLock(out_dir / "cells" / cell.name, "sweep cell", root=out_dir):
            pass
    done = 0
    frames = []
    fresh = True
    for k, cell in enumerate(cells, 1):
        folder = out_dir / "cells" / cell.name
        if status:
            status(f"cell {cell.name} ({k} of {len(cells)})")

        def cell_progress(d, n, base=done):
            if progress:
                progress(base + d, total)

        with FolderLock(folder, "sweep cell", root=out_dir):
            res = run_experiment(cell.exp, folder, workers=workers, resume=resume,
                                 progress=cell_progress, executor=executor, warn=warn,
                                 traces=False, force=force)
        write_cell_table(cell.exp, res.rows, res.meta, folder)
        done += cell.exp.trials
        fresh &= res.up_to_date
        if progress and res.up_to_date:
            progress(done, total)
        df = pd.DataFrame(res.rows)
        for k, v in cell.values.items():
            df.insert(0, k, json.dumps(v) if isinstance(v, (list, dict)) else v)
        frames.append(df)
    trials = pd.concat(frames, ignore_index=True)
    # the trials file holds what the seed determines; the run times go to the timings file
    keys = list(cells[0].values) if cells else []
    write_csv(out_dir / "trials.csv", trials.drop(columns=["wall_s"], errors="ignore"))
    if "wall_s" in trials and trials["wall_s"].notna().any():    # none: the cells have no
        write_csv(out_dir / TIMINGS, trials[keys + ["trial", "filter", "wall_s"]])  # timings
    trials.attrs["up_to_date"] = fresh      # every cell held its trials: nothing ran
    return trials


def write_cell_table(exp, rows, meta: dict | None, folder: Path) -> None:
    """A sweep cell's comparison, table.csv and table.md, in its folder (its rows: the cell's
    trials, never run again), with the ranking of its filters: what a run's folder holds beside
    its trials."""
    from . import tables
    from .tablecache import anytime_of, cached_compare
    tables.write(cached_compare(exp, rows, anytime=anytime_of(meta)), folder, meta, rows)


# ---- what a sweep prints (JSON-able strings: what pfbench.replay keeps)

def console_parts(summ, trials_df, keys: list, exp, curves: tuple,
                  run_times: bool = True) -> dict:
    """What the console prints of a sweep: its table (``console_table``) and its verdicts
    against the paper's ``curves`` (``curves_blocks``, from ``summ.attrs["curves"]``). Without
    ``run_times``, as a sweep prints them where its cells have none (pfbench.replay's folder
    entry): the table's time column empty; the curves' verdicts read no run times."""
    if not run_times:
        trials_df = trials_df.drop(columns=["wall_s"], errors="ignore")
    return {"table": console_table(summ, trials_df, keys, exp),
            "curves": curves_blocks(curves, summ.attrs.get("curves"), keys)}


def record_in_folder(cells: list, folder: Path, summ, trials_df, figures: list[Path], fmt: str,
                     replace: bool) -> None:
    """Keep in the sweep's ``folder`` what the console prints of it without the run times
    (console_parts), with the figures an up-to-date sweep leaves: the folder's own entry
    (pfbench.replay.record_sweep_in_folder; ``replace`` as there). Never an error."""
    from .replay import record_sweep_in_folder
    if not cells:
        return
    keys = list(cells[0].values)
    record_sweep_in_folder(cells, folder, lambda: console_parts(
        summ, trials_df, keys, cells[0].exp, cells[0].curves, run_times=False),
        figures, fmt, replace)


def console_table(summ, trials_df, keys: list, exp) -> dict:
    """A sweep's table as strings (JSON-able, what pfbench.replay keeps): ``head`` and a row per
    cell and filter run, the means of RMSE and two more metrics, and the time a trial took."""
    from .plots import sweep_metrics
    extra = [m for m in sweep_metrics(exp)[1:] if f"{m}_mean" in summ][:2]
    head = ([k.split(".")[-1] for k in keys] + ["Filter", "N", "RMSE [95% CI]"]
            + [label(m) for m in extra] + ["ms/trial"])
    # the run times (not in summary.csv): the same cells and filter runs, in the same order
    wall = summary(trials_df, keys, ("wall_s",))
    ms_per_trial = (list(1e3 * wall["wall_s_mean"]) if "wall_s_mean" in wall
                    else [float("nan")] * len(summ))
    rows = []
    for (_, r), ms in zip(summ.iterrows(), ms_per_trial):
        n = r["particles"]
        rows.append([*[str(r[k]) for k in keys], str(r["label"]),
                     "-" if n != n or n is None else str(int(n)),
                     f"{r['rmse_mean']:.3g} [{r['rmse_ci_lo']:.3g}, {r['rmse_ci_hi']:.3g}]",
                     *[f"{r[f'{m}_mean']:.3g}" for m in extra],
                     "-" if ms != ms else f"{ms:.3g}"])
    return {"head": head, "rows": rows}


def curves_blocks(curves: tuple, judged, keys: list) -> list[dict]:
    """The sweep's verdicts against the paper's curves as strings (JSON-able): per curve, a
    ``title`` (its counts), its ``description`` and its table (``head``, a row per point)."""
    if not curves or judged is None:
        return []
    from . import curves as cv
    blocks = []
    for name, c in curves:
        g = judged[judged["curve"] == name]
        rows = []
        for _, r in g.iterrows():
            paper = ("-" if r["paper"] != r["paper"] else
                     f"{r['paper']:.4g} +- {r['reading_error']:.2g}"
                     + (" (interpolated)" if r["how"].startswith("interpolated") else ""))
            rows.append([*[str(r[k]) for k in keys], str(r["label"]), paper,
                         f"{r['ours']:.4g} [{r['ours_lo']:.4g}, {r['ours_hi']:.4g}]",
                         str(r["verdict"])])
        blocks.append({"title": f"curve {name}: {cv.counts(judged, name)}",
                       "description": cv.describe(name, c),
                       "head": [k.split(".")[-1] for k in keys]
                       + ["Filter", "paper", "ours [95% CI]", "verdict"], "rows": rows})
    return blocks
