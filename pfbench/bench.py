"""``pfbench bench``: throughput of the bootstrap PF kernel on UNGM, beside references timed in
the same run.

Workload (that of the C reference program ``--c-ref`` times): UNGM with Q = 10, R = 1, T = 100, truth from
x_0 = 0.1, particle prior N(0, 2), systematic resampling every step, weighted-mean estimate. The
pfbench kernel is the one ``pfbench run`` uses, with the per-step diagnostics off. Implementations:
``pfbench`` (single trial, one thread; and a batch of trials over threads), ``numpy`` (vectorised
over particles, one process), and ``c`` when ``--c-ref`` names a compiled ungm_ref.

The run-path rows (part ``run``; ``run-ungm``, ``run-mcl``, ``run-fastslam`` one at a time) time
the path of ``pfbench run`` itself, ``runner.trial_result`` with the diagnostics and traces a
committed config computes, beside the same filters' bare kernels on the same trials, and hold
their ratio against a target (RUN_PATH).
"""
from __future__ import annotations

import json
import math
import os
import platform
import struct
import subprocess
import tempfile
import time
from pathlib import Path

import numba
import numpy as np
from numba import prange, types

from ._lazy import kernel
from .errors import UserError
from .filters.pf import pf_kernel
from .rng import state_from_seed
from .scenarios import ungm
from .models.scalar import ModelFn, simulate

T = 100
Q, R, P0, X0 = 10.0, 1.0, 2.0, 0.1
SIZES = (100, 1_000, 10_000, 100_000, 1_000_000)
BATCH_TRIALS, BATCH_N = 1000, 100
_SCHEME_SYSTEMATIC = 1

_F = types.float64[::1]
_F2 = types.float64[:, ::1]


@kernel(types.void(ModelFn, ModelFn, _F, _F, _F2, types.float64, types.float64, types.int64,
                   types.uint64[:, ::1], _F2), cache=True, parallel=True, error_model="python")
def pf_batch(f, h, theta, noise, Y, prior_mean, prior_var, N, S, XH):
    """Run pf_kernel on every row of Y (trials x (T+1)) in parallel; estimates into XH."""
    K, T1 = Y.shape
    for k in prange(K):
        ess = np.empty(T1)
        res = np.empty(T1, dtype=np.int64)
        d1 = np.empty(T1)
        d2 = np.empty(T1)
        pf_kernel(f, h, theta, noise, Y[k], prior_mean, prior_var, N, 1, np.inf, 0, 0, -np.inf, 0,
                  S[k], XH[k], ess, res, d1, d2)


def bench_model():
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
    T1 = y.size
    xhat, ess, d1, d2 = (np.empty(T1) for _ in range(4))
    res = np.empty(T1, dtype=np.int64)
    pf_kernel(model.transition, model.observe, model.theta, model.noise, y, model.prior_mean,
              model.prior_var, N, _SCHEME_SYSTEMATIC, np.inf, 0, 0, -np.inf, 0, state, xhat, ess,
              res, d1, d2)
    return xhat


def numpy_pf(y: np.ndarray, N: int, rng, resample=None) -> np.ndarray:
    """The same filter written as plain vectorised numpy (the usual way without a compiler).
    rng: a numpy Generator (or the numpy.random module); resample: a function from normalised
    weights to ancestor indices (filterpy's), else systematic resampling by searchsorted."""
    sq = math.sqrt(Q)
    x = rng.normal(0.0, math.sqrt(P0), N)
    xhat = np.zeros(y.size)
    steps = np.arange(N)
    for t in range(1, y.size):
        xn = 0.5 * x + 25.0 * x / (1.0 + x * x) + 8.0 * math.cos(1.2 * t) + sq * rng.standard_normal(N)
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
        sec, _ = _best(lambda: pfbench_single(model, Y[0], N, state), min_time, reps)
        records.append(_record("pfbench", "single", N, 1, sec, 1, workload="ungm-peers"))
        for name, run in peers.items():
            run(Y[0], N)            # particles compiles its numba functions on first use
            sec, _ = _best(lambda: run(Y[0], N), min_time, 1 if N >= 100_000 else reps)
            records.append(_record(name, "single", N, 1, sec, 1, workload="ungm-peers"))
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
    say(f"check, the same filter: mean RMSE over the same {K} trials at N = {BATCH_N}: " + ", ".join(
        f"{n} {r['mean_rmse']:.3f}" for n, r in chk.items()) + "; paired differences to pfbench: "
        + ", ".join(f"{n} {r['paired_diff']:+.3f} (standard error {r['paired_diff_se']:.3f})"
                    for n, r in chk.items() if n != "pfbench"))
    return records


