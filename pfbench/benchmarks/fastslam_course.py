"""Part ``fastslam``: FastSLAM at N = 100 on the ifa2021 course (configs/worlds/ifa_course.yaml),
pfbench's kernel over a whole trial beside FastSLAM 1.0 written the straightforward way in numpy
over a shorter stretch of the same data, with the check that both compute the same filter."""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ..rng import state_from_seed
from .common import best_time

def numpy_fastslam(model, data, N: int, steps: int, rng: np.random.Generator) -> np.ndarray:
    """FastSLAM 1.0 written the straightforward way: vectorised prediction, then a Python loop over
    particles and observations with 2 x 2 numpy matrices, systematic resampling when ESS < N / 2.
    Returns the weighted position estimates (steps + 1, 2)."""
    dt, L = model.vehicle.dt, model.vehicle.wheelbase
    sV, sG = model.noise.drive, model.noise.turn
    R = np.diag([model.noise.range ** 2, model.noise.bearing ** 2])
    M = model.landmarks.shape[0]
    every = int(model.sensor.every)
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
                    H = (np.array([[d[0], d[1]], [-d[1] / np.sqrt(q), d[0] / np.sqrt(q)]])
                         / np.sqrt(q))
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
    from ..config import Params
    from ..filters import FILTERS
    from ..scenarios import waypoint_course as wc
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
    sec, _ = best_time(lambda: ft.run(model, data, params, N, state, False), min_time, reps)
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
