"""pfbench from Python: run an experiment into pandas DataFrames, or read a results folder.

    import pfbench
    res = pfbench.run_experiment("configs/ifa_pf_ungm.yaml", trials=50)
    res.table[["label", "particles", "rmse_mean", "rmse_ci_lo", "rmse_ci_hi"]]
    res.trials.groupby("label")["rmse"].describe()

Nothing is written unless ``out`` names a results folder; then the folder holds what ``pfbench
run`` writes (the CLI calls this function). ``load_results`` reads such a folder back;
``load_trials`` reads the trials of many folders into one DataFrame.
"""
from __future__ import annotations

import copy
import dataclasses
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Iterable, Mapping

from .errors import UserError
from .fsutil import FolderLock, recover_aside, require_regular
from .outputs import anytime_of, check_figure_format  # noqa: F401  (this module's API)
from .outputs import clear_leftovers, write_experiment
from .progress import shown
from .schema import ConfigError, describe

if TYPE_CHECKING:     # pandas loads after a run's workers start (runner.import_ahead)
    import pandas as pd

__all__ = ["Result", "load_results", "load_trials", "run_experiment", "run_until_decided"]


@dataclass
class Result:
    """What an experiment gave.

    trials : one row per trial and filter run: ``trial``, ``filter`` (the run's key, such as
        ``pf@50``), ``label``, ``particles``, the metrics of the scenario's kind, and ``wall_s``,
        the run's wall time in seconds (NaN where the folder's timings file has none)
    table : one row per filter run: the statistics over trials (``rmse_mean``, ``rmse_ci_lo``,
        ...), and beside a paper's table ``paper_Q``, ``ours_Q``, ``verdict_Q`` for each of its
        quantities Q (a sweep's results: its summary, one row per cell and filter run)
    meta : the experiment's name, hash, seed, trials, and the provenance of its trials (commit,
        versions, machine): a results folder's meta.json
    run : what the run took on this machine (``wall_s``, ``trials_run_now``, ``workers``,
        start and end): a results folder's timings.json; None where it has none
    experiment : the validated config (None when a results folder's config is gone or changed)
    folder : the results folder, or None when nothing was written
    comparison : the comparison the table comes from (pfbench.compare; None for a sweep, or a
        results folder without its config)
    figures : the figures drawn into the results folder
    up_to_date : the results folder held every trial already: nothing ran
    """
    trials: pd.DataFrame
    table: pd.DataFrame
    meta: dict
    experiment: Any = None
    folder: Path | None = None
    comparison: Any = None
    figures: list = field(default_factory=list)
    up_to_date: bool = False
    run: dict | None = None


# ---- the arguments of the API's functions, checked before anything runs or is written

def _is_int(v) -> bool:
    """An integer (a numpy one too), never a boolean."""
    import numbers
    return (isinstance(v, numbers.Integral) and not isinstance(v, bool)
            and type(v).__name__ != "bool_")


def _int(v):
    return None if v is None else int(v)


def _describe(v) -> str:
    return describe(v)


# (test, what it expects): each kind of argument the API's functions take
_PATH = (lambda v: isinstance(v, (str, os.PathLike)), "a path (a string or a pathlib.Path)")
_OPT_PATH = (lambda v: v is None or _PATH[0](v), "a path (a string or a pathlib.Path) or None")
_CONFIG = (lambda v: isinstance(v, (str, os.PathLike, Mapping)) or _is_experiment(v),
           "a path or a mapping (a YAML file, a mapping of config keys, or a "
           "pfbench.config.Experiment)")
_COUNT = (lambda v: _is_int(v) and v >= 1, "an integer >= 1")
_OPT_COUNT = (lambda v: v is None or _COUNT[0](v), "an integer >= 1 or None")
_OPT_SEED = (lambda v: v is None or (_is_int(v) and v >= 0), "an integer >= 0 or None")
_FLAG = (lambda v: isinstance(v, bool), "True or False")
def _takes(v, n: int) -> bool:
    """Whether ``v`` can be called with ``n`` positional arguments (a callable whose signature
    cannot be read is given the benefit of the doubt)."""
    import inspect
    if not callable(v):
        return False
    try:
        inspect.signature(v).bind(*range(n))
    except TypeError:
        return False
    except ValueError:
        return True
    return True