def _best(fn, min_time: float, reps: int) -> tuple[float, int]:
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


def _record(impl, mode, N, trials, seconds, threads, **extra):
    rec = {"workload": "ungm", "impl": impl, "mode": mode, "particles": N, "trials": trials,
           "steps": T, "threads": threads, "seconds": seconds,
           "particle_steps_per_s": N * T * trials / seconds}
    rec.update(extra)
    return rec


def _write_c_data(path: Path, X, Y):
    with open(path, "wb") as fh:
        fh.write(struct.pack("<qq", X.shape[0], X.shape[1] - 1))
        fh.write(np.ascontiguousarray(X, dtype="<f8").tobytes())
        fh.write(np.ascontiguousarray(Y, dtype="<f8").tobytes())


def _c_lines(binary: Path, *args) -> list[list[float]]:
    try:
        res = subprocess.run([str(binary), *map(str, args)], capture_output=True, text=True,
                             timeout=600, check=True)
    except (OSError, subprocess.SubprocessError) as exc:
        raise UserError(f"--c-ref {binary}: could not run it: {exc}") from None
    return [list(map(float, line.split())) for line in res.stdout.splitlines() if line.strip()]


def filter_costs(Y, min_time: float, reps: int, N: int = BATCH_N) -> list[dict]:
    """Seconds per step of every filter type at N particles on the benchmark's UNGM data, through
    the same entry point the runner uses (so each call's fixed cost is included), each filter
    with its default settings."""
    from .config import Params
    from .filters import FILTERS
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
        sec, _ = _best(once, min_time, reps)
        out.append({"workload": "ungm-filters", "impl": "pfbench", "filter": name,
                    "particles": n or 0, "trials": 1, "steps": T, "seconds": sec,
                    "grows_as": ftype.cost,
                    "seconds_per_step": sec / T,
                    "particle_steps_per_s": (n or 1) * T / sec})
    return out


def numpy_fastslam(model, data, N: int, steps: int, rng: np.random.Generator) -> np.ndarray:
    """FastSLAM 1.0 written the straightforward way: vectorised prediction, then a Python loop over
    particles and observations with 2 x 2 numpy matrices, systematic resampling when ESS < N / 2.
    Returns the weighted position estimates (steps + 1, 2)."""
    dt, L = model.vehicle[1], model.vehicle[2]
    sV, sG = model.noise[0], model.noise[1]
    R = np.diag([model.noise[2] ** 2, model.noise[3] ** 2])
    M = model.landmarks.shape[0]
    every = int(model.sensor[2])
    P = np.tile(model.start, (N, 1))
    mu = np.zeros((N, M, 2))
    sig = np.zeros((N, M, 2, 2))
    seen = np.zeros((N, M), dtype=bool)
    w = np.full(N, 1.0 / N)
    est = np.zeros((steps + 1, 2))
    est[0] = model.start[:2]
    for t in range(steps):
        v = data.ctrl[t, 0] + sV * rng.standard_normal(N)
        g = data.ctrl[t, 1] + sG * rng.standard_normal(N)
        P[:, 0] += v * dt * np.cos(P[:, 2] + g)
        P[:, 1] += v * dt * np.sin(P[:, 2] + g)
        P[:, 2] = (P[:, 2] + v * dt * np.sin(g) / L + np.pi) % (2 * np.pi) - np.pi
        k = (t + 1) // every - 1
        if (t + 1) % every == 0 and k < len(data.obs_n):
            for i in range(N):
                x, y, th = P[i]
                for j in range(data.obs_n[k]):
                    m = data.obs_id[k, j]
                    z = data.obs_z[k, j]
                    if not seen[i, m]:
                        c, s_ = np.cos(th + z[1]), np.sin(th + z[1])
                        mu[i, m] = [x + z[0] * c, y + z[0] * s_]
                        Gz = np.array([[c, -z[0] * s_], [s_, z[0] * c]])
                        sig[i, m] = Gz @ R @ Gz.T
                        seen[i, m] = True
                        continue
                    d = mu[i, m] - [x, y]
                    q = d @ d
                    zhat = np.array([np.sqrt(q), np.arctan2(d[1], d[0]) - th])
                    H = np.array([[d[0], d[1]], [-d[1] / np.sqrt(q), d[0] / np.sqrt(q)]]) / np.sqrt(q)
                    S = H @ sig[i, m] @ H.T + R
                    Si = np.linalg.inv(S)
                    inn = z - zhat
                    inn[1] = (inn[1] + np.pi) % (2 * np.pi) - np.pi
                    K = sig[i, m] @ H.T @ Si
                    mu[i, m] += K @ inn
                    A = np.eye(2) - K @ H
                    sig[i, m] = A @ sig[i, m] @ A.T + K @ R @ K.T
                    w[i] *= np.exp(-0.5 * inn @ Si @ inn) / (2 * np.pi * np.sqrt(np.linalg.det(S)))
            w /= w.sum()
            if 1.0 / np.sum(w * w) < 0.5 * N:
                idx = np.minimum(np.searchsorted(np.cumsum(w), (rng.random() + np.arange(N)) / N),
                                 N - 1)
                P, mu, sig, seen = P[idx].copy(), mu[idx].copy(), sig[idx].copy(), seen[idx].copy()
                w = np.full(N, 1.0 / N)
        est[t + 1] = w @ P[:, :2]
    return est


