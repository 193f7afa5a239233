"""mkdocs hook: the committed results (results/REPORT.md, each experiment's table.md and its
figures, the HTML report) become pages and files of the site, read from results/ where pfbench
writes them, so the docs link to them instead of keeping copies that could go stale."""
from __future__ import annotations

from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ("results/REPORT.md", "results/*/table.md", "results/*/figures/*.png",
           "results/report/*.html", "results/report/figures/**/*.svg")


def on_files(files, config):
    for pattern in RESULTS:
        for path in sorted(ROOT.glob(pattern)):
            files.append(File(path.relative_to(ROOT).as_posix(), src_dir=str(ROOT),
                              dest_dir=config["site_dir"],
                              use_directory_urls=config["use_directory_urls"]))
    return files
