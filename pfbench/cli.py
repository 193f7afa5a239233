"""The ``pfbench`` command line (typer): parses arguments, calls the runner, prints. No numerics."""
from __future__ import annotations

import contextlib
import os
import sys
from dataclasses import replace
from pathlib import Path
from typing import List, Optional

import typer
from rich.console import Console
from rich.table import Table as RichTable
from typer.core import TyperGroup

from . import __version__
from .errors import UserError

try:                                    # typer 0.2x carries its own copy of click
    from typer import _click as _ck
except ImportError:                     # pragma: no cover - older typer on click
    import click as _ck

_NO_ARGS = getattr(_ck.exceptions, "NoArgsIsHelpError", None)


class _OneLineErrors(TyperGroup):
    """Usage errors (a bad flag or value) as one line on stderr and exit status 2, like every
    other error, instead of click's boxed usage text."""

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):
        args = _bare_readings(sys.argv[1:] if args is None else list(args))
        try:
            rv = super().main(args=args, prog_name=prog_name, complete_var=complete_var,
                              standalone_mode=False, **extra)
        except _ck.exceptions.ClickException as exc:
            if _NO_ARGS is not None and isinstance(exc, _NO_ARGS):
                text = exc.format_message()     # the help (typer's rich help printed it already)
                if text.strip():
                    print(text)
                rv = 0
            else:
                msg = " ".join(exc.format_message().split())
                ctx = getattr(exc, "ctx", None)
                param = getattr(exc, "param", None)
                if param is not None and getattr(param, "opts", None) and param.opts[0] not in msg:
                    msg = f"{param.opts[0]}: {msg}"
                # the command's words after the program's name ('pfbench', or 'python -m pfbench')
                root = ctx.find_root().command_path if ctx is not None else ""
                sub = ctx.command_path[len(root):].split() if ctx is not None else []
                hint = f" (see 'pfbench {' '.join(sub + ['--help'])}')" if ctx is not None else ""
                msg = msg.replace("greater than or equal to ", ">= ")
                print(f"pfbench: error: {msg}{hint}", file=sys.stderr)
                rv = exc.exit_code
        except typer.Abort:
            print("pfbench: aborted", file=sys.stderr)
            rv = 130
        if not standalone_mode:
            return rv
        sys.exit(rv if isinstance(rv, int) else 0)


def _bare_readings(args: list[str]) -> list[str]:
    """``--readings`` without a value (last, or before another option or a config file) as
    ``--readings=all``: the option takes NAME,NAME or nothing."""
    out = list(args)
    for i, a in enumerate(out):
        if a == "--":
            break
        if a == "--readings":
            nxt = out[i + 1] if i + 1 < len(out) else None
            if nxt is None or nxt.startswith("-") or nxt.endswith((".yaml", ".yml")):
                out[i] = "--readings=all"
    return out


app = typer.Typer(cls=_OneLineErrors, add_completion=False, no_args_is_help=True,
                  pretty_exceptions_enable=False,
                  help="Reproduce the tables of particle-filter papers from YAML experiments.")
err = Console(stderr=True, highlight=False, emoji=False)   # no :100: -> an emoji


class _Out:
    """stdout through rich, bound to the sys.stdout of the moment (test runners swap it)."""

    def print(self, *args, wide: bool = False, **kwargs):
        # On a terminal, its width. Piped: 100 columns (what the headline tables fit; $COLUMNS
        # if set), and for a wide table wide enough to keep one line per row.
        width = None
        if not sys.stdout.isatty():
            width = 320 if wide else int(os.environ.get("COLUMNS") or 0) or 100
        Console(file=sys.stdout, highlight=False, emoji=False, width=width).print(*args, **kwargs)


out = _Out()
_state = {"debug": False}


@contextlib.contextmanager
def _guard():
    """A UserError becomes one line on stderr and exit status 2 (a traceback only with --debug)."""
    from .fsutil import os_error_line
    try:
        yield
    except UserError as exc:
        if _state["debug"]:
            raise
        _fail(str(exc))
    except OSError as exc:              # a full disk, a read-only folder, a path below a file
        if _state["debug"]:
            raise
        _fail(os_error_line(exc))
    except MemoryError:
        if _state["debug"]:
            raise
        _fail("out of memory: lower the particles, steps, trials or workers")


def _fail(message: str):
    err.print(f"pfbench: error: {' '.join(message.split())}", markup=False, soft_wrap=True)
    raise typer.Exit(2) from None


def _path(value: str | None, flag: str) -> Path | None:
    """A path option as a Path; an empty one is an error (Path('') would be the current
    folder, which nobody named)."""
    if value is None:
        return None
    if not value.strip():
        raise UserError(f"{flag}: expected a path, got an empty one")
    if "\x00" in value:
        raise UserError(f"{flag}: a path cannot contain a NUL character")
    return Path(value)


def _once(fn):
    """``fn`` as a function that runs it the first time it is called, and then never again."""
    done = []

    def call():
        if not done:
            done.append(1)
            fn()
    return call


def _workers_that_fit(runs: list[tuple], workers: int, executor: str) -> int:
    """--workers capped at the trials of the largest of ``runs`` ((experiment, where) pairs),
    once every run is known to fit the memory on that many local workers; a warning above the
    machine's cores."""
    from .resources import cap_workers, check_fits, warn_above_cores
    capped = cap_workers(workers, max(exp.trials for exp, _ in runs))
    for exp, where in runs:
        check_fits(exp, capped if executor == "local" else 1, where)
    warn_above_cores(workers, _warn)
    return capped


def _first_words(exps) -> str:
    """The bar's words before the first trial finishes: which kernels compile (those of the
    experiments' filters and scenarios that the numba cache does not hold yet), or 'trials'."""
    from .runner import uncompiled
    names = sorted({n for exp in exps for n in uncompiled(exp)})
    if not names:
        return "trials"
    return f"compiling the {', '.join(names)} kernels (first run only)"


def _progress(bar, total: int, first, exps=(), underway=None):
    """The progress callback of a run (pfbench.progress.tracker): a bar task of ``total``
    trials that says which kernels compile until the first trial finishes; ``first()`` on its
    first call (once the folder is ready and the trials start); ``underway``: an executor's,
    so that the bar moves while trials of seconds run."""
    from .progress import tracker
    words = _first_words(exps)
    if words != "trials" and not err.is_terminal:     # a log: one line where it takes long

        def first(header=first):
            header()
            err.print(f"pfbench: {words} ...", markup=False)
        first = _once(first)
    return tracker(bar, total, words, first, underway)


def _warn(message: str) -> None:
    err.print(f"pfbench: warning: {message}", markup=False, soft_wrap=True)


def _version(value: bool):
    if value:
        out.print(f"pfbench {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True,
                                 help="Print the version and exit."),
    debug: bool = typer.Option(False, "--debug", help="Show tracebacks for errors."),
):
    _state["debug"] = debug


def _executor(kind: str, workers: int, scheduler: str | None):
    """The executor of --executor / --scheduler (a context manager that closes it)."""
    from .runner import make_executor
    if kind not in ("local", "dask"):
        raise UserError(f"--executor: expected 'local' or 'dask', got '{kind}'")
    return make_executor(kind, workers, scheduler)


def _bar():
    """The progress bar of long runs (on stderr, gone when done; pfbench.progress.bar)."""
    from .progress import bar
    return bar(err)


@contextlib.contextmanager
def _steps(command: str):
    """A callback that says what ``command`` does as each of its steps begins: on a terminal a
    spinner with the step's words ('report: reading results/NAME (2 of 9)'), gone when done, on
    stderr. In a log, nothing: a log keeps the command's output and, for bad input, its one line
    of error."""
    if not err.is_terminal:
        yield lambda text: None
        return
    with err.status(f"{command} ...", spinner="dots") as status:
        yield lambda text: status.update(f"{command}: {text}")