def fastslam_bench(quick: bool, min_time: float, reps: int, say) -> list[dict]:
    """Control steps per second of FastSLAM at N = 100 on the ifa2021 course: the pfbench kernel
    over a whole trial, the numpy implementation over a shorter stretch of the same data."""
    from .config import Params
    from .filters import FILTERS
    from .scenarios import waypoint_course as wc
    world = Path("configs/worlds/ifa_course.yaml")
    if not world.exists():
        say("FastSLAM: skipped (configs/worlds/ifa_course.yaml not found; run from the repository "
            "root)")
        return []
    p = {k: key.default for k, key in wc.SCHEMA.items()}
    p["world"] = str(world.resolve())
    model = wc.build(wc.resolve(p, Path(".")))
    trials = [wc.simulate(model, state_from_seed(ss))
              for ss in np.random.SeedSequence(21).spawn(2 if quick else 8)]
    N = 100
    ft = FILTERS["fastslam"]
    params = Params({k: key.default for k, key in ft.schema.items()})
    state = state_from_seed(np.random.SeedSequence(22))
    truth, data = trials[0]
    T = data.ctrl.shape[0]
    sec, _ = _best(lambda: ft.run(model, data, params, N, state, False), min_time, reps)
    # the numpy implementation over the first steps_np steps of every trial: its speed, and a
    # check that both compute the same filter (position RMSE over those steps, mean over trials)
    steps_np = 160 if quick else 800
    rng = np.random.default_rng(23)
    e_pf, e_np, sec_np = [], [], 0.0
    for truth, data in trials:
        t_xy = truth.pose[1:steps_np + 1, :2]
        out = ft.run(model, data, params, N, state, False)
        e_pf.append(np.sqrt(np.mean(np.sum((out["pose"][1:steps_np + 1, :2] - t_xy) ** 2, 1))))
        t0 = time.perf_counter()
        est_np = numpy_fastslam(model, data, N, steps_np, rng)
        sec_np += time.perf_counter() - t0
        e_np.append(np.sqrt(np.mean(np.sum((est_np[1:] - t_xy) ** 2, 1))))
    sec_np /= len(trials)
    err_pf, err_np = float(np.mean(e_pf)), float(np.mean(e_np))
    se = lambda e: float(np.std(e, ddof=1) / math.sqrt(len(e))) if len(e) > 1 else math.nan
    recs = [{"workload": "fastslam-course", "impl": "pfbench", "particles": N, "trials": 1,
             "steps": T, "seconds": sec, "steps_per_s": T / sec,
             "particle_steps_per_s": N * T / sec},
            {"workload": "fastslam-course", "impl": "numpy", "particles": N, "trials": 1,
             "steps": steps_np, "seconds": sec_np, "steps_per_s": steps_np / sec_np,
             "particle_steps_per_s": N * steps_np / sec_np}]
    say(f"FastSLAM on the ifa2021 course, N = {N}, one thread: pfbench {T / sec:,.0f} control "
        f"steps/s ({T} steps), numpy per-particle {steps_np / sec_np:,.0f} steps/s ({steps_np} "
        f"steps): {(T / sec) / (steps_np / sec_np):.0f}x. Check, the same filter: position RMSE "
        f"over the first {steps_np} steps, mean of {len(trials)} trials: pfbench {err_pf:.3f} m "
        f"(standard error {se(e_pf):.3f}), numpy {err_np:.3f} m ({se(e_np):.3f})")
    return recs