_PROGRESS = (lambda v: v is None or isinstance(v, bool) or _takes(v, 2),
             "a function of (done, total), True (a progress bar) or None")
_WARN = (lambda v: v is None or _takes(v, 1), "a function of one message or None")
_ON_LOOK = (lambda v: v is None or _takes(v, 1), "a function of one look or None")
_OVERRIDES = (lambda v: (not isinstance(v, (str, bytes, Mapping)) and hasattr(v, "__iter__")),
              "a list of 'KEY.PATH=VALUE' strings")
_EXECUTOR = (lambda v: v is None or (not isinstance(v, type)
                                     and callable(getattr(v, "run", None))
                                     and callable(getattr(v, "describe", None))),
             "a pfbench.runner executor (with run and describe) or None")
_FORMAT = (lambda v: v in ("png", "svg", "pdf") if isinstance(v, str) else False,
           "one of 'png', 'svg', 'pdf'")


def _is_experiment(v) -> bool:
    from .config import Experiment
    return isinstance(v, Experiment)


def _check_args(fn: str, **args) -> None:
    """A one-line UserError naming the function and the argument when one is not what it takes
    (``args``: name -> (value, (test, what it expects)))."""
    for name, (value, (test, what)) in args.items():
        if not test(value):
            raise UserError(f"{fn}: {name}: expected {what}, got {_describe(value)}")


def _overrides(fn: str, overrides) -> tuple[str, ...]:
    """The overrides as a tuple of strings (an iterator is read once)."""
    _check_args(fn, overrides=(overrides, _OVERRIDES))
    out = tuple(overrides)
    for o in out:
        if not isinstance(o, str):
            raise UserError(f"{fn}: overrides: expected 'KEY.PATH=VALUE' strings, got "
                            f"{_describe(o)} among them")
    return out


def _experiment(config, trials, seed, overrides):
    from .config import Experiment, apply_override, load, refuse_incompatible, validate
    if isinstance(config, Experiment):          # validated already (the CLI's)
        if trials is not None or seed is not None or tuple(overrides):
            raise UserError("trials, seed and overrides go with a config file or mapping")
        refuse_incompatible(config)         # one built or changed by hand: its pairs checked
        return config
    if isinstance(config, (str, Path)):
        return load(config, {"trials": trials, "seed": seed}, tuple(overrides))
    if not isinstance(config, Mapping):
        raise UserError(f"config: expected a path or a mapping, got {describe(config)}")
    data = copy.deepcopy(dict(config))
    for assignment in overrides:
        apply_override(data, assignment)
    for k, v in (("trials", trials), ("seed", seed)):
        if v is not None:
            data[k] = v
    # relative files (a world) and papers/ resolve against the current folder
    try:
        return validate(data, "config")
    except ConfigError as err:
        raise ConfigError(err.path, err.message, source="config (a mapping)",
                          line=None) from None


def out_folder(out, what: str = "out") -> Path | None:
    """``out`` as a results folder's path (None: none), or the one-line UserError the CLI gives
    for its --out: an empty or blank path (it would be the current folder, which nobody named),
    a NUL, a file where the folder should be."""
    if out is None:
        return None
    if isinstance(out, bytes) or not isinstance(out, (str, os.PathLike)):
        raise UserError(f"{what}: expected a path (a str or a pathlib.Path), got "
                        f"{type(out).__name__}")
    text = os.fspath(out)
    if not isinstance(text, str):
        raise UserError(f"{what}: expected a path (a str or a pathlib.Path), got bytes")
    if not text.strip():
        raise UserError(f"{what}: expected a path, got an empty one")
    if "\x00" in text:
        raise UserError(f"{what}: a path cannot contain a NUL character")
    folder = Path(text)
    if folder.exists() and not folder.is_dir():
        raise UserError(f"{what} {folder}: exists and is not a folder")
    return folder


