"""Kernels compiled on every core before a run's first trial (pfbench.precompile)."""
import os
import time
from dataclasses import replace

import pytest

import pfbench.runner as runner
from pfbench import _lazy, precompile
from pfbench.config import load
from pfbench.filters import FILTERS

from .conftest import ROOT

CONFIG = ROOT / "configs" / "ifa_pf_ungm.yaml"


def _names(kernels) -> set:
    return {k.__qualname__ for k in kernels}


def test_the_kernels_are_found_without_running_a_trial():
    """The scenario's simulate kernel beside each filter module's, with nothing simulated: the
    trial the runner hands down runs only with its kernels recorded, not run."""
    exp = load(CONFIG, {"trials": 2})
    ran = []

    def trial(e, k):
        ran.append(_lazy._RECORD.calls is not None)
        return runner.trial_result(e, k)
    found = precompile.roots(exp, trial)
    assert _names(found) == {"simulate_scalar", "pf_kernel", "swarm_pf_kernel"}
    assert ran and all(ran)                 # never a trial with its kernels run


def test_a_recorded_kernel_is_not_built_nor_run():
    from pfbench.models.scalar import simulate
    exp = load(CONFIG, {"trials": 2})
    kern = _lazy.variant(FILTERS["pf"].run.__globals__["pf_kernel"], "_test_recorded")
    with _lazy.recording() as calls:
        assert kern(*range(17)) == 0        # its return type's blank, whatever the arguments
        simulate(runner.build_model(exp), None)
    assert calls[0] is kern and calls[1].__qualname__ == "simulate_scalar"
    assert not kern.built
    assert _lazy._RECORD.calls is None


def test_only_the_kernel_a_run_picks_is_compiled():
    """FastSLAM picks its kernel from its keys: a run without AFSA's refinement or directional
    resampling names only the kernel without them."""
    exp = load(ROOT / "configs" / "ifa_fastslam.yaml", {"trials": 1})
    assert _names(precompile.roots(exp, runner.trial_result)) == {
        "simulate_course", "fastslam_kernel_without_afsa2014"}


def test_a_plug_in_filter_run_is_left_to_its_first_trial(monkeypatch):
    exp = load(CONFIG, {"trials": 2})
    pf = FILTERS["pf"]

    def plug_in_run(*a, **k):
        raise AssertionError("a plug-in's run is not called ahead")
    plug_in_run.__module__ = "someone_elses.filters"
    monkeypatch.setitem(FILTERS, "pf", replace(pf, run=plug_in_run))
    found = precompile.roots(exp, runner.trial_result)
    assert "pf_kernel" not in _names(found) and "swarm_pf_kernel" in _names(found)


def test_a_run_that_names_no_kernel_is_read_from_its_code():
    """A filter run whose Python fails before its kernel (here: every trial fails) is read from
    its code: the kernels its run names."""
    exp = load(CONFIG, {"trials": 2})

    def failing(e, k):
        raise RuntimeError("fails before any kernel")
    assert _names(precompile.roots(exp, failing)) == {"pf_kernel", "swarm_pf_kernel"}


def _plan(monkeypatch, exp=None):
    """The jobs of CONFIG as with an empty cache."""
    monkeypatch.setattr(precompile, "_cached", lambda k: False)
    return precompile.uncompiled_kernels(exp or load(CONFIG, {"trials": 2}), runner.trial_result)


def _built_with(kern) -> set:
    """The kernels numba builds when it compiles ``kern``: its callees, and in place of a callee
    whose body it inlines (unless that one is taken by address), that callee's."""
    out = set()
    for c in _lazy.callees(kern):
        if precompile._own(c):
            out |= _built_with(c) if c.inlined and not c.taken_by_address else {id(c)}
    return out


def test_a_kernel_compiles_without_compiling_those_it_inlines():
    """numba copies an inlined kernel's body into its caller: compiling the caller compiles
    nothing of it; a call from Python compiles its signature."""
    from numba import types
    f8 = types.float64(types.float64)

    @_lazy.kernel(f8, inline="always")
    def twice(x):
        return 2.0 * x

    @_lazy.kernel(f8)
    def caller(x):
        return twice(x) + 1.0
    @_lazy.kernel(f8, inline="always", by_address=True)
    def thrice(x):
        return 3.0 * x

    @_lazy.kernel(f8)
    def both(x):
        return twice(x) + thrice(x)
    assert twice.inlined and not caller.inlined and not twice.built_by_callers
    assert caller(3.0) == 7.0
    assert caller.built and not twice.built
    assert twice(3.0) == 6.0 and twice.built and twice.signatures == [(types.float64,)]
    assert thrice.built_by_callers and both(1.0) == 5.0
    assert thrice.built      # taken by address: a value of it is its signatures' dispatcher


