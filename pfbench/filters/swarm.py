"""Swarm-intelligence moves for particles: firefly (FA), improved firefly (IFA), bat (BA),
particle swarm (PSO) and artificial fish swarm (AFSA).

The moves work on particles stored flat, X : (N * D,) in C order (particle i is X[i*D:(i+1)*D]),
and never call a model: a move either uses the fitness values it is given, or proposes candidate
positions that the caller evaluates before the matching ``*_accept``. So the same moves serve the
scalar filters here (D = 1, fitness = likelihood of the measurement) and robot poses in FastSLAM.
Fitness is positive and larger is better (the filters use the max-shifted likelihood in (0, 1]).
Distances are Euclidean over the D coordinates (a caller with angles must wrap them itself); the
random steps take a per-coordinate unit ``scale`` (1 for a scalar state; FastSLAM passes the
spread of the predicted poses, so a heading is not stepped in metres).

Cost: the firefly moves compare every pair, O(N^2) per iteration; BA, PSO and AFSA's behaviours
are O(N) per iteration except AFSA's neighbourhoods, which are O(N^2) as well.
"""
from __future__ import annotations

import math

import numpy as np
from numba import types
from .._lazy import kernel

from ..rng import STATE, normal, uniform
from ..schema import Key

# The swarm algorithms, one numbering for every kernel that moves particles with them (codes).
from ..codes import AFSA, ALGORITHMS, BA, BRIGHTNESS, FA, IFA, NO_SWARM, PSO  # noqa: F401


def keys(algo: str, unit: str = "state units", prefix: bool = False) -> dict:
    """The config keys of swarm algorithm ``algo``. ``unit``: what AFSA's visual range and step
    are measured in; ``prefix``: start each doc line with the algorithm's name (a filter that
    takes several algorithms' keys)."""
    declared = {
        "fa": {
            "beta0": Key("float", 1.0, "maximum attractiveness (ifa2021: 1)", min=0.0),
            "gamma": Key("float", 1.0, "light absorption, per squared state unit (ifa2021: 1)",
                         min=0.0),
            "alpha": Key("float", 0.2, "fixed random-step size (FA-PF's reference gives none; "
                         "our default)", min=0.0)},
        "ba": {
            "freq_min": Key("float", 0.0, "lowest frequency"),
            "freq_max": Key("float", 1.0, "highest frequency"),
            "loudness": Key("float", 1.0, "initial loudness A0 (acceptance probability)", min=0.0),
            "pulse_rate": Key("float", 0.5, "pulse rate r0 (1 - r: chance of a local walk around "
                              "the best bat)", min=0.0, max=1.0),
            "loudness_decay": Key("float", 0.9, "A <- decay A on acceptance", min=0.0, max=1.0),
            "pulse_growth": Key("float", 0.9, "r <- r0 (1 - exp(-growth k)) at iteration k on "
                                "acceptance", min=0.0)},
        "pso": {
            "inertia": Key("float", 0.7, "velocity inertia w", min=0.0),
            "c1": Key("float", 1.5, "pull toward the particle's own best", min=0.0),
            "c2": Key("float", 1.5, "pull toward the swarm's best", min=0.0)},
        "afsa": {
            "visual": Key("float", 1.0, f"visual range ({unit})", min=0.0, min_exclusive=True),
            "step": Key("float", 0.5, f"largest move per behaviour ({unit})", min=0.0),
            "crowding": Key("float", 0.618, "crowding factor delta", min=0.0),
            "tries": Key("int", 5, "prey: neighbours tried before a random step", min=1),
            "greedy": Key("bool", True, "keep a fish where it is when no behaviour improves it")},
    }
    declared["ifa"] = {k: declared["fa"][k] for k in ("beta0", "gamma")}
    out = declared[algo]
    if prefix:
        from dataclasses import replace
        out = {k: replace(key, doc=f"{algo.upper()}: {key.doc}") for k, key in out.items()}
    return out


def pack(algo: str, params) -> np.ndarray:
    """The parameter array p the kernels read for swarm algorithm ``algo``:
    fa [beta0, gamma, alpha]; ifa [beta0, gamma] and, where the filter has the key, brightness
    (codes.BRIGHTNESS); ba [fmin, fmax, A0, r0, decay, growth]; pso [w, c1, c2];
    afsa [visual, step, delta, tries, greedy]."""
    if algo == "fa":
        vals = (params["beta0"], params["gamma"], params["alpha"])
    elif algo == "ifa":
        vals = (params["beta0"], params["gamma"])
        if "brightness" in params:
            vals += (float(BRIGHTNESS[params["brightness"]]),)
    elif algo == "ba":
        vals = (params["freq_min"], params["freq_max"], params["loudness"], params["pulse_rate"],
                params["loudness_decay"], params["pulse_growth"])
    elif algo == "pso":
        vals = (params["inertia"], params["c1"], params["c2"])
    elif algo == "afsa":
        vals = (params["visual"], params["step"], params["crowding"], float(params["tries"]),
                float(params["greedy"]))
    else:
        vals = (0.0,)
    return np.array(vals, dtype=np.float64)

