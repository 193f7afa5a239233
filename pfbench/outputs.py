"""What a finished run writes beside its trials: the comparison (table.csv, table.md), the
figures and trials.parquet (pfbench.dataset) of an experiment, the summary, figures and
trials.parquet of a sweep. ``pfbench run`` (pfbench.api),
``pfbench sweep`` and ``pfbench tables`` (pfbench.regen) all write them through here.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from .errors import UserError
from .figstyle import FORMATS, prune
from .fsutil import file_digest, left_by_a_kill, own_folder
from .tablecache import anytime_of  # noqa: F401  (api, report_data and regen import it from here)

if TYPE_CHECKING:     # pandas loads with the tables, after a run's workers start
    import pandas as pd


def check_figure_format(fmt, what: str = "figure_format") -> str:
    """``fmt`` when it is a figure format pfbench draws (png, svg, pdf), else a UserError."""
    if not isinstance(fmt, str) or fmt not in FORMATS:
        raise UserError(f"{what} {fmt}: one of {', '.join(FORMATS)}")
    return fmt


def write_experiment(exp, res, folder: Path, figures: bool = True,
                     figure_format: str = "png") -> tuple:
    """The comparison (table.csv / table.md) and figures of a finished run; returns (comparison,
    figure paths). Without ``figures``, a run that ran trials now takes away the figures the
    folder holds of its earlier trials (drop_stale_figures)."""
    from . import tables
    from .tablecache import cached_compare
    if figures:
        check_figure_format(figure_format)
        own_folder(Path(folder) / "figures", folder, "figures folder")
    from .dataset import write_parquet
    cmp = cached_compare(exp, res.rows, anytime=anytime_of(res.meta))
    tables.write(cmp, folder, res.meta, res.rows)
    write_parquet(folder)
    paths = []
    if figures:
        from .plots import write_figures
        paths = write_figures(exp, res.rows, folder, figure_format, cmp.table)
    elif not res.up_to_date:
        drop_stale_figures(folder)
    return cmp, paths


def drop_stale_figures(folder: Path, others: list[Path] | tuple = ()) -> None:
    """Remove the figures a results folder holds (figures/, and the figures ``others`` it draws
    elsewhere in the folder) when trials were written into it without drawing them: they show
    trials the folder no longer holds, and an up-to-date run or sweep asked for figures would
    take them for its own. A figures folder that is a link is left alone (its files are not the
    folder's)."""
    figs = Path(folder) / "figures"
    if figs.is_dir() and not figs.is_symlink():
        prune(figs, [])
    for p in others:
        if p.is_file() or p.is_symlink():
            p.unlink()


def clear_leftovers(figures: Path) -> None:
    """Remove from ``figures`` the temporary files a drawing killed half-way left (an up-to-date
    run's or sweep's, before it checks its figures)."""
    if figures.is_dir() and not figures.is_symlink():
        for p in figures.iterdir():
            if left_by_a_kill(p.name) and p.is_file():
                p.unlink()


def _drawn_key(curves: tuple, paths: list[Path]) -> str:
    """A SHA-256 of the package's code, a sweep's paper ``curves`` and the names and bytes of
    the figures at ``paths``."""
    import hashlib

    from .tablecache import code_digest
    h = hashlib.sha256(f"{code_digest()}|{curves!r}".encode())
    for p in sorted(paths, key=lambda p: p.name):
        h.update(f"|{p.name}|".encode())
        h.update(file_digest(p))
    return h.hexdigest()


def _drawn_with(curves: tuple, paths: list[Path]) -> bool:
    """Whether this code drew the figures at ``paths``, as they are now, with the paper's
    ``curves`` on them (_note_drawn noted it in the table cache's folder, pfbench.tablecache).
    No cache, or a figure that cannot be read: False (they are drawn again)."""
    from .tablecache import folder
    where = folder()
    try:
        return where is not None and (where / f"{_drawn_key(curves, paths)}.curves").is_file()
    except OSError:
        return False


def _note_drawn(curves: tuple, paths: list[Path]) -> None:
    """Note that the figures at ``paths`` show ``curves`` (see _drawn_with). Never an error."""
    from .tablecache import folder, store
    where = folder()
    if where is None or not paths:
        return
    try:
        store(where, where / f"{_drawn_key(curves, paths)}.curves", b"", "*.curves")
    except Exception:
        pass


def write_sweep(trials_df: pd.DataFrame, keys: list[str], folder: Path, name: str,
                figures: bool = True, figure_format: str = "png", exp=None,
                missing_only: bool = False, curves: tuple = ()) -> tuple:
    """summary.csv and the figures of a finished sweep (``exp``: a cell's experiment, whose
    metrics the figures draw); with ``curves`` (the paper's curves the sweep names), the
    verdicts against them (curves.csv, curves.md) and their points on the figures. Returns
    (summary, figure paths); the summary's ``attrs["curves"]`` holds the curves' verdicts (a
    frame, pfbench.curves.judge). ``missing_only`` (an up-to-date sweep): the figures are drawn
    only when one is missing, as an up-to-date run's, or, with ``curves``, when they are not
    known to show these curves (_drawn_with: the paper's points may have changed since).
    Without ``figures`` none is drawn, and a sweep that ran trials now (not ``missing_only``)
    takes away the figures of its earlier trials, its run times' figure too
    (drop_stale_figures)."""
    if figures:
        check_figure_format(figure_format)
        own_folder(Path(folder) / "figures", folder, "figures folder")
    from . import curves as cv
    from .store import sweep_summary, write_csv
    from .dataset import write_parquet
    summ = sweep_summary(trials_df, keys)
    write_csv(folder / "summary.csv", summ)
    write_parquet(folder)
    judged = cv.judge(curves, trials_df, keys, exp.seed if exp else 0) if curves else None
    cv.write(folder, curves, judged, keys)
    if not figures:
        if not missing_only:        # and the run times' figure beside the timings file
            drop_stale_figures(folder, [_timings_figure(folder, fmt) for fmt in FORMATS])
        summ.attrs["curves"] = judged
        return summ, []
    from .kinds import kind_of
    from .plots import sweep_figures, sweep_metrics
    if missing_only:
        clear_leftovers(Path(folder) / "figures")
        which = sweep_metrics(exp) if exp else ["rmse"]
        want = [folder / "figures" / f"{m}.{figure_format}" for m in which
                if f"{m}_mean" in summ and not summ[f"{m}_mean"].isna().all()]
        if want and all(p.is_file() for p in want) and (not curves
                                                       or _drawn_with(curves, want)):
            summ.attrs["curves"] = judged
            return summ, want
    paths = sweep_figures(summ, keys, folder, name, sweep_metrics(exp) if exp else None,
                          fmt=figure_format, unit=kind_of(exp.scenario).unit if exp else "",
                          curves=curves)
    if curves:
        _note_drawn(curves, paths)
    prune(folder / "figures", paths)
    if "wall_s" in trials_df and trials_df["wall_s"].notna().any():
        sweep_figures(sweep_summary(trials_df, keys, ("wall_s",)), keys, folder, name,
                      ["wall_s"], _timings_figure(folder, figure_format), figure_format)
    summ.attrs["curves"] = judged
    return summ, paths


def _timings_figure(folder: Path, fmt: str) -> Path:
    """A sweep's figure of its run times in format ``fmt``: beside the timings file, never in
    figures/ (the times depend on the machine)."""
    return Path(folder) / f"timings.{fmt}"
