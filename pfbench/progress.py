"""Progress bars: what the CLI shows while trials run, and what the Python API shows with
``progress=True``.

A bar shows what runs, the trials done, the time since it started and, once a trial of this run
has finished, the time left at the pace of the trials finished since the trials started
(reckoned anew at each refresh, so that it grows while nothing finishes instead of standing
still at its last guess; nothing before the first trial, whose time may be the kernels'
compilation). While trials of seconds run, the bar adds the part of the trials under way that
is done (an executor's ``underway``) twice a second; the count beside it stays the trials
finished.
"""
from __future__ import annotations

import threading
import time
from typing import Callable


def bar(console):
    """A rich progress bar on ``console`` (gone when done). Where the console cannot redraw a
    line (a log, a pipe, a dumb terminal) the bar is off: it would draw nothing there, and
    rich's bar would still end with an empty line (before a run's one-line error, say)."""
    from rich.progress import (BarColumn, MofNCompleteColumn, Progress, SpinnerColumn,
                               TextColumn, TimeElapsedColumn)
    return Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(),
                    MofNCompleteColumn(), TimeElapsedColumn(), time_left_column(),
                    console=console, transient=True,
                    disable=not (console.is_interactive or console.is_jupyter))


def time_left_column():
    """The bar's time left (see the module's notes)."""
    from rich.progress import ProgressColumn
    from rich.text import Text

    class TimeLeft(ProgressColumn):
        max_refresh = 0.5

        def render(self, task) -> Text:
            # a task that no tracker drives: the pace since it started
            return Text(time_left(task.fields.get("since", task.start_time),
                                  task.fields.get("base", 0), task.completed, task.total,
                                  time.monotonic()),
                        style="progress.remaining")
    return TimeLeft()


def time_left(since: float | None, base: float, done: float, total: float | None,
              now: float) -> str:
    """'H:MM:SS left' for ``total - done`` trials at the pace of the ``done - base`` finished
    since ``since``; '' before one has finished (or when done, or without a total)."""
    ran = done - base
    if total is None or since is None or ran <= 0 or done >= total:
        return ""
    left = (total - done) * (now - since) / ran
    minutes, seconds = divmod(int(left + 0.5), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours}:{minutes:02d}:{seconds:02d} left"


def tracker(progress_bar, total: int, words: str = "trials",
            first: Callable[[], None] | None = None,
            underway: Callable[[], float] | None = None):
    """A progress callback ``(done, total)`` that drives a task of ``progress_bar`` (from
    ``bar``) of ``total`` trials (a run until decided raises it batch by batch). The task says
    ``words`` until the first trial finishes, then 'trials' (or what ``describe(words)`` set
    last: a sweep's cell). ``first()`` is called on its first call. ``underway()``: the part of
    the trials under way that is done (see the module's notes)."""
    task = progress_bar.add_task(words, total=total)
    state = {"done": None, "shown": 0.0, "words": "trials"}
    lock = threading.Lock()

    def show(done, total=None):
        with lock:
            state["shown"] = max(state["shown"], done)
            progress_bar.update(task, completed=state["shown"], total=total)

    def progress(done, total):
        if first:
            first()
        if state["done"] is None:       # the trials start: the time left is reckoned from here
            progress_bar.update(task, since=time.monotonic(), base=done)
        state["done"] = done
        show(done, total)
        if done:
            progress_bar.update(task, description=state["words"])

    def describe(words: str, now: bool = False) -> None:
        state["words"] = words
        if now or state["done"]:
            progress_bar.update(task, description=words)

    def tick():
        while progress_bar.live.is_started:
            time.sleep(0.5)
            done = state["done"]
            if done is None:
                continue
            try:
                part = underway()
            except Exception:       # a pool torn down meanwhile
                continue
            total = next(t for t in progress_bar.tasks if t.id == task).total
            if part > 0 and total:
                show(min(done + part, total - 0.01))

    console = progress_bar.console
    if underway is not None and progress_bar.live.is_started \
            and (console.is_terminal or console.is_jupyter):
        threading.Thread(target=tick, daemon=True, name="pfbench-progress").start()
    progress.describe = describe
    return progress


class shown:
    """``with shown(progress, executor) as callback``: the API's ``progress`` argument as a
    callback: True draws a bar on stderr (in a notebook, below the cell) for as long as the
    ``with`` lasts; a function or None is given back as it is."""

    def __init__(self, progress, executor=None, words: str = "trials"):
        self.progress, self.executor, self.words, self._bar = progress, executor, words, None

    def __enter__(self):
        if self.progress is not True:
            return self.progress or None
        from rich.console import Console
        self._bar = bar(Console(stderr=True, highlight=False, emoji=False))
        self._bar.start()
        return tracker(self._bar, None, self.words,
                       underway=getattr(self.executor, "underway", None))

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.stop()
