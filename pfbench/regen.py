"""``pfbench tables``: regenerate every config's results, or check them against the committed ones.

Regeneration runs each config of a folder (``pfbench run``, or ``pfbench sweep`` for a file with a
``sweep:`` section) into ``<results>/<name>``, tables and figures included.

The check re-runs the first ``check.trials`` trials of each config (its ``check:`` section) into a
scratch folder and compares, for every filter run and every metric, the mean over those trials
with the mean over the committed trials:

    |mean_check - mean_committed| <= z s_pooled sqrt(1/n_check + 1/n_committed)

(s_pooled: the pooled standard deviation over the trials of both, the standard error of the
difference under the hypothesis that nothing changed; z = 4 by default), and never less than 1e-9
relative (the rounding of two means over different numbers of trials). Metrics that are constant
in both (a particle count, the likelihood evaluations) must agree to 1e-9 relative. Trials are pure functions
of the seed and the index, so on the machine that produced the results the first trials are
reproduced bit for bit (reported, not required: another platform's floating point may differ in
the last bits, which a chaotic filter can grow into a different trial, but not into a different
mean).
"""
from __future__ import annotations

import math
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable

import numpy as np
import pandas as pd

from .config import load, read_yaml
from .errors import UserError
from .store import REPORT_NAMES, reserved_name  # noqa: F401  (this module's API)
from .metrics import METRICS
from .fsutil import FolderLock, child, own_folder, recover_aside, remove_tree, replace_tree
from .runner import LocalExecutor, keep_provenance, missing_data, run_experiment
from . import sweep as sw
from .api import run_until_decided
from .outputs import check_figure_format
from .outputs import write_experiment, write_sweep  # noqa: F401  (this module's API)
from .store import TIMING_COLUMNS, read_results, trial_columns

Z_DEFAULT = 4.0


def config_files(folder: Path) -> list[Path]:
    """The experiment files of a folder (its YAML files, not those of subfolders such as
    worlds/), sorted by name."""
    folder = Path(folder)
    if not folder.is_dir():
        raise UserError(f"{folder}: no such folder of configs")
    files = sorted(p for p in folder.iterdir() if p.suffix in (".yaml", ".yml") and p.is_file())
    if not files:
        raise UserError(f"{folder}: no configs (*.yaml) in it")
    return files


def is_sweep(path: Path) -> bool:
    raw, _ = read_yaml(path)
    return isinstance(raw, dict) and "sweep" in raw


def experiment_name(path: Path, trials: int | None = None) -> str:
    """The name of a config's experiment (a sweep's too): its folder under the results."""
    if is_sweep(path):
        return sw.expand(path, {}, {"trials": trials})[0]
    return load(path, {"trials": trials}).name


# the files that mark a folder as holding a run's (or a sweep's) results
RESULT_MARKS = ("meta.json", "trials.csv", "run.json", "trials.partial.csv", "summary.csv")


def holder_of(folder: Path) -> Path | None:
    """``folder`` or the nearest folder above it that holds a run's or a sweep's results, or
    None."""
    try:
        cur = Path(folder).resolve()
    except (OSError, RuntimeError):
        return None
    for p in (cur, *cur.parents):
        if any((p / m).is_file() for m in RESULT_MARKS):
            return p
    return None


def check_outputs(files: list[Path], results: Path, names: list[str] | None = None) -> list[str]:
    """Refuse, before anything runs, a regeneration whose results folders would collide: two
    configs of one experiment name (one's results would replace the other's), a results folder
    that lies inside another experiment's results (replacing it would delete them), or a
    folder of results that is a symbolic link. Returns the names."""
    names = names if names is not None else [experiment_name(p) for p in files]
    seen: dict[str, Path] = {}
    for p, name in zip(files, names):
        child(Path(results), name, f"{p}: name")
        reserved_name(name, p)
        if name in seen:
            raise UserError(f"{seen[name]} and {p} both name the experiment '{name}': their "
                            f"results would share {Path(results) / name}; give one another "
                            "name")
        seen[name] = p
    holder = holder_of(results)
    if holder is not None:
        raise UserError(f"--results {results}: lies inside the results of a run ({holder}); "
                        "choose a folder of its own")
    for name in names:
        for folder in (Path(results) / name, Path(results) / f".{name}.partial"):
            own_folder(folder, results, "results folder")
    return names


