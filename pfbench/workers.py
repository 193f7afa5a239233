"""Worker processes on this machine, each with a pipe of its own, that can be stopped at any moment.

multiprocessing.Pool shares one task queue and one result queue, and their locks, among its
workers and three threads of this process. A worker stopped while it writes a result (Ctrl-C, or a
run that ends on another worker's error) leaves the result queue's lock taken, and
``Pool.terminate`` then waits for ever on a thread that needs it (CPython issue 96995, open; it
hung pfbench's tests about once in five runs). Here every worker reads its items from, and writes
its results to, a pipe that only it and this process use, and this process waits on the pipes and
the processes themselves (``multiprocessing.connection.wait``): no lock is shared and no thread
is started, so ``stop`` ends every worker and returns whatever they were doing, and a worker that
dies is seen at once, as the end of its pipe or of its process.

Which work goes to which worker is the caller's choice (``send``): this module only carries it.
"""
from __future__ import annotations

import multiprocessing as mp
import signal
from multiprocessing.connection import wait
from typing import Any, Callable

from .fsutil import close_inherited_locks


class WorkerDied(Exception):
    """A worker process ended while work was under way: ``slot`` (its index) and ``exitcode``
    (None when unknown; negative: the signal that killed it)."""

    def __init__(self, slot: int, exitcode: int | None):
        super().__init__(f"worker {slot} ended ({exitcode})")
        self.slot, self.exitcode = slot, exitcode


def _context():
    return mp.get_context("fork" if "fork" in mp.get_all_start_methods() else "spawn")


def _serve(conn, slot: int, handle: Callable, setup: Callable | None, setup_args: tuple) -> None:
    """A worker's life: ``setup(*setup_args, slot)``, then ``handle`` each item that arrives,
    sending back (True, result) or (False, the exception), until None or the pipe's end."""
    if setup is not None:
        setup(*setup_args, slot)
    while True:
        try:
            item = conn.recv()
        except (EOFError, OSError):
            return
        if item is None:
            return
        try:
            out = (True, handle(item))
        except BaseException as exc:        # a filter's SystemExit too: the caller decides
            out = (False, exc)
        try:
            conn.send(out)
        except (EOFError, OSError):         # this process stopped listening
            return
        except Exception as exc:            # a result or an exception that cannot be pickled
            conn.send((False, RuntimeError(f"{type(exc).__name__}: {exc}")))


class Workers:
    """``count`` daemon worker processes that run ``handle(item)`` on the items sent to them,
    after ``setup(*setup_args, slot)`` (slot: the worker's index). With the fork start method
    ``handle`` is inherited, not pickled: a closure or a large object costs nothing to pass. Use
    as a context manager (``stop`` on the way out). ``collect``: where this process keeps its
    objects frozen (see below), collect its garbage before the new ones are frozen too (False
    where there is next to none to collect: the command line's first fork, right after its
    imports)."""

    def __init__(self, count: int, handle: Callable[[Any], Any], setup: Callable | None = None,
                 setup_args: tuple = (), collect: bool = True):
        ctx = _context()
        self.procs: list = []
        self.conns: list = []
        # The workers fork with this process's objects frozen out of the cyclic collector: a
        # worker's collections then never write to (and so copy) the pages it shares with this
        # process. Starting numba's compiler in a forked worker took 0.32 s, 0.20 s so (medians
        # of three, this project's 2-core machine). This process has them back at once, unless
        # it keeps objects frozen already (the command line, which ends soon: pfbench.cli.main);
        # then they stay frozen, once the garbage among them is collected (a collection of
        # what is not frozen yet, which is little), unless ``collect`` is False.
        import gc
        kept = gc.get_freeze_count() > 0
        if kept and collect:
            gc.collect()
        gc.freeze()
        try:
            for slot in range(count):
                ours, theirs = ctx.Pipe()
                proc = ctx.Process(target=_serve, args=(theirs, slot, handle, setup, setup_args),
                                   daemon=True, name=f"pfbench-worker-{slot}")
                proc.start()
                theirs.close()
                self.procs.append(proc)
                self.conns.append(ours)
        except BaseException:
            self.stop()
            raise
        finally:
            if not kept:
                gc.unfreeze()

    @property
    def pids(self) -> list[int]:
        return [p.pid for p in self.procs]

    def send(self, slot: int, item: Any) -> None:
        """Hand ``item`` to worker ``slot`` (it runs them in the order sent); WorkerDied when
        that worker has ended."""
        try:
            self.conns[slot].send(item)
        except (EOFError, OSError):
            raise self._dead(slot) from None

    def _dead(self, slot: int) -> WorkerDied:
        proc = self.procs[slot]
        proc.join(1.0)          # its exit code, which follows the end of its pipe
        return WorkerDied(slot, proc.exitcode)

    def results(self, timeout: float | None = None) -> list[tuple[int, bool, Any]]:
        """The results that arrive within ``timeout`` seconds (at least one unless it passes):
        (slot, ok, the result or the exception). WorkerDied when a worker has ended with no
        result left to read: call this only while work is under way."""
        ready = wait(self.conns + [p.sentinel for p in self.procs], timeout)
        out = []
        for slot, (conn, proc) in enumerate(zip(self.conns, self.procs)):
            if any(r is conn for r in ready) or conn.poll():
                try:
                    ok, got = conn.recv()
                except (EOFError, OSError):
                    raise self._dead(slot) from None
                out.append((slot, ok, got))
            elif proc.sentinel in ready or proc.exitcode is not None:
                raise self._dead(slot)
        return out

    def close(self, timeout: float = 5.0) -> None:
        """Ask every worker to end when its items are done, wait ``timeout`` seconds at most,
        then stop."""
        for conn in self.conns:
            try:
                conn.send(None)
            except (EOFError, OSError):
                pass
        for proc in self.procs:
            proc.join(timeout)
        self.stop()

    def stop(self) -> None:
        """End every worker now, whatever it is doing (SIGTERM, then SIGKILL for one that has not
        ended a second later), and close the pipes. Never waits on a worker's cooperation."""
        for proc in self.procs:
            if proc.exitcode is None:
                proc.terminate()
        for proc in self.procs:
            proc.join(1.0)
            if proc.exitcode is None:
                proc.kill()
                proc.join()
        for conn in self.conns:
            conn.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.stop()


def in_worker() -> bool:
    """Whether this process is a worker (a daemonic process), which may start none."""
    return mp.current_process().daemon


def quiet_worker(*_args) -> None:
    """A worker's setup: it leaves Ctrl-C to its parent, which stops it, and closes the parent's
    folder locks (the parent keeps them)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    close_inherited_locks()
