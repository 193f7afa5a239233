"""Part ``afsa``: every filter of configs/afsa_fastslam.yaml (FastSLAM, PSO- and AFSA-FastSLAM)
at 10 and 100 particles on one trial of its landmark world: control steps per second and
likelihood evaluations per step, relative to plain FastSLAM."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..rng import state_from_seed
from .common import best_time

def afsa_bench(quick: bool, min_time: float, reps: int, say, console=None) -> list[dict]:
    """Control steps per second and likelihood evaluations per step of every filter of
    configs/afsa_fastslam.yaml (FastSLAM, PSO- and AFSA-FastSLAM, either resampling) at 10 and 100
    particles on one trial of its landmark world, one thread, relative to plain FastSLAM."""
    from rich.table import Table

    from ..config import load
    from ..filters import FILTERS
    from ..runner import trial_data
    cfg = Path("configs/afsa_fastslam.yaml")
    if not cfg.exists():
        say("AFSA-FastSLAM: skipped (configs/afsa_fastslam.yaml not found; run from the "
            "repository root)")
        return []
    steps = 100 if quick else 500
    exp = load(cfg, sets=[f"scenario.steps={steps}"])
    model, truth, data = trial_data(exp, 0)
    state = state_from_seed(np.random.SeedSequence(24))
    recs = []
    for N in (10, 100):
        for run in exp.filters:
            ft = FILTERS[run.type]
            last = {}           # the timed calls' output, for the evaluation count

            def one(ft=ft, run=run, N=N, last=last):
                last["out"] = ft.run(model, data, run.params, N, state, False)

            sec, _ = best_time(one, min_time, reps)
            out = last["out"]
            recs.append({"workload": "afsa-world", "impl": "pfbench", "filter": run.label,
                         "particles": N, "trials": 1, "steps": steps, "seconds": sec,
                         "steps_per_s": steps / sec, "particle_steps_per_s": N * steps / sec,
                         "evals_per_step": out["lik_evals_per_step"]})
    tab = Table(title=f"FastSLAM variants of configs/afsa_fastslam.yaml, one trial of {steps} "
                      "steps (an observation each), one thread")
    for h in ("filter", "N", "steps/s", "x FastSLAM", "evals/step"):
        tab.add_column(h, justify="right")
    for r in recs:
        base = next(b for b in recs if b["particles"] == r["particles"]
                    and b["filter"] == exp.filters[0].label)
        r["relative_to_fastslam"] = r["steps_per_s"] / base["steps_per_s"]
        tab.add_row(r["filter"], str(r["particles"]), f"{r['steps_per_s']:,.0f}",
                    f"{r['relative_to_fastslam']:.2f}x", f"{r['evals_per_step']:.0f}")
    if console:
        console.print(tab)
    else:
        for r in recs:
            say(f"{r['filter']} N={r['particles']}: {r['steps_per_s']:,.0f} steps/s "
                f"({r['relative_to_fastslam']:.2f}x FastSLAM), "
                f"{r['evals_per_step']:.0f} evals/step")
    return recs