def regenerate(path: Path, results: Path, executor: LocalExecutor, trials: int | None = None,
               figures: bool = True, resume: bool = False,
               progress: Callable[[int, int], None] | None = None,
               until_decided: bool = False, max_trials: int | None = None,
               figure_format: str = "png", warn: Callable[[str], None] | None = None,
               status: Callable[[str], None] | None = None, readings: bool = False) -> Path:
    """Run one config (an experiment or a sweep) into results/<name>, replacing what the folder
    held; return the folder. ``progress(done, total)`` is called as trials finish (over every
    cell of a sweep; a run until decided raises the total batch by batch), ``status(line)`` as
    each cell of a sweep begins. With ``until_decided``, an experiment that compares with a paper's
    table runs in batches until its judged cells are decided (pfbench.api.run_until_decided;
    ``max_trials``: at most, default ten batches); the others run as usual.

    The run goes to a staging folder beside it (``.<name>.partial``) that replaces the old folder
    only when everything is written, so an error or Ctrl-C leaves the committed results as they
    were; ``resume`` keeps the staging folder's finished trials.

    The folder's readings (pfbench.readings) are kept when the config's trials are the same;
    ``readings`` runs every reading its paper file declares (those kept and up to date are not
    run again) and judges them (readings.csv, readings.md)."""
    sweep = is_sweep(path)
    if sweep:
        name, cells = sw.expand(path, {}, {"trials": trials})
    else:
        exp = load(path, {"trials": trials})
        name = exp.name
    if figures:
        check_figure_format(figure_format)
    results = Path(results)
    folder = child(results, name, f"{path}: name")
    stage = results / f".{name}.partial"
    check_outputs([path], results, [name])
    with FolderLock(results, "--results"):
        recover_aside(folder, results, warn)
        if not resume:
            remove_tree(stage, results)
        with FolderLock(stage, "results folder", root=results):
            if sweep:
                df = sw.run_sweep(cells, stage, resume=resume, progress=progress,
                                  executor=executor, status=status)
                keys = list(cells[0].values)
                summ, figs = write_sweep(df, keys, stage, name, figures, figure_format,
                                         cells[0].exp, curves=cells[0].curves)
                sw.record_in_folder(cells, stage, summ, df, figs, figure_format, True)
            elif until_decided and exp.reported is not None:
                run_until_decided(exp, out=stage, max_trials=max_trials, resume=resume,
                                  figures=figures, executor=executor, progress=progress,
                                  figure_format=figure_format)
            else:
                res = run_experiment(exp, stage, resume=resume, progress=progress,
                                     executor=executor)
                cmp, _ = write_experiment(exp, res, stage, figures, figure_format)
                from .api import _record
                _record(exp, res, stage, cmp, figures, figure_format, replace=True)
                _readings(exp, folder, stage, executor, readings, warn, status)
        with FolderLock(folder, "results folder", root=results):
            keep_provenance(stage, folder)
            replace_tree(stage, folder, results)
    return folder


def redraw(path: Path, results: Path, figure_format: str = "png") -> Path:
    """Draw again the figures of one config's committed results from its trials and traces,
    running no trial: an experiment's figures (its table.md stays as it is), a sweep's summary,
    curves and figures, and each cell's table (table.csv, table.md). The trials files are only read. Returns the
    folder; a UserError when it holds no finished results of the config."""
    from .store import read_sweep
    check_figure_format(figure_format)
    if is_sweep(path):
        name, cells = sw.expand(path, {}, {})
        folder = child(Path(results), name, f"{path}: name")
        with FolderLock(folder, "results folder", root=Path(results)):
            from .sweep import write_cell_table
            for cell in cells:
                meta, tf = read_results(folder / "cells" / cell.name)
                write_cell_table(cell.exp, tf.rows, meta, folder / "cells" / cell.name)
            df, _ = read_sweep(folder)      # checked: its trials, summary and cells agree
            write_sweep(df, list(cells[0].values), folder, name, True, figure_format,
                        cells[0].exp, curves=cells[0].curves)
        return folder
    exp = load(path)
    folder = child(Path(results), exp.name, f"{path}: name")
    with FolderLock(folder, "results folder", root=Path(results)):
        meta, tf = read_results(folder)
        # as the report: the committed trials as they are (a config edited since, in a way
        # that keeps its trials, leaves them standing; 'pfbench tables --check' says whether)
        if meta.get("experiment") != exp.name or tf.rejected:
            raise UserError(f"{folder}: its trials are not {exp.name}'s, or some fail their "
                            "checksum (run it again: pfbench tables)")
        from .outputs import anytime_of
        from .plots import write_figures
        from .tablecache import cached_compare
        from .store import read_timings, with_timings
        with_timings(tf.rows, read_timings(folder))     # the run times, for a time ratio
        table = cached_compare(exp, tf.rows, anytime=anytime_of(meta)).table
        write_figures(exp, tf.rows, folder, figure_format, table)
    return folder