def test_every_kernel_below_the_roots_is_a_job_after_its_callees(monkeypatch):
    """Every kernel the roots call, directly or through the bodies they inline, is a job after
    the jobs of what it calls; an inlined kernel is none (its body compiles in its callers),
    unless it is taken by address."""
    jobs = _plan(monkeypatch)
    kernels = [j.kernel for j in jobs]
    assert len({id(k) for k in kernels}) == len(kernels)         # each kernel once
    roots = precompile.roots(load(CONFIG, {"trials": 2}), runner.trial_result)
    below = [c for k in roots for c in precompile._below(k)]
    skipped = {id(c) for c in below if c.inlined and not c.taken_by_address}
    assert len(skipped) >= 10                                   # vecmath's, the ziggurat's, ...
    assert any(c.inlined and c.taken_by_address for c in below)  # rng.uniform, say
    want = {id(k) for k in roots} | {id(c) for c in below} - skipped
    assert {id(k) for k in kernels} == want
    for i, job in enumerate(jobs):
        assert {id(kernels[n]) for n in job.needs} == _built_with(job.kernel)
        assert all(jobs[n].rank > job.rank for n in job.needs)   # a callee before its callers
    by = {j.kernel.__qualname__: j for j in jobs}
    # the swarm filters' chain is the longest: its kernels go first
    assert by["swarm_refine"].rank > by["pf_kernel"].rank > by["simulate_scalar"].rank


def test_a_cached_kernel_is_no_job_nor_are_its_callees(monkeypatch):
    exp = load(CONFIG, {"trials": 2})
    names = {"pf_kernel"}
    below = {k.__qualname__ for r in precompile.roots(exp, runner.trial_result)
             if r.__qualname__ == "pf_kernel" for k in precompile._below(r)}
    monkeypatch.setattr(precompile, "_cached", lambda k: k.__qualname__ in names)
    jobs = _names(j.kernel for j in precompile.uncompiled_kernels(exp, runner.trial_result))
    assert "pf_kernel" not in jobs and "swarm_pf_kernel" in jobs
    assert "mh_move" in below and "mh_move" not in jobs     # the pf kernel's own callee


def _marking(folder, seconds=0.0):
    """A stand-in for _build that notes which process built which job, from when to when."""
    def mark(kernels, i):
        t0 = time.monotonic()
        time.sleep(seconds)
        (folder / f"{i}").write_text(f"{os.getpid()} {t0} {time.monotonic()}")
        return True
    return mark


def _ready(monkeypatch):
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: ["pf", "fa"])
    monkeypatch.setattr(precompile, "_cached", lambda k: False)


def test_each_kernel_compiles_once_after_its_callees_in_a_process_of_its_own(tmp_path,
                                                                                monkeypatch):
    _ready(monkeypatch)
    monkeypatch.setattr(precompile, "_build", _marking(tmp_path, 0.002))
    exp = load(CONFIG, {"trials": 2})
    jobs = precompile.uncompiled_kernels(exp, runner.trial_result)
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) == len(jobs)
    marks = {int(p.name): p.read_text().split() for p in tmp_path.iterdir()}
    assert sorted(marks) == list(range(len(jobs)))              # every job, once
    pids = {m[0] for m in marks.values()}
    assert len(pids) == 2 and str(os.getpid()) not in pids
    for i, job in enumerate(jobs):
        for n in job.needs:         # started after every callee had finished
            assert float(marks[i][1]) >= float(marks[n][2])
    assert precompile.compile_ahead(exp, runner.trial_result, processes=1) == 0  # one core


