"""``pfbench bench --limit``: how far each kernel is from what this core can do.

A filter step is a few passes over the particles that no implementation can skip: the normal
draws, the move, the likelihood, the exponentials with their sums, resampling with the gather of
the survivors (and for FastSLAM the association, the landmark EKF updates and the copy of the
maps). Each pass is timed here alone, as a plain compiled loop over the same number of particles
and the same steps' data, the way it runs fastest on this machine; their sum is the practical
limit of a step, and the kernel's time per step over that sum says how much of a step goes to
anything else (calls, branches, memory traffic between the passes, diagnostics).

How each workload's passes are written:

- UNGM (the bench's bootstrap PF): every pass in its fastest form: the model's arithmetic in line
  (the kernel calls it through a function pointer), ``vecmath.exp`` with the three sums in
  partial sums across lanes, systematic resampling in its counting form and a gather.
- MCL (plain MCL on the beacon field of configs/sspf_global.yaml): the kernel's own passes, each
  called alone: the draws with the copy of the resampled set they carry, the move, the
  likelihood and the exponentials (vectorised, rows of particles, ``vecmath``), the running sums
  with the estimate and ESS they carry, and the resampling's counts.
- FastSLAM (the landmark world of configs/afsa_fastslam.yaml, nearest-neighbour association): the
  kernel's own per-landmark functions over every particle and observation of each step, the map
  of each particle being the true landmarks at its truth pose, so association searches that many.

The passes do not run a filter: the numbers they compute are not used, and the particles they
work on are held fixed (drawn once around the truth); only their time counts.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numba import njit, types

from .. import vecmath as vm
from .._lazy import kernel
from ..filters import mcl
from ..filters.weights import exp_pass
from ..filters.fastslam import ekf_apply, innovation, nearest_innovation, options
from ..models.beacons import loglik_const
from ..resampling import systematic
from ..rng import STATE, fill_normal, state_from_seed
from .common import P0, Q, R, SCHEME_SYSTEMATIC, T, bench_data, bench_model, best_time, \
    pfbench_single

_F = types.float64[::1]
_F2 = types.float64[:, ::1]
_F3 = types.float64[:, :, ::1]
_I = types.int64[::1]
_I2 = types.int64[:, ::1]
_LANES = 8


# --- UNGM ----------------------------------------------------------------------------------------

@kernel(types.void(STATE, _F, types.int64), cache=True, error_model="python")
def _ungm_draws(s, z, T):
    for _ in range(T):
        fill_normal(s, z)


@kernel(types.void(_F, _F, _F, types.float64, types.int64), cache=True, error_model="numpy")
def _ungm_move(x, z, xn, sd, T):
    for t in range(1, T + 1):
        c = 8.0 * math.cos(1.2 * t)
        for i in range(x.size):
            xi = x[i]
            xn[i] = 0.5 * xi + 25.0 * xi / (1.0 + xi * xi) + c + sd * z[i]


@kernel(types.float64(_F, _F, _F, types.float64), cache=True, error_model="numpy")
def _ungm_likelihood(xn, lw, y, half_inv_R):
    mx = np.full(_LANES, -np.inf)
    N = xn.size
    top = -np.inf
    for t in range(1, y.size):
        yt = y[t]
        for i in range(N):
            d = yt - xn[i] * xn[i] / 20.0
            lw[i] = -half_inv_R * d * d
        mx[:] = -np.inf
        for i in range(0, N - N % _LANES, _LANES):
            for k in range(_LANES):
                mx[k] = max(mx[k], lw[i + k])
        for i in range(N - N % _LANES, N):
            mx[0] = max(mx[0], lw[i])
        top = mx.max()
    return top


@kernel(types.float64(_F, _F, _F, types.float64, types.int64), cache=True,
        error_model="numpy")
def _ungm_exp_sums(lw, w, xn, m, T):
    acc = np.zeros((3, _LANES))
    N = lw.size
    for _ in range(T):
        for i in range(N):
            w[i] = vm.exp(lw[i] - m)
        acc[:] = 0.0
        for i in range(0, N - N % _LANES, _LANES):
            for k in range(_LANES):
                e = w[i + k]
                acc[0, k] += e
                acc[1, k] += e * e
                acc[2, k] += e * xn[i + k]
        for i in range(N - N % _LANES, N):
            acc[0, 0] += w[i]
            acc[1, 0] += w[i] * w[i]
            acc[2, 0] += w[i] * xn[i]
    return acc.sum()


@kernel(types.void(_F, types.float64, STATE, _I, _F, _F, types.int64), cache=True,
        error_model="numpy")
def _ungm_resample(w, S, s, idx, x, xn, T):
    for _ in range(T):
        systematic(w, S, s, idx)
        for i in range(x.size):
            x[i] = xn[idx[i]]


def _timed(fn, min_time, reps) -> float:
    """Seconds a call of ``fn`` takes, best of ``reps`` (after a first call: compiled or
    loaded, and the caches warm)."""
    fn()
    return best_time(fn, min_time, reps)[0]


def _rows(workload, N, T, passes, kernel_s, label):
    """Records: one per pass (seconds per step), their sum (the limit) and the kernel."""
    limit = sum(s for _, s in passes)
    recs = [{"workload": workload, "impl": "pass", "filter": name, "particles": N, "trials": 1,
             "steps": T, "seconds": s * T, "seconds_per_step": s,
             "ns_per_particle_step": 1e9 * s / N, "particle_steps_per_s": N / s,
             "share_of_limit": s / limit} for name, s in passes]
    recs.append({"workload": workload, "impl": "limit", "filter": "sum of the passes",
                 "particles": N, "trials": 1, "steps": T, "seconds": limit * T,
                 "seconds_per_step": limit, "ns_per_particle_step": 1e9 * limit / N,
                 "particle_steps_per_s": N / limit})
    recs.append({"workload": workload, "impl": "pfbench", "filter": label, "particles": N,
                 "trials": 1, "steps": T, "seconds": kernel_s * T, "seconds_per_step": kernel_s,
                 "ns_per_particle_step": 1e9 * kernel_s / N, "particle_steps_per_s": N / kernel_s,
                 "kernel_over_limit": kernel_s / limit})
    return recs


def ungm_limit(N: int, min_time: float, reps: int) -> list[dict]:
    """The UNGM bootstrap PF's passes at N particles over the bench's T steps, and its kernel."""
    _, Y = bench_data(1)
    y = Y[0]
    s = state_from_seed(np.random.SeedSequence(31))
    rng = np.random.default_rng(31)
    x = rng.normal(0.0, math.sqrt(P0), N)
    z = rng.standard_normal(N)
    xn = np.empty(N)
    lw = np.empty(N)
    w = np.empty(N)
    idx = np.empty(N, dtype=np.int64)
    xo = np.empty(N)
    _ungm_move(x, z, xn, math.sqrt(Q), 1)
    m = _ungm_likelihood(xn, lw, y[:2], 0.5 / R)
    _ungm_exp_sums(lw, w, xn, m, 1)
    S = float(w.sum())
    passes = [
        ("normal draws", _timed(lambda: _ungm_draws(s, z, T), min_time, reps) / T),
        ("move", _timed(lambda: _ungm_move(x, z, xn, math.sqrt(Q), T), min_time, reps) / T),
        ("likelihood and max", _timed(lambda: _ungm_likelihood(xn, lw, y, 0.5 / R), min_time,
                                      reps) / T),
        ("exponentials and sums", _timed(lambda: _ungm_exp_sums(lw, w, xn, m, T), min_time,
                                         reps) / T),
        ("resampling and gather", _timed(lambda: _ungm_resample(w, S, s, idx, xo, xn, T),
                                         min_time, reps) / T),
    ]
    model = bench_model()
    kern = _timed(lambda: pfbench_single(model, y, N, s), min_time, reps) / T
    return _rows("ungm-limit", N, T, passes, kern, "bootstrap PF")


# --- MCL -----------------------------------------------------------------------------------------

@njit(cache=True, error_model="numpy")
def _mcl_draws(s, Z, P, CS, idx, P2, CS2, motion, T):
    N = P.shape[1]
    for _ in range(T):
        mcl.draws_copying(s, Z, motion, P, CS, idx, P2, CS2, N)


@njit(cache=True, error_model="numpy")
def _mcl_move(P, CS, Z, ctrl, mnoise, o):
    for t in range(ctrl.shape[0]):
        mcl.move_particles(P, CS, Z, ctrl[t], o, mnoise)


@njit(cache=True, error_model="numpy")
def _mcl_likelihood(P, bc, obs_n, obs_id, obs_z, o, ll):
    N = P.shape[1]
    for t in range(obs_n.size):
        mcl.loglik_pass(P[0], P[1], P[2], N, bc, obs_n[t], obs_id[t], obs_z[t], o.sensor, o.sr, o.sb,
                    loglik_const(obs_n[t], o.sensor, o.sr, o.sb), ll)


@njit(cache=True, error_model="numpy")
def _mcl_exps(ll, W, T):
    N = ll.size
    for _ in range(T):
        exp_pass(ll, ll.max(), N, W)


@njit(cache=True, error_model="numpy")
def _mcl_summarise(P, W, CS, cum, T):
    out = np.empty(3)
    for _ in range(T):
        mcl.weighted_sums(P, W, P.shape[1], CS, cum, out)


@njit(cache=True, error_model="numpy")
def _mcl_resample(W, cum, o, idx, scratch, s, T):
    for _ in range(T):
        mcl.ancestors(W, cum, o, idx, scratch, s)


def mcl_limit(N: int, min_time: float, reps: int) -> list[dict]:
    """Plain MCL's passes (the kernel's own) at N particles over one trial of the beacon field of
    configs/sspf_global.yaml, and its kernel; [] without that config."""
    from ..config import Params, load
    from ..filters import FILTERS
    from ..runner import trial_data
    cfg = Path("configs/sspf_global.yaml")
    if not cfg.exists():
        return []
    exp = load(cfg, sets=["scenario.initial=known"])
    model, truth, data = trial_data(exp, 0)
    T = data.ctrl.shape[0]
    ft = FILTERS["mcl"]
    params = Params({**{k: key.default for k, key in ft.schema.items()}, "resample": "always"})
    s = state_from_seed(np.random.SeedSequence(32))
    rng = np.random.default_rng(32)
    P = np.ascontiguousarray((truth.pose[0] + 0.3 * rng.standard_normal((N, 3))).T)
    CS = np.empty((2, N))
    mcl.trig_pass(P, 0, N, CS)
    Z = np.empty(2 * N if model.motion == 0 else 3 * N)
    ll = np.empty(N)
    W = np.empty(N)
    P2, CS2 = np.empty_like(P), np.empty_like(CS)
    idx = np.empty(N, dtype=np.int64)
    o = mcl.MclOptions(motion=int(model.motion), sensor=int(model.sensor),
                       sr=model.sense.sr, sb=model.sense.sb, N=N,
                       threshold=np.inf, scheme=SCHEME_SYSTEMATIC, reset=0, inject_sensor=0, kld=0)
    P0, CS0 = P.copy(), CS.copy()
    cum = np.empty(N)
    scratch = np.empty(N, dtype=np.int64)

    def move():
        P[:], CS[:] = P0, CS0
        _mcl_move(P, CS, Z, data.ctrl, model.mnoise, o)

    lik = lambda: _mcl_likelihood(P, model.beacons, data.obs_n, data.obs_id, data.obs_z, o, ll)
    lik()
    exps = lambda: _mcl_exps(ll, W, T)
    exps()
    _mcl_summarise(P, W, CS, cum, 1)
    _mcl_resample(W, cum, o, idx, scratch, s, 1)
    passes = [
        ("normal draws, copying the resampled set",
         _timed(lambda: _mcl_draws(s, Z, P, CS, idx, P2, CS2, o.motion, T), min_time, reps) / T),
        ("move", _timed(move, min_time, reps) / T),
        ("likelihood", _timed(lik, min_time, reps) / T),
        ("maximum and exponentials", _timed(exps, min_time, reps) / T),
        ("running sums, estimate and ESS",
         _timed(lambda: _mcl_summarise(P, W, CS, cum, T), min_time, reps) / T),
        ("resampling", _timed(lambda: _mcl_resample(W, cum, o, idx, scratch, s, T), min_time,
                              reps) / T),
    ]
    kern = _timed(lambda: ft.run(model, data, params, N, s, False), min_time, reps) / T
    return _rows("mcl-limit", N, T, passes, kern, "MCL")


# --- FastSLAM ------------------------------------------------------------------------------------

@njit(cache=True)
def _fs_draws(s, z, K):
    for _ in range(K):
        fill_normal(s, z)


@njit(cache=True)
def _fs_move(P, z, ctrl, K):
    N = P.shape[0]
    for k in range(K):
        v, g = ctrl[k, 0], ctrl[k, 1]
        for i in range(N):
            th = P[i, 2] + g + 1e-3 * z[3 * i]
            st, ct = vm.sincos(th)
            P[i, 0] += v * ct + 1e-2 * z[3 * i + 1]
            P[i, 1] += v * st + 1e-2 * z[3 * i + 2]
            P[i, 2] = vm.wrap(th)


@njit(cache=True)
def _fs_association(poses, mu, sig, nl, obs_n, obs_z, Rr, Rb, pc, bound):
    acc = 0.0
    N = mu.shape[0]
    for k in range(obs_n.size):
        px, py, pth = poses[k, 0], poses[k, 1], poses[k, 2]
        for i in range(N):
            for j in range(obs_n[k]):
                r = nearest_innovation(px, py, pth, i, mu, sig, nl[k], obs_z[k, j, 0],
                                       obs_z[k, j, 1], Rr, Rb, pc[i], bound)
                acc += r[0] + r[1] + r[2] + r[3]
    return acc


@njit(cache=True)
def _fs_innovations(poses, mu, sig, obs_n, obs_id, obs_z, Rr, Rb):
    """Every step's innovations of every particle's observed landmarks, as the association
    leaves them for the update (so that the update pass times the update alone)."""
    N = mu.shape[0]
    out = np.zeros((obs_n.size, N, obs_z.shape[1], 10))
    for k in range(obs_n.size):
        px, py, pth = poses[k, 0], poses[k, 1], poses[k, 2]
        for i in range(N):
            for j in range(obs_n[k]):
                m = obs_id[k, j]
                r = innovation(px, py, pth, mu[i, m, 0], mu[i, m, 1], sig[i, m, 0], sig[i, m, 1],
                               sig[i, m, 2], obs_z[k, j, 0], obs_z[k, j, 1], Rr, Rb)
                for q in range(10):
                    out[k, i, j, q] = r[q]
    return out


@njit(cache=True)
def _fs_update(inn, mu, sig, obs_n, obs_id, Rr, Rb, lw):
    N = mu.shape[0]
    mu0 = mu.copy()
    sig0 = sig.copy()
    for k in range(obs_n.size):
        mu[:] = mu0          # each step updates the same maps: its cost, not their drift
        sig[:] = sig0
        for i in range(N):
            for j in range(obs_n[k]):
                m = obs_id[k, j]
                v = inn[k, i, j]
                lw[i] += ekf_apply(mu[i, m], sig[i, m], v[0], v[1], v[2], v[3], v[4], v[5],
                                   v[6], v[7], v[8], v[9], Rr, Rb, 1)
    return lw.sum()


@njit(cache=True)
def _fs_copy_maps(mu0, sig0, mu, sig, K):
    """What one step's map copy costs at least: the restores _fs_update does once a step."""
    for _ in range(K):
        mu[:] = mu0
        sig[:] = sig0