def _missing_figures(exp, res, folder: Path, fmt: str) -> bool:
    """Whether an up-to-date folder lacks a figure a run draws (a run killed while it drew them);
    the temporary files such a kill left are removed."""
    from .plots import expected_figures
    figs = folder / "figures"
    clear_leftovers(figs)
    return any(not (figs / name).is_file() for name in expected_figures(exp, res.rows, fmt))


def _record(exp, res, folder: Path, cmp, figures: bool, fmt: str,
            replace: bool | None = None) -> None:
    """Keep what the console shows of this comparison for the next up-to-date run of it
    (pfbench.replay), with the figures it checks for when ``figures``; and in the folder, what
    it shows without the run times (replay.record_in_folder: replaced where ``replace``, by
    default where trials ran)."""
    from .replay import record, record_in_folder
    from .tables import console_parts
    try:
        names = None
        if figures:
            from .plots import expected_figures
            names = expected_figures(exp, res.rows, fmt)
        record(exp, folder, console_parts(cmp), names, fmt)
        record_in_folder(exp, folder, lambda: console_parts(cmp.without_timings()), names, fmt,
                         not res.up_to_date if replace is None else replace)
    except Exception:       # a cache: never a run's error
        pass


def _frame(rows: list[dict], columns: Iterable[str]) -> pd.DataFrame:
    cols = [c for c in columns if c not in ("crc", "wall_s")] + ["wall_s"]
    import pandas as pd
    df = pd.DataFrame([{c: r.get(c) for c in cols} for r in rows], columns=cols)
    return df.assign(wall_s=pd.to_numeric(df["wall_s"], errors="coerce"))


def run_experiment(config: str | Path | Mapping, *, trials: int | None = None,
                   seed: int | None = None, workers: int = 1, overrides: Iterable[str] = (),
                   out: str | Path | None = None, resume: bool = False, figures: bool = True,
                   executor=None, progress: Callable[[int, int], None] | bool | None = None,
                   warn: Callable[[str], None] | None = None, force: bool = False,
                   figure_format: str = "png") -> Result:
    """Run every trial of an experiment and compare it with its paper.

    config : a YAML file, or a mapping with the same keys (``{"scenario": {"name": "ungm"},
        "filters": {"pf": {"particles": 100}}}``), or a validated pfbench.config.Experiment
    trials, seed : override the config's
    workers : local worker processes (the results do not depend on it)
    overrides : ``KEY.PATH=VALUE`` assignments, as ``pfbench run --set``
    out : a results folder to write (trials.csv, table.csv, table.md, meta.json, figures); None
        writes nothing
    resume : (with ``out``) keep the finished trials of an earlier run of the same experiment
        (a folder that holds this experiment's trials keeps them anyway; one that holds all of
        them is up to date: nothing runs, and only the table is written again)
    force : (with ``out``) replace a folder that holds another experiment, or more trials of
        this one (refused otherwise)
    figures : (with ``out``) draw the figures; False: draw none, and where trials run now, take
        away the figures the folder holds of the trials they replace; figure_format : png, svg
        or pdf
    executor : where the trials run (a pfbench.runner executor; default: ``workers`` local
        processes)
    progress : ``progress(done, total)`` is called when the trials start (``done``: those an
        earlier run left, usually 0) and again each time trials finish, ``done`` growing to
        ``total``; trials are handed out in units of a fraction of a second (one at a time
        where a trial takes longer), so it is called every second or so. True shows a progress
        bar on stderr (in a notebook, below the cell) instead; None (default) shows nothing.
    warn : ``warn(message)`` is told what a run keeps or drops of an earlier one
    """
    fn = "run_experiment"
    _check_args(fn, config=(config, _CONFIG), trials=(trials, _OPT_COUNT),
                seed=(seed, _OPT_SEED), workers=(workers, _COUNT), out=(out, _OPT_PATH),
                resume=(resume, _FLAG), figures=(figures, _FLAG), executor=(executor, _EXECUTOR),
                progress=(progress, _PROGRESS), warn=(warn, _WARN), force=(force, _FLAG),
                figure_format=(figure_format, _FORMAT))
    overrides = _overrides(fn, overrides)
    trials, seed, workers = _int(trials), _int(seed), int(workers)
    from .runner import LocalExecutor
    out = out_folder(out)
    check_figure_format(figure_format)
    exp = _experiment(config, trials, seed, overrides)
    executor = executor or LocalExecutor(workers)
    with shown(progress, executor) as progress:
        return _run(exp, workers, out, resume, figures, executor, progress, warn, force,
                    figure_format)