_F = types.float64[::1]
_I = types.int64[::1]


@kernel(types.float64(_F, types.int64, types.int64, types.int64), cache=True, inline="always")
def _dist2(X, i, j, D):
    acc = 0.0
    for d in range(D):
        e = X[i * D + d] - X[j * D + d]
        acc += e * e
    return acc


@kernel(types.void(_F, _F, types.int64, types.float64, types.float64, types.float64, _F, STATE),
      cache=True)
def fa_move(X, bright, D, beta0, gamma, alpha, scale, s):
    """Firefly move (Yang 2008), in place: each i moves toward every brighter j,
    x_i += beta0 exp(-gamma r_ij^2) (x_j - x_i) + alpha scale (u - 0.5), u ~ U(0, 1) per
    coordinate; scale (D,) gives each coordinate's unit for the random step. O(N^2)."""
    N = bright.size
    for i in range(N):
        for j in range(N):
            if bright[j] > bright[i]:
                b = beta0 * math.exp(-gamma * _dist2(X, i, j, D))
                for d in range(D):
                    X[i * D + d] += (b * (X[j * D + d] - X[i * D + d])
                                     + alpha * scale[d] * (uniform(s) - 0.5))


@kernel(types.void(_F, _F, types.int64, types.float64, types.float64, types.float64, _F, STATE),
      cache=True)
def ifa_move(X, bright, D, beta0, gamma, R, scale, s):
    """Improved firefly move (ifa2021): like ``fa_move`` with the adaptive step
    alpha_i = exp(-R I_i / I_j) toward the brighter firefly j. O(N^2)."""
    N = bright.size
    for i in range(N):
        for j in range(N):
            if bright[j] > bright[i]:
                b = beta0 * math.exp(-gamma * _dist2(X, i, j, D))
                a = math.exp(-R * bright[i] / bright[j])
                for d in range(D):
                    X[i * D + d] += (b * (X[j * D + d] - X[i * D + d])
                                     + a * scale[d] * (uniform(s) - 0.5))


@kernel(types.int64(_F), cache=True)
def argmax(v):
    best = 0
    for i in range(1, v.size):
        if v[i] > v[best]:
            best = i
    return best


@kernel(types.void(_F, _F, _F, _F, types.int64, types.int64, types.float64, types.float64,
                 types.float64, STATE), cache=True)
def pso_propose(X, V, P, Pfit, D, g, w, c1, c2, s):
    """Particle-swarm step (Kennedy & Eberhart), in place: v = w v + c1 r1 (p_i - x) +
    c2 r2 (p_g - x), x += v, with P (N*D,) the personal bests and g the index of the best of them.
    The caller evaluates the new X and calls ``pso_accept``."""
    N = Pfit.size
    for i in range(N):
        for d in range(D):
            k = i * D + d
            V[k] = (w * V[k] + c1 * uniform(s) * (P[k] - X[k])
                    + c2 * uniform(s) * (P[g * D + d] - X[k]))
            X[k] += V[k]


@kernel(types.int64(_F, _F, _F, _F, types.int64), cache=True)
def pso_accept(X, fit, P, Pfit, D):
    """Update the personal bests P (fitness Pfit) with the evaluated X; return the global best."""
    for i in range(fit.size):
        if fit[i] > Pfit[i]:
            Pfit[i] = fit[i]
            for d in range(D):
                P[i * D + d] = X[i * D + d]
    return argmax(Pfit)


@kernel(types.void(_F, _F, _F, _F, _F, types.int64, types.int64, types.float64, types.float64,
                 _F, STATE), cache=True)
def ba_propose(X, V, A, r, C, D, g, fmin, fmax, scale, s):
    """Bat algorithm (Yang 2010) candidates C (N*D,): frequency f = fmin + (fmax - fmin) u,
    v += (x - x_best) f, c = x + v; with probability 1 - r_i a local walk
    c = x_best + e mean(A) scale, e ~ N(0, 1) per coordinate, instead. The caller evaluates C and
    calls ``ba_accept``."""
    N = A.size
    meanA = A.sum() / N
    for i in range(N):
        fr = fmin + (fmax - fmin) * uniform(s)
        local = uniform(s) > r[i]
        for d in range(D):
            k = i * D + d
            V[k] += (X[k] - X[g * D + d]) * fr
            C[k] = X[g * D + d] + meanA * scale[d] * normal(s) if local else X[k] + V[k]


@kernel(types.int64(_F, _F, _F, _F, _F, _F, types.int64, types.float64, types.float64,
                  types.float64, types.int64, STATE), cache=True)