@contextlib.contextmanager
def _stop_on_interrupt(bar, before: str = "", after: str = ""):
    """Ctrl-C in a run (runner.Interrupted): stop the progress bar, say what was kept in one
    line, exit 130."""
    from .runner import Interrupted
    try:
        yield
    except Interrupted as exc:
        bar.stop()
        err.print(f"pfbench: {before}{exc}{after}", markup=False, soft_wrap=True)
        raise typer.Exit(130) from None


def _papers_option():
    """The --papers option of the commands that read configs (a fresh one for each)."""
    return typer.Option([], "--papers", help="A folder of paper files (PAPER.yaml), looked in "
                        "before papers/ beside the config and configs/papers/; repeatable.")


def _use_papers(folders) -> None:
    """The --papers folders, looked in first for a config's paper file."""
    from .papers import search_folders
    search_folders([_path(f, "--papers") for f in folders])


@contextlib.contextmanager
def _kernels():
    """Say what happens while the filters' numba kernels load, before any config is read: the
    first run compiles them (minutes on a small machine), later runs load them from the cache.
    A spinner on a terminal (gone when they are loaded), one line in a log when they compile;
    never a silent minute."""
    if "pfbench.filters" in sys.modules:
        yield
        return
    from . import CACHE_DIR
    cold = not any(Path(CACHE_DIR).rglob("*.nbi"))
    what = ("compiling the filters' numba kernels (first run only; a few minutes on 2 cores, "
            "then cached)" if cold else "loading the filters' compiled kernels")
    if not err.is_terminal:         # a log: one line, where it takes long
        if cold:
            err.print(f"pfbench: {what} ...", markup=False)
        yield
        return
    with err.status(what + " ...", spinner="dots"):
        yield


def _load_kernels() -> None:
    """Import the filters and scenarios (their kernels), saying so (_kernels)."""
    with _kernels():
        from . import filters, scenarios  # noqa: F401


def _load(config: Path, trials=None, seed=None, sets=()):
    _load_kernels()
    from .config import load
    return load(config, {"trials": trials, "seed": seed}, sets)


def _check_figure_format(fmt: str) -> None:
    from .figstyle import FORMATS
    if fmt not in FORMATS:
        raise UserError(f"--figure-format {fmt}: one of {', '.join(FORMATS)}")


def _rich_table(title: str, head: list[str], cells: list[list[str]], edge: bool = True):
    t = RichTable(title=title, title_justify="left", show_edge=edge)
    for h in head:
        t.add_column(h, overflow="fold")
    for row in cells:
        t.add_row(*row)
    return t


def _print_table(parts: dict, wide: bool = False, folder: Path | None = None):
    """The comparison on the console (``parts``: pfbench.tables.console_parts): the headline table
    (our values, the paper's, the verdicts in a few words: it fits 100 columns) and a line on
    where the rest is; ``wide``: every column and note, as before."""
    title = parts["title"]
    if wide:
        for name, head, cells in parts["wide"]:
            out.print(_rich_table(f"{title}: {name}" if name else title, head, cells), wide=True)
        for note in parts["footnotes"]:
            out.print(note, markup=False)
    else:
        out.print(f"{title}: {parts['trials']} trials", markup=False, style="bold")
        for name, head, cells in parts["headline"]:
            out.print(_rich_table(name, head, cells, edge=False))
    counts = parts["counts"]
    where = f"{folder}/table.md" if folder else "table.md"
    out.print((f"{counts}. " if counts else "") + "Intervals: 95% over trials; verdicts "
              "Holm-adjusted across the table. "
              + ("Every column, the verdicts in full, the interval methods and the paper's "
                 f"notes: {where}" + ("" if wide else "; --wide prints them here") + "."),
              markup=False)