def _readings(exp, folder: Path, stage: Path, executor, run: bool, warn, status) -> None:
    """The readings of a regenerated experiment: those ``folder`` held, kept in ``stage`` when
    its trials are the same (pfbench.readings.carry); with ``run``, every reading its paper file
    declares run into ``stage`` (a reading kept up to date is not) and judged."""
    from . import readings as rd
    rd.carry(folder, stage, warn)
    if not run or not rd.declared(exp):
        return
    runs = rd.plan(exp)

    def say(r, fresh):
        if status:
            status(f"reading {r.name}" + (" (up to date)" if fresh else ""))
    rd.run_all(runs, stage, executor, say)
    rd.write(runs, stage)


def total_trials(path: Path, trials: int | None = None) -> int:
    """Trials a regeneration of the config runs (over all cells of a sweep)."""
    if is_sweep(path):
        return sum(c.exp.trials for c in sw.expand(path, {}, {"trials": trials})[1])
    return load(path, {"trials": trials}).trials


@dataclass
class MovedMetric:
    """One (filter run, metric) of a --check that moved past its tolerance."""
    where: str          # config, and the sweep cell if any
    run: str
    metric: str
    check: float
    committed: float
    tolerance: float

    def line(self) -> str:
        return (f"{self.where}: {self.run} {self.metric}: {self.check:.6g} now, {self.committed:.6g} "
                f"committed (difference {self.check - self.committed:+.3g}, tolerance "
                f"{self.tolerance:.3g})")


@dataclass
class CheckResult:
    config: str
    trials: int                   # trials re-run (per cell)
    compared: int = 0             # (run, metric) pairs compared
    identical: bool = True        # the re-run trials equal the committed ones bit for bit
    findings: list[MovedMetric] = field(default_factory=list)
    skipped: str = ""             # why nothing was re-run (the recorded data are absent)

    @property
    def ok(self) -> bool:
        return not self.findings



def check_against_committed(check: pd.DataFrame, committed: pd.DataFrame, where: str,
                            z: float = Z_DEFAULT,
                            result: CheckResult | None = None) -> CheckResult:
    """Compare re-run trials with committed ones, metric by metric, for every filter run."""
    result = result or CheckResult(where, int(check["trial"].nunique()))
    for run, a_rows in check.groupby("filter", sort=False):
        b_rows = committed[committed["filter"] == run]
        if b_rows.empty:
            result.findings.append(MovedMetric(where, run, "(missing)", math.nan, math.nan, 0.0))
            continue
        for metric in (m for m in METRICS if m in check.columns and m in committed.columns):
            a = a_rows[metric].to_numpy(float)
            b = b_rows[metric].to_numpy(float)
            a, b = a[np.isfinite(a)], b[np.isfinite(b)]
            if a.size < 2 or b.size < 2:
                continue            # too few finite values to compare (e.g. no convergence yet)
            result.compared += 1
            d = float(a.mean() - b.mean())
            se = pooled_se(a, b)
            # never below 1e-9 relative: two means over different trial counts round apart by
            # an ulp or so, which a near-constant metric's tiny spread would call a move
            tol = max(z * se, 1e-9 * max(1.0, abs(float(b.mean()))))
            if not abs(d) <= tol:
                result.findings.append(MovedMetric(where, run, metric, float(a.mean()),
                                               float(b.mean()), tol))
    cols = [c for c in check.columns if c not in TIMING_COLUMNS + ("crc",)]
    same = committed[committed["trial"].isin(check["trial"].unique())]
    key = ["trial", "filter"]
    mine = check[cols].sort_values(key).reset_index(drop=True)
    theirs = same[cols].sort_values(key).reset_index(drop=True) if set(cols) <= set(same.columns) \
        else None
    result.identical &= theirs is not None and mine.equals(theirs)
    return result


