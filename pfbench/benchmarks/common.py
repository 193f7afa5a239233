"""What the parts of ``pfbench bench`` share: the UNGM workload (that of the C reference program
bench/ungm_ref.c: Q = 10, R = 1, T = 100, truth from x_0 = 0.1, particle prior N(0, 2)), its data,
its kernel run once, and the timer."""
from __future__ import annotations

import math
import time

import numpy as np

from ..filters.pf import pf_kernel
from ..models.scalar import simulate
from ..resampling import SCHEME_CODES
from ..rng import state_from_seed
from ..scenarios import ungm

T = 100
Q, R, P0, X0 = 10.0, 1.0, 2.0, 0.1
SIZES = (100, 1_000, 10_000, 100_000, 1_000_000)
BATCH_TRIALS, BATCH_N = 1000, 100
SCHEME_SYSTEMATIC = SCHEME_CODES["systematic"]


def bench_model():
    """The UNGM model of the workload (pfbench.scenarios.ungm at T, Q, R, X0, P0)."""
    params = {k: key.default for k, key in ungm.SCHEMA.items()}
    params.update(steps=T, process_noise_var=Q, measurement_noise_var=R, x0=X0, prior_mean=0.0,
                  prior_var=P0)
    return ungm.build(params)


def bench_data(K: int, seed: int = 12345):
    """Truths X and measurements Y, each (K, T+1), of the benchmark model."""
    model = bench_model()
    X = np.empty((K, T + 1))
    Y = np.empty((K, T + 1))
    for k, ss in enumerate(np.random.SeedSequence(seed).spawn(K)):
        X[k], Y[k] = simulate(model, state_from_seed(ss))
    return X, Y


def pfbench_single(model, y, N, state):
    """pfbench's bootstrap PF kernel (the one ``pfbench run`` uses, diagnostics off) on the
    measurements y at N particles with systematic resampling every step; the estimates."""
    T1 = y.size
    xhat, ess, d1, d2, d3 = (np.empty(T1) for _ in range(5))
    res = np.empty(T1, dtype=np.int64)
    pf_kernel(model.transition, model.observe, *model.likelihood(), model.theta, model.noise, y,
              model.prior_mean, model.prior_var, N, SCHEME_SYSTEMATIC, np.inf, 0, 0, -np.inf, 0, state, xhat, ess,
              res, d1, d2, d3)
    return xhat


def ungm_record(impl, mode, N, trials, seconds, threads, **extra):
    """A record of the UNGM workload: N particles, ``trials`` trials of T steps in ``seconds``."""
    rec = {"workload": "ungm", "impl": impl, "mode": mode, "particles": N, "trials": trials,
           "steps": T, "threads": threads, "seconds": seconds,
           "particle_steps_per_s": N * T * trials / seconds}
    rec.update(extra)
    return rec


def best_time(fn, min_time: float, reps: int) -> tuple[float, int]:
    """Best over ``reps`` of the mean time per call, each rep repeating fn for >= min_time."""
    best, calls = math.inf, 0
    for _ in range(reps):
        n, t0 = 0, time.perf_counter()
        while True:
            fn()
            n += 1
            el = time.perf_counter() - t0
            if el >= min_time:
                break
        if el / n < best:
            best, calls = el / n, n
    return best, calls
