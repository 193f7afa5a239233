"""Part ``ungm``: the bootstrap PF on UNGM (the workload of .common), pfbench's kernel one trial
at a time at N = 100 .. 1e6 on one thread and a batch of trials over every thread, beside the
same filter written in vectorised numpy and, with ``--c-ref``, the C reference program
(bench/ungm_ref.c) timed in the same run on the same data."""
from __future__ import annotations

import math
import os

import numba
import numpy as np
from numba import prange, types

from .._lazy import kernel
from ..filters.pf import pf_kernel
from ..models.scalar import LikFn, ModelFn
from ..rng import state_from_seed
from .c_reference import c_rows
from .common import (BATCH_N, P0, Q, R, SCHEME_SYSTEMATIC, SIZES, T, bench_data, bench_model,
                     best_time, pfbench_single, ungm_record)

_F = types.float64[::1]
_F2 = types.float64[:, ::1]


@kernel(types.void(ModelFn, ModelFn, LikFn, _F, _F, _F2, types.float64, types.float64, types.int64,
                   types.uint64[:, ::1], _F2), cache=True, parallel=True, error_model="python")
def pf_batch(f, h, lik, theta, noise, Y, prior_mean, prior_var, N, S, XH):
    """Run pf_kernel on every row of Y (trials x (T+1)) in parallel; estimates into XH."""
    K, T1 = Y.shape
    for k in prange(K):
        ess = np.empty(T1)
        res = np.empty(T1, dtype=np.int64)
        d1 = np.empty(T1)
        d2 = np.empty(T1)
        d3 = np.empty(T1)
        pf_kernel(f, h, lik, 0, theta, noise, Y[k], prior_mean, prior_var, N, SCHEME_SYSTEMATIC,
                  np.inf, 0, 0, -np.inf, 0, S[k], XH[k], ess, res, d1, d2, d3)


def numpy_pf(y: np.ndarray, N: int, rng, resample=None) -> np.ndarray:
    """The same filter written as plain vectorised numpy (the usual way without a compiler).
    rng: a numpy Generator (or the numpy.random module); resample: a function from normalised
    weights to ancestor indices (filterpy's), else systematic resampling by searchsorted."""
    sq = math.sqrt(Q)
    x = rng.normal(0.0, math.sqrt(P0), N)
    xhat = np.zeros(y.size)
    steps = np.arange(N)
    for t in range(1, y.size):
        xn = (0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * math.cos(1.2 * t)
              + sq * rng.standard_normal(N))
        lw = -0.5 * (y[t] - xn * xn / 20.0) ** 2 / R
        w = np.exp(lw - lw.max())
        if resample is not None:            # it sums the weights its own way
            S = w.sum()
            xhat[t] = w @ xn / S
            x = xn[resample(w / S)]
            continue
        c = np.cumsum(w)
        S = c[-1]
        xhat[t] = w @ xn / S
        pos = (rng.random() + steps) * (S / N)
        idx = np.minimum(np.searchsorted(c, pos, side="right"), N - 1)
        x = xn[idx]
    return xhat


def ungm_bench(quick, c_ref, K, min_time, reps, threads, say, console) -> list[dict]:
    """The bootstrap PF on UNGM, one trial at N = 100 .. 1e6 on one thread and a batch of K
    trials on every thread, beside numpy (and the C reference)."""
    from rich.table import Table
    sizes = (100, 10_000) if quick else SIZES
    X, Y = bench_data(K)
    model = bench_model()
    records = []
    say(f"UNGM bootstrap PF, T = {T}, systematic resampling every step; {os.cpu_count()} cores; "
        f"numba {numba.__version__}, numpy {np.__version__}")
    state = state_from_seed(np.random.SeedSequence(7))
    rng = np.random.default_rng(7)
    for N in sizes:
        sec, _ = best_time(lambda: pfbench_single(model, Y[0], N, state), min_time, reps)
        records.append(ungm_record("pfbench", "single", N, 1, sec, 1))
        sec, _ = best_time(lambda: numpy_pf(Y[0], N, rng), min_time, 1 if N >= 100_000 else reps)
        records.append(ungm_record("numpy", "single", N, 1, sec, 1))
    S = np.stack([state_from_seed(ss) for ss in np.random.SeedSequence(8).spawn(K)])
    XH = np.empty_like(Y)
    run_batch = lambda: pf_batch(model.transition, model.observe, model.likelihood()[0],
                                 model.theta, model.noise, Y,
                                 model.prior_mean, model.prior_var, BATCH_N, S, XH)
    run_batch()
    sec, _ = best_time(run_batch, min_time, reps)
    rmse_pf = np.sqrt(np.mean((XH[:, 1:] - X[:, 1:]) ** 2, axis=1))
    rm_pf = float(rmse_pf.mean())
    records.append(ungm_record("pfbench", "batch", BATCH_N, K, sec, numba.get_num_threads(),
                               mean_rmse=rm_pf))
    XN = np.empty_like(Y)

    def numpy_batch():
        for k in range(K):
            XN[k] = numpy_pf(Y[k], BATCH_N, rng)

    sec, _ = best_time(numpy_batch, min_time, 1)  # one rep: it takes seconds
    rmse_np = np.sqrt(np.mean((XN[:, 1:] - X[:, 1:]) ** 2, axis=1))
    rm_np = float(rmse_np.mean())
    diff = rmse_pf - rmse_np
    diff_se = float(diff.std(ddof=1) / math.sqrt(K))
    records.append(ungm_record("numpy", "batch", BATCH_N, K, sec, 1, mean_rmse=rm_np))
    if c_ref is not None:
        records += c_rows(c_ref, X, Y, sizes, K, min_time, reps, threads)
    by = {(r["impl"], r["mode"], r["particles"]): r["particle_steps_per_s"] for r in records}
    tab = Table(title="particle-steps per second (higher is better)")
    for h in ("workload", "N", "trials", "pfbench", "numpy", "C", "pfbench/numpy", "pfbench/C"):
        tab.add_column(h, justify="right")
    for mode, N, trials in [("single", n, 1) for n in sizes] + [("batch", BATCH_N, K)]:
        p, n, c = (by.get((i, mode, N)) for i in ("pfbench", "numpy", "c"))
        tab.add_row(f"{mode}", f"{N:,}", f"{trials:,}", f"{p / 1e6:.1f} M", f"{n / 1e6:.1f} M",
                    f"{c / 1e6:.1f} M" if c else "-", f"{p / n:.1f}x",
                    f"{p / c:.2f}x" if c else "-")
    if console:
        console.print(tab)
    say(f"check, the same filter: batch mean RMSE on the same data: pfbench {rm_pf:.3f}, numpy "
        f"{rm_np:.3f}; paired difference {rm_pf - rm_np:+.3f} (standard error {diff_se:.3f})")
    say(f"batch: pfbench on {numba.get_num_threads()} threads; numpy and the single-trial rows on "
        "one core")
    return records
