"""Kernels compiled on every core before a run's first trial (pfbench.precompile)."""
import os

import pfbench.runner as runner
from pfbench import precompile
from pfbench.config import load

from .conftest import ROOT

CONFIG = ROOT / "configs" / "ifa_pf_ungm.yaml"


def test_runs_are_grouped_by_the_module_whose_kernels_they_compile():
    exp = load(CONFIG, {"trials": 2})
    got = precompile.groups(exp)
    assert sorted(k for g in got for k in g) == sorted(f.key for f in exp.filters)
    by_type = [{exp.filter(k).type for k in g} for g in got]
    assert by_type == [{"pf"}, {"ba", "fa", "ifa", "pso", "afsa"}]     # pf.py, swarm_pf.py


def test_nothing_is_compiled_ahead_when_the_cache_holds_it(monkeypatch):
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: [])
    monkeypatch.setattr(precompile, "_compile", lambda *a: 1 / 0)
    assert precompile.compile_ahead(load(CONFIG, {"trials": 2}), runner.trial_result) == 0


def _marking(folder):
    def mark(exp, keys, trial):
        (folder / f"{os.getpid()}-{keys[0]}").write_text(",".join(keys))
    return mark


def test_each_group_compiles_once_in_a_process_of_its_own(tmp_path, monkeypatch):
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: ["pf", "fa"])
    monkeypatch.setattr(precompile, "_compile", _marking(tmp_path))
    exp = load(CONFIG, {"trials": 2})
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) == 2
    marks = sorted(tmp_path.iterdir())
    assert sorted(m.read_text() for m in marks) == sorted(",".join(g) for g in
                                                          precompile.groups(exp))
    assert all(int(m.name.split("-")[0]) != os.getpid() for m in marks)
    assert precompile.compile_ahead(exp, runner.trial_result, processes=1) == 0  # one core: no split


def test_a_worker_that_dies_ends_the_compiling_not_the_run(monkeypatch):
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: ["pf", "fa"])
    monkeypatch.setattr(precompile, "_compile", lambda exp, keys, trial: os._exit(3))
    assert precompile.compile_ahead(load(CONFIG, {"trials": 2}), runner.trial_result,
                                     processes=2) == 0


def test_a_failing_group_is_left_to_the_run(monkeypatch):
    """_compile swallows a filter's error: the run reports it with its trial and filter."""
    exp = load(CONFIG, {"trials": 2})

    def boom(*a, **k):
        raise RuntimeError("a filter that fails")
    precompile._compile(exp, ("pf@50",), boom)       # no error out of it


def test_no_more_groups_at_once_than_the_memory_holds(tmp_path, monkeypatch):
    """Each group runs a part of a trial: never more at once than whole trials fit the memory."""
    import pfbench.resources as resources
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: ["pf", "fa"])
    monkeypatch.setattr(precompile, "_compile", _marking(tmp_path))
    exp = load(CONFIG, {"trials": 2})
    one = resources.estimate(exp, 1).bytes
    monkeypatch.setattr(resources, "available_bytes", lambda: int(1.5 * one))
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) == 0  # only one fits
    assert not list(tmp_path.iterdir())
    monkeypatch.setattr(resources, "available_bytes", lambda: 3 * one)
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) == 2
