#!/usr/bin/env python3
"""Regenerate the generated blocks of README.md: the config-key reference (from the schemas), the
trials file's metric columns of each scenario kind (from pfbench.kinds and pfbench.metrics) and the
worked example (from the committed results/ifa_pf_ungm/table.csv).

    python scripts/update_readme.py            # print the blocks
    python scripts/update_readme.py --write    # replace them in README.md
    python scripts/update_readme.py --check    # exit 1 if README.md is stale
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pandas as pd

from pfbench.config import CHECK_SCHEMA, COMPARE_SCHEMA, FILTER_COMMON, TOP_SCHEMA
from pfbench.filters import FILTERS
from pfbench.kinds import KINDS
from pfbench.metrics import METRICS
from pfbench.scenarios import SCENARIOS
from pfbench.schema import REQUIRED

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
EXAMPLE = ROOT / "results" / "ifa_pf_ungm" / "table.csv"


def _default(key) -> str:
    if key.default is REQUIRED:
        return "required"
    if key.default is None:
        return "-"
    if isinstance(key.default, bool):
        return f"`{str(key.default).lower()}`"
    return f"`{key.default}`"


def _table(title: str, schema: dict, prefix: str) -> list[str]:
    lines = [f"**{title}**", "", "| key | type | default | meaning |", "| --- | --- | --- | --- |"]
    for name, key in schema.items():
        lines.append(f"| `{prefix}{name}` | {key.expected()} | {_default(key)} | "
                     f"{key.doc.replace('|', '/')} |")
    return lines + [""]


def keys_block() -> str:
    out = ["", "*Generated from the schemas by `python scripts/update_readme.py --write`.*", ""]
    out += _table("Top level", TOP_SCHEMA, "")
    out += _table("`compare:` (how verdicts are given)", COMPARE_SCHEMA, "compare.")
    out += _table("`check:` (what `pfbench tables --check` runs)", CHECK_SCHEMA, "check.")
    out += _table("Every filter (`filters.<key>.`)", FILTER_COMMON, "")
    for name, ftype in FILTERS.items():
        if ftype.schema:
            out += _table(f"Filter type `{name}`: {ftype.description}", ftype.schema, "")
        else:
            out += [f"**Filter type `{name}`**: {ftype.description}; no keys of its own.", ""]
    for name, mod in SCENARIOS.items():
        out += _table(f"Scenario `{name}` (`scenario.name: {name}`): {mod.DESCRIPTION}",
                      mod.SCHEMA, "scenario.")
    return "\n".join(out)


def _g(v, digits=4) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}g}"


def example_block() -> str:
    tab = pd.read_csv(EXAMPLE)
    out = ["", "| Filter | N | Trials | RMSE mean [95% CI] | Paper RMSE | Ratio | Verdict |",
           "| --- | --- | --- | --- | --- | --- | --- |"]
    for _, r in tab.iterrows():
        verdict = r["verdict_rmse_mean"] if isinstance(r["verdict_rmse_mean"], str) else "-"
        out.append(f"| {r['label']} | {int(r['particles'])} | {int(r['trials'])} | "
                   f"{_g(r['rmse_mean'])} [{_g(r['rmse_ci_lo'])}, {_g(r['rmse_ci_hi'])}] | "
                   f"{_g(r['paper_rmse_mean'], 6)} | {_g(r['ratio_rmse_mean'], 3)} | {verdict} |")
    return "\n".join(out + [""])


def metrics_block() -> str:
    kinds = list(KINDS.values())
    out = ["", "*Generated from `pfbench/kinds.py` and `pfbench/metrics.py` by `python "
           "scripts/update_readme.py --write`.*", "",
           "| column | " + " | ".join(k.name for k in kinds) + " | meaning |",
           "| --- | " + " | ".join("---" for _ in kinds) + " | --- |"]
    for m, doc in METRICS.items():
        marks = " | ".join("x" if m in k.metrics else "" for k in kinds)
        out.append(f"| `{m}` | {marks} | {doc.replace('|', '/')} |")
    return "\n".join(out + [""])


BLOCKS = {"config-keys": keys_block, "metrics": metrics_block, "example": example_block}


def render(text: str) -> str:
    for name, make in BLOCKS.items():
        begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
        i, j = text.find(begin), text.find(end)
        if i < 0 or j < 0:
            raise SystemExit(f"README.md has no {name} block")
        text = text[: i + len(begin)] + "\n" + make() + "\n" + text[j:]
    return text


def main(argv: list[str]) -> int:
    text = README.read_text()
    new = render(text)
    if "--write" in argv:
        README.write_text(new)
    elif "--check" in argv:
        if new != text:
            print("README.md is stale (config keys or the worked example): run python "
                  "scripts/update_readme.py --write", file=sys.stderr)
            return 1
    else:
        print(new)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