def ba_accept(X, fit, C, fitc, A, r, D, alpha, gamma, r0, it, s):
    """Accept candidate i when it is fitter and u < A_i; then A_i *= alpha and
    r_i = r0 (1 - exp(-gamma it)). Returns the index of the fittest bat."""
    for i in range(fit.size):
        if fitc[i] > fit[i] and uniform(s) < A[i]:
            fit[i] = fitc[i]
            for d in range(D):
                X[i * D + d] = C[i * D + d]
            A[i] *= alpha
            r[i] = r0 * (1.0 - math.exp(-gamma * it))
    return argmax(fit)


@kernel(types.void(_F, _F, types.int64, types.float64, _F, _F), cache=True)
def afsa_centres(X, fit, D, visual, Xc, nf):
    """Centre Xc (N*D,) of each fish's neighbours within ``visual`` (itself included) and their
    number nf (N,). O(N^2)."""
    N = fit.size
    v2 = visual * visual
    for i in range(N):
        cnt = 0
        for d in range(D):
            Xc[i * D + d] = 0.0
        for j in range(N):
            if _dist2(X, i, j, D) <= v2:
                cnt += 1
                for d in range(D):
                    Xc[i * D + d] += X[j * D + d]
        for d in range(D):
            Xc[i * D + d] /= cnt
        nf[i] = cnt


@kernel(types.void(_F, types.int64, types.int64, _F, types.int64, types.float64, types.float64, _F,
                 types.int64), cache=True, inline="always")
def _toward(X, i, D, tgt, toff, step, u, C, coff):
    """C[coff:coff+D] = x_i + u step (t - x_i) / ||t - x_i||, t = tgt[toff:toff+D] (x_i itself when
    t = x_i)."""
    n2 = 0.0
    for d in range(D):
        e = tgt[toff + d] - X[i * D + d]
        n2 += e * e
    n = math.sqrt(n2)
    for d in range(D):
        C[coff + d] = X[i * D + d] + (u * step * (tgt[toff + d] - X[i * D + d]) / n
                                      if n > 0 else 0.0)


@kernel(types.void(_F, _F, _F, _F, _F, types.int64, types.float64, types.float64, types.float64,
                 types.int64, STATE, _F), cache=True)
def afsa_propose(X, fit, Xc, fitc, nf, D, visual, step, delta, tries, s, C):
    """Three candidates per fish (afsa2014's prey, swarm and follow) into C (3 N D,): rows [0, N) prey,
    [N, 2N) swarm, [2N, 3N) follow.

    prey: up to ``tries`` random neighbours j within visual; move a random fraction of ``step``
        toward the first fitter one, else a random step of length <= step;
    swarm: toward the neighbours' centre if fit(centre) / nf > delta fit_i, else prey;
    follow: toward the fittest neighbour if its fitness / nf > delta fit_i, else prey.
    fitc : (N,) fitness of the centres Xc. The caller evaluates C and calls ``afsa_select``.
    """
    N = fit.size
    v2 = visual * visual
    tmp = np.empty(D)
    for i in range(N):
        # prey
        done = False
        for _ in range(tries):
            j = int(uniform(s) * N)
            if j != i and _dist2(X, i, j, D) <= v2 and fit[j] > fit[i]:
                _toward(X, i, D, X, j * D, step, uniform(s), C, i * D)
                done = True
                break
        if not done:
            n2 = 0.0
            for d in range(D):
                tmp[d] = normal(s)
                n2 += tmp[d] * tmp[d]
            n = math.sqrt(n2)
            u = uniform(s)
            for d in range(D):
                C[i * D + d] = X[i * D + d] + u * step * tmp[d] / n
        prey_row = i * D
        # swarm
        b = (N + i) * D
        if nf[i] > 1 and fitc[i] / nf[i] > delta * fit[i]:
            _toward(X, i, D, Xc, i * D, step, uniform(s), C, b)
        else:
            for d in range(D):
                C[b + d] = C[prey_row + d]
        # follow
        b = (2 * N + i) * D
        best = -1
        for j in range(N):
            if j != i and _dist2(X, i, j, D) <= v2 and (best < 0 or fit[j] > fit[best]):
                best = j
        if best >= 0 and fit[best] / nf[i] > delta * fit[i]:
            _toward(X, i, D, X, best * D, step, uniform(s), C, b)
        else:
            for d in range(D):
                C[b + d] = C[prey_row + d]


@kernel(types.void(_F, _F, _F, _F, types.int64, types.int64), cache=True)
def afsa_select(X, fit, C, fitC, D, greedy):
    """Each fish takes its fittest behaviour's candidate (C, fitness fitC, rows as in
    ``afsa_propose``); with ``greedy`` only if that is at least as fit as where it is."""
    N = fit.size
    for i in range(N):
        k = i
        for r in (N + i, 2 * N + i):
            if fitC[r] > fitC[k]:
                k = r
        if not greedy or fitC[k] >= fit[i]:
            fit[i] = fitC[k]
            for d in range(D):
                X[i * D + d] = C[k * D + d]