def pooled_se(a: np.ndarray, b: np.ndarray) -> float:
    """Standard error of mean(a) - mean(b) when both samples come from one distribution (the
    hypothesis under test): the pooled variance of the two, times 1/n_a + 1/n_b.

    The pooled variance is dominated by the larger, committed sample. Estimating the re-run's
    spread from its own few trials instead (Welch) understates it whenever a metric is
    heavy-tailed: 5 trials of a SLAM heading error rarely contain the one bad trial in 20 that
    sets the spread."""
    na, nb = a.size, b.size
    var = ((na - 1) * a.var(ddof=1) + (nb - 1) * b.var(ddof=1)) / (na + nb - 2)
    return math.sqrt(var * (1.0 / na + 1.0 / nb))


def _committed(folder: Path, exp) -> pd.DataFrame:
    path = folder / "trials.csv"
    if not path.exists():
        raise UserError(f"{path}: no committed trials to check against; run 'pfbench tables' "
                        "first")
    # checked: every row's checksum, and the trials and filter runs its meta.json records
    df = pd.DataFrame(read_results(folder)[1].rows)
    missing = [m for m in trial_columns(exp) if m not in df.columns]
    if missing:
        raise UserError(f"{path}: written by another version (no column {missing[0]}); "
                        "regenerate it with 'pfbench tables'")
    return df


def check_trials(path: Path) -> int:
    """Trials a check of the config re-runs (over all cells of a sweep); validates it."""
    if is_sweep(path):
        return sum(min(c.exp.check["trials"], c.exp.trials)
                   for c in sw.expand(path, {}, {})[1])
    exp = load(path)
    return min(exp.check["trials"], exp.trials)


def check_config(path: Path, results: Path, executor: LocalExecutor, z: float = Z_DEFAULT,
                 progress: Callable[[int, int], None] | None = None) -> CheckResult:
    """Re-run the first check.trials trials of a config and compare them with results/<name>;
    ``progress(done, total)`` is called as trials finish (over every cell of a sweep)."""
    progress = progress or (lambda done, total: None)
    with tempfile.TemporaryDirectory(prefix="pfbench-check-") as tmp:
        if is_sweep(path):
            name, cells = sw.expand(path, {}, {})
            result = CheckResult(name, 0)
            before = 0
            total = sum(min(c.exp.check["trials"], c.exp.trials) for c in cells)
            for cell in cells:
                k = min(cell.exp.check["trials"], cell.exp.trials)
                committed = _committed(child(Path(results), name, f"{path}: name") / "cells"
                                       / cell.name, cell.exp)
                res = run_experiment(replace(cell.exp, trials=k), Path(tmp) / cell.name,
                                     progress=lambda d, n, b=before: progress(b + d, total),
                                     executor=executor)
                before += k
                result.trials = k
                check_against_committed(pd.DataFrame(res.rows), committed,
                                        f"{name} [{cell.name}]", z, result)
            return result
        exp = load(path)
        why = missing_data(exp)
        if why is not None:         # nothing to re-run here: said, not failed
            return CheckResult(exp.name, 0, skipped=why)
        k = min(exp.check["trials"], exp.trials)
        where = child(Path(results), exp.name, f"{path}: name")
        committed = _committed(where, exp)
        res = run_experiment(replace(exp, trials=k), Path(tmp) / exp.name, progress=progress,
                             executor=executor)
        result = check_against_committed(pd.DataFrame(res.rows), committed, exp.name, z,
                                         CheckResult(exp.name, k))
        return _check_readings(replace(exp, trials=k), where, Path(tmp) / exp.name, executor,
                               z, result)


def _check_readings(exp, where: Path, scratch: Path, executor, z: float,
                    result: CheckResult) -> CheckResult:
    """The committed readings of results folder ``where`` (pfbench.readings.committed) checked
    as its trials are: each reading's first trials run again beside the config's in ``scratch``
    (the filter runs it leaves alone keep their rows) and compared with its committed trials."""
    from . import readings as rd
    from .store import read_results as read
    for run in rd.committed(exp, where):
        theirs = _committed(rd.reading_folder(where, run.name), run.exp)
        mine = read(rd.run_reading(run, scratch, executor))[1].rows
        check_against_committed(pd.DataFrame(mine), theirs, f"{exp.name} [reading {run.name}]",
                                z, result)
    return result