def afsa_bench(quick: bool, min_time: float, reps: int, say, console=None) -> list[dict]:
    """Control steps per second and likelihood evaluations per step of every filter of
    configs/afsa_fastslam.yaml (FastSLAM, PSO- and AFSA-FastSLAM, either resampling) at 10 and 100
    particles on one trial of its landmark world, one thread, relative to plain FastSLAM."""
    from rich.table import Table

    from .config import load
    from .filters import FILTERS
    from .runner import trial_data
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

            sec, _ = _best(one, min_time, reps)
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
                f"({r['relative_to_fastslam']:.2f}x FastSLAM), {r['evals_per_step']:.0f} evals/step")
    return recs


def numpy_mcl(model, data, N: int, rng: np.random.Generator) -> np.ndarray:
    """MCL written the straightforward way in numpy, vectorised over particles: uniform start (or
    around the start, scenario ``initial: known``), odometry motion with per-particle noise, Gaussian range (and bearing) likelihood of the step's
    observations, weighted-mean estimate, systematic resampling every step. Returns the estimated
    poses (T + 1, 3)."""
    T = data.ctrl.shape[0]
    area, bc = model.area, model.beacons
    sr, sb = model.sense[2], model.sense[3]
    wrap = lambda a: (a + np.pi) % (2 * np.pi) - np.pi
    if model.init[0]:
        P = model.init[1:4] + model.init[[4, 4, 5]] * rng.standard_normal((N, 3))
        P[:, 2] = wrap(P[:, 2])
    else:
        P = np.column_stack([area[0] * rng.random(N), area[1] * rng.random(N),
                             np.pi * (2 * rng.random(N) - 1)])
    est = np.empty((T + 1, 3))

    def estimate(w):
        return [w @ P[:, 0], w @ P[:, 1], math.atan2(w @ np.sin(P[:, 2]), w @ np.cos(P[:, 2]))]

    est[0] = estimate(np.full(N, 1.0 / N))
    for t in range(T):
        r1, tr, r2 = data.ctrl[t]
        if model.motion == 0:
            n1, n2, n3 = (np.full(N, r1), tr + model.mnoise[0] * rng.standard_normal(N),
                          r2 + model.mnoise[1] * rng.standard_normal(N))
        else:
            a1, a2, a3, a4 = model.mnoise
            n1 = r1 + (a1 * abs(r1) + a2 * abs(tr)) * rng.standard_normal(N)
            n2 = tr + (a3 * abs(tr) + a4 * (abs(r1) + abs(r2))) * rng.standard_normal(N)
            n3 = r2 + (a1 * abs(r2) + a2 * abs(tr)) * rng.standard_normal(N)
        th = P[:, 2] + n1
        P[:, 0] += n2 * np.cos(th)
        P[:, 1] += n2 * np.sin(th)
        P[:, 2] = wrap(th + n3)
        lw = np.zeros(N)
        for j in range(data.obs_n[t]):
            b = data.obs_id[t, j]
            dx, dy = bc[b, 0] - P[:, 0], bc[b, 1] - P[:, 1]
            lw -= 0.5 * ((data.obs_z[t, j, 0] - np.hypot(dx, dy)) / sr) ** 2
            if model.sensor == 1:
                lw -= 0.5 * (wrap(data.obs_z[t, j, 1] - (np.arctan2(dy, dx) - P[:, 2])) / sb) ** 2
        w = np.exp(lw - lw.max())
        w /= w.sum()
        est[t + 1] = estimate(w)
        idx = np.minimum(np.searchsorted(np.cumsum(w), (rng.random() + np.arange(N)) / N), N - 1)
        P = P[idx]
    return est


