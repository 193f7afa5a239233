"""The HTML report (issue 18, part 1): every table and figure there, verdicts readable without
colour, no script, and in a headless browser (where one is installed) nothing overflows."""
import re
import shutil
import time
from html.parser import HTMLParser
from pathlib import Path

import pytest

from pfbench import report_html
from pfbench.report import collect

from .conftest import ROOT


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.tables, self.imgs, self.scripts, self.links = 0, [], 0, []
        self.verdicts = []
        self._verdict = None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "table":
            self.tables += 1
        elif tag == "img":
            self.imgs.append(a["src"])
        elif tag == "script":
            self.scripts += 1
        elif tag == "a":
            self.links.append(a.get("href", ""))
        elif tag == "td" and "verdict" in (a.get("class") or ""):
            self._verdict = ""

    def handle_data(self, data):
        if self._verdict is not None:
            self._verdict += data

    def handle_endtag(self, tag):
        if tag == "td" and self._verdict is not None:
            self.verdicts.append(self._verdict)
            self._verdict = None


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The committed results' HTML report, written into a copy of the results folder."""
    results = tmp_path_factory.mktemp("r") / "results"
    shutil.copytree(ROOT / "results", results, ignore=shutil.ignore_patterns("report"))
    index, _ = report_html.write(ROOT / "configs", results)
    return index.parent


def _parse(path: Path) -> _Page:
    p = _Page()
    p.feed(path.read_text(encoding="utf-8"))
    return p


@pytest.mark.slow
def test_every_paper_table_and_figure_is_in_the_report(report, monkeypatch):
    monkeypatch.chdir(ROOT)
    entries = collect(ROOT / "configs", ROOT / "results")
    index = _parse(report / "index.html")
    assert index.scripts == 0 and index.tables == 1
    for e in entries:
        assert e.status == "ok", e.name
        # an experiment that names no paper (recorded data) has the page "other"
        key = e.exp.paper or "other"
        page = report / f"{key}.html"
        assert f"{key}.html#{e.name}" in index.links
        parsed = _parse(page)
        assert parsed.scripts == 0
        text = page.read_text(encoding="utf-8")
        assert f'id="{e.name}"' in text
        figures = sorted((ROOT / "results" / e.name / "figures").glob("*.png"))
        for f in figures:      # every committed figure, as SVG
            src = f"figures/{e.name}/{f.stem}.svg"
            assert src in parsed.imgs, (e.name, src)
            assert (report / src).read_bytes().startswith(b"<?xml")
        if e.exp.reported is not None and e.table is not None:
            for q in e.exp.reported.quantities:
                assert f"<h3>{q.title}" in text.replace("&#39;", "'"), (e.name, q.title)
    # a verdict says itself in words and a mark, not only in colour
    verdicts = [v for p in report.glob("*.html") for v in _parse(p).verdicts]
    assert any(v.startswith("[x]differs") for v in verdicts)
    assert any(v.startswith("[=]reproduced") for v in verdicts)
    assert all(re.match(r"^(\[.\])?", v) for v in verdicts)


@pytest.mark.slow     # the whole report written twice: 11 s
def test_the_report_is_the_same_bytes_again_and_check_sees_a_change(tmp_path):
    results = tmp_path / "results"
    shutil.copytree(ROOT / "results", results, ignore=shutil.ignore_patterns("report"))
    report_html.write(ROOT / "configs", results, figures=False)
    report = results / "report"
    (report / "ifa2021.html").write_text("edited")
    (report / "stray.html").write_text("not the report's")
    # a second build gives the same bytes but for the two files touched, which it puts back
    _, differ = report_html.write(ROOT / "configs", results, figures=False)
    assert differ == ["ifa2021.html", "stray.html"]
    assert not (report / "stray.html").exists()
    assert "<!DOCTYPE html>" in (report / "ifa2021.html").read_text()


@pytest.mark.slow
def test_check_holds_figures_to_their_presence_not_their_bytes(report):
    results = report.parent
    svg = next((report / "figures").rglob("*.svg"))
    svg.write_bytes(svg.read_bytes().replace(b"<svg", b"<!-- another matplotlib --><svg", 1))
    assert report_html.write(ROOT / "configs", results, check=True)[1] == []
    svg.unlink()
    assert report_html.write(ROOT / "configs", results, check=True)[1] == \
        [svg.relative_to(report).as_posix()]
    report_html.write(ROOT / "configs", results)


def _browser():
    chrome = shutil.which("chromium") or shutil.which("chromium-browser") or \
        shutil.which("google-chrome")
    driver = shutil.which("chromedriver")
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        pytest.skip("selenium is not installed")
    if not chrome or not driver:
        pytest.skip("no headless Chromium and chromedriver installed")
    opts = webdriver.ChromeOptions()
    opts.binary_location = chrome
    for a in ("--headless=new", "--no-sandbox", "--disable-gpu", "--window-size=1280,900",
              "--disable-dev-shm-usage"):
        opts.add_argument(a)
    return webdriver.Chrome(service=Service(driver), options=opts)