def _run(exp, workers, out, resume, figures, executor, progress, warn, force,
         figure_format) -> Result:
    from .runner import run_experiment as run_into, versions
    from .store import trial_columns
    if out is not None:
        recover_aside(out, out.parent, warn, clean=False)   # a replace killed half-way
        with FolderLock(out, "out"):
            res = run_into(exp, out, workers=workers, resume=resume, progress=progress,
                           executor=executor, warn=warn, force=force)
            # up to date: the table again (the same bytes when nothing changed), and the
            # figures when asked to resume (which redraws them from the trials and traces
            # kept) or when one is missing (a run killed while it drew them)
            draw = figures and (resume or not res.up_to_date
                                or _missing_figures(exp, res, out, figure_format))
            cmp, paths = write_experiment(exp, res, out, draw, figure_format)
            _record(exp, res, out, cmp, figures, figure_format)
        return Result(_frame(res.rows, trial_columns(exp)), cmp.table, res.meta, exp,
                      out, cmp, paths, up_to_date=res.up_to_date, run=res.run)
    if resume:
        raise UserError("resume needs a results folder (out)")
    done: dict[int, list[dict]] = {}
    t0 = time.perf_counter()
    if progress:
        progress(0, exp.trials)
    for chunk in executor.run(exp, range(exp.trials), exp.trials):
        for t in chunk:
            done.setdefault(t.index, t.rows)
        if progress:
            progress(len(done), exp.trials)
    rows = [r for k in sorted(done) for r in done[k]]
    meta = {"experiment": exp.name, "config": exp.source, "experiment_hash": exp.hash,
            "paper": exp.paper, "table": exp.table, "seed": exp.seed, "trials": exp.trials,
            "versions": versions()}
    run = {"trials_run_now": exp.trials, "workers": workers, "executor": executor.describe(),
           "wall_s": round(time.perf_counter() - t0, 3)}
    from .compare import compare        # (pandas: imported while the trials ran)
    cmp = compare(exp, rows)
    return Result(_frame(rows, trial_columns(exp)), cmp.table, meta, exp, None, cmp, run=run)


def undecided(cmp) -> list[int | None]:
    """For every judged cell (and factor) of a comparison left inconclusive, the trials that
    would likely decide it (None: none would)."""
    table = cmp.reported
    out: list[int | None] = []
    if table is None:
        return out
    for q in table.quantities:
        if f"kind_{q.key}" not in cmp.table:
            continue
        rows = cmp.table[cmp.table[f"kind_{q.key}"] == "inconclusive"]
        out += [None if v != v else int(v) for v in rows[f"needed_{q.key}"]]
    out += [f.get("needed") for f in cmp.factors if f["kind"] == "inconclusive"]
    return out


def until_decided_budget(exp, max_trials: int | None) -> int:
    """The most trials a run of ``exp`` until decided may reach (default: ten batches of its
    trials); refuses an experiment without a paper's table, or a budget below one batch."""
    if exp.reported is None:
        raise UserError(f"{exp.name}: --until-decided needs a paper's table to decide "
                        "(the config names none)")
    most = max_trials if max_trials is not None else 10 * exp.trials
    if most < exp.trials:
        raise UserError(f"--max-trials {most} is below the first batch of {exp.trials} trials")
    return most


