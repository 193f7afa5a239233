"""Swarm-intelligence moves for particles: firefly (FA), improved firefly (IFA), bat (BA),
particle swarm (PSO) and artificial fish swarm (AFSA).

The moves work on particles stored flat, X : (N * D,) in C order (particle i is X[i*D:(i+1)*D]),
and never call a model: a move either uses the fitness values it is given, or proposes candidate
positions that the caller evaluates before the matching ``*_accept``. So the same moves serve the
scalar filters here (D = 1, fitness = likelihood of the measurement) and robot poses in FastSLAM.
Fitness is positive and larger is better (the filters use the max-shifted likelihood in (0, 1]),
except IFA's brightness read as a distance, -d (``ifa_move``).
``swarm_move`` is the one dispatcher: it runs an iteration of any algorithm in phases and
returns, between them, what its caller evaluates (scratch: ``SwarmWork``).
Distances are Euclidean over the D coordinates (a caller with angles must wrap them itself); the
random steps take a per-coordinate unit ``scale`` (1 for a scalar state; FastSLAM passes the
spread of the predicted poses, so a heading is not stepped in metres).

Cost: the firefly moves compare every pair, O(N^2) per iteration; BA, PSO and AFSA's behaviours
are O(N) per iteration except AFSA's neighbourhoods, which are O(N^2) as well.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import types
from .._lazy import kernel

from ..rng import STATE, load_local, next_local, normal, store_local, uniform, unit
from ..schema import Key
from .weights import shifted_exp

# The swarm algorithms, one numbering for every kernel that moves particles with them (codes).
from ..codes import AFSA, ALGORITHMS, BA, BRIGHTNESS, FA, IFA, NO_SWARM, PSO  # noqa: F401
from ..codes import (BA_ACCEPT, BA_ACCEPT_FITTER_AND_LOUD, BA_WALK, BA_WALK_GAUSSIAN, MOVE_TOWARD,
                     PREY_FISH, PREY_RANDOM_POINT, PREY_TARGET, RANDOM_GAUSSIAN, RANDOM_TERMS,
                     RANDOM_UNIFORM_HALF, RANDOM_UNIFORM_SQRT3, TOWARD_BRIGHTER_ALL_AT_ONCE,
                     TOWARD_BRIGHTEST)


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
                         "our default)", min=0.0),
            **firefly_reading_keys()},
        "ba": {
            "freq_min": Key("float", 0.0, "lowest frequency"),
            "freq_max": Key("float", 1.0, "highest frequency"),
            "loudness": Key("float", 1.0, "initial loudness A0 (acceptance probability)", min=0.0),
            "pulse_rate": Key("float", 0.5, "pulse rate r0 (1 - r: chance of a local walk around "
                              "the best bat)", min=0.0, max=1.0),
            "loudness_decay": Key("float", 0.9, "A <- decay A on acceptance", min=0.0, max=1.0),
            "pulse_growth": Key("float", 0.9, "r <- r0 (1 - exp(-growth k)) at iteration k on "
                                "acceptance", min=0.0),
            "ba_accept": Key("choice", "fitter_and_loud", "which candidate a bat takes, with "
                             "probability its loudness A_i: 'fitter_and_loud' one fitter than the "
                             "bat itself (our reading, as Yang's demonstration code); "
                             "'better_than_best' one fitter than the best bat of the iteration "
                             "(Yang 2010's text: 'if (rand < A_i & f(x_i) < f(x*)) accept')",
                             choices=tuple(BA_ACCEPT)),
            "ba_walk": Key("choice", "gaussian_loudness", "the local walk around the best bat, "
                           "x_best + e mean(A) per coordinate: 'gaussian_loudness' e ~ N(0, 1) "
                           "(our reading, as Yang's demonstration code's randn); 'uniform' e ~ "
                           "U(-1, 1) (Yang 2010's text: 'x_new = x_old + epsilon A^t, epsilon in "
                           "[-1, 1]')", choices=tuple(BA_WALK))},
        "pso": {
            "inertia": Key("float", 0.7, "velocity inertia w", min=0.0),
            "c1": Key("float", 1.5, "pull toward the particle's own best", min=0.0),
            "c2": Key("float", 1.5, "pull toward the swarm's best", min=0.0)},
        "afsa": {
            "visual": Key("float", 1.0, f"visual range ({unit})", min=0.0, min_exclusive=True),
            "step": Key("float", 0.5, f"largest move per behaviour ({unit})", min=0.0),
            "crowding": Key("float", 0.618, "crowding factor delta", min=0.0),
            "tries": Key("int", 5, "prey: targets tried before a random step (afsa2014's text "
                         "tries one)", min=1),
            "greedy": Key("bool", True, "keep a fish where it is when no behaviour improves it"),
            "prey_target": Key("choice", "fish", "what the prey behaviour tries: 'fish' a random "
                               "other fish within the visual range (our reading); 'random_point' "
                               "a random point within it (afsa2014: 'select at random a state "
                               "X_j it can perceive, ||X_j - X_i|| < visual'), each try's points "
                               "one more likelihood evaluation per fish", choices=tuple(PREY_TARGET)),
            "converge": Key("bool", False, "false: 'iterations' iterations; true: repeat them "
                            "until an iteration moves no fish to a fitter place, at most "
                            "'iterations' times (afsa2014: 'repeat until the convergence condition "
                            "holds', which it does not state)")},
    }
    declared["ifa"] = {k: declared["fa"][k] for k in ("beta0", "gamma", "random_term",
                                                       "move_toward")}
    out = declared[algo]
    if prefix:
        from dataclasses import replace
        out = {k: replace(key, doc=f"{algo.upper()}: {key.doc}") for k, key in out.items()}
    return out


def firefly_reading_keys() -> dict:
    """The keys of the firefly moves' readings (FA and IFA): the random term's law and which
    fireflies a firefly moves toward."""
    return {
        "random_term": Key(
            "choice", "uniform_half", "the random term of a firefly move, per coordinate, times "
            "the step (FA's alpha, IFA's alpha_i) and the coordinate's unit: 'uniform_half' u - "
            "0.5, u ~ U(0, 1) (pfbench's reading of ifa2021's 'rand - 0.5'); 'uniform_sqrt3' "
            "U(-sqrt 3, sqrt 3) (ifa2021's words for rand: 'uniform, mean 0, variance 1', taken "
            "as the whole term); 'gaussian' N(0, 1); 'none' no random term",
            choices=tuple(RANDOM_TERMS)),
        "move_toward": Key(
            "choice", "brighter_in_place", "which fireflies a firefly moves toward: "
            "'brighter_in_place' every brighter one in turn, in place, so later fireflies see "
            "moved ones (pfbench's reading: Yang 2008's double loop; ifa2021 says only 'i is "
            "attracted by j and moves toward it'); 'brighter_all_at_once' every brighter one, "
            "each move computed from the positions at the iteration's start (Jacobi); "
            "'brightest' the brightest one only (the brightest does not move)",
            choices=tuple(MOVE_TOWARD))}


class SwarmParams(NamedTuple):
    """The swarm algorithms' parameters, one field per config key (``keys``); the fields of the
    algorithms a filter does not run are 0.0. FA: beta0, gamma, alpha; IFA: beta0, gamma and
    brightness (its kind, a code of codes.BRIGHTNESS, as a float); BA: freq_min, freq_max,
    loudness (A0), pulse_rate (r0), loudness_decay, pulse_growth, ba_accept and ba_walk (codes of
    codes.BA_ACCEPT and codes.BA_WALK); PSO: inertia (w), c1, c2; AFSA: visual, step, crowding
    (delta), tries, greedy (0 or 1), prey_target (a code of codes.PREY_TARGET) and converge (0 or
    1); FA and IFA: random_term and move_toward (codes of codes.RANDOM_TERMS and
    codes.MOVE_TOWARD); codes, counts and flags as floats (0.0, pfbench's reading, where a filter
    lacks the key)."""

    beta0: float
    gamma: float
    alpha: float
    brightness: float
    freq_min: float
    freq_max: float
    loudness: float
    pulse_rate: float
    loudness_decay: float
    pulse_growth: float
    inertia: float
    c1: float
    c2: float
    visual: float
    step: float
    crowding: float
    tries: float
    greedy: float
    random_term: float
    move_toward: float
    ba_accept: float
    ba_walk: float
    prey_target: float
    converge: float


SWARM_PARAMS = types.NamedUniTuple(types.float64, len(SwarmParams._fields), SwarmParams)

# The config keys each algorithm reads into its fields (IFA's brightness, and FA's and IFA's
# random_term and move_toward, where the filter has them: codes, ``swarm_params``).
_READS = {"fa": ("beta0", "gamma", "alpha"), "ifa": ("beta0", "gamma"),
          "ba": ("freq_min", "freq_max", "loudness", "pulse_rate", "loudness_decay",
                 "pulse_growth", "ba_accept", "ba_walk"),
          "pso": ("inertia", "c1", "c2"),
          "afsa": ("visual", "step", "crowding", "tries", "greedy", "prey_target", "converge")}
# The choice keys among them, read as their codes.
_CODES = {"ba_accept": BA_ACCEPT, "ba_walk": BA_WALK, "prey_target": PREY_TARGET}


def swarm_params(algo: str, params) -> SwarmParams:
    """The parameters (``SwarmParams``) the kernels read for swarm algorithm ``algo`` from a
    filter run's keys ``params``; every field ``algo`` does not read is 0.0 (all of them for an
    algorithm that is not a swarm's, e.g. FastSLAM's ``refine: none``)."""
    vals = dict.fromkeys(SwarmParams._fields, 0.0)
    for key in _READS.get(algo, ()):
        vals[key] = float(_CODES[key][params[key]] if key in _CODES else params[key])
    if algo == "ifa" and "brightness" in params:
        vals["brightness"] = float(BRIGHTNESS[params["brightness"]])
    if algo in ("fa", "ifa"):
        for key, codes in (("random_term", RANDOM_TERMS), ("move_toward", MOVE_TOWARD)):
            if key in params:
                vals[key] = float(codes[params[key]])
    return SwarmParams(**vals)


_F = types.float64[::1]
_I = types.int64[::1]


@kernel(types.float64(_F, types.int64, types.int64, types.int64), cache=True, inline="always")
def _dist2(X, i, j, D):
    acc = 0.0
    for d in range(D):
        e = X[i * D + d] - X[j * D + d]
        acc += e * e
    return acc


@kernel(types.int64(_F), cache=True)
def argmax(v):
    best = 0
    for i in range(1, v.size):
        if v[i] > v[best]:
            best = i
    return best


SQRT3 = math.sqrt(3.0)


@kernel(types.float64(types.int64, STATE), cache=True, inline="always")
def random_term(law, s):
    """One draw of a firefly move's random term of law ``law`` (codes.RANDOM_TERMS): u - 0.5,
    u ~ U(0, 1); U(-sqrt 3, sqrt 3); N(0, 1); or 0.0 without a draw (RANDOM_NONE)."""
    if law == RANDOM_UNIFORM_HALF:
        return uniform(s) - 0.5
    if law == RANDOM_UNIFORM_SQRT3:
        return SQRT3 * (2.0 * uniform(s) - 1.0)
    if law == RANDOM_GAUSSIAN:
        return normal(s)
    return 0.0


@kernel(types.float64(types.int64, types.uint64), cache=True, inline="always")
def uniform_term(law, r):
    """``random_term`` of a uniform law (codes.RANDOM_UNIFORM_HALF or RANDOM_UNIFORM_SQRT3) from
    64 random bits r, the value ``random_term`` draws from them."""
    u = unit(r)
    if law == RANDOM_UNIFORM_HALF:
        return u - 0.5
    return SQRT3 * (2.0 * u - 1.0)


@kernel(types.void(_F, _F, types.int64, types.float64, types.float64, types.float64,
                   types.float64, types.boolean, types.int64, types.int64, _F, STATE),
        cache=True, inline="always")
def _firefly(X, bright, D, beta0, gamma, alpha, R, adaptive, law, toward, scale, s):
    """The firefly moves, in place: each i toward the brighter j that ``toward`` picks
    (codes.MOVE_TOWARD), x_i += beta0 exp(-gamma r_ij^2) (x_j - x_i) + a scale e, e a draw of
    law ``law`` per coordinate, a = alpha, or exp(-R I_i / I_j) when ``adaptive``. In place (the
    default) r_ij and x_j - x_i are read from the positions as moved so far; all at once, from a
    copy made at the start; toward the brightest, j is the first of the brightest (which stays
    where it is). Draws go in the order (i, j, coordinate).

    For each i the brighter j are listed first, in order, without a branch (which half of the
    pairs take cannot be predicted), then moved toward one after another; a scalar state with a
    uniform random term keeps x_i and the generator's state in registers meanwhile. Each x_i's
    moves are a chain (every step reads the x_i the one before made), so the exponential's
    latency bounds them: 1.3 to 1.6 times faster than testing each pair in the loop at N = 50
    and 150, the same bits."""
    N = bright.size
    src = X.copy() if toward == TOWARD_BRIGHTER_ALL_AT_ONCE else X
    in_place = toward != TOWARD_BRIGHTER_ALL_AT_ONCE
    lo, hi = 0, N
    if toward == TOWARD_BRIGHTEST:
        lo = argmax(bright)
        hi = lo + 1
    js = np.empty(hi - lo, np.int64)
    fast = D == 1 and (law == RANDOM_UNIFORM_HALF or law == RANDOM_UNIFORM_SQRT3)
    for i in range(N):
        bi = bright[i]
        m = 0
        for j in range(lo, hi):
            js[m] = j
            m += bright[j] > bi
        if m == 0:
            continue
        if fast:
            q = load_local(s)
            xi = X[i]
            si = src[i]
            a = alpha
            sc = scale[0]
            for k in range(m):
                j = js[k]
                if in_place:
                    si = xi
                e = si - src[j]
                b = beta0 * math.exp(-gamma * (0.0 + e * e))
                if adaptive:
                    a = math.exp(-R * bi / bright[j])
                r, q = next_local(q)
                xi += b * (src[j] - si) + a * sc * uniform_term(law, r)
            X[i] = xi
            store_local(s, q)
            continue
        for k in range(m):
            j = js[k]
            b = beta0 * math.exp(-gamma * _dist2(src, i, j, D))
            a = math.exp(-R * bi / bright[j]) if adaptive else alpha
            for d in range(D):
                X[i * D + d] += (b * (src[j * D + d] - src[i * D + d])
                                 + a * scale[d] * random_term(law, s))


_MOVE = types.void(_F, _F, types.int64, types.float64, types.float64, types.float64, _F, STATE,
                   types.int64, types.int64)


@kernel(_MOVE, cache=True)
def fa_move(X, bright, D, beta0, gamma, alpha, scale, s, law, toward):
    """Firefly move (Yang 2008), in place: each i moves toward every brighter j,
    x_i += beta0 exp(-gamma r_ij^2) (x_j - x_i) + alpha scale (u - 0.5), u ~ U(0, 1) per
    coordinate; scale (D,) gives each coordinate's unit for the random step. ``law`` and
    ``toward`` (codes.RANDOM_TERMS, codes.MOVE_TOWARD; 0 and 0 as written here) choose the random
    term and which fireflies it moves toward (``_firefly``). O(N^2)."""
    _firefly(X, bright, D, beta0, gamma, alpha, 0.0, False, law, toward, scale, s)


@kernel(_MOVE, cache=True)
def ifa_move(X, bright, D, beta0, gamma, R, scale, s, law, toward):
    """Improved firefly move (ifa2021): like ``fa_move`` with the adaptive step
    alpha_i = exp(-R I_i / I_j) toward the brighter firefly j. O(N^2).

    A brightness that is a distance d (smaller brighter) comes as I = -d: j brighter than i is
    -d_j > -d_i, and I_i / I_j = d_i / d_j, at least 1, so the step is at most exp(-R) (0 toward a
    firefly at distance 0)."""
    _firefly(X, bright, D, beta0, gamma, 0.0, R, True, law, toward, scale, s)


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
                 _F, types.int64, STATE), cache=True)
def ba_propose(X, V, A, r, C, D, g, fmin, fmax, scale, walk, s):
    """Bat algorithm (Yang 2010) candidates C (N*D,): frequency f = fmin + (fmax - fmin) u,
    v += (x - x_best) f, c = x + v; with probability 1 - r_i a local walk
    c = x_best + e mean(A) scale instead, per coordinate e ~ N(0, 1) (``walk`` BA_WALK_GAUSSIAN)
    or e ~ U(-1, 1) (BA_WALK_UNIFORM). The caller evaluates C and calls ``ba_accept``."""
    N = A.size
    meanA = A.sum() / N
    for i in range(N):
        fr = fmin + (fmax - fmin) * uniform(s)
        local = uniform(s) > r[i]
        for d in range(D):
            k = i * D + d
            V[k] += (X[k] - X[g * D + d]) * fr
            if not local:
                C[k] = X[k] + V[k]
            elif walk == BA_WALK_GAUSSIAN:
                C[k] = X[g * D + d] + meanA * scale[d] * normal(s)
            else:
                C[k] = X[g * D + d] + meanA * scale[d] * (2.0 * uniform(s) - 1.0)


@kernel(types.int64(_F, _F, _F, _F, _F, _F, types.int64, types.float64, types.float64,
                  types.float64, types.int64, types.int64, STATE), cache=True)
def ba_accept(X, fit, C, fitc, A, r, D, alpha, gamma, r0, it, rule, s):
    """Accept candidate i when u < A_i and it is fitter than bat i (``rule``
    BA_ACCEPT_FITTER_AND_LOUD) or than the fittest bat before this pass
    (BA_ACCEPT_BETTER_THAN_BEST; u is drawn only for a candidate that passes the fitness test);
    then A_i *= alpha and r_i = r0 (1 - exp(-gamma it)). Returns the index of the fittest bat."""
    best = fit[argmax(fit)]
    for i in range(fit.size):
        bar = fit[i] if rule == BA_ACCEPT_FITTER_AND_LOUD else best
        if fitc[i] > bar and uniform(s) < A[i]:
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
                 types.int64, types.int64, _F, _F, STATE, _F), cache=True)
def afsa_propose(X, fit, Xc, fitc, nf, D, visual, step, delta, tries, prey, Xp, found, s, C):
    """Three candidates per fish (afsa2014's prey, swarm and follow) into C (3 N D,): rows [0, N) prey,
    [N, 2N) swarm, [2N, 3N) follow.

    prey: with ``prey`` PREY_FISH, up to ``tries`` random neighbours j within visual, a random
        fraction of ``step`` toward the first fitter one; with PREY_RANDOM_POINT, toward the
        fitter random point Xp[i] its tries found (found[i] = 1, ``afsa_prey_check``); else a
        random step of length <= step;
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
        if prey == PREY_FISH:
            for _ in range(tries):
                j = int(uniform(s) * N)
                if j != i and _dist2(X, i, j, D) <= v2 and fit[j] > fit[i]:
                    _toward(X, i, D, X, j * D, step, uniform(s), C, i * D)
                    done = True
                    break
        elif found[i] > 0.0:
            _toward(X, i, D, Xp, i * D, step, uniform(s), C, i * D)
            done = True
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


@kernel(types.void(_F, types.int64, types.float64, _F, _F, STATE), cache=True)
def afsa_prey_points(X, D, visual, found, Xq, s):
    """One try of the prey behaviour toward a random point (PREY_RANDOM_POINT): for each fish i
    that has not found a fitter point (found[i] = 0), Xq[i] (Xq (N D,)) a point drawn uniformly
    from the ball of radius ``visual`` around x_i (a direction of D normal draws, a radius visual
    u^(1/D)); the others' rows are x_i itself. The caller evaluates Xq."""
    N = found.size
    for i in range(N):
        if found[i] > 0.0:
            for d in range(D):
                Xq[i * D + d] = X[i * D + d]
            continue
        n2 = 0.0
        for d in range(D):
            Xq[i * D + d] = normal(s)
            n2 += Xq[i * D + d] * Xq[i * D + d]
        n = math.sqrt(n2)
        rad = visual * uniform(s) ** (1.0 / D)
        for d in range(D):
            Xq[i * D + d] = X[i * D + d] + (rad * Xq[i * D + d] / n if n > 0 else 0.0)


@kernel(types.int64(_F, _F, _F, _F, _F, types.int64), cache=True)
def afsa_prey_check(ll, llq, Xq, Xp, found, D):
    """After a try of ``afsa_prey_points``: each fish still looking whose point Xq[i] is likelier
    than itself (llq[i] > ll[i], log-likelihoods) keeps it as its target Xp[i], found[i] = 1.
    Returns the fish still looking."""
    left = 0
    for i in range(found.size):
        if found[i] > 0.0:
            continue
        if llq[i] > ll[i]:
            found[i] = 1.0
            for d in range(D):
                Xp[i * D + d] = Xq[i * D + d]
        else:
            left += 1
    return left


@kernel(types.int64(_F, _F, _F, _F, types.int64, types.int64), cache=True)
def afsa_select(X, fit, C, fitC, D, greedy):
    """Each fish takes its fittest behaviour's candidate (C, fitness fitC, rows as in
    ``afsa_propose``); with ``greedy`` only if that is at least as fit as where it is. Returns the
    fish that moved to a strictly fitter place."""
    N = fit.size
    better = 0
    for i in range(N):
        k = i
        for r in (N + i, 2 * N + i):
            if fitC[r] > fitC[k]:
                k = r
        if fitC[k] > fit[i]:
            better += 1
        if not greedy or fitC[k] >= fit[i]:
            fit[i] = fitC[k]
            for d in range(D):
                X[i * D + d] = C[k * D + d]
    return better


# --- the dispatcher: one swarm iteration, its fitness evaluated by the caller between phases ------

class SwarmWork(NamedTuple):
    """Scratch of the swarm moves over N particles of D coordinates (flat, as the moves take
    them), the log-likelihoods kept up to date by the caller (``swarm_move``)."""

    ll: np.ndarray      # (N,) the particles' log-likelihood (their fitness)
    fit: np.ndarray     # (N,) their fitness or brightness, in (0, 1]
    V: np.ndarray       # (N D,) BA and PSO velocities
    P: np.ndarray       # (N D,) PSO: each particle's best position
    Pfit: np.ndarray    # (N,) PSO: its log-likelihood
    A: np.ndarray       # (N,) BA loudness
    r: np.ndarray       # (N,) BA pulse rate
    C: np.ndarray       # (3 N D,) candidates: BA's N, AFSA's three behaviours' 3 N
    llC: np.ndarray     # (3 N,) their log-likelihood
    fitC: np.ndarray    # (3 N,) their fitness (AFSA_FISH_SHIFT)
    Xc: np.ndarray      # (N D,) AFSA: the neighbourhoods' centres
    llc: np.ndarray     # (N,) their log-likelihood
    fitc: np.ndarray    # (N,) their fitness
    nf: np.ndarray      # (N,) AFSA: neighbours of each fish
    scale: np.ndarray   # (D,) each coordinate's unit for the random steps (1 for a scalar)
    mean: np.ndarray    # (D,) the origin of the particles in units of scale
    Xu: np.ndarray      # (N D,) the particles in those units, mean + scale Xu (a caller's AFSA)
    Xp: np.ndarray      # (N D,) AFSA's prey toward a random point: the fitter point each fish found
    found: np.ndarray   # (N,) 1 where it found one
    ctl: np.ndarray     # (2,) AFSA: [0] the phase its prey's tries ended (-1: still trying);
                        # [1] 1 once an iteration moved no fish to a fitter place (converge)


SWARM_WORK = types.NamedUniTuple(_F, 20, SwarmWork)


@kernel(SWARM_WORK(types.int64, types.int64), cache=True)
def new_swarm_work(N, D):
    """The scratch of N particles of D coordinates: unit scale, origin 0."""
    return SwarmWork(np.empty(N), np.empty(N), np.empty(N * D), np.empty(N * D), np.empty(N),
                     np.empty(N), np.empty(N), np.empty(3 * N * D), np.empty(3 * N),
                     np.empty(3 * N), np.empty(N * D), np.empty(N), np.empty(N), np.empty(N),
                     np.ones(D), np.zeros(D), np.empty(N * D), np.empty(N * D), np.empty(N),
                     np.zeros(2))


# What ``swarm_move`` asks its caller to evaluate before it calls it again (the caller's fitness:
# a model's likelihood of the measurement, a pose's under its particle's map).
DONE = 0                # the iteration is over
FIT_X = 1               # the particles X: their log-likelihood into wk.ll
FIT_CANDIDATES = 2      # BA's N candidates wk.C[:N D]: into wk.llC[:N]
FIT_CENTRES = 3         # AFSA's centres wk.Xc: into wk.llc
FIT_BEHAVIOURS = 4      # AFSA's 3 N candidates wk.C: into wk.llC
FIT_BRIGHTNESS = 5      # IFA's brightness of X, into wk.fit from wk.ll (the caller's distance)

# AFSA's two arithmetics of fitness (``afsa_joint_shift``, ``afsa_fish_shift``)
AFSA_JOINT_SHIFT = 0
AFSA_FISH_SHIFT = 1


@kernel(types.int64(types.int64, types.int64), cache=True)
def evaluations(request, N):
    """The likelihood evaluations a request of ``swarm_move`` costs over N particles."""
    if request == FIT_BEHAVIOURS:
        return 3 * N
    return N if request != FIT_BRIGHTNESS and request != DONE else 0


@kernel(types.int64(types.int64, _F, types.int64, SWARM_PARAMS, SWARM_WORK, STATE), cache=True,
        inline="always")
def afsa_joint_shift(phase, X, D, p, wk, s):
    """AFSA's iteration with one shift for the fish and their centres, the largest of both
    log-likelihoods (a centre can be far likelier than every fish when the noise is small: no
    fitness overflows), and the choice among the behaviours on the log-likelihoods (exact where
    exp(ll - M) would underflow to a tie at 0): the scalar swarm PFs."""
    if phase == 0:
        afsa_centres(X, wk.fit, D, p.visual, wk.Xc, wk.nf)
        return FIT_CENTRES
    if phase == 1:
        M = wk.ll.max()
        M = max(M, wk.llc.max())
        shifted_exp(wk.ll, M, wk.fit)
        shifted_exp(wk.llc, M, wk.fitc)
        afsa_propose(X, wk.fit, wk.Xc, wk.fitc, wk.nf, D, p.visual, p.step, p.crowding,
                     int(p.tries), int(p.prey_target), wk.Xp, wk.found, s, wk.C)
        return FIT_BEHAVIOURS
    if afsa_select(X, wk.ll, wk.C, wk.llC, D, int(p.greedy)) == 0:
        wk.ctl[1] = 1.0
    return DONE


@kernel(types.int64(types.int64, _F, types.int64, SWARM_PARAMS, SWARM_WORK, STATE), cache=True,
        inline="always")
def afsa_fish_shift(phase, X, D, p, wk, s):
    """AFSA's iteration with the fish's largest log-likelihood M0 as the one shift of every
    fitness (fish, centres, candidates) and the choice among the behaviours on those fitnesses;
    the fish's log-likelihoods are then log(fit) + M0 (-inf where it underflowed): FastSLAM's
    refinement."""
    M0 = wk.ll.max()
    if phase == 0:
        shifted_exp(wk.ll, M0, wk.fit)
        afsa_centres(X, wk.fit, D, p.visual, wk.Xc, wk.nf)
        return FIT_CENTRES
    if phase == 1:
        shifted_exp(wk.llc, M0, wk.fitc)
        afsa_propose(X, wk.fit, wk.Xc, wk.fitc, wk.nf, D, p.visual, p.step, p.crowding,
                     int(p.tries), int(p.prey_target), wk.Xp, wk.found, s, wk.C)
        return FIT_BEHAVIOURS
    shifted_exp(wk.llC, M0, wk.fitC)
    if afsa_select(X, wk.fit, wk.C, wk.fitC, D, int(p.greedy)) == 0:
        wk.ctl[1] = 1.0
    for i in range(wk.ll.size):
        wk.ll[i] = math.log(wk.fit[i]) + M0 if wk.fit[i] > 0.0 else -np.inf
    return DONE


@kernel(types.int64(types.int64, _F, types.int64, SWARM_PARAMS, SWARM_WORK, STATE), cache=True,
        inline="always")
def afsa_prey_tries(phase, X, D, p, wk, s):
    """The tries of AFSA's prey toward a random point (PREY_RANDOM_POINT), the first phases of its
    iteration: each asks FIT_CENTRES for the points ``afsa_prey_points`` drew into wk.Xc (N
    evaluations), the next keeps the fitter ones (``afsa_prey_check``); after p.tries tries, or
    once every fish found a fitter point, DONE, wk.ctl[0] the phase it ended at."""
    if phase == 0:
        wk.found[:] = 0.0
        wk.ctl[0] = -1.0
    elif wk.ctl[0] < 0.0:
        left = afsa_prey_check(wk.ll, wk.llc, wk.Xc, wk.Xp, wk.found, D)
        if left == 0 or phase >= int(p.tries):
            wk.ctl[0] = float(phase)
            return DONE
    else:
        return DONE
    afsa_prey_points(X, D, p.visual, wk.found, wk.Xc, s)
    return FIT_CENTRES


@kernel(types.int64(types.int64, types.int64, types.int64, _F, types.int64, SWARM_PARAMS,
                    types.float64, types.int64, SWARM_WORK, STATE), cache=True, inline="always")
def swarm_move(algo, afsa, phase, X, D, p, R, it, wk, s):
    """Phase ``phase`` (0, 1, ...) of iteration ``it`` of the swarm algorithm ``algo`` (parameters
    p, a ``SwarmParams``; IFA's R: the measurement variance in its adaptive step) over the
    particles X (N D,), whose log-likelihoods wk.ll are up to date; ``afsa`` picks AFSA's arithmetic
    (AFSA_JOINT_SHIFT or AFSA_FISH_SHIFT). Returns what the caller evaluates before it calls
    phase + 1 (FIT_X, FIT_CANDIDATES, FIT_CENTRES, FIT_BEHAVIOURS, FIT_BRIGHTNESS), or DONE.

    FA: fitness exp(ll - max ll), move, FIT_X. IFA: FIT_BRIGHTNESS, move, FIT_X. BA: propose,
    FIT_CANDIDATES, accept. PSO: propose, FIT_X, keep the bests. AFSA: centres, FIT_CENTRES,
    propose, FIT_BEHAVIOURS, select; with its prey toward a random point, first the tries
    (``afsa_prey_tries``: FIT_CENTRES each); with p.converge, an iteration after one that moved
    no fish to a fitter place is DONE at once (no draws, no evaluations).

    Inlined into its caller (call it from one place, in a loop over the phases): the moves then
    see the caller's D as a constant, and their loops over the coordinates compile away (a
    scalar AFSA-PF ran 1.7 times slower with D a run-time argument)."""
    N = wk.ll.size
    if algo == FA:
        if phase == 0:
            shifted_exp(wk.ll, wk.ll.max(), wk.fit)
            fa_move(X, wk.fit, D, p.beta0, p.gamma, p.alpha, wk.scale, s, int(p.random_term),
                    int(p.move_toward))
            return FIT_X
        return DONE
    if algo == IFA:
        if phase == 0:
            return FIT_BRIGHTNESS
        if phase == 1:
            ifa_move(X, wk.fit, D, p.beta0, p.gamma, R, wk.scale, s, int(p.random_term),
                     int(p.move_toward))
            return FIT_X
        return DONE
    if algo == BA:
        if phase == 0:
            if it == 0:
                wk.V[:] = 0.0
                wk.A[:] = p.loudness
                wk.r[:] = p.pulse_rate
            ba_propose(X, wk.V, wk.A, wk.r, wk.C[:N * D], D, argmax(wk.ll), p.freq_min,
                       p.freq_max, wk.scale, int(p.ba_walk), s)
            return FIT_CANDIDATES
        ba_accept(X, wk.ll, wk.C[:N * D], wk.llC[:N], wk.A, wk.r, D, p.loudness_decay,
                  p.pulse_growth, p.pulse_rate, it + 1, int(p.ba_accept), s)
        return DONE
    if algo == PSO:
        if phase == 0:
            if it == 0:
                wk.V[:] = 0.0
                wk.P[:] = X
                wk.Pfit[:] = wk.ll
            pso_propose(X, wk.V, wk.P, wk.Pfit, D, argmax(wk.Pfit), p.inertia, p.c1, p.c2, s)
            return FIT_X
        pso_accept(X, wk.ll, wk.P, wk.Pfit, D)
        return DONE
    if phase == 0 and it == 0:
        wk.ctl[1] = 0.0
    if phase == 0 and p.converge > 0.0 and wk.ctl[1] > 0.0:
        return DONE
    if p.prey_target == PREY_RANDOM_POINT:
        request = afsa_prey_tries(phase, X, D, p, wk, s)
        if request != DONE:
            return request
        phase -= int(wk.ctl[0])
    if afsa == AFSA_JOINT_SHIFT:
        return afsa_joint_shift(phase, X, D, p, wk, s)
    return afsa_fish_shift(phase, X, D, p, wk, s)