# In the page: each image's source, whether it loaded, whether it fits its column (its parent's
# width) and the window; each table's container within the window (a wide table scrolls inside
# it); and every word of a table cell (a run of Latin letters and digits) that the layout broke
# across two lines ('Reprodu|ced', 'afsa20|14'), with its page-wide text for the message.
LAYOUT = """
    const W = document.documentElement.clientWidth;
    const imgs = [...document.images].map(i => {
        const r = i.getBoundingClientRect(), col = i.closest('figure') || i.parentElement;
        return [i.getAttribute('src'), i.complete && i.naturalWidth > 0,
                r.width <= col.clientWidth + 1 && r.right <= W + 1];
    });
    const boxes = [...document.querySelectorAll('table')].map(t =>
        t.parentElement.getBoundingClientRect().right <= W + 1);
    const broken = [];
    for (const cell of document.querySelectorAll('td, th')) {
        const walk = document.createTreeWalker(cell, NodeFilter.SHOW_TEXT);
        for (let n = walk.nextNode(); n; n = walk.nextNode()) {
            for (const m of n.data.matchAll(/[A-Za-z0-9]{2,}/g)) {
                const range = document.createRange();
                range.setStart(n, m.index);
                range.setEnd(n, m.index + m[0].length);
                const tops = new Set([...range.getClientRects()].filter(r => r.width > 0)
                                     .map(r => Math.round(r.top)));
                if (tops.size > 1) broken.push(m[0] + ' in: ' + cell.textContent.slice(0, 60));
            }
        }
    }
    return {page: document.documentElement.scrollWidth <= W + 1, imgs, boxes, broken};
"""


@pytest.mark.slow
@pytest.mark.parametrize("width", [1400, 800])
def test_in_a_browser_no_word_breaks_in_a_cell_and_every_figure_fits(report, width):
    """At 1400 and 800 px: every figure loads and is no wider than its column, no table cell
    breaks a word across lines (a wide table scrolls inside its container instead), and the
    page itself is no wider than the window."""
    browser = _browser()
    try:
        browser.set_window_size(width, 900)
        for page in sorted(report.glob("*.html")):
            browser.get(page.resolve().as_uri())
            for _ in range(100):        # images decode after the load event on a busy machine
                if browser.execute_script("return [...document.images].every(i => i.complete)"):
                    break
                time.sleep(0.2)
            got = browser.execute_script(LAYOUT)
            assert got["page"], f"{page.name} at {width} px: the page is wider than the window"
            assert all(ok for _, ok, _ in got["imgs"]), (page.name, got["imgs"])
            assert all(fits for _, _, fits in got["imgs"]), (page.name, width, [
                src for src, _, fits in got["imgs"] if not fits])
            assert got["boxes"] and all(got["boxes"]), (page.name, width, got["boxes"])
            assert not got["broken"], (page.name, width, got["broken"][:10])
    finally:
        browser.quit()


@pytest.mark.slow
def test_the_layout_check_sees_a_broken_word_and_a_wide_image(tmp_path):
    """The browser check can fail: a narrow cell that breaks inside words, and an image wider
    than its column, are both found."""
    page = tmp_path / "bad.html"
    page.write_text('<!DOCTYPE html><html><body><main>'
                    '<table><tr><td style="width:3em;max-width:3em;overflow-wrap:anywhere">'
                    'Reproduced afsa2014</td></tr></table>'
                    '<figure style="width:100px"><img style="width:300px" src="data:image/'
                    'svg+xml,%3Csvg xmlns=%22http://www.w3.org/2000/svg%22 width=%2210%22 '
                    'height=%2210%22/%3E"></figure></main></body></html>')
    browser = _browser()
    try:
        browser.set_window_size(800, 900)
        browser.get(page.resolve().as_uri())
        got = browser.execute_script(LAYOUT)
    finally:
        browser.quit()
    assert any(b.startswith(("Reproduced", "afsa2014")) for b in got["broken"]), got["broken"]
    assert not got["imgs"][0][2]


def test_an_experiment_without_a_paper_has_a_page_too(tmp_path, write_config, monkeypatch):
    from pfbench.config import load
    from pfbench.runner import run_experiment
    from .conftest import TINY
    configs, results = tmp_path / "configs", tmp_path / "results"
    configs.mkdir()
    cfg = configs / "plain.yaml"
    cfg.write_text(TINY)
    monkeypatch.chdir(tmp_path)
    exp = load(cfg)
    run_experiment(exp, results / exp.name, traces=False)
    index, _ = report_html.write(configs, results, figures=False)
    page = index.parent / "other.html"
    assert page.exists() and f'id="{exp.name}"' in page.read_text()
    assert f"other.html#{exp.name}" in _parse(index).links