def run_until_decided(config: str | Path | Mapping, *, out: str | Path,
                      max_trials: int | None = None, trials: int | None = None,
                      seed: int | None = None, workers: int = 1, overrides: Iterable[str] = (),
                      resume: bool = False, figures: bool = True, executor=None,
                      progress: Callable[[int, int], None] | bool | None = None,
                      warn: Callable[[str], None] | None = None,
                      on_look: Callable[[dict], None] | None = None,
                      force: bool = False, figure_format: str = "png") -> Result:
    """Run an experiment in batches until every cell its paper's table judges is decided
    ('reproduced' or 'differs'), or ``max_trials`` is reached (default: ten times the first
    batch), or the cells left would need more than that.

    The first batch is the config's trials (or ``trials``); each look adds as many again. Every
    verdict uses confidence sequences tuned for ``max_trials``: valid at every look, so looking
    after each batch does not inflate false decisions (pfbench.verdicts). The results folder
    holds one run of the trials reached; meta.json's ``until_decided`` records the looks, and
    the table is recomputed with the same intervals by ``pfbench tables`` / ``report``.
    ``on_look(look)`` is called after each batch with {'trials', 'undecided'}.
    ``progress(done, total)`` is called as trials finish, as run_experiment's; ``total`` is the
    trials of the batches so far, raised as each batch starts. True shows a progress bar on
    stderr (in a notebook, below the cell) instead.
    """
    fn = "run_until_decided"
    _check_args(fn, config=(config, _CONFIG), out=(out, _PATH),
                max_trials=(max_trials, _OPT_COUNT), trials=(trials, _OPT_COUNT),
                seed=(seed, _OPT_SEED), workers=(workers, _COUNT), resume=(resume, _FLAG),
                figures=(figures, _FLAG), executor=(executor, _EXECUTOR),
                progress=(progress, _PROGRESS), warn=(warn, _WARN),
                on_look=(on_look, _ON_LOOK), force=(force, _FLAG),
                figure_format=(figure_format, _FORMAT))
    overrides = _overrides(fn, overrides)
    trials, seed, workers = _int(trials), _int(seed), int(workers)
    max_trials = _int(max_trials)
    folder = out_folder(out)
    if folder is None:
        raise UserError("out: a run until decided needs a results folder, got None")
    check_figure_format(figure_format)
    first = _experiment(config, trials, seed, overrides)
    batch, most = first.trials, until_decided_budget(first, max_trials)
    recover_aside(folder, folder.parent, warn, clean=False)
    from .runner import LocalExecutor
    executor = executor or LocalExecutor(workers)
    with FolderLock(folder, "out"), shown(progress, executor) as progress:
        return _until_decided(first, folder, batch, most, workers, resume, figures, executor,
                              progress, warn, on_look, force, figure_format)


def _until_decided(first, folder, batch, most, workers, resume, figures, executor, progress,
                   warn, on_look, force, figure_format) -> Result:
    from .compare import compare
    from .runner import RUN_TIMINGS, run_experiment as run_into
    from .store import trial_columns, write_json
    n, looks, ran, wall = batch, [], 0, 0.0
    while True:
        exp = dataclasses.replace(first, trials=n)
        res = run_into(exp, folder, workers=workers, resume=resume or n > batch,
                       progress=progress, executor=executor, warn=warn,
                       force=force and n == batch)
        ran += res.run["trials_run_now"]
        wall += res.run["wall_s"]
        cmp = compare(exp, res.rows, anytime=most)
        left = undecided(cmp)
        looks.append({"trials": n, "undecided": len(left)})
        if on_look:
            on_look(looks[-1])
        if not left:
            stopped = "every judged cell decided"
            break
        if n >= most:
            stopped = f"reached the most trials allowed ({most})"
            break
        if all(k is None or k > most for k in left):
            stopped = (f"the {len(left)} cell{'s' if len(left) > 1 else ''} left would need more "
                       f"than {most} trials, or no number decides them")
            break
        n = min(n + batch, most)
    res.run.update(trials_run_now=ran, wall_s=round(wall, 3))
    res.meta["until_decided"] = {"max_trials": most, "batch": batch, "looks": looks,
                                 "stopped": stopped}
    write_json(folder / "meta.json", res.meta)
    if not res.up_to_date:
        write_json(folder / RUN_TIMINGS, res.run)
    cmp, paths = write_experiment(exp, res, folder, figures, figure_format)
    return Result(_frame(res.rows, trial_columns(exp)), cmp.table, res.meta, exp, folder, cmp,
                  paths, run=res.run)


