"""mkdocs hooks: the committed results (results/REPORT.md, each experiment's table.md and its
figures, the HTML report) become pages and files of the site, read from results/ where pfbench
writes them, so the docs link to them instead of keeping copies that could go stale.

A page links to them as it would on GitHub, relative to the page's file in the repository
(`../../results/kidnap/table.md` from docs/papers/); in the site they lie under results/ beside
the pages, and on_page_markdown rewrites such links to that place (mkdocs then checks them)."""
from __future__ import annotations

import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ("results/REPORT.md", "results/*/table.md", "results/*/readings.md",
           "results/*/figures/*.png", "results/report/*.html", "results/report/figures/**/*.svg")
_LINK = re.compile(r"(\]\()((?:\.\./)+results/[^)\s]*)")


def on_files(files, config):
    for pattern in RESULTS:
        for path in sorted(ROOT.glob(pattern)):
            files.append(File(path.relative_to(ROOT).as_posix(), src_dir=str(ROOT),
                              dest_dir=config["site_dir"],
                              use_directory_urls=config["use_directory_urls"]))
    return files


def on_page_markdown(markdown, page, config, files):
    if page.file.src_uri.startswith("results/"):
        return markdown                     # a results page links within results/ already
    where = posixpath.dirname(page.file.src_uri)

    def site_link(m):
        in_repo = posixpath.normpath(posixpath.join("docs", where, m.group(2)))
        if not in_repo.startswith("results/"):
            return m.group(0)               # not into results/: mkdocs reports it
        return m.group(1) + posixpath.relpath(in_repo, where or ".")
    return _LINK.sub(site_link, markdown)
