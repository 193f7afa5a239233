"""The ``pfbench`` console script, and ``python -m pfbench``: the command line
(``pfbench.cli.main``), with a ``run``'s worker process started before the command line's own
modules (typer, rich) are imported, and the process ended without tearing those modules down.

The worker starts what loading kernels needs while this process imports them and reads its
command line and config (``pfbench.runner.prestart``): a two-trial run (``pfbench run
configs/ifa_pf_ungm.yaml --trials 2``) took 0.95 times as long as with the worker forked after
them, on this project's 2-core machine (medians of 12). Every other command goes straight to
``pfbench.cli.main``.

Once the command is done, the interpreter's own ending would take apart every module it imported
(numba, llvmlite, pandas, scipy: 30 ms of that two-trial run's 1.1 s); the process ends instead
once the exit functions have run and the output is flushed (``_end``).
"""
from __future__ import annotations

import sys


def main():
    """The command line, a ``run``'s worker started first of all."""
    if sys.argv[1:2] == ["run"]:
        import gc
        gc.freeze()         # as pfbench.cli.main does: the worker forks with it frozen
        from .runner import prestart
        prestart()
    from .cli import main as command_line
    try:
        code = command_line()
    except SystemExit as exc:
        code = exc.code
    _end(code)


def _status(code) -> int:
    """The exit status of ``sys.exit(code)``: 0 for None, the number, else 1 (the message printed
    on stderr, as the interpreter does)."""
    if code is None:
        return 0
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return 1


def _end(code) -> None:
    """End the process with ``sys.exit(code)``'s status: what the interpreter's ending does that
    anyone could see is done first (the exit functions, atexit: multiprocessing's reaping of its
    children among them; stdout and stderr flushed), then the process ends, leaving the modules
    as they are. Where a thread that is not a daemon still runs (which the interpreter would wait
    for), or the output cannot be flushed, the interpreter ends it as usual."""
    import atexit
    import os
    import threading
    status = _status(code)
    if any(t is not threading.main_thread() and t.is_alive() and not t.daemon
           for t in threading.enumerate()):
        sys.exit(status)
    atexit._run_exitfuncs()
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    except Exception:           # a closed pipe: the interpreter says so, as it would have
        sys.exit(status)
    os._exit(status)


if __name__ == "__main__":  # pragma: no cover
    main()
