"""Draw the committed figures again from the committed trials and traces, running no trial.

    python scripts/redraw_figures.py [CONFIG ...]     (default: every config in configs/)

Each config's results folder under results/ gets its figures drawn again (its table.md stays); a
sweep its summary, curves and figures, and each of its cells a table.md. The trials files are only
read. The HTML report's figures are drawn by ``pfbench report``.
"""
from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent


def main(argv: list[str]) -> int:
    sys.path.insert(0, str(ROOT))
    from pfbench import regen
    configs = [Path(a) for a in argv] or regen.config_files(ROOT / "configs")
    for path in configs:
        folder = regen.redraw(path, ROOT / "results")
        print(f"{path}: redrew {folder}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
