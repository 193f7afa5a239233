"""The cache of comparisons (pfbench.tablecache): an up-to-date folder's table without computing
it again, and never a stale one."""
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

import pfbench
import pfbench.compare as compare_module
import pfbench.runner
from pfbench import tablecache
from pfbench.config import load

from .conftest import ROOT, tree

CONFIG = ROOT / "configs" / "ifa_pf_ungm.yaml"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    where = tmp_path / "cache"
    monkeypatch.setattr(tablecache, "folder", lambda: where)
    return where


@pytest.fixture
def counted(monkeypatch):
    """compare, counting its calls."""
    calls = []
    real = compare_module.compare

    def compare(*a, **k):
        calls.append(a[0].name)
        return real(*a, **k)
    monkeypatch.setattr(compare_module, "compare", compare)
    return calls


def test_an_up_to_date_folder_takes_its_table_from_the_cache(tmp_path, cache, counted):
    out = tmp_path / "r"
    first = pfbench.run_experiment(CONFIG, trials=3, out=out, figures=False)
    # two entries: the comparison and table.md's ranking of all filters at once
    assert counted == ["ifa_pf_ungm"] and len(list(cache.glob("*.pickle"))) == 2
    files = {k: v for k, v in tree(out).items() if not k.startswith("timings")}
    again = pfbench.run_experiment(CONFIG, trials=3, out=out, figures=False)
    assert again.up_to_date and counted == ["ifa_pf_ungm"]     # not computed again
    pd.testing.assert_frame_equal(again.table, first.table)
    assert again.comparison.exp == again.experiment
    assert {k: v for k, v in tree(out).items() if not k.startswith("timings")} == files


def test_what_the_table_depends_on_is_in_the_key(monkeypatch):
    exp = load(CONFIG, {"trials": 2})
    rows = pfbench.runner.run_trial(exp, 0) + pfbench.runner.run_trial(exp, 1)
    k = tablecache.key(exp, rows, None)
    assert tablecache.key(exp, rows, None) == k
    changed = [dict(r) for r in rows]
    changed[3]["rmse"] = float(changed[3]["rmse"]) + 1e-12      # one trial's metric, one ulp-ish
    assert tablecache.key(exp, changed, None) != k
    timed = [dict(r, wall_s=0.5) for r in rows]                # the run times (speed tables)
    assert tablecache.key(exp, timed, None) != k
    assert tablecache.key(exp, rows, 1000) != k                 # confidence sequences
    other = load(CONFIG, {"trials": 2}, ["filters.pf.label=P F"])
    assert tablecache.key(other, rows, None) != k               # the experiment
    monkeypatch.setattr(tablecache, "_CODE", "another version of pfbench's source")
    assert tablecache.key(exp, rows, None) != k                 # the code


def test_a_damaged_entry_is_computed_again(tmp_path, cache, counted):
    exp = load(CONFIG, {"trials": 2})
    rows = pfbench.runner.run_trial(exp, 0) + pfbench.runner.run_trial(exp, 1)
    want = tablecache.cached_compare(exp, rows)
    (entry,) = cache.glob("*.pickle")
    for junk in (b"", b"not a pickle", entry.read_bytes()[:50]):
        entry.write_bytes(junk)
        got = tablecache.cached_compare(exp, rows)
        pd.testing.assert_frame_equal(got.table, want.table)
    assert len(counted) == 4
    entry.write_bytes(__import__("pickle").dumps({"a": "dict, not a comparison"}))
    tablecache.cached_compare(exp, rows)
    assert len(counted) == 5


def test_a_cache_folder_that_cannot_be_written_is_no_cache(tmp_path, monkeypatch, counted):
    blocker = tmp_path / "file"
    blocker.write_text("in the way")
    monkeypatch.setattr(tablecache, "folder", lambda: blocker / "cache")
    exp = load(CONFIG, {"trials": 2})
    rows = pfbench.runner.run_trial(exp, 0) + pfbench.runner.run_trial(exp, 1)
    a = tablecache.cached_compare(exp, rows)
    b = tablecache.cached_compare(exp, rows)
    pd.testing.assert_frame_equal(a.table, b.table)
    assert len(counted) == 2


def test_the_cache_keeps_its_newest_entries(tmp_path, cache, monkeypatch):
    """Entries accumulate to PRUNE_AT; the store that passes it keeps the newest KEEP."""
    monkeypatch.setattr(tablecache, "KEEP", 3)
    monkeypatch.setattr(tablecache, "PRUNE_AT", 4)
    exp = load(CONFIG, {"trials": 2})
    rows = pfbench.runner.run_trial(exp, 0) + pfbench.runner.run_trial(exp, 1)
    counts = []
    for anytime in (100, 200, 300, 400, 500):
        tablecache.cached_compare(exp, rows, anytime)
        counts.append(len(list(cache.glob("*.pickle"))))
    assert counts == [1, 2, 3, 4, 3]
    kept = {p.name for p in cache.glob("*.pickle")}
    assert kept == {f"{tablecache.key(exp, rows, a)}.pickle" for a in (300, 400, 500)}
    assert not list(cache.glob(".*"))           # no temporary file left