@njit(cache=True, error_model="numpy")
def _fs_weights(lw, w, x, K):
    acc = 0.0
    for _ in range(K):
        m = lw.max()
        S = 0.0
        S2 = 0.0
        sx = 0.0
        for i in range(lw.size):
            e = vm.exp(lw[i] - m)
            w[i] = e
            S += e
            S2 += e * e
            sx += e * x[i]
        acc += S + S2 + sx
    return acc


@njit(cache=True)
def _fs_resample(w, s, idx, P, mu, sig, seen, nl, src, P2, mu2, sig2, seen2, nl2, src2, used, K):
    """Systematic resampling and the copy of each survivor's pose and the used slots of its map
    (used[k] at step k: the landmarks seen so far)."""
    S = w.sum()
    for k in range(K):
        systematic(w, S, s, idx)
        for i in range(idx.size):
            j = idx[i]
            P2[i, 0], P2[i, 1], P2[i, 2] = P[j, 0], P[j, 1], P[j, 2]
            for m in range(used[k]):
                mu2[i, m, 0], mu2[i, m, 1] = mu[j, m, 0], mu[j, m, 1]
                sig2[i, m, 0], sig2[i, m, 1], sig2[i, m, 2] = sig[j, m, 0], sig[j, m, 1], \
                    sig[j, m, 2]
                seen2[i, m] = seen[j, m]
                src2[i, m] = src[j, m]
            nl2[i] = nl[j]