def load_trials(*folders: str | Path) -> pd.DataFrame:
    """The trials of many results folders (of ``pfbench run`` or ``pfbench sweep``) as one
    DataFrame, one row per trial and filter run, after two columns that say where it comes from:
    ``folder`` (the path as given) and ``experiment`` (its name). Each folder is read from its
    trials.parquet where that matches its trials.csv (their checksum), else from trials.csv,
    checked against its row checksums and meta.json; the folders' metadata (seed, versions,
    provenance) is ``frame.attrs["meta"]``, by folder. A folder that is no finished results
    folder, or whose files disagree, is refused with a one-line UserError.

        df = pfbench.load_trials("results/ifa_pf_ungm", "results/sspf_ungm")
        df.groupby(["experiment", "label"])["rmse"].mean()
    """
    from .dataset import load_trials as load
    for f in folders:
        _check_args("load_trials", folder=(f, _PATH))
    return load(*folders)


def load_results(folder: str | Path) -> Result:
    """The results of ``pfbench run`` (or ``pfbench sweep``) in ``folder``: its trials, its table
    (a sweep's summary), its meta; ``experiment`` when the config that made them is still there
    unchanged. The trials file and meta.json are checked against each other (every row's
    checksum, the trials and filter runs meta.json records, the file's checksum where it records
    one; a sweep's summary against its trials): a folder whose files disagree, whose meta.json
    is malformed, or that a newer pfbench wrote is refused with a one-line UserError."""
    _check_args("load_results", folder=(folder, _PATH))
    from .runner import RUN_TIMINGS
    from .store import read_results, read_sweep, read_timings, with_timings
    folder = Path(folder)
    trials_path = folder / "trials.csv"
    table_path = folder / "table.csv"
    if not folder.is_dir():
        raise UserError(f"{folder}: no such results folder")
    for path in (trials_path, folder / "meta.json", table_path, folder / "summary.csv"):
        require_regular(path)
    if not trials_path.is_file():
        raise UserError(f"{folder}: no trials.csv: not a finished pfbench run (an unfinished "
                        "one continues with 'pfbench run CONFIG --out FOLDER --resume')")
    if not table_path.is_file() and (folder / "summary.csv").is_file():      # a sweep
        trials, summary = read_sweep(folder)
        return Result(trials, summary, {}, None, folder)
    meta, got = read_results(folder)
    with_timings(got.rows, read_timings(folder))
    columns = list(got.rows[0]) if got.rows else []
    trials = _frame(sorted(got.rows, key=lambda r: (r["trial"])), columns)
    exp = None
    source = meta.get("config")
    if source and Path(source).is_file():
        try:
            from .config import load
            candidate = load(source, {"trials": meta.get("trials")})
            exp = candidate if candidate.hash == meta.get("experiment_hash") else None
        except UserError:
            exp = None
    cmp = None
    if exp is not None:
        from .tablecache import cached_compare
        cmp = cached_compare(exp, trials, anytime=anytime_of(meta))
        table = cmp.table
    elif table_path.is_file():
        require_regular(table_path)
        import pandas as pd
        table = pd.read_csv(table_path)
    else:
        raise UserError(f"{folder}: no table.csv, and its config is gone or changed")
    try:
        require_regular(folder / RUN_TIMINGS)
        run = json.loads((folder / RUN_TIMINGS).read_text(encoding="utf-8"))
    except (OSError, ValueError, UserError):
        run = None
    return Result(trials, table, meta, exp, folder, cmp,
                  run=run if isinstance(run, dict) else None)
