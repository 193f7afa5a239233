"""Parts ``run``, ``run-ungm``, ``run-mcl``, ``run-fastslam``: what ``pfbench run`` runs, beside
the bare kernel.

A filter through ``runner.trial_result`` (the path of ``pfbench run``: the trial's simulation,
each run's fresh copies of its inputs, its kernel with the diagnostics its config computes, the
output checks, the metrics, the trace its kind keeps for the figures) beside the same filter's
bare kernel (diagnostics off) on the same trials, in the same run, and their ratio held against
a target.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..rng import state_from_seed
from .common import best_time

# The families: (family, config, the one filter run kept (None: all of the config's), its
# particle count, the scenario steps (None: the config's; quick, full), the target: run / kernel
# at most this)
RUN_PATH = (
    ("ungm", "configs/ifa_pf_ungm.yaml", "pf", 10_000, None, 1.3),
    ("mcl", "configs/sspf_global.yaml", "mcl", 10_000, None, 1.3),
    ("fastslam", "configs/afsa_fastslam.yaml", None, None, (100, 500), 1.5),
)
RUN_FAMILIES = tuple(f"run-{f[0]}" for f in RUN_PATH)


def run_path_experiment(config: Path, keep: str | None, particles: int | None,
                        steps: int | None):
    """The experiment of ``config`` as the bench times it through the runner: only filter
    ``keep`` (None: all), at ``particles`` (None: the config's), ``steps`` scenario steps (None:
    the config's); its paper, table and diagnostics as the config has them."""
    from ..config import read_yaml, validate
    raw, _ = read_yaml(config)
    if keep is not None:
        spec = dict(raw["filters"][keep] or {})
        if particles is not None:
            spec["particles"] = particles
        raw["filters"] = {keep: spec}
        raw.pop("compare", None)        # its baseline or floor may be a run left out
    if steps is not None:
        raw["scenario"]["steps"] = steps
    return validate(raw, str(config))


def families_of(parts) -> set[str]:
    """The run-path families the bench parts ``parts`` name ('run': every one)."""
    return ({f[0] for f in RUN_PATH} if "run" in parts
            else {f[0] for f in RUN_PATH if f"run-{f[0]}" in parts})


def _run_path_steps(data) -> int:
    """Steps of a trial's data: the controls of a robot, the measurements of a scalar model."""
    ctrl = getattr(data, "ctrl", None)
    return int(ctrl.shape[0]) if ctrl is not None else int(np.asarray(data).size - 1)


def run_path_bench(quick: bool, min_time: float, reps: int, say, console=None,
                   families=None) -> list[dict]:
    """For each RUN_PATH family (``families``: their names, None: all): nanoseconds per
    particle-step of the same trials through ``runner.trial_result`` (traces as ``pfbench run``
    keeps them) and through the bare kernels (``FilterType.run`` with the diagnostics off), timed
    alternately, best of ``reps``; their ratio against the family's target."""
    from ..filters import FILTERS
    from ..runner import trial_data, trial_result
    recs = []
    n_trials = 2 if quick else 4
    for family, cfg, keep, N, steps, target in RUN_PATH:
        if families is not None and family not in families:
            continue
        cfg = Path(cfg)
        if not cfg.exists():
            say(f"run path, {family}: skipped ({cfg} not found; run from the repository root)")
            continue
        exp = run_path_experiment(cfg, keep, N, None if steps is None else steps[not quick])
        trials = [trial_data(exp, k) for k in range(n_trials)]
        state = state_from_seed(np.random.SeedSequence(27))
        T = _run_path_steps(trials[0][2])
        psteps = n_trials * T * sum(r.particles or 0 for r in exp.filters)

        def kernel(trials=trials, exp=exp, state=state):
            for model, _, data in trials:
                for r in exp.filters:
                    FILTERS[r.type].run(model, data, r.params, r.particles, state, False)

        def run(exp=exp):
            for k in range(n_trials):
                trial_result(exp, k, traces=True)

        kernel()
        run()               # both built and warm before either is timed
        best = {"kernel": math.inf, "run": math.inf}
        for _ in range(max(reps, 2)):       # alternately: a busy moment hits both
            for impl, fn in (("kernel", kernel), ("run", run)):
                best[impl] = min(best[impl], best_time(fn, min_time, 1)[0])
        labels = sorted({r.label for r in exp.filters})
        what = ", ".join(labels) if len(labels) <= 2 else f"{len(exp.filters)} filters"
        Ns = sorted({r.particles for r in exp.filters})
        for impl, sec in best.items():
            rec = {"workload": "run-path", "impl": impl, "filter": family, "particles": Ns[-1],
                   "trials": n_trials, "steps": T, "seconds": sec,
                   "particle_steps_per_s": psteps / sec,
                   "ns_per_particle_step": 1e9 * sec / psteps, "config": str(cfg),
                   "runs": what, "diagnostics": _diag_names(exp)}
            recs.append(rec)
        ratio = best["run"] / best["kernel"]
        recs[-1].update(run_over_kernel=ratio, target=target, meets_target=bool(ratio <= target))
    if recs:
        _print_run_path(recs, n_trials, max(reps, 2), say, console)
    return recs


def _print_run_path(recs: list[dict], n_trials: int, reps: int, say, console) -> None:
    """The run-path records (a kernel row, then its run row, per family) as a table on
    ``console``, else as lines through ``say``."""
    from rich.table import Table
    tab = Table(title="what `pfbench run` runs, beside the bare kernel: ns per particle-step on "
                      "the same trials (one thread)", title_justify="left")
    for h in ("workload", "N", "diagnostics", "kernel", "run", "run / kernel", "target"):
        tab.add_column(h, justify="left" if h in ("workload", "diagnostics") else "right")
    for k, r in zip(recs[0::2], recs[1::2]):
        tab.add_row(f"{r['filter']}: {Path(r['config']).stem}, {r['runs']}", f"{r['particles']:,}",
                    ", ".join(r["diagnostics"]) or "none",
                    f"{k['ns_per_particle_step']:.1f}", f"{r['ns_per_particle_step']:.1f}",
                    f"{r['run_over_kernel']:.2f}x",
                    f"{r['target']:.1f}x " + ("met" if r["meets_target"] else "MISSED"))
    if console:
        console.print(tab)
        say("kernel: each filter's run with the diagnostics off; run: runner.trial_result, the "
            "path of 'pfbench run' (the trial's simulation, each run's fresh inputs, the "
            "diagnostics its config computes, the output checks, the metrics, the traces kept "
            f"for the figures); the same {n_trials} trials, timed alternately, best of "
            f"{reps}", markup=False)
    else:
        for k, r in zip(recs[0::2], recs[1::2]):
            say(f"run path, {r['filter']}: kernel {k['ns_per_particle_step']:.1f} ns, run "
                f"{r['ns_per_particle_step']:.1f} ns a particle-step: "
                f"{r['run_over_kernel']:.2f}x (target {r['target']:.1f}x)")


def _diag_names(exp) -> list[str]:
    """The per-step diagnostics ``exp`` computes (pfbench.diagnostics.plan)."""
    from ..diagnostics import plan
    return list(plan(exp).names)