_MODULES = """
import sys
from pfbench.cli import main
sys.argv = ["pfbench"] + sys.argv[1:]
try:
    main()
except SystemExit:
    pass
print(sorted({m for m in sys.modules if m.startswith(("scipy.stats", "matplotlib",
                                                       "statsmodels"))}))
"""


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_a_run_without_figures_imports_only_what_it_uses(tmp_path):
    """A run that draws no figure imports no matplotlib; its verdicts (t intervals, Holm) need
    no scipy.stats or statsmodels: only the tests of table.md's ranking of its filters ("All
    filters at once": Friedman's and Wilcoxon's) import scipy.stats, while the trials run, and
    only on blocks enough for a test to tell two filters apart (two trials of ifa_pf_ungm: 6
    blocks, the average ranks alone). Run again, its folder up to date, it computes nothing."""
    tested = tmp_path / "three.yaml"
    tested.write_text("seed: 1\ntrials: 4\nscenario: {name: ungm, steps: 10}\nfilters:\n"
                      "  pf: {particles: [20, 30]}\n  pf_b: {type: pf, particles: [20, 30]}\n"
                      "  pf_c: {type: pf, particles: [20, 30], resampling: multinomial}\n")
    single = tmp_path / "one.yaml"
    single.write_text("seed: 1\ntrials: 2\nscenario: {name: ungm, steps: 20}\n"
                      "filters:\n  pf: {particles: 50}\n  pf_big: {type: pf, particles: 100}\n")
    for config, ranked, tests in ((CONFIG, True, False), (tested, True, True),
                                  (single, False, False)):
        out = tmp_path / f"r_{config.stem}"
        cmd = [sys.executable, "-c", _MODULES, "run", str(config), "--trials",
               "4" if config == tested else "2", "--out", str(out), "--no-figures"]
        for up_to_date in (False, True):
            res = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=tmp_path)
            seen = eval(res.stdout.strip().splitlines()[-1])
            assert not [m for m in seen if m.startswith(("matplotlib", "statsmodels"))], seen
            assert bool(seen) == (tests and not up_to_date), res.stdout + res.stderr
            assert ("up to date" in res.stderr) == up_to_date
            md = (out / "table.md").read_text()
            assert ("## All filters at once" in md) == ranked
            assert ("Wilcoxon signed-rank tests, Holm" in md) == tests
            assert ("No test: on " in md) == (ranked and not tests)


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_a_run_with_consistency_bounds_imports_no_scipy_stats(tmp_path):
    """The NEES and NIS chi-square bounds of a run with a Kalman filter come from
    scipy.special: its table needs no scipy.stats either."""
    cfg = tmp_path / "kf.yaml"
    cfg.write_text("seed: 1\ntrials: 3\nscenario: {name: linear_gaussian, steps: 5}\n"
                   "filters:\n  kf: {}\n")
    out = tmp_path / "r"
    res = subprocess.run([sys.executable, "-c", _MODULES, "run", str(cfg), "--out", str(out),
                          "--no-figures"], capture_output=True, text=True, check=True,
                         cwd=tmp_path)
    assert res.stdout.strip().splitlines()[-1] == "[]", res.stdout + res.stderr
    table = pd.read_csv(out / "table.csv")
    assert table["nees_check"].notna().all() and table["nis_bound_hi"].gt(1).all()


_AT_FORK = """
import sys
from pfbench import workers
from pfbench.cli import main
seen = []
start = workers.Workers.__init__
def at_fork(self, *args, **kwargs):
    seen.append(sorted(m for m in ("pandas", "scipy.special", "pfbench.compare") if m in sys.modules))
    start(self, *args, **kwargs)
workers.Workers.__init__ = at_fork
sys.argv = ["pfbench"] + sys.argv[1:]
try:
    main()
except SystemExit:
    pass
print(seen)
"""


@pytest.mark.slow     # what a fresh interpreter imports: a speed property, checked in CI
def test_the_workers_start_before_the_tables_modules_import(tmp_path):
    """A run forks its workers before it imports pandas and the comparison (a quarter of a
    second on 2 cores): those import in this process while the workers run the trials."""
    cmd = [sys.executable, "-c", _AT_FORK, "run", str(CONFIG), "--trials", "2", "--out",
           str(tmp_path / "r"), "--no-figures"]
    res = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=tmp_path)
    assert res.stdout.strip().splitlines()[-1] == "[[]]", res.stdout + res.stderr


def test_a_frame_of_rows_is_keyed_on_every_value():
    """The rows as a DataFrame (what a run passes) are keyed on every bit of every number and on
    each other value's type: one ulp, a -0.0, 1 against "1" in a column of objects, a column's
    name or dtype each give another key."""
    exp = load(CONFIG, {"trials": 2})
    rows = pd.DataFrame({"filter": ["pf", "ifa"], "trial": [0, 1], "rmse": [1.5, 2.0],
                         "note": pd.Series([1, None], dtype=object)})
    k = tablecache.key(exp, rows, None)
    assert tablecache.key(exp, rows.copy(), None) == k

    def changed(edit):
        other = rows.copy()
        edit(other)
        return tablecache.key(exp, other, None)

    assert changed(lambda d: d.__setitem__("rmse", [1.5, np.nextafter(2.0, 3.0)])) != k
    assert changed(lambda d: d.__setitem__("rmse", [1.5, 2.0])) == k
    zero = rows.assign(rmse=[0.0, 2.0])
    assert tablecache.key(exp, zero.assign(rmse=[-0.0, 2.0]), None) != tablecache.key(
        exp, zero, None)
    assert changed(lambda d: d.__setitem__("note", pd.Series(["1", None], dtype=object))) != k
    assert changed(lambda d: d.__setitem__("trial", [0.0, 1.0])) != k          # the dtype
    assert tablecache.key(exp, rows.rename(columns={"rmse": "mae"}), None) != k
    assert tablecache.key(exp, rows.iloc[::-1], None) != k                     # the order