def mcl_bench(quick: bool, min_time: float, reps: int, say) -> list[dict]:
    """Steps per second of plain MCL (systematic resampling every step) on the beacon field of
    configs/sspf_global.yaml at 1000 and 10000 particles, one thread: the pfbench kernel and the
    numpy implementation on the same trial, and a check that both compute the same filter: their
    mean position errors over the same trials tracking from a known start (from a uniform start
    this MCL mostly settles on a wrong mode, and its errors are too spread to compare). Then
    KLD-sampling MCL (at most 10,000 particles) and the field SSPF (1000) on the same trial,
    pfbench alone; their particle-steps count the particles each step drew."""
    from .config import Params, load
    from .filters import FILTERS
    from .runner import trial_data
    cfg = Path("configs/sspf_global.yaml")
    if not cfg.exists():
        say("MCL: skipped (configs/sspf_global.yaml not found; run from the repository root)")
        return []
    exp = load(cfg)
    model, _, data = trial_data(exp, 0)
    tracking = load(cfg, sets=["scenario.initial=known"])
    trials = [trial_data(tracking, k) for k in range(2 if quick else 8)]
    ft = FILTERS["mcl"]
    params = Params({k: key.default for k, key in ft.schema.items()})
    state = state_from_seed(np.random.SeedSequence(25))
    rng = np.random.default_rng(26)
    T = data.ctrl.shape[0]
    recs = []
    for N in (1000, 10_000):
        sec, _ = _best(lambda: ft.run(model, data, params, N, state, False), min_time, reps)
        sec_np, _ = _best(lambda: numpy_mcl(model, data, N, rng), min_time, 1)
        e_pf, e_np = [], []
        for m, truth, d in trials:
            for est, errs in ((ft.run(m, d, params, N, state, False)["pose"], e_pf),
                              (numpy_mcl(m, d, N, rng), e_np)):
                errs.append(float(np.mean(np.hypot(*(est[1:, :2] - truth.pose[1:, :2]).T))))
        se = lambda e: float(np.std(e, ddof=1) / math.sqrt(len(e))) if len(e) > 1 else math.nan
        for impl, t_s, errs in (("pfbench", sec, e_pf), ("numpy", sec_np, e_np)):
            recs.append({"workload": "mcl-beacon-field", "impl": impl, "particles": N,
                         "trials": 1, "steps": T, "seconds": t_s, "steps_per_s": T / t_s,
                         "particle_steps_per_s": N * T / t_s,
                         "mean_position_error": float(np.mean(errs))})
        say(f"MCL on the beacon field (sspf_global), N = {N:,}, one thread: pfbench "
            f"{T / sec:,.0f} steps/s, numpy {T / sec_np:,.0f} steps/s: {sec_np / sec:.1f}x. "
            f"Check, the same filter: mean position error tracking from a known start, "
            f"{len(trials)} trials: pfbench {np.mean(e_pf):.3f} m (standard error "
            f"{se(e_pf):.3f}), numpy {np.mean(e_np):.3f} m ({se(e_np):.3f})")
    # KLD-sampling MCL and the field SSPF on the same trial (global localization), pfbench alone
    runs = [("kld-mcl-global", "KLD-MCL", "mcl", 10_000, {"sampling": "kld"}),
            ("sspf-field", "SSPF", "sspf_field", 1000,
             {"resample": "weight_change", "mh_steps": 1})]
    for workload, label, ftype, N, extra in runs:
        f = FILTERS[ftype]
        p = Params({**{k: key.default for k, key in f.schema.items()}, **extra})
        # every timed run from the same state, so that each draws the particles counted here
        drawn = float(np.sum(f.run(model, data, p, N, state.copy(), False)["n"]))
        sec, _ = _best(lambda: f.run(model, data, p, N, state.copy(), False), min_time, reps)
        recs.append({"workload": workload, "impl": "pfbench", "filter": label, "particles": N,
                     "trials": 1, "steps": T, "seconds": sec, "steps_per_s": T / sec,
                     "particle_steps_per_s": drawn / sec, "mean_particles": drawn / T})
        say(f"{label} on the beacon field (sspf_global, global localization), at most N = "
            f"{N:,}, one thread: {T / sec:,.0f} steps/s, {drawn / T:,.0f} particles a step on "
            f"average, {sec / drawn * 1e9:,.0f} ns a particle-step")
    return recs


