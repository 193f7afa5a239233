"""``pfbench bench --peers``: the bench's UNGM filter written with N. Chopin's ``particles`` and
with filterpy's resampling (the 'peers' extra), timed beside pfbench's kernel one trial at a time
on one thread, with the check that the three compute the same filter."""
from __future__ import annotations

import math

import numpy as np

from ..errors import UserError
from ..rng import state_from_seed
from .common import (BATCH_N, P0, Q, R, T, bench_data, bench_model, best_time, pfbench_single,
                     ungm_record)
from .ungm_pf import numpy_pf

def peer_modules():
    """The peers' modules (the 'peers' extra); a UserError saying how to install them."""
    try:
        import particles
        from particles import distributions, state_space_models
        from particles.collectors import Moments
        from filterpy.monte_carlo import systematic_resample
    except ImportError as exc:
        raise UserError(f"--peers needs the peers extra ({exc.name} is not installed): "
                        "pip install '.[peers]'") from None
    return particles, distributions, state_space_models, Moments, systematic_resample


def particles_pf(mods):
    """The bench's filter written with ``particles`` (N. Chopin's SMC library): a
    ``state_space_models.StateSpaceModel`` of UNGM, its ``Bootstrap`` Feynman-Kac model and
    ``SMC`` with systematic resampling at every step (ESSrmin = 1), the weighted mean collected by
    ``Moments``. Returns run(y, N) -> the estimates at t = 1..T (its random numbers: numpy's
    global generator)."""
    particles, dists, ssm, Moments, _ = mods
    sq, sr = math.sqrt(Q), math.sqrt(R)
    f = lambda x, t: 0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * math.cos(1.2 * t)

    class FirstState(dists.ProbDist):
        """x_1 = f(x_0, 1) + w with x_0 from the prior: particles' first state is the one the
        first measurement sees (our y_0 is unused)."""
        dim = 1

        def rvs(self, size=None):
            x0 = np.random.normal(0.0, math.sqrt(P0), size)
            return f(x0, 1.0) + sq * np.random.standard_normal(size)

    class UNGM(ssm.StateSpaceModel):
        def PX0(self):
            return FirstState()

        def PX(self, t, xp):            # particles' t is our t - 1
            return dists.Normal(loc=f(xp, t + 1.0), scale=sq)

        def PY(self, t, xp, x):
            return dists.Normal(loc=x * x / 20.0, scale=sr)

    def run(y, N):
        fk = ssm.Bootstrap(ssm=UNGM(), data=list(y[1:]))
        alg = particles.SMC(fk=fk, N=N, resampling="systematic", ESSrmin=1.0,
                            collect=[Moments()])
        alg.run()
        return np.array([m["mean"] for m in alg.summaries.moments])

    return run


def filterpy_pf(mods):
    """numpy_pf with its resampling by filterpy's ``monte_carlo.systematic_resample`` (the usual
    filterpy particle filter: numpy for the rest; its random numbers from numpy's global
    generator, which filterpy draws from). Returns run(y, N) -> estimates at t = 1..T."""
    return lambda y, N: numpy_pf(y, N, np.random, resample=mods[4])[1:]


def peers_bench(quick: bool, min_time: float, reps: int, say, console=None) -> list[dict]:
    """The UNGM filter of pfbench, of ``particles`` and of filterpy's resampling helpers, one
    trial at a time on one thread at the same sizes in the same run, and the check that they
    compute the same filter: mean RMSE over the same trials at N = 100, with the paired
    differences to pfbench and their standard errors."""
    from rich.table import Table
    mods = peer_modules()
    peers = {"particles": particles_pf(mods), "filterpy": filterpy_pf(mods)}
    sizes = (100, 10_000) if quick else (100, 1_000, 10_000, 100_000)
    K = 20 if quick else 200
    X, Y = bench_data(K)
    model = bench_model()
    state = state_from_seed(np.random.SeedSequence(41))
    np.random.seed(41)          # the peers draw from numpy's global generator
    records = []
    for N in sizes:
        sec, _ = best_time(lambda: pfbench_single(model, Y[0], N, state), min_time, reps)
        records.append(ungm_record("pfbench", "single", N, 1, sec, 1, workload="ungm-peers"))
        for name, run in peers.items():
            run(Y[0], N)            # particles compiles its numba functions on first use
            sec, _ = best_time(lambda: run(Y[0], N), min_time, 1 if N >= 100_000 else reps)
            records.append(ungm_record(name, "single", N, 1, sec, 1, workload="ungm-peers"))
    err = {"pfbench": np.array([np.sqrt(np.mean((pfbench_single(model, Y[k], BATCH_N, state)[1:]
                                                 - X[k, 1:]) ** 2)) for k in range(K)])}
    for name, run in peers.items():
        err[name] = np.array([np.sqrt(np.mean((run(Y[k], BATCH_N) - X[k, 1:]) ** 2))
                              for k in range(K)])
    for name, e in err.items():
        d = e - err["pfbench"]
        records.append({"workload": "ungm-peers-check", "impl": name, "particles": BATCH_N,
                        "trials": K, "steps": T, "mean_rmse": float(e.mean()),
                        "rmse_se": float(e.std(ddof=1) / math.sqrt(K)),
                        "paired_diff": float(d.mean()),
                        "paired_diff_se": float(d.std(ddof=1) / math.sqrt(K))})
    by = {(r["impl"], r["particles"]): r["particle_steps_per_s"] for r in records
          if r["workload"] == "ungm-peers"}
    tab = Table(title="UNGM bootstrap PF, one trial, one thread: particle-steps per second "
                      "beside the peers", title_justify="left")
    for h in ("N", "pfbench", "particles", "filterpy", "pfbench/particles", "pfbench/filterpy"):
        tab.add_column(h, justify="right")
    for N in sizes:
        p, a, b = by[("pfbench", N)], by[("particles", N)], by[("filterpy", N)]
        tab.add_row(f"{N:,}", f"{p / 1e6:.1f} M", f"{a / 1e6:.2f} M", f"{b / 1e6:.2f} M",
                    f"{p / a:.0f}x", f"{p / b:.1f}x")
    if console:
        console.print(tab)
    chk = {r["impl"]: r for r in records if r["workload"] == "ungm-peers-check"}
    say(f"check, the same filter: mean RMSE over the same {K} trials at N = {BATCH_N}: "
        + ", ".join(f"{n} {r['mean_rmse']:.3f}" for n, r in chk.items())
        + "; paired differences to pfbench: "
        + ", ".join(f"{n} {r['paired_diff']:+.3f} (standard error {r['paired_diff_se']:.3f})"
                    for n, r in chk.items() if n != "pfbench"))
    return records