@app.command()
def run(
    config: Path = typer.Argument(..., help="Experiment YAML file."),
    trials: Optional[int] = typer.Option(None, "--trials", min=1, help="Override the trial count."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Override the base seed."),
    workers: int = typer.Option(1, "--workers", "-w", min=1,
                                help="Local worker processes (results do not depend on it)."),
    out_dir: Optional[str] = typer.Option(None, "--out", help="Results folder "
                                           "(default: results/<experiment>)."),
    resume: bool = typer.Option(False, "--resume", help="Keep the finished trials of an earlier "
                                "run of the same experiment in the results folder."),
    force: bool = typer.Option(False, "--force", help="Replace a results folder that holds "
                               "another experiment, or more trials of this one, and run again "
                               "what is up to date."),
    set_: List[str] = typer.Option([], "--set", help="Override a config key: KEY.PATH=VALUE "
                                   "(YAML value; '*' matches every key), repeatable."),
    no_figures: bool = typer.Option(False, "--no-figures", help="Skip the figures."),
    figure_format: str = typer.Option("png", "--figure-format", help="The figures' format: png, "
                                      "svg or pdf."),
    executor: str = typer.Option("local", "--executor", help="'local' (this machine's "
                                 "processes) or 'dask' (a Dask cluster; results do not depend on "
                                 "it)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler "
                                            "tcp://HOST:PORT (default with --executor dask: a "
                                            "local cluster of --workers processes)."),
    papers: List[str] = _papers_option(),
    until_decided: bool = typer.Option(False, "--until-decided", help="Add batches of the "
                                       "config's trials until every cell the paper's table "
                                       "judges is decided, with confidence sequences valid at "
                                       "every look."),
    max_trials: Optional[int] = typer.Option(None, "--max-trials", min=1, help="With "
                                             "--until-decided: the most trials (default: ten "
                                             "batches)."),
    wide: bool = typer.Option(False, "--wide", help="Print every column and note of the table "
                              "(default: our values, the paper's and the verdicts, in 100 "
                              "columns; table.md has the rest)."),
    readings: Optional[str] = typer.Option(None, "--readings", metavar="[NAME,NAME]",
                                           help="Then run the readings of the paper's open "
                                           "choices its paper file declares for the table (all, "
                                           "or NAME,NAME) on the same trials, and judge each "
                                           "claim under each (readings.md)."),
):
    """Run an experiment: Monte Carlo trials, then the table beside the paper's values."""
    with _guard():
        _check_figure_format(figure_format)
        _use_papers(papers)
        out_dir = _path(out_dir, "--out")
        if max_trials is not None and not until_decided:
            raise UserError("--max-trials goes with --until-decided")
        if readings is not None and until_decided:
            raise UserError("--readings runs the config's trials count; --until-decided grows "
                            "it: run them one after the other")
        exp = _load(config, trials, seed, set_)
        plan = None
        if readings is not None:        # every reading valid before anything runs
            from . import readings as rd
            plan = rd.plan(exp, rd.parse_names(readings))
        from .api import until_decided_budget
        folder = _results_folder(exp.name, config, out_dir)
        most = until_decided_budget(exp, max_trials) if until_decided else exp.trials
        workers = _workers_that_fit([(replace(exp, trials=most), str(config))], workers,
                                    executor)
        parts = None
        if not (until_decided or resume or force) and executor == "local":
            parts = _replayed(exp, folder, out_dir, not no_figures, figure_format)
        if parts is not None:           # up to date, and the table it printed last time
            _print_table(parts, wide, folder)
            _say_up_to_date(exp, folder)
        else:
            res = _run_trials(exp, folder, out_dir, most, workers, (executor, scheduler),
                              until_decided, dict(resume=resume, figures=not no_figures,
                                                  figure_format=figure_format, force=force))
            from .tables import console_parts
            _print_table(console_parts(res.comparison), wide, folder)
            _say_what_ran(exp, res, folder, until_decided)
        if plan is not None:
            _run_readings(plan, folder, out_dir, workers, (executor, scheduler))


def _run_readings(plan: list, folder: Path, out_dir, workers: int, where: tuple) -> None:
    """Run the readings of ``plan`` (pfbench.readings.plan) beside the config's results in
    ``folder``, a line and a progress bar for each, then judge them (readings.csv,
    readings.md) and print the robustness lines."""
    import time
    from . import readings as rd
    from .fsutil import FolderLock
    exp = plan[0].exp
    n = len(plan) - 1
    with _executor(where[0], workers, where[1]) as ex, \
            FolderLock(folder, "--out" if out_dir else "results folder"):
        with _bar() as bar:
            seen = {"i": 0, "t0": time.perf_counter(), "last": None}

            def done_line():
                last = seen["last"]
                if last is not None:
                    bar.console.print(f"  {last}: {time.perf_counter() - seen['t0']:.1f} s",
                                      markup=False)

            def progress_for(run, fresh):
                done_line()
                seen["i"] += 1
                seen["t0"], seen["last"] = time.perf_counter(), None
                head = f"reading {seen['i']} of {n}, {run.name} ({run.title})"
                if fresh:
                    bar.console.print(f"{head}: up to date in {folder}/readings/{run.name}",
                                      markup=False)
                    return None
                again, every = len(run.changed), len(run.exp.filters)
                bar.console.print(f"{head}: {exp.trials} trials of " + (
                    f"every filter run ({every})" if again == every else
                    f"{again} of {every} filter runs (the others' rows are the config's)"),
                    markup=False)
                seen["last"] = run.name
                return _progress(bar, exp.trials, lambda: None, [run.exp],
                                 getattr(ex, "underway", None))
            try:
                rd.run_all(plan, folder, ex, progress_for)
            except KeyboardInterrupt:
                bar.stop()
                err.print("pfbench: readings: interrupted; the readings finished are kept (the "
                          "same command runs the rest)", markup=False)
                raise typer.Exit(130) from None
            done_line()
        lines = rd.write(plan, folder)
    names = ", ".join(r.name for r in plan)
    out.print(f"Readings of {exp.paper} {exp.table}: {len(plan)} ({names})"
              f"; each claim across them (one Holm family over claims x readings; "
              f"{folder}/readings.md has every value):", markup=False, style="bold")
    for line in lines:
        out.print(f"- {line}", markup=False, soft_wrap=True)
    err.print(f"wrote {folder}/readings/ (trials of each reading), readings.csv and readings.md",
              markup=False)


def _results_folder(name: str, config: Path, out_dir: Path | None) -> Path:
    """The results folder of the experiment ``name``: --out, else results/<name> (a name no
    other config reserves); a replace of it killed half-way is recovered first."""
    if out_dir is None:
        from .store import reserved_name
        reserved_name(name, config)
    folder = out_dir or Path("results") / name
    from .fsutil import recover_aside
    recover_aside(folder, folder.parent, _warn, clean=False)   # a replace killed half-way
    return folder


def _run_trials(exp, folder: Path, out_dir, most: int, workers: int, where: tuple,
                until_decided: bool, opts: dict):
    """Run the trials of ``exp`` into ``folder`` (locked meanwhile) on the executor ``where``
    ((kind, scheduler)) under a progress bar: all at once, or in batches until decided (at most
    ``most``); opts: the api's resume, figures, figure_format and force. The api's result."""
    from .api import run_experiment, run_until_decided
    from .fsutil import FolderLock
    runs = ", ".join(f.key for f in exp.filters)
    with _executor(where[0], workers, where[1]) as ex, \
            FolderLock(folder, "--out" if out_dir else "results folder"):
        upto = f" (batches until decided, at most {most})" if until_decided else ""
        header = _once(lambda: err.print(
            f"{exp.name}: {exp.trials} trials{upto} of {exp.scenario} x [{runs}], seed "
            f"{exp.seed}, {ex.describe()} -> {folder}", markup=False))
        with _bar() as bar:
            progress = _progress(bar, exp.trials, header, [exp],
                                 getattr(ex, "underway", None))

            def look(k):
                bar.console.print(f"after {k['trials']} trials: {k['undecided']} judged "
                                  f"cell{'s' if k['undecided'] != 1 else ''} undecided",
                                  markup=False)
            with _stop_on_interrupt(bar):
                if until_decided:
                    return run_until_decided(exp, out=folder, max_trials=most, workers=workers,
                                             progress=progress, executor=ex, warn=_warn,
                                             on_look=look, **opts)
                return run_experiment(exp, out=folder, workers=workers, progress=progress,
                                      executor=ex, warn=_warn, **opts)


def _replayed(exp, folder: Path, out_dir, figures: bool, fmt: str) -> dict | None:
    """When ``folder`` is up to date and still holds what the run that printed its table left
    (pfbench.replay), that table's strings: the run then neither computes nor writes anything
    (nor imports pandas). None otherwise: the run takes its ordinary path."""
    if not (folder / "meta.json").is_file():
        return None
    from .fsutil import FolderLock
    from .replay import replay
    from .runner import up_to_date
    with FolderLock(folder, "--out" if out_dir else "results folder"):
        if up_to_date(exp, folder) is None:
            return None
        return replay(exp, folder, figures, fmt)


def _say_up_to_date(exp, folder: Path) -> None:
    err.print(f"{folder} is up to date: it holds the {exp.trials} trials of this "
              "experiment (the table above is computed from them; nothing ran). "
              "--force runs them again.", markup=False)


def _say_what_ran(exp, res, folder: Path, until_decided: bool) -> None:
    """The lines after a run's table: nothing ran (up to date), or what ran and was written."""
    if res.up_to_date:
        _say_up_to_date(exp, folder)
        return
    if until_decided:
        u = res.meta["until_decided"]
        err.print(f"until decided: {len(u['looks'])} look(s), {res.experiment.trials} "
                  f"trials; stopped: {u['stopped']}", markup=False)
    exp = res.experiment
    ran = res.run["trials_run_now"]
    note = f" ({exp.trials - ran} resumed)" if ran < exp.trials else ""
    err.print(f"{ran} trials in {res.run['wall_s']:.1f} s{note}; wrote {folder}/trials.csv, "
              "trials.parquet, table.csv, table.md, meta.json, timings.csv, console.json"
              + (f" and {len(res.figures)} figures" if res.figures else ""), markup=False)


@app.command()
def sweep(
    config: Path = typer.Argument(..., help="Experiment YAML file (its 'sweep:' section, if any, "
                                  "gives the values)."),
    set_: List[str] = typer.Option([], "--set", help="KEY.PATH=V1,V2,... values to sweep (YAML "
                                   "each; '*' matches every key), repeatable: the cartesian "
                                   "product is run."),
    trials: Optional[int] = typer.Option(None, "--trials", min=1, help="Trials per cell."),
    seed: Optional[int] = typer.Option(None, "--seed", min=0, help="Override the base seed."),
    workers: int = typer.Option(1, "--workers", "-w", min=1, help="Local worker processes."),
    out_dir: Optional[str] = typer.Option(None, "--out", help="Results folder (default: "
                                           "results/<experiment>)."),
    resume: bool = typer.Option(False, "--resume", help="Keep the finished trials of every cell."),
    force: bool = typer.Option(False, "--force", help="Replace cell folders that hold another "
                               "experiment's trials."),
    yes: bool = typer.Option(False, "--yes", help="Run even when there are many cells."),
    no_figures: bool = typer.Option(False, "--no-figures", help="Skip the figures."),
    figure_format: str = typer.Option("png", "--figure-format", help="The figures' format: png, "
                                      "svg or pdf."),
    executor: str = typer.Option("local", "--executor", help="'local' or 'dask' (see run)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler "
                                            "tcp://HOST:PORT (see run)."),
    papers: List[str] = _papers_option(),
):
    """Run an experiment over the cartesian product of values of some of its keys."""
    with _guard():
        _check_figure_format(figure_format)
        _load_kernels()
        _use_papers(papers)
        out_dir = _path(out_dir, "--out")
        from . import sweep as sw
        from .fsutil import FolderLock
        name, cells = sw.expand(config, sw.parse_sets(set_), {"trials": trials, "seed": seed},
                                confirm_above=None if yes else sw.CONFIRM_ABOVE)
        folder = _results_folder(name, config, out_dir)
        keys = list(cells[0].values)
        total = sum(c.exp.trials for c in cells)
        workers = _workers_that_fit([(c.exp, f"{config} (sweep cell {c.name})") for c in cells],
                                    workers, executor)
        parts, fresh = (_sweep_replayed(cells, folder, out_dir, figure_format, not no_figures)
                        if not (resume or force) and executor == "local" else (None, False))
        if parts is not None:       # up to date, and the tables it printed last time
            _show_sweep(parts["table"], name, keys, cells[0].exp.trials, folder)
            _show_curves(parts["curves"])
            _say_sweep_up_to_date(folder, cells)
            return
        header = (lambda: None) if fresh else _once(lambda: err.print(   # fresh: nothing runs
            f"{name}: {len(cells)} cells ({', '.join(keys)}) x {cells[0].exp.trials} trials "
            f"= {total} trials -> {folder}", markup=False))
        with _executor(executor, workers, scheduler) as ex, \
                FolderLock(folder, "--out" if out_dir else "results folder"):
            with _bar() as bar:
                progress = _progress(bar, total, header, [] if fresh else [c.exp for c in cells],
                                     getattr(ex, "underway", None))
                with _stop_on_interrupt(bar, "interrupted in a cell: "):
                    trials_df = sw.run_sweep(cells, folder, workers=workers, resume=resume,
                                             progress=progress, executor=ex, warn=_warn,
                                             force=force, status=progress.describe)
            from .regen import write_sweep
            with _steps("sweep") as say:
                say(f"writing {folder}/summary.csv" + ("" if no_figures else " and the figures"))
                summ, figs = write_sweep(trials_df, keys, folder, name, not no_figures,
                                         figure_format, cells[0].exp,
                                         missing_only=trials_df.attrs.get("up_to_date", False),
                                         curves=cells[0].curves)
            parts = sw.console_parts(summ, trials_df, keys, cells[0].exp, cells[0].curves)
            _record_sweep(cells, folder, parts, summ, trials_df, figs, figure_format)
        _show_sweep(parts["table"], name, keys, cells[0].exp.trials, folder)
        if trials_df.attrs.get("up_to_date", False):    # as a replayed one says it
            _show_curves(parts["curves"])
            _say_sweep_up_to_date(folder, cells)
            return
        err.print(f"wrote {folder}/trials.csv, summary.csv, {len(figs)} figures and a results "
                  "folder per cell under cells/", markup=False)
        _show_curves(parts["curves"])
        if parts["curves"]:
            err.print(f"wrote {folder}/curves.csv and curves.md", markup=False)


def _record_sweep(cells: list, folder: Path, parts: dict, summ, trials_df, figs: list,
                  fmt: str) -> None:
    """Keep what the sweep printed (pfbench.replay): in the user's cache, and in the folder
    without the run times (replaced where trials ran)."""
    from . import sweep as sw
    from .replay import record_sweep
    record_sweep(cells, folder, parts, figs, fmt)
    sw.record_in_folder(cells, folder, summ, trials_df, figs, fmt,
                        not trials_df.attrs.get("up_to_date", False))


def _say_sweep_up_to_date(folder: Path, cells: list) -> None:
    err.print(f"{folder} is up to date: its {len(cells)} cells hold their "
              f"{cells[0].exp.trials} trials each (the tables above are computed from "
              "them; nothing ran). --force runs them again.", markup=False)


def _show_sweep(table: dict, name: str, keys: list, trials: int, folder: Path) -> None:
    """Print a sweep's table (pfbench.sweep.console_parts) under its title line."""
    out.print(f"{name}: sweep over {', '.join(keys)}, {trials} trials a cell; "
              f"means, every metric with its interval in {folder}/summary.csv",
              markup=False, style="bold")
    t = RichTable(show_edge=False)
    for h in table["head"]:
        t.add_column(h, no_wrap=h in ("RMSE [95% CI]", "Filter"))
    for row in table["rows"]:
        t.add_row(*row)
    out.print(t)


def _show_curves(blocks: list[dict]) -> None:
    """Print the sweep's verdicts against the paper's curves (pfbench.sweep.console_parts)."""
    for b in blocks:
        out.print(b["title"], markup=False, style="bold")
        out.print(b["description"], markup=False)
        t = RichTable(show_edge=False)
        for h in b["head"]:
            t.add_column(h, no_wrap=h != "verdict")
        for row in b["rows"]:
            t.add_row(*row)
        out.print(t)


def _sweep_replayed(cells: list, folder: Path, out_dir, fmt: str,
                    figures: bool = True) -> tuple[dict | None, bool]:
    """(parts, up to date): when every cell of the sweep in ``folder`` is up to date (then True)
    and the folder still holds what the sweep that printed its tables left (pfbench.replay;
    its figures only where ``figures`` asks for them), those tables' strings: the sweep then
    neither computes nor writes anything (nor imports pandas). None otherwise: it takes its
    ordinary path (which, up to date, runs nothing)."""
    if (folder / "meta.json").exists() or not (folder / "summary.csv").is_file():
        return None, False
    if (folder / "cells").is_symlink() or not (folder / "cells").is_dir():
        return None, False
    from .fsutil import FolderLock
    from .replay import replay_sweep
    from .runner import up_to_date
    with FolderLock(folder, "--out" if out_dir else "results folder"):
        for cell in cells:
            with FolderLock(folder / "cells" / cell.name, "sweep cell", root=folder):
                if up_to_date(cell.exp, folder / "cells" / cell.name, traces=False) is None:
                    return None, False
        return replay_sweep(cells, folder, fmt, figures), True


@app.command("tables")
def tables_(
    check: bool = typer.Option(False, "--check", help="Re-run each config's first check.trials "
                               "trials and compare with the committed results instead of "
                               "regenerating them; exit 1 when a metric moved."),
    configs: str = typer.Option("configs", "--configs", help="Folder of configs."),
    results: str = typer.Option("results", "--results", help="Folder of results."),
    only: List[str] = typer.Option([], "--only", help="Only this config (file name or stem), "
                                   "repeatable."),
    workers: int = typer.Option(1, "--workers", "-w", min=1, help="Local worker processes."),
    z: float = typer.Option(4.0, "--z", min=0.0, help="--check tolerance in standard errors of "
                            "the difference of the means."),
    resume: bool = typer.Option(False, "--resume", help="Keep the finished trials of an "
                                "interrupted regeneration."),
    no_figures: bool = typer.Option(False, "--no-figures", help="Skip the figures."),
    figure_format: str = typer.Option("png", "--figure-format", help="The figures' format: png, "
                                      "svg or pdf."),
    executor: str = typer.Option("local", "--executor", help="'local' or 'dask' (see run)."),
    scheduler: Optional[str] = typer.Option(None, "--scheduler", help="Dask scheduler "
                                            "tcp://HOST:PORT (see run)."),
    papers: List[str] = _papers_option(),
    until_decided: bool = typer.Option(False, "--until-decided", help="Regenerate each config "
                                       "that compares with a paper's table in batches until its "
                                       "judged cells are decided (see run)."),
    max_trials: Optional[int] = typer.Option(None, "--max-trials", min=1, help="With "
                                             "--until-decided: the most trials per config "
                                             "(default: ten times its trials)."),
    readings: Optional[str] = typer.Option(None, "--readings", metavar="", help="Also run the "
                                           "readings of the paper's open choices beside each "
                                           "config whose paper file declares them (see run); "
                                           "--check checks the committed readings anyway."),
):
    """Regenerate every config's results, or check them (--check) against the committed ones."""
    import math
    with _guard():
        _check_figure_format(figure_format)
        _load_kernels()
        _use_papers(papers)
        configs, results = _path(configs, "--configs"), _path(results, "--results")
        from . import regen
        from .fsutil import FolderLock
        if not math.isfinite(z) or z <= 0:
            raise UserError(f"--z: expected a finite number > 0, got {z}")
        files = _only_configs(regen.config_files(configs), only, configs)
        _check_tables_flags(check, resume, until_decided, max_trials)
        if readings is not None and readings != "all":
            raise UserError(f"--readings {readings}: 'tables --readings' runs every reading "
                            "(it takes no names)")
        if readings is not None and (check or until_decided):
            raise UserError("--readings regenerates the readings; --check checks the committed "
                            "ones anyway, and --until-decided grows the trials they share")
        # every config is valid (and its trial count known) before anything runs, and no two
        # write into one folder, or into another's
        totals = [regen.check_trials(p) if check else regen.total_trials(p) for p in files]
        if not check:
            regen.check_outputs(files, results)
        with _executor(executor, workers, scheduler) as ex, FolderLock(results, "--results"), \
                _bar() as bar:
            rows = _each_config(files, totals, results, ex, bar, z if check else None,
                                dict(figures=not no_figures, resume=resume,
                                     until_decided=until_decided, max_trials=max_trials,
                                     figure_format=figure_format,
                                     readings=readings is not None))
        if not check:
            from . import report as rp
            with _steps("report") as say:
                w = rp.write_report(configs, results, warn=_warn, status=say)
            err.print(f"wrote {w.markdown} and {w.index}", markup=False)
            return
        _print_check(rows, len(files), results, z)
        if not all(r.ok for _, r, _ in rows):
            raise typer.Exit(1)


def _only_configs(files: list[Path], only: list[str], configs: Path) -> list[Path]:
    """The config files ``only`` names (by file name or stem; every one of them, if none)."""
    if not only:
        return files
    want = set(only)
    unknown = want - {p.name for p in files} - {p.stem for p in files}
    if unknown:
        raise UserError(f"--only {sorted(unknown)[0]}: no such config in {configs}; "
                        f"configs: {', '.join(p.stem for p in files)}")
    return [p for p in files if p.name in want or p.stem in want]


def _check_tables_flags(check: bool, resume: bool, until_decided: bool, max_trials) -> None:
    """The flags of 'pfbench tables' that do not go together."""
    if check and resume:
        raise UserError("--resume continues a regeneration; --check starts afresh each time")
    if check and until_decided:
        raise UserError("--until-decided regenerates; --check re-runs the committed trials")
    if max_trials is not None and not until_decided:
        raise UserError("--max-trials goes with --until-decided")


def _each_config(files: list[Path], totals: list[int], results: Path, ex, bar, z, opts: dict):
    """Check (z: the tolerance; None: regenerate, with regen.regenerate's opts) each config of
    ``files`` in turn under one progress bar of their ``totals`` trials (a run until decided
    grows it). Returns the checks' (name, result, seconds)."""
    import time
    from . import regen
    rows = []
    progress = _progress(bar, sum(totals), lambda: None, (), getattr(ex, "underway", None))
    before, grown = 0, {"total": sum(totals)}
    for p, n in zip(files, totals):
        t0 = time.perf_counter()
        progress.describe(p.stem, now=True)
        seen = [n]

        def step(d, t, b=before, seen=seen):
            if t > seen[0]:             # a run until decided adds a batch
                grown["total"] += t - seen[0]
                seen[0] = t
            progress(b + d, grown["total"])

        def cell(words, name=p.stem):   # a sweep's cell
            progress.describe(f"{name}: {words}", now=True)
        with _stop_on_interrupt(bar, f"{p.name}: ", "" if z is not None else
                                "; 'pfbench tables --resume' continues"):
            if z is not None:
                r = regen.check_config(p, results, ex, z, progress=step)
                rows.append((p.name, r, time.perf_counter() - t0))
            else:
                folder = regen.regenerate(p, results, ex, progress=step, warn=_warn,
                                          status=cell, **opts)
                bar.console.print(f"{p.name} -> {folder} in "
                                  f"{time.perf_counter() - t0:.1f} s", markup=False)
        before += seen[0]
    return rows


def _print_check(rows: list, configs: int, results: Path, z: float) -> None:
    """The table of 'pfbench tables --check', a line for each metric that moved, the
    tolerance."""
    t = RichTable(title=f"pfbench tables --check: {configs} configs against {results}",
                  title_justify="left")
    for h in ("config", "trials re-run", "metrics compared", "same trials bit for bit",
              "result", "s"):
        t.add_column(h)
    for name, r, sec in rows:
        t.add_row(name, str(r.trials), str(r.compared),
                  "-" if r.skipped else "yes" if r.identical else "no",
                  "skipped: data absent" if r.skipped else "ok" if r.ok
                  else f"{len(r.findings)} moved", f"{sec:.1f}")
    out.print(t)
    for name, r, _ in rows:
        if r.skipped:
            out.print(f"skipped: {name}: {r.skipped}", markup=False, soft_wrap=True)
    for _, r, _ in rows:
        for f in r.findings:
            out.print(f"moved: {f.line()}", markup=False, soft_wrap=True)
    out.print(f"Tolerance: |mean now - mean committed| <= {z:g} s sqrt(1/n_now + "
              "1/n_committed) per filter run and metric (s: the pooled standard deviation "
              "of the trials of both), never below 1e-9 relative; constant metrics to 1e-9 "
              "relative.", markup=False,
              soft_wrap=True)


@app.command()
def report(
    configs: str = typer.Option("configs", "--configs", help="Folder of configs."),
    results: str = typer.Option("results", "--results", help="Folder of results."),
    out_file: Optional[str] = typer.Option(None, "--out", help="Folder to write the report "
                                            "into, created: REPORT.md and the HTML report in "
                                            "report/ (default: RESULTS; a path ending in .md: "
                                            "the Markdown file, report/ beside it)."),
    check: bool = typer.Option(False, "--check", help="Write nothing; exit 1 when the files "
                               "where --out says are not what the results give."),
    papers: List[str] = _papers_option(),
):
    """Write the reproduction report: every paper's tables beside ours, from the results
    (RESULTS/REPORT.md and the HTML report in RESULTS/report/, or where --out says)."""
    with _guard():
        _load_kernels()
        _use_papers(papers)
        configs, results = _path(configs, "--configs"), _path(results, "--results")
        out_file = _path(out_file, "--out")
        from . import report as rp
        with _steps("report") as say:
            w = rp.write_report(configs, results, out_file, check=check, warn=_warn,
                                status=say)
        path, same, index, differ = w.markdown, w.same, w.index, w.differ
        if not check:
            err.print(f"wrote {path} and {index} ({len(differ)} of its files changed)",
                      markup=False)
            return
        again = "'pfbench report" + (f" --out {out_file}'" if out_file else "'")
        if same:
            err.print(f"{path} is up to date", markup=False)
        else:
            err.print(f"{path} is not what the results give: run {again}", markup=False)
        if not differ:
            err.print(f"{index.parent} is up to date", markup=False)
        else:
            err.print(f"{index.parent}: {len(differ)} file(s) not what the results give "
                      f"({', '.join(differ[:3])}{'...' if len(differ) > 3 else ''}): run "
                      f"{again}", markup=False)
        if not same or differ:
            raise typer.Exit(1)


@app.command()
def validate(config: Path = typer.Argument(..., help="Experiment YAML file."),
             set_: List[str] = typer.Option([], "--set", help="KEY.PATH=VALUE override."),
             papers: List[str] = _papers_option()):
    """Check a config (and its paper file) against the schema; run nothing."""
    with _guard():
        _load_kernels()
        _use_papers(papers)
        from .config import read_yaml
        from .resources import check_fits, human
        raw, _ = read_yaml(config)
        if isinstance(raw, dict) and "sweep" in raw:
            from . import sweep as sw
            name, cells = sw.expand(config, sw.parse_sets(set_), {})
            need = max(check_fits(c.exp, 1, f"{config} (sweep cell {c.name})").bytes
                       for c in cells)
            out.print(f"{config}: ok: sweep {name}: {len(cells)} cells over "
                      f"{', '.join(cells[0].values)}, {cells[0].exp.trials} trials each, "
                      f"about {human(need)} of memory on one worker", markup=False)
            from .diagnostics import plan
            # one line, unless the swept keys change what the cells compute
            for line in dict.fromkeys(plan(c.exp).describe() for c in cells):
                out.print(f"{config}: {line}", markup=False, soft_wrap=True)
            return
        exp = _load(config, sets=set_)
        need = check_fits(exp, 1)
        runs = ", ".join(f.key for f in exp.filters)
        out.print(f"{config}: ok: {exp.name}: scenario {exp.scenario}, {exp.trials} trials, "
                  f"seed {exp.seed}, filter runs {runs}; about {human(need.bytes)} of memory on "
                  "one worker", markup=False)
        from .diagnostics import plan
        out.print(f"{config}: {plan(exp).describe()}", markup=False, soft_wrap=True)


@app.command("list")
def list_(configs: Path = typer.Option(Path("configs"), "--configs",
                                       help="Folder of experiment files to list (and, with "
                                       "--check, where the files a scenario names resolve)."),
          check: bool = typer.Option(False, "--check", help="Run the contract (as 'pfbench "
                                     "check'): every registered filter on every scenario it runs "
                                     "on, plug-ins included, and the trap suite; exit 1 when "
                                     "one breaks it."),
          executor: str = typer.Option("local", "--executor", help="--check: also run the "
                                       "contract's trials on this executor ('dask') and compare."),
          workers: int = typer.Option(1, "--workers", "-w", min=1, help="--check with "
                                      "--executor dask: workers of the local cluster."),
          scheduler: Optional[str] = typer.Option(None, "--scheduler", help="--check with "
                                                  "--executor dask: a scheduler tcp://HOST:PORT."),
          probe_timeout: float = typer.Option(600.0, "--probe-timeout", help="--check: seconds "
                                              "each probe may take, its kernels' first "
                                              "compilation included, before it is stopped and "
                                              "reported as a problem naming its filter."),
          keys: Optional[str] = typer.Option(None, "--keys", metavar="NAME", help="Print the "
                                             "keys of the filter type or scenario NAME (plug-ins "
                                             "too): each key's kind, default, bounds and doc, "
                                             "instead of the lists.")):
    """List scenarios, filters (with which filter runs on which scenario), resampling schemes and
    configs; with --keys NAME, the keys of the filter type or scenario NAME."""
    import math
    if not math.isfinite(probe_timeout) or probe_timeout <= 0:
        with _guard():
            raise UserError(f"--probe-timeout: expected a finite number > 0, got {probe_timeout}")
    if keys is not None:
        with _guard():
            if check:
                raise UserError("--keys prints one filter's or scenario's keys; run --check "
                                "on its own")
            _load_kernels()
            _print_keys(keys)
        return
    _load_kernels()
    from . import plugins
    from .config import read_yaml
    from .filters import FILTERS
    from .resampling import SCHEMES
    from .scenarios import SCENARIOS

    def origin(group, name):
        pkg = plugins.ORIGIN.get((group, name), "pfbench")
        return "" if pkg == "pfbench" else f" (plug-in: {pkg})"

    out.print("scenarios:", style="bold")
    for name, mod in SCENARIOS.items():
        out.print(f"  {name:<18} {mod.DESCRIPTION}{origin(plugins.SCENARIO_GROUP, name)}",
                  markup=False)
    out.print("filters:", style="bold")
    for name, f in FILTERS.items():
        out.print(f"  {name:<18} {f.description}{origin(plugins.FILTER_GROUP, name)}",
                  markup=False)
    _print_compatibility(FILTERS, SCENARIOS)
    out.print("resampling:", style="bold")
    for name, text in SCHEMES.items():
        out.print(f"  {name:<18} {text}", markup=False)
    out.print(f"configs ({configs}):", style="bold")
    for path in sorted(configs.glob("*.yaml")):
        try:
            raw = read_yaml(path)[0] or {}
            what = raw.get("description") or ""
            tag = (f"{raw.get('paper')} {raw.get('table') or ''}".strip() + ": "
                   if raw.get("paper") else "")
        except (UserError, AttributeError):
            tag, what = "", "(not a valid config)"
        out.print(f"  {path.name:<28} {tag}{what}", markup=False)
    for problem in plugins.PROBLEMS:
        _warn(f"{problem}; left out")
    if check:
        with _guard():
            _check_contract(configs if configs.is_dir() else None, executor, workers, scheduler,
                            probe_timeout)


def need_letters(needs) -> dict[str, str]:
    """A capital letter for each name of ``needs``: its first letter not taken by an earlier one
    (jacobians J, gaussian_measurement G, likelihood L, linear I)."""
    letters: dict[str, str] = {}
    for name in needs:
        free = [c.upper() for c in name if c.isalpha() and c.upper() not in letters.values()]
        letters[name] = free[0] if free else "?"
    return letters


def compatibility_lines(filters: dict, scenarios: dict, width: int = 100) -> list[str]:
    """The compatibility matrix as text lines of at most ``width`` columns: for each kind, a row
    per scenario and a column per filter type, each cell 'ok' or the letters of what the scenario
    lacks of what the filter needs; a legend below."""
    from .protocols import NEEDS, NOT_NAMED, UNKNOWN, compatibility
    letters = need_letters(NEEDS)
    lines = ["compatibility (a row per scenario, a column per filter type of its kind: 'ok', or "
             "what it lacks):"]
    blocks = compatibility(filters, scenarios)
    for kind, (scens, filts, cells) in blocks.items():
        text = {k: "ok" if not v else "x" if v == (NOT_NAMED,) else "?" if v == (UNKNOWN,)
                else "".join(letters[n] for n in v) for k, v in cells.items()}
        label = max([len(kind), *map(len, scens)]) + 2
        cols = {f: max([len(f), *(len(text[s, f]) for s in scens)]) + 1 for f in filts}
        chunk: list[str] = []
        chunks = [chunk]
        for f in filts:            # as many columns as fit in width
            if chunk and 2 + label + sum(cols[g] for g in chunk) + cols[f] > width:
                chunk = []
                chunks.append(chunk)
            chunk.append(f)
        for chunk in chunks:
            if not chunk:
                lines.append(f"  {kind:<{label}}(no filter type)")
                continue
            lines.append(f"  {kind:<{label}}" + "".join(f"{f:<{cols[f]}}" for f in chunk).rstrip())
            lines += [f"  {s:<{label}}" + "".join(f"{text[s, f]:<{cols[f]}}"
                                                  for f in chunk).rstrip() for s in scens]
    legend = [f"{c} {n}" for n, c in letters.items()]
    seen = {v for _, _, cells in blocks.values() for v in cells.values()}
    if (NOT_NAMED,) in seen:
        legend.append("x: the filter runs only on scenarios it names")
    if (UNKNOWN,) in seen:
        legend.append("?: its model, asked what it provides, cannot be built from its keys' "
                      "defaults (a config's keys decide)")
    line = " "
    for item in legend:
        item += "," if item is not legend[-1] else ""
        if len(line) + 1 + len(item) > width:
            lines.append(line)
            line = " "
        line += " " + item
    lines.append(line)
    return lines


def _print_compatibility(filters: dict, scenarios: dict) -> None:
    lines = compatibility_lines(filters, scenarios)
    out.print(lines[0], style="bold", markup=False)
    for line in lines[1:]:
        out.print(line, markup=False, soft_wrap=True)


def _key_lines(schema: dict, note: str = "") -> list[str]:
    """Two lines per key of ``schema``: its name, kind, default and what it accepts (its
    bounds); then its doc."""
    lines = []
    for name, key in schema.items():
        try:
            null = ", or null" if key.nullable else ""
            head = f"({key.kind}, default {key.default_text()}): {key.expected()}{null}"
            doc = " ".join(str(key.doc).split()) or "(no doc)"
        except Exception as exc:    # a plug-in's key that cannot describe itself
            head, doc = f"(cannot be described: {type(exc).__name__}: {exc})", ""
        lines.append(f"  {name} {head}")
        lines.append(f"      {doc}{note}")
    return lines or ["  (no keys of its own)"]


def _print_keys(name: str) -> None:
    """``pfbench list --keys NAME``: the keys of the filter type or scenario NAME, or a
    UserError naming the close names."""
    import difflib
    from . import plugins
    from .filters import FILTERS, KIND_TYPES
    from .protocols import FILTER_COMMON, declared
    from .scenarios import SCENARIOS
    from .schema import printable

    def origin(group, what):
        pkg = plugins.ORIGIN.get((group, what), "pfbench")
        return "" if pkg == "pfbench" else f" (plug-in: {pkg})"

    lines = []
    if name in FILTERS:
        f = FILTERS[name]
        extra = [f"runs on {f.kind} scenarios"
                 + (f" ({', '.join(f.scenarios)} only)" if f.scenarios else "")]
        if f.needs:
            extra.append(f"needs {', '.join(f.needs)}")
        if not f.particles:
            extra.append("no particles")
        lines.append(f"filter type {name}{origin(plugins.FILTER_GROUP, name)}: {f.description} "
                     f"({'; '.join(extra)})")
        lines.append("keys every filter has (filters.<key>.):")
        lines += _key_lines(FILTER_COMMON)
        lines.append(f"keys of {name}:")
        lines += _key_lines(f.schema)
        lines += [f"  (a config's 'type: {name}' runs {t} on {k} scenarios)"
                  for (n, k), t in KIND_TYPES.items() if n == name]
    if name in SCENARIOS:
        mod = SCENARIOS[name]
        gives = declared(mod)
        lines.append(f"scenario {name}{origin(plugins.SCENARIO_GROUP, name)}: "
                     f"{mod.DESCRIPTION} (kind {mod.KIND}"
                     + (f"; provides {', '.join(gives)}" if gives else "") + ")")
        lines.append(f"keys of scenario {name} (scenario.<key>):")
        lines += _key_lines(mod.SCHEMA)
    if not lines:
        shown = printable(name)
        left = (plugins.problem_for(plugins.FILTER_GROUP, name)
                or plugins.problem_for(plugins.SCENARIO_GROUP, name))
        if left:
            raise UserError(f"--keys '{shown}': {left}; left out")
        names = [*FILTERS, *SCENARIOS]
        close = difflib.get_close_matches(name, names, n=3, cutoff=0.5)
        hint = (f"did you mean {', '.join(repr(c) for c in close)}?" if close else
                f"filters: {', '.join(FILTERS)}; scenarios: {', '.join(SCENARIOS)}")
        raise UserError(f"--keys '{shown}': no filter type or scenario of that name; {hint}")
    for line in lines:
        out.print(line, markup=False, soft_wrap=True)


@app.command("check")
def check_(executor: str = typer.Option("local", "--executor", help="Also run the contract's "
                                        "trials on this executor ('dask') and compare."),
           workers: int = typer.Option(1, "--workers", "-w", min=1, help="With --executor "
                                       "dask: workers of the local cluster."),
           scheduler: Optional[str] = typer.Option(None, "--scheduler", help="With --executor "
                                                   "dask: a scheduler tcp://HOST:PORT."),
           probe_timeout: float = typer.Option(600.0, "--probe-timeout", help="Seconds each "
                                               "probe may take, its kernels' first compilation "
                                               "included, before it is stopped and reported as "
                                               "a problem naming its filter."),
           only: Optional[str] = typer.Option(None, "--only", help="Only the probes and traps "
                                              "of this filter (or the probes of this "
                                              "scenario)."),
           traps: bool = typer.Option(True, "--traps/--no-traps", help="Run the trap suite on "
                                      "every filter after the probes."),
           configs: Optional[Path] = typer.Option(None, "--configs", help="Folder the files a "
                                                  "scenario names resolve from (default: "
                                                  "generated ones; no folder is needed).")):
    """The contract, from any folder: every registered filter on every scenario it runs on
    (plug-ins included) on small generated experiments, deterministic from the seed, across
    worker counts and executors, finite; then the trap suite on every filter. Exit 1 when one
    breaks it, with one line per problem."""
    import math
    with _guard():
        if not math.isfinite(probe_timeout) or probe_timeout <= 0:
            raise UserError(f"--probe-timeout: expected a finite number > 0, got {probe_timeout}")
        _load_kernels()
        from . import plugins
        from .filters import FILTERS
        from .scenarios import SCENARIOS
        if only is not None and only not in FILTERS and only not in SCENARIOS:
            raise UserError(f"--only: no filter or scenario '{only}' (filters: "
                            f"{', '.join(FILTERS)}; scenarios: {', '.join(SCENARIOS)})")
        for problem in plugins.PROBLEMS:
            _warn(f"{problem}; left out")
        _check_contract(configs, executor, workers, scheduler, probe_timeout, only=only,
                        traps=traps)


def _check_contract(configs: Path | None, executor: str, workers: int, scheduler: str | None,
                    timeout: float = 600.0, only: str | None = None, traps: bool = True) -> None:
    import time
    from .contract import ProbeInterrupted, check_all
    if configs is not None and not configs.is_dir():
        raise UserError(f"--configs {configs}: no such folder")
    t0 = time.perf_counter()
    ex_cm = _executor(executor, workers, scheduler)     # checks the name
    if executor == "local":      # the in-process run is the reference: nothing to compare
        ex_cm = contextlib.nullcontext()
    with ex_cm as ex:
        with _bar() as bar:
            task = bar.add_task("contract", total=None)
            try:
                n, problems = check_all(configs, ex, lambda done, total: bar.update(
                    task, completed=done, total=total), timeout, only=only)
            except ProbeInterrupted as exc:
                bar.stop()
                err.print(f"pfbench: {exc}", markup=False, soft_wrap=True)
                raise typer.Exit(130) from None
        where = f", and under {ex.describe()}" if ex is not None else ""
    for p in problems:
        err.print(f"pfbench: contract: {p}", markup=False, soft_wrap=True)
    what = "cover every filter and scenario" if only is None else f"of {only}"
    err.print(f"contract: {n} probes {what}{where}: "
              + (f"{len(problems)} problem(s)" if problems else "all kept")
              + f" ({time.perf_counter() - t0:.0f} s)", markup=False)
    broken = _check_traps(only, timeout) if traps else 0
    if problems or broken:
        raise typer.Exit(1)


def _check_traps(only: str | None, timeout: float | None = None) -> int:
    """The trap suite on every filter (or ``only``): a line per broken trap, a line per trap
    naming the filters that kept it and those it does not apply to (and why); the number
    broken. ``timeout``: seconds each filter's traps may take."""
    import time
    from .filters import FILTERS
    from .traps import BROKEN, KEPT, NOT_APPLICABLE, TRAPS, run_traps
    names = [f for f in FILTERS if only is None or only == f]
    t0 = time.perf_counter()
    with _bar() as bar:
        task = bar.add_task("traps", total=len(names))
        found = run_traps(names, progress=lambda done, total: bar.update(task, completed=done),
                          timeout=timeout)
    for f in found:
        if f.status == BROKEN:
            err.print(f"pfbench: contract: {f.line()}", markup=False, soft_wrap=True)
    for trap in TRAPS:
        mine = [f for f in found if f.trap == trap]
        kept = [f.filter for f in mine if f.status == KEPT]
        broke = [f.filter for f in mine if f.status == BROKEN]
        why: dict[str, list[str]] = {}
        for f in mine:
            if f.status == NOT_APPLICABLE:
                why.setdefault(f.detail, []).append(f.filter)
        na = [f"{', '.join(fs)} ({detail})" for detail, fs in why.items()]
        parts = ([f"broken by {', '.join(broke)}"] if broke else []) + (
            [f"kept by {', '.join(kept)}"] if kept else []) + (
            [f"does not apply to {'; '.join(na)}"] if na else [])
        err.print(f"trap {trap}: {'; '.join(parts) or 'no filter'}", markup=False,
                  soft_wrap=True)
    n = sum(f.status == BROKEN for f in found)
    err.print(f"traps: {len(TRAPS)} traps on {len(names)} filter(s): "
              + (f"{n} broken" if n else "all kept where they apply")
              + f" ({time.perf_counter() - t0:.0f} s)", markup=False)
    return n


@app.command("rank")
def rank_(
    folders: List[str] = typer.Argument(..., help="Results folders (of 'pfbench run' or "
                                        "'pfbench sweep'), one or many."),
    metric: str = typer.Option("rmse", "--metric", help="The metric the filters are ranked on."),
    filters: List[str] = typer.Option([], "--filter", help="A filter (its label) to rank; "
                                      "repeat it (default: every filter that ran at every "
                                      "particle count where two or more ran)."),
    out_dir: Optional[str] = typer.Option(None, "--out", help="Folder to draw the "
                                          "critical-difference diagram into (cd_METRIC.png), "
                                          "created; nothing is written without it."),
    as_json: bool = typer.Option(False, "--json", help="Print the ranking as JSON."),
):
    """Rank many filters at once: average ranks over blocks (one trial at one particle count),
    the Friedman test, Wilcoxon signed-rank tests between every two filters with Holm's
    procedure, and the critical-difference diagram."""
    with _guard():
        import json
        from . import rank as rk
        from .dataset import load_trials
        out_path = _path(out_dir, "--out")
        paths = [_path(f, "FOLDER") for f in folders]
        if len(set(map(str, paths))) < len(paths):
            raise UserError("FOLDER: a results folder named twice")
        r = rk.rank(load_trials(*paths), metric, filters)
        drawn = None
        if out_path is not None:
            from .fsutil import ensure_folder
            drawn = rk.draw_cd(r, ensure_folder(out_path, "--out") / f"cd_{metric}.png")
        if as_json:
            d = r.as_dict()
            d["diagram"] = str(drawn) if drawn else None
            out.print(json.dumps(d, indent=2), markup=False, soft_wrap=True)
            return
        out.print(rk.head_line(r), markup=False, soft_wrap=True)
        out.print(_rich_table("Average ranks", ["Filter", "Average rank"],
                              [[f, f"{r.average_ranks[f]:.2f}"] for f in r.filters]))
        for line in rk.test_lines(r):
            out.print(line, markup=False, soft_wrap=True)
        head, cells = rk.pair_rows(r)
        out.print(_rich_table("Pairs (Wilcoxon signed-rank, Holm)", head, cells), wide=True)
        if drawn:
            err.print(f"wrote {drawn}", markup=False)


@app.command("compare")
def compare_(
    folder_a: str = typer.Argument(..., help="The first results folder (the reference)."),
    folder_b: str = typer.Argument(..., help="The second results folder."),
    threshold: float = typer.Option(1.05, "--threshold", help="Flag a change only when B / A "
                                    "lies outside [1/FACTOR, FACTOR] (and it is significant)."),
    metrics: List[str] = typer.Option([], "--metric", help="A metric to compare; repeat it "
                                      "(default: every metric both hold)."),
    only_changed: bool = typer.Option(False, "--only-changed", help="Print only the "
                                      "significant changes."),
    as_json: bool = typer.Option(False, "--json", help="Print the comparison as JSON."),
):
    """Compare two results folders: each metric's change per filter run with its interval
    (paired by trial when the seeds are the same, Welch's otherwise, Holm over every change),
    flagged when significant and beyond the threshold factor. Exit status 1 when a change is
    flagged, 0 when none is, 2 on bad input."""
    with _guard():
        import json
        from . import runs_compare as rc
        a, b = _path(folder_a, "FOLDER_A"), _path(folder_b, "FOLDER_B")
        cmp = rc.compare_runs(a, b, metrics, threshold)
        if as_json:
            out.print(json.dumps(cmp.as_dict(), indent=2), markup=False, soft_wrap=True)
        else:
            head, cells = rc.rows(cmp, only_changed)
            if cells:
                out.print(_rich_table(f"{b} against {a}", head, cells), wide=True)
            out.print(rc.summary_line(cmp), markup=False, soft_wrap=True)
    if cmp.flagged:
        raise typer.Exit(1)


@app.command()
def bench(
    json_path: Optional[str] = typer.Option(None, "--json", help="Also write the records as "
                                            "JSON to this file."),
    quick: bool = typer.Option(False, "--quick", help="Fewer sizes and repeats (a smoke test)."),
    c_ref: Optional[str] = typer.Option(None, "--c-ref", help="A compiled C reference "
                                        "(ungm_ref) to time in the same run."),
    threads: int = typer.Option(0, "--threads", min=0, help="Threads for the batch "
                                "(0: every core)."),
    only: List[str] = typer.Option([], "--only", help="Only this part, repeatable: ungm, costs, "
                                   "fastslam, afsa, mcl, run (what 'pfbench run' runs beside the "
                                   "kernel: run-ungm, run-mcl, run-fastslam), limit."),
    limit: bool = typer.Option(False, "--limit", help="Also time each kernel's irreducible "
                               "passes alone: their sum, the practical limit, beside the "
                               "kernel (UNGM, MCL, FastSLAM)."),
    peers: bool = typer.Option(False, "--peers", help="Also time the same UNGM filter written "
                               "with the particles library and with filterpy's resampling "
                               "(pip install '.\\[peers]')."),
    compare: Optional[str] = typer.Option(None, "--compare", help="An earlier run's --json "
                                          "file: print each record's throughput ratio to it."),
):
    """Kernel speed beside numpy (and a C reference): UNGM PF, every filter, FastSLAM, MCL."""
    with _guard():
        json_path, c_ref = _path(json_path, "--json"), _path(c_ref, "--c-ref")
        compare = _path(compare, "--compare")
        _load_kernels()
        from .benchmarks.suite import run_bench
        run_bench(json_path=json_path, quick=quick, c_ref=c_ref, threads=threads, console=out,
                  only=only, compare=compare, limit=limit, peers=peers)


def main():  # console-script entry point
    """The command line. What its imports made (numba, typer, rich: about 70,000 objects that the
    collector tracks) lives until the process ends, so it is frozen out of the cyclic collector
    (gc.freeze): the collections of a command no longer walk it, nor do those of the workers it
    forks (pfbench.workers), and the process ends without the collector's last pass over its heap.
    Together 0.1 s of a two-trial run (two full collections of 0.07 s each gone). A ``run``
    starts its worker first of all (pfbench.runner.prestart)."""
    import gc
    gc.freeze()
    early = sys.argv[1:2] == ["run"]
    if early:
        from .runner import prestart
        prestart()          # its worker starts numba while the command line and config are read
    try:
        app()
    finally:
        if early:           # (another command never imports the runner for it)
            from .runner import discard_prestarted
            discard_prestarted()
        gc.freeze()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
