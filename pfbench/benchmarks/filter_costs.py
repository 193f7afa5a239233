"""Part ``costs``: the cost per step of every scalar filter at N = BATCH_N on the bench's UNGM
data, through the entry point the runner calls (each call's fixed cost included)."""
from __future__ import annotations

import numpy as np

from ..rng import state_from_seed
from .common import BATCH_N, T, bench_model, best_time

def filter_costs(Y, min_time: float, reps: int, N: int = BATCH_N) -> list[dict]:
    """Seconds per step of every filter type at N particles on the benchmark's UNGM data, through
    the same entry point the runner uses (so each call's fixed cost is included), each filter
    with its default settings."""
    from ..config import Params
    from ..filters import FILTERS
    model = bench_model()
    out = []
    for name, ftype in FILTERS.items():
        if ftype.scenarios is not None or ftype.kind != "scalar":   # kf: linear only; SLAM: poses
            continue
        params = Params({k: key.default for k, key in ftype.schema.items()})
        n = N if ftype.particles else None
        state = state_from_seed(np.random.SeedSequence(9))
        k = [0]

        def once():
            ftype.run(model, Y[k[0] % len(Y)], params, n, state, False)
            k[0] += 1

        once()
        sec, _ = best_time(once, min_time, reps)
        out.append({"workload": "ungm-filters", "impl": "pfbench", "filter": name,
                    "particles": n or 0, "trials": 1, "steps": T, "seconds": sec,
                    "grows_as": ftype.cost,
                    "seconds_per_step": sec / T,
                    "particle_steps_per_s": (n or 1) * T / sec})
    return out


def costs_bench(Y, min_time, reps, say, console) -> list[dict]:
    """Every scalar filter's cost per step at N = BATCH_N, as a table."""
    from rich.table import Table
    costs = filter_costs(Y, min_time, reps)
    base = next(c["seconds_per_step"] for c in costs if c["filter"] == "pf")
    tab = Table(title=f"cost per step of each filter at N = {BATCH_N} (one thread, default "
                      "settings)")
    for h in ("filter", "N", "cost grows as", "us / step", "x bootstrap PF"):
        tab.add_column(h, justify="right")
    for c in costs:
        tab.add_row(c["filter"], str(c["particles"] or "-"), c["grows_as"],
                    f"{1e6 * c['seconds_per_step']:.2f}", f"{c['seconds_per_step'] / base:.2f}x")
    if console:
        console.print(tab)
    say("per-step costs include each run's fixed cost (about 9 us a call: the arguments and the "
        "kernel's set-up), which weighs most on the filters without particles")
    return costs