def _true_maps(model, data, N: int, M: int):
    """Every particle's map (M slots): the true landmarks in the order the trial first sees them
    (so that step k searches those seen before it, as a particle that associates them right
    does), with a landmark's covariance after a few observations. Returns the map arrays (mu,
    sig, seen, src, nl), the landmarks seen by each step, and the observations' slots."""
    K = data.obs_n.shape[0]
    M_true = model.landmarks.shape[0]
    order = list(dict.fromkeys(int(i) for k in range(K) for i in data.obs_id[k, :data.obs_n[k]]))
    order += [m for m in range(M_true) if m not in order]
    seen_by = np.array([len(set(int(i) for kk in range(k + 1)
                                for i in data.obs_id[kk, :data.obs_n[kk]])) for k in range(K)])
    mu = np.zeros((N, M, 2))
    sig = np.zeros((N, M, 3))
    mu[:, :M_true] = model.landmarks[order]
    sig[:, :M_true] = (1e-4, 0.0, 1e-4)
    seen = np.zeros((N, M), dtype=np.int8)
    seen[:, :M_true] = 1
    src = np.full((N, M), -1, dtype=np.int64)
    src[:, :M_true] = order
    nl = np.full(N, M_true, dtype=np.int64)
    slot = np.empty(M_true, dtype=np.int64)
    slot[order] = np.arange(M_true)
    ids = np.ascontiguousarray(slot[np.maximum(data.obs_id, 0)])
    return mu, sig, seen, src, nl, seen_by, ids


