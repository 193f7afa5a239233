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
from numba import njit, types

from ..rng import STATE, normal, uniform

_F = types.float64[::1]
_I = types.int64[::1]


@njit(types.float64(_F, types.int64, types.int64, types.int64), cache=True, inline="always")
def _dist2(X, i, j, D):
    acc = 0.0
    for d in range(D):
        e = X[i * D + d] - X[j * D + d]
        acc += e * e
    return acc


@njit(types.void(_F, _F, types.int64, types.float64, types.float64, types.float64, _F, STATE),
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


@njit(types.void(_F, _F, types.int64, types.float64, types.float64, types.float64, _F, STATE),
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


@njit(types.int64(_F), cache=True)
def argmax(v):
    best = 0
    for i in range(1, v.size):
        if v[i] > v[best]:
            best = i
    return best


@njit(types.void(_F, _F, _F, _F, types.int64, types.int64, types.float64, types.float64,
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


@njit(types.int64(_F, _F, _F, _F, types.int64), cache=True)
def pso_accept(X, fit, P, Pfit, D):
    """Update the personal bests P (fitness Pfit) with the evaluated X; return the global best."""
    for i in range(fit.size):
        if fit[i] > Pfit[i]:
            Pfit[i] = fit[i]
            for d in range(D):
                P[i * D + d] = X[i * D + d]
    return argmax(Pfit)


@njit(types.void(_F, _F, _F, _F, _F, types.int64, types.int64, types.float64, types.float64,
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


@njit(types.int64(_F, _F, _F, _F, _F, _F, types.int64, types.float64, types.float64,
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


@njit(types.void(_F, _F, types.int64, types.float64, _F, _F), cache=True)
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


@njit(types.void(_F, types.int64, types.int64, _F, types.int64, types.float64, types.float64, _F,
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


@njit(types.void(_F, _F, _F, _F, _F, types.int64, types.float64, types.float64, types.float64,
                 types.int64, STATE, _F), cache=True)
def afsa_propose(X, fit, Xc, fitc, nf, D, visual, step, delta, tries, s, C):
    """Three candidates per fish (PAPERS.md section 2) into C (3 N D,): rows [0, N) prey,
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


@njit(types.void(_F, _F, _F, _F, types.int64, types.int64), cache=True)
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