def limit_bench(quick: bool, min_time: float, reps: int, say, console=None) -> list[dict]:
    """The practical limit of each kernel (pfbench.limits): its irreducible passes timed alone,
    their sum, and the kernel's time over that sum, for UNGM at N = 100 and 1e5, MCL at 10,000
    and FastSLAM in the landmark world at 100."""
    from rich.table import Table

    from . import limits
    runs = [("UNGM bootstrap PF", lambda: limits.ungm_limit(100, min_time, reps))]
    if not quick:
        runs.append(("UNGM bootstrap PF", lambda: limits.ungm_limit(100_000, min_time, reps)))
    runs += [("MCL, beacon field (sspf_global), systematic resampling every step",
              lambda: limits.mcl_limit(1000 if quick else 10_000, min_time, reps)),
             ("FastSLAM, landmark world (afsa_fastslam), nearest-neighbour association",
              lambda: limits.fastslam_limit(100, 50 if quick else 200, min_time, reps))]
    records = []
    for title, run in runs:
        recs = run()
        if not recs:
            say(f"{title}: skipped (its config is not here; run from the repository root)")
            continue
        records += recs
        N = recs[0]["particles"]
        tab = Table(title=f"{title}, N = {N:,}: each pass alone, per particle and step",
                    title_justify="left")
        for h in ("pass", "ns", "share"):
            tab.add_column(h, justify="right" if h != "pass" else "left")
        for r in recs:
            share = (f"{100 * r['share_of_limit']:.0f}%" if "share_of_limit" in r
                     else f"{r['kernel_over_limit']:.2f}x the limit"
                     if "kernel_over_limit" in r else "")
            name = {"limit": "practical limit (the sum)"}.get(r["impl"], r["filter"])
            if r["impl"] == "pfbench":
                name = f"the pfbench kernel ({r['filter']})"
            tab.add_row(name, f"{r['ns_per_particle_step']:.1f}", share)
        if console:
            console.print(tab)
        else:
            for r in recs:
                say(f"{r['filter']}: {r['ns_per_particle_step']:.1f} ns")
    return records


# ---------------------------------------------------------------- what `pfbench run` runs

# The run-path rows: a filter through ``runner.trial_result`` (the path of ``pfbench run``: the
# trial's simulation, each run's fresh copies of its inputs, its kernel with the diagnostics its
# config computes, the output checks, the metrics, the trace its kind keeps for the figures)
# beside the same filter's bare kernel (diagnostics off) on the same trials, in the same run.
# (family, config, the one filter run kept (None: all of the config's), its particle count,
# the scenario steps (None: the config's; quick, full), the target: run / kernel at most this)
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
    from .config import read_yaml, validate
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
    from rich.table import Table

    from .filters import FILTERS
    from .runner import trial_data, trial_result
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
                best[impl] = min(best[impl], _best(fn, min_time, 1)[0])
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
    if not recs:
        return recs
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
            f"{max(reps, 2)}", markup=False)
    else:
        for k, r in zip(recs[0::2], recs[1::2]):
            say(f"run path, {r['filter']}: kernel {k['ns_per_particle_step']:.1f} ns, run "
                f"{r['ns_per_particle_step']:.1f} ns a particle-step: "
                f"{r['run_over_kernel']:.2f}x (target {r['target']:.1f}x)")
    return recs


def _diag_names(exp) -> list[str]:
    """The per-step diagnostics ``exp`` computes (pfbench.diagnostics.plan)."""
    from .diagnostics import plan
    return list(plan(exp).names)


PARTS = ("ungm", "costs", "fastslam", "afsa", "mcl", "run") + RUN_FAMILIES + ("limit",)
# the limit runs when asked for (--limit or --only limit); 'run' is every run-path family
DEFAULT_PARTS = ("ungm", "costs", "fastslam", "afsa", "mcl", "run")

# What names a bench record (two runs' records with the same identity timed the same work), and
# the throughput compared, in order of preference.
IDENTITY = ("workload", "impl", "mode", "filter", "particles", "trials", "steps", "threads")
RATES = ("particle_steps_per_s", "steps_per_s")
SLOWER = 0.9        # a row below this ratio to the earlier run is flagged


def record_key(rec: dict) -> tuple:
    return tuple((k, rec[k]) for k in IDENTITY if k in rec)


def record_rate(rec: dict) -> float:
    for k in RATES:
        if isinstance(rec.get(k), (int, float)) and rec[k] > 0:
            return float(rec[k])
    s = rec.get("seconds")
    return 1.0 / s if isinstance(s, (int, float)) and s > 0 else math.nan