def fastslam_limit(N: int, steps: int, min_time: float, reps: int) -> list[dict]:
    """FastSLAM's passes at N particles over the first ``steps`` steps of one trial of
    configs/afsa_fastslam.yaml (its first filter: FastSLAM with nearest-neighbour association),
    and its kernel; [] without that config."""
    from ..config import load
    from ..filters import FILTERS
    from ..runner import trial_data
    cfg = Path("configs/afsa_fastslam.yaml")
    if not cfg.exists():
        return []
    exp = load(cfg, sets=[f"scenario.steps={steps}"])
    model, truth, data = trial_data(exp, 0)
    run = exp.filters[0]
    ft = FILTERS[run.type]
    s = state_from_seed(np.random.SeedSequence(33))
    K = data.obs_n.shape[0]
    o = options(model, run.params, N, False)      # the kernel's own settings
    M, Rr, Rb = o.M, o.Rr, o.Rb
    poses = np.ascontiguousarray(truth.pose[1:K + 1] if truth.pose.shape[0] > K else truth.pose)
    mu, sig, seen, src, nl, seen_by, ids = _true_maps(model, data, N, M)
    bound = max(o.gate_reject, o.gate_augment)
    pc = np.full((N, 6), 1e-6)
    P = np.tile(poses[0], (N, 1))
    z = np.empty(3 * N)
    lw = np.zeros(N)
    w = np.random.default_rng(33).random(N)
    idx = np.empty(N, dtype=np.int64)
    copies = (np.empty_like(P), np.empty_like(mu), np.empty_like(sig), np.empty_like(seen),
              np.empty_like(nl), np.empty_like(src))
    mu0, sig0 = mu.copy(), sig.copy()
    ctrl = np.ascontiguousarray(data.ctrl[:K])
    n_obs = float(data.obs_n.mean())

    def updates():
        """The EKF update pass, a block of steps at a time: the block's innovations (computed
        untimed) fit in cache, as the kernel's, computed as it goes, do. All of them at once
        (tens of MB) made the pass a memory stream the kernel never has."""
        B = 20
        total = 0.0
        for b0 in range(0, K, B):
            b1 = min(b0 + B, K)
            sl = slice(b0, b1)
            inn = _fs_innovations(poses[sl], mu, sig, data.obs_n[sl], ids[sl], data.obs_z[sl],
                                  Rr, Rb)
            bt = min_time * (b1 - b0) / K
            total += (_timed(lambda: _fs_update(inn, mu, sig, data.obs_n[sl], ids[sl], Rr, Rb,
                                                lw), bt, reps)
                      - _timed(lambda: _fs_copy_maps(mu0, sig0, mu, sig, b1 - b0), bt, reps))
        return total / K

    passes = [
        ("normal draws", _timed(lambda: _fs_draws(s, z, K), min_time, reps) / K),
        ("move", _timed(lambda: _fs_move(P, z, ctrl, K), min_time, reps) / K),
        (f"association ({n_obs:.1f} observations x {seen_by.mean():.1f} landmarks)",
         _timed(lambda: _fs_association(poses, mu, sig, seen_by, data.obs_n, data.obs_z, Rr, Rb,
                                        pc, bound), min_time, reps) / K),
        (f"EKF updates ({n_obs:.1f} landmarks)",
         updates()),
        ("exponentials and sums", _timed(lambda: _fs_weights(lw, w, P[:, 0].copy(), K), min_time,
                                         reps) / K),
        ("resampling and map copy", _timed(lambda: _fs_resample(w, s, idx, P, mu, sig, seen, nl,
                                                                src, *copies, seen_by, K),
                                           min_time, reps) / K),
    ]
    kern = _timed(lambda: ft.run(model, data, run.params, N, s, False), min_time, reps) / K
    return _rows("fastslam-limit", N, K, passes, kern, run.label)


def limit_bench(quick: bool, min_time: float, reps: int, say, console=None) -> list[dict]:
    """The practical limit of each kernel (this module): its irreducible passes timed alone,
    their sum, and the kernel's time over that sum, for UNGM at N = 100 and 1e5, MCL at 10,000
    and FastSLAM in the landmark world at 100."""
    from rich.table import Table

    runs = [("UNGM bootstrap PF", lambda: ungm_limit(100, min_time, reps))]
    if not quick:
        runs.append(("UNGM bootstrap PF", lambda: ungm_limit(100_000, min_time, reps)))
    runs += [("MCL, beacon field (sspf_global), systematic resampling every step",
              lambda: mcl_limit(1000 if quick else 10_000, min_time, reps)),
             ("FastSLAM, landmark world (afsa_fastslam), nearest-neighbour association",
              lambda: fastslam_limit(100, 50 if quick else 200, min_time, reps))]
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
