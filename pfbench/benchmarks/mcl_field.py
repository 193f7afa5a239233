"""Part ``mcl``: plain MCL on the beacon field of configs/sspf_global.yaml, pfbench's kernel
beside MCL written the straightforward way in numpy, with the check that both compute the same
filter; then KLD-sampling MCL and the field SSPF on the same trial, pfbench alone."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..rng import state_from_seed
from .common import best_time


def numpy_mcl(model, data, N: int, rng: np.random.Generator) -> np.ndarray:
    """MCL written the straightforward way in numpy, vectorised over particles: uniform start (or
    around the start, scenario ``initial: known``), odometry motion with per-particle noise,
    Gaussian range (and bearing) likelihood of the step's observations, weighted-mean estimate, systematic resampling every step. Returns the estimated
    poses (T + 1, 3)."""
    T = data.ctrl.shape[0]
    area, bc = model.area, model.beacons
    sr, sb = model.sense.sr, model.sense.sb
    wrap = lambda a: (a + np.pi) % (2 * np.pi) - np.pi
    init = model.init
    if init.known:
        P = (np.array([init.x, init.y, init.heading])
             + np.array([init.sd_m, init.sd_m, init.sd_rad]) * rng.standard_normal((N, 3)))
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
            n1, n2, n3 = (np.full(N, r1), tr + model.mnoise.trans * rng.standard_normal(N),
                          r2 + model.mnoise.turn * rng.standard_normal(N))
        else:
            a1, a2, a3, a4 = model.mnoise[2:]
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
    from ..config import Params, load
    from ..filters import FILTERS
    from ..runner import trial_data
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
        sec, _ = best_time(lambda: ft.run(model, data, params, N, state, False), min_time, reps)
        sec_np, _ = best_time(lambda: numpy_mcl(model, data, N, rng), min_time, 1)
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
        sec, _ = best_time(lambda: f.run(model, data, p, N, state.copy(), False), min_time, reps)
        recs.append({"workload": workload, "impl": "pfbench", "filter": label, "particles": N,
                     "trials": 1, "steps": T, "seconds": sec, "steps_per_s": T / sec,
                     "particle_steps_per_s": drawn / sec, "mean_particles": drawn / T})
        say(f"{label} on the beacon field (sspf_global, global localization), at most N = "
            f"{N:,}, one thread: {T / sec:,.0f} steps/s, {drawn / T:,.0f} particles a step on "
            f"average, {sec / drawn * 1e9:,.0f} ns a particle-step")
    return recs