def test_a_compiling_worker_collects_less_often_and_leaves_ctrl_c_to_the_run(tmp_path,
                                                                              monkeypatch):
    """The processes that compile ahead collect garbage at COMPILER_GC's thresholds (numba's
    compiler allocates much and keeps most of it), not at this process's, and ignore Ctrl-C."""
    import gc
    import signal

    def note(kernels, i):
        handler = signal.getsignal(signal.SIGINT) is signal.SIG_IGN
        (tmp_path / f"{i}").write_text(f"{gc.get_threshold()} {handler}")
        return True
    _ready(monkeypatch)
    monkeypatch.setattr(precompile, "_build", note)
    kept = gc.get_threshold()
    gc.set_threshold(700, 10, 10)           # Python's default, which a fork would inherit
    try:
        exp = load(CONFIG, {"trials": 2})
        assert precompile.compile_ahead(exp, runner.trial_result, processes=2) > 0
    finally:
        gc.set_threshold(*kept)
    said = {p.read_text() for p in tmp_path.iterdir()}
    assert said == {f"{precompile.COMPILER_GC} True"}


def test_nothing_is_compiled_ahead_when_the_cache_holds_it(monkeypatch):
    monkeypatch.setattr(precompile, "uncompiled", lambda exp: [])
    monkeypatch.setattr(precompile, "_build", lambda *a: 1 / 0)
    assert precompile.compile_ahead(load(CONFIG, {"trials": 2}), runner.trial_result) == 0


def test_nothing_is_compiled_ahead_without_a_disk_cache(monkeypatch):
    """Compiled in another process, a kernel with no disk cache would reach the run nowhere."""
    _ready(monkeypatch)
    monkeypatch.setattr(precompile._cache, "ENABLED", False)
    monkeypatch.setattr(precompile, "_build", lambda *a: 1 / 0)
    assert precompile.compile_ahead(load(CONFIG, {"trials": 2}), runner.trial_result,
                                    processes=2) == 0


def test_a_worker_that_dies_ends_the_compiling_not_the_run(monkeypatch):
    _ready(monkeypatch)
    monkeypatch.setattr(precompile, "_build", lambda kernels, i: os._exit(3))
    assert precompile.compile_ahead(load(CONFIG, {"trials": 2}), runner.trial_result,
                                     processes=2) == 0


def test_a_kernel_that_fails_to_compile_is_left_to_the_run():
    """_build says False and raises nothing: the run reports the failure with its trial and
    filter."""
    broken = _lazy.LazyKernel(lambda x: undefined_name(x), "float64(float64)",  # noqa: F821
                              {"cache": False})
    assert precompile._build([broken], 0) is False


def test_no_more_processes_at_once_than_the_memory_holds(tmp_path, monkeypatch):
    import pfbench.resources as resources
    _ready(monkeypatch)
    monkeypatch.setattr(precompile, "_build", _marking(tmp_path))
    exp = load(CONFIG, {"trials": 2})
    one = resources.estimate(exp, 1).bytes
    monkeypatch.setattr(resources, "available_bytes", lambda: int(1.5 * one))
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) == 0  # only one fits
    assert not list(tmp_path.iterdir())
    monkeypatch.setattr(resources, "available_bytes", lambda: 3 * one)
    assert precompile.compile_ahead(exp, runner.trial_result, processes=2) > 0


@pytest.mark.slow
def test_the_run_after_compiling_ahead_compiles_nothing(tmp_path):
    """With an empty cache: every kernel a trial builds was compiled ahead (a fresh process
    that then runs a trial loads them all from the cache)."""
    import subprocess
    import sys
    code = (
        "import sys\n"
        "from numba.core import event\n"
        "from pfbench.config import load\n"
        "from pfbench import precompile, runner\n"
        f"exp = load({str(CONFIG)!r}, {{'trials': 1}})\n"
        "assert precompile.compile_ahead(exp, runner.trial_result, processes=2) > 0\n"
        "names = []\n"
        "class L(event.Listener):\n"
        "    def on_start(self, ev):\n"
        "        d = (ev.data or {}).get('dispatcher')\n"
        "        names.append(getattr(getattr(d, 'py_func', None), '__module__', ''))\n"
        "    def on_end(self, ev): pass\n"
        "event.register('numba:compile', L())\n"
        "runner.trial_result(exp, 0)\n"
        "print([n for n in names if n.startswith('pfbench.')])\n")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(ROOT)}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True,
                         timeout=900)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "[]"