def read_records(path: Path) -> list[dict]:
    """The records of an earlier ``pfbench bench --json`` run; a UserError for anything else."""
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise UserError(f"--compare {path}: cannot read it ({exc.strerror})") from None
    except (ValueError, UnicodeDecodeError):
        raise UserError(f"--compare {path}: not JSON (a file 'pfbench bench --json' wrote?)") \
            from None
    if (not isinstance(data, list) or not data
            or not all(isinstance(r, dict) and "workload" in r and "impl" in r for r in data)):
        raise UserError(f"--compare {path}: not a list of bench records (a file 'pfbench bench "
                        "--json' wrote?)")
    return data


def compare_records(new: list[dict], old: list[dict]) -> list[dict]:
    """Each record of ``new`` beside the record of ``old`` that timed the same work (same
    identity: IDENTITY): {'key', 'new', 'old', 'ratio' (new throughput / old; > 1 faster),
    'slower' (ratio below SLOWER)}; records of only one run have None for the other."""
    before = {record_key(r): r for r in old if r.get("workload") != "run"}
    out = []
    for r in new:
        if r.get("workload") == "run":          # what ran, not a timing
            continue
        k = record_key(r)
        o = before.pop(k, None)
        ratio = record_rate(r) / record_rate(o) if o is not None else math.nan
        out.append({"key": k, "new": r, "old": o, "ratio": ratio,
                    "slower": ratio == ratio and ratio < SLOWER})
    out += [{"key": k, "new": None, "old": o, "ratio": math.nan, "slower": False}
            for k, o in before.items()]
    return out


def _what(key: tuple) -> str:
    d = dict(key)
    parts = [d.get("workload", "?"), d.get("impl", "?")]
    parts += [str(d[k]) for k in ("mode", "filter") if k in d]
    if d.get("particles"):
        parts.append(f"N={d['particles']}")
    if d.get("trials", 1) != 1:
        parts.append(f"x{d['trials']}")
    if "threads" in d and d["threads"] != 1:
        parts.append(f"{d['threads']} threads")
    return " ".join(parts)


def print_comparison(rows: list[dict], path: Path, console) -> None:
    from rich.table import Table as RichTable
    t = RichTable(title=f"this run beside {path} (throughput; ratio > 1: faster now)",
                  title_justify="left", show_edge=False)
    for h in ("record", "earlier", "now", "ratio"):
        t.add_column(h, no_wrap=h != "record")
    for r in rows:
        fmt = lambda rec: ("-" if rec is None or record_rate(rec) != record_rate(rec)
                           else f"{record_rate(rec):.3g}")
        ratio = "-" if r["ratio"] != r["ratio"] else f"{r['ratio']:.2f}"
        t.add_row(_what(r["key"]), fmt(r["old"]), fmt(r["new"]),
                  ratio + ("  SLOWER" if r["slower"] else ""))
    console.print(t)
    slow = [r for r in rows if r["slower"]]
    console.print(f"{len(slow)} of {sum(r['ratio'] == r['ratio'] for r in rows)} records "
                  f"matched are below {SLOWER:g}x the earlier run (on a shared machine a single "
                  "run moves 10-30%: rerun before calling it a slowdown)", markup=False)


