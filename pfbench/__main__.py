"""The ``pfbench`` console script, and ``python -m pfbench``: the command line
(``pfbench.cli.main``), with a ``run``'s worker process started before the command line's own
modules (typer, rich) are imported.

The worker then starts numba's compiler while this process imports them and reads its command
line and config (``pfbench.runner.prestart``): a two-trial run (``pfbench run
configs/ifa_pf_ungm.yaml --trials 2``) took 0.95 times as long as with the worker forked after
them, on this project's 2-core machine (medians of 12). Every other command goes straight to
``pfbench.cli.main``.
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
    return command_line()


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