def run_bench(json_path=None, quick=False, c_ref=None, threads=0, console=None, only=(),
              compare=None, limit=False, peers=False, command="pfbench bench"):
    """Time every implementation (or the parts named in ``only``: PARTS), print tables of
    throughputs and ratios, optionally write JSON; ``compare``: an earlier run's JSON, each
    record's ratio to it printed at the end; ``limit``: also the practical limits
    (``limit_bench``); ``peers``: also the peers (``peers_bench``, the 'peers' extra);
    ``command``: the command that ran, for the JSON's run record."""
    old = read_records(compare) if compare is not None else None
    unknown = sorted(set(only) - set(PARTS))
    if unknown:
        raise UserError(f"--only {unknown[0]}: no such part of the bench; parts: "
                        f"{', '.join(PARTS)}")
    parts = set(only) or set(DEFAULT_PARTS)
    if limit:
        parts.add("limit")
    if peers:
        peer_modules()          # installed? (before anything is timed)
    if c_ref is not None and not Path(c_ref).is_file():
        raise UserError(f"--c-ref {c_ref}: no such file (build it: gcc -O3 -march=native "
                        "-fopenmp -o ungm_ref bench/ungm_ref.c -lm)")
    if c_ref is not None and "ungm" not in parts:
        raise UserError("--c-ref times the UNGM rows: add --only ungm")
    threads = threads or os.cpu_count() or 1
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    min_time, reps = (0.05, 1) if quick else (0.3, 3)
    K = 100 if quick else BATCH_TRIALS
    records = []
    say = console.print if console else print
    if "ungm" in parts:
        records += ungm_bench(quick, c_ref, K, min_time, reps, threads, say, console)
    if "costs" in parts:
        records += costs_bench(bench_data(K)[1], min_time, reps, say, console)
    if "fastslam" in parts:
        records += fastslam_bench(quick, min_time, reps, say)
    if "afsa" in parts:
        records += afsa_bench(quick, min_time, reps, say, console)
    if "mcl" in parts:
        records += mcl_bench(quick, min_time, reps, say)
    if peers:
        records += peers_bench(quick, min_time, reps, say, console)
    families = ({f[0] for f in RUN_PATH} if "run" in parts
                else {f[0] for f in RUN_PATH if f"run-{f[0]}" in parts})
    if families:
        records += run_path_bench(quick, min_time, reps, say, console, families)
    if "limit" in parts:
        records += limit_bench(quick, min_time, reps, say, console)
    records.append({"workload": "run", "impl": "pfbench", "command": command,
                    "cores": os.cpu_count(), "numba": numba.__version__,
                    "numpy": np.__version__, "python": platform.python_version()})
    if json_path is not None:
        Path(json_path).write_text(json.dumps(records, indent=2) + "\n")
        say(f"wrote {json_path}")
    if old is not None and console is not None:
        print_comparison(compare_records(records, old), Path(compare), console)
    return records


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
        sec, _ = _best(lambda: pfbench_single(model, Y[0], N, state), min_time, reps)
        records.append(_record("pfbench", "single", N, 1, sec, 1))
        sec, _ = _best(lambda: numpy_pf(Y[0], N, rng), min_time, 1 if N >= 100_000 else reps)
        records.append(_record("numpy", "single", N, 1, sec, 1))
    S = np.stack([state_from_seed(ss) for ss in np.random.SeedSequence(8).spawn(K)])
    XH = np.empty_like(Y)
    run_batch = lambda: pf_batch(model.transition, model.observe, model.theta, model.noise, Y,
                                 model.prior_mean, model.prior_var, BATCH_N, S, XH)
    run_batch()
    sec, _ = _best(run_batch, min_time, reps)
    rmse_pf = np.sqrt(np.mean((XH[:, 1:] - X[:, 1:]) ** 2, axis=1))
    rm_pf = float(rmse_pf.mean())
    records.append(_record("pfbench", "batch", BATCH_N, K, sec, numba.get_num_threads(),
                           mean_rmse=rm_pf))
    XN = np.empty_like(Y)

    def numpy_batch():
        for k in range(K):
            XN[k] = numpy_pf(Y[k], BATCH_N, rng)

    sec, _ = _best(numpy_batch, min_time, 1)  # one rep: it takes seconds
    rmse_np = np.sqrt(np.mean((XN[:, 1:] - X[:, 1:]) ** 2, axis=1))
    rm_np = float(rmse_np.mean())
    diff = rmse_pf - rmse_np
    diff_se = float(diff.std(ddof=1) / math.sqrt(K))
    records.append(_record("numpy", "batch", BATCH_N, K, sec, 1, mean_rmse=rm_np))
    if c_ref is not None:
        with tempfile.TemporaryDirectory() as tmp:
            data = Path(tmp) / "ungm.bin"
            _write_c_data(data, X, Y)
            for N in sizes:
                lines = _c_lines(c_ref, data, "single", N, reps, min_time)
                records.append(_record("c", "single", N, 1, min(l[0] for l in lines), 1))
            lines = _c_lines(c_ref, data, "batch", BATCH_N, reps, K, threads)
            records.append(_record("c", "batch", BATCH_N, K, min(l[0] for l in lines), threads))
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


def costs_bench(Y, min_time, reps, say, console) -> list[dict]:
    """Every scalar filter's cost per step at N = BATCH_N, as a table."""
    from rich.table import Table
    costs = filter_costs(Y, min_time, reps)
    base = next(c["seconds_per_step"] for c in costs if c["filter"] == "pf")
    tab = Table(title=f"cost per step of each filter at N = {BATCH_N} (one thread, default settings)")
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
