"""The trap suite: the known traps of particle-filter code, each a named check run on every
registered filter, plug-ins and pfbench's own alike (``pfbench check``).

Each trap gives each filter one ``TrapResult``: kept, broken (one line saying what went wrong), or
not applicable (one line saying why: a filter without particles has no weights to underflow).

- ``resampling-ulp``: weights that sum to 1 +- k ulp (k = 1 .. 64) into every scheme of
  pfbench.resampling the filter's ``resampling`` key offers, with the sum the weights have and
  with 1.0: every ancestor index in [0, N), never one of a zero weight, the counts summing to N.
- ``resampling-one-hot``: one weight 1 and the rest 0 into the same schemes: every ancestor is
  that particle.
- ``particles-1-2``: N = 1 and N = 2 particles: the run gives finite headline metrics, or the
  experiment is refused at validation with a one-line error.
- ``log-weights-all-inf``: one measurement so far outside the model (1e200) that every particle's
  log-weight is -inf at that step: finite headline metrics and a counted underflow step
  (``underflow_steps``), never NaN or an exception.
- ``log-weights-far-below-0``: one measurement far from every particle but not impossible, so that
  the log-weights are finite but all far below exp's underflow (like [-1000, -1001]): finite
  headline metrics and no underflow step counted (the weights are normalised from their largest,
  never 0 / 0).
- ``resample-every-ess-never``: on linear_gaussian, resampling every step, when the ESS falls
  below N / 5, and never, each against the Kalman filter (``kf``) on the same data: each mode's
  RMSE within Monte Carlo error of the Kalman filter's (weights overwritten instead of multiplied
  between resamplings fail this).
- ``rotated-world``: (localization and SLAM kinds) the generated world (pfbench.contract.world)
  and the same world turned by pi, so that headings and bearings cross +-pi: the headline metrics
  agree within Monte Carlo error (bit for bit where the arithmetic allows it: said so).
- ``kld-bound``: (filters with ``sampling: kld``) the KLD-sampling bound of pfbench
  (pfbench.filters.mcl.kld_count) at k = 1 (0 particles) and at k up to 10^6 against its closed
  form (Fox 2003, the Wilson-Hilferty form, and the chi-square quantile for large k); the filter
  run with every particle in one histogram bin (k = 1) and with bins so small that every particle
  has its own: finite headline metrics.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from .codes import SCHEME_CODES
from .errors import UserError

KEPT, BROKEN, NOT_APPLICABLE = "kept", "broken", "n/a"


@dataclass
class TrapResult:
    """What a trap found on a filter: ``status`` KEPT, BROKEN or NOT_APPLICABLE, ``detail`` one
    line (what broke, why it does not apply, or a note on how it was kept)."""

    trap: str
    filter: str
    status: str
    detail: str = ""

    def line(self) -> str:
        return f"trap {self.trap}: filter {self.filter}: " + {
            KEPT: "kept", BROKEN: "BROKEN", NOT_APPLICABLE: "does not apply"}[self.status] + (
            f": {self.detail}" if self.detail else "")


class _Broken(Exception):
    """A trap's check failed: its message is the finding's line."""


def _one_line(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {' '.join(str(exc).split())}"


# ---------------------------------------------------------------- helpers shared by the traps

def scenario_for(name: str, kinds=None) -> str | None:
    """The first registered scenario filter ``name`` runs on (FilterType.cannot_run_on), of one of
    ``kinds`` when given."""
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    ft = FILTERS[name]
    for s, mod in SCENARIOS.items():
        if (kinds is None or mod.KIND in kinds) and ft.cannot_run_on(s, mod.KIND, mod) is None:
            return s
    return None


def _experiment(name: str, scenario: str, spec=None, scen=None, trials=1, others=None):
    from .contract import Probe, experiment
    return experiment(Probe(name, scenario), scenario=scen, spec=spec, trials=trials,
                      others=others)


def _rows(exp, trial: int, mutate: Callable | None = None) -> list[dict]:
    """The metric rows of trial ``trial`` of ``exp``, its data changed by ``mutate`` first."""
    from .diagnostics import plan as plan_diagnostics
    from .runner import checked_output, metrics_of, run_filter, trial_data
    model, truth, data = trial_data(exp, trial)
    if mutate is not None:
        data = mutate(data)
    diag = plan_diagnostics(exp).for_trial(False)
    rows = []
    for run in exp.filters:
        out, _ = run_filter(exp, trial, run, model, data, diag)
        out = checked_output(exp, trial, run, model, truth, data, out)
        rows.append({"filter": run.key, **metrics_of(exp, model, truth, out)})
    return rows


def _headline(exp, row: dict, what: str) -> None:
    from .kinds import kind_of
    for m in kind_of(exp.scenario).headline:
        v = row.get(m)
        if not isinstance(v, (int, float)) or not math.isfinite(v):
            raise _Broken(f"{what}: {m} is {v!r}, expected a finite number")


def _choices(name: str, key: str) -> tuple:
    from .filters import FILTERS
    k = FILTERS[name].schema.get(key)
    return tuple(k.choices) if k is not None and k.kind == "choice" and k.choices else ()


# ---------------------------------------------------------------- resampling traps

ULPS = (1, 2, 4, 16, 64)
SIZES = (1, 2, 3, 7, 100, 1000)


def _schemes(name: str) -> tuple[list[str], str]:
    """The schemes of pfbench.resampling the filter's 'resampling' key offers, or ([], why)."""
    from .resampling import SCHEMES
    got = _choices(name, "resampling")
    if not got:
        return [], "no 'resampling' key: it picks no scheme of pfbench.resampling"
    ours = [c for c in got if c in SCHEMES]
    if not ours:
        return [], f"its 'resampling' offers only {', '.join(got)}: no scheme of " \
                   "pfbench.resampling"
    return ours, ""


def _ancestors(scheme: str, w: np.ndarray, S: float, state) -> np.ndarray:
    from . import resampling
    idx = np.full(w.size, -1, dtype=np.int64)
    resampling.resample(SCHEME_CODES[scheme], w, S, state, idx)
    return idx


def _check_ancestors(idx, w, what: str) -> None:
    N = w.size
    if idx.min() < 0 or idx.max() >= N:
        raise _Broken(f"{what}: ancestor index {int(idx.min() if idx.min() < 0 else idx.max())}"
                      f" outside [0, {N})")
    counts = np.bincount(idx, minlength=N)
    if counts.sum() != N:
        raise _Broken(f"{what}: the counts sum to {counts.sum()}, not N = {N}")
    if (counts[w == 0] > 0).any():
        raise _Broken(f"{what}: picked particle {int(np.flatnonzero((counts > 0) & (w == 0))[0])}"
                      " of weight 0")


def trap_resampling_ulp(name: str) -> TrapResult:
    from .rng import state_from_seed
    schemes, why = _schemes(name)
    if not schemes:
        return TrapResult("resampling-ulp", name, NOT_APPLICABLE, why)
    rng = np.random.default_rng(33)
    eps = np.finfo(float).eps
    for scheme in schemes:
        for N in SIZES:
            base = rng.dirichlet(np.ones(N)) if N > 1 else np.ones(1)
            base[N // 2] = 0.0 if N > 2 else base[N // 2]   # one zero weight
            base /= base.sum()
            for k in ULPS:
                for sign in (1, -1):
                    w = base * (1.0 + sign * k * eps)
                    for S in (float(w.sum()), 1.0):
                        state = state_from_seed(np.random.SeedSequence([33, N, k]))
                        what = (f"{scheme}, N = {N}, weights summing to 1 {'+-'[sign < 0]} {k} "
                                f"ulp, S = {S!r}")
                        try:
                            idx = _ancestors(scheme, w, S, state)
                        except _Broken:
                            raise
                        except Exception as exc:
                            raise _Broken(f"{what}: raised {_one_line(exc)}") from None
                        _check_ancestors(idx, w, what)
    return TrapResult("resampling-ulp", name, KEPT, f"schemes {', '.join(schemes)}")


def trap_resampling_one_hot(name: str) -> TrapResult:
    from .rng import state_from_seed
    schemes, why = _schemes(name)
    if not schemes:
        return TrapResult("resampling-one-hot", name, NOT_APPLICABLE, why)
    for scheme in schemes:
        for N in SIZES:
            for j in sorted({0, N // 2, N - 1}):
                w = np.zeros(N)
                w[j] = 1.0
                what = f"{scheme}, N = {N}, weight 1 at particle {j}, the rest 0"
                try:
                    idx = _ancestors(scheme, w, 1.0, state_from_seed(np.random.SeedSequence(j)))
                except Exception as exc:
                    raise _Broken(f"{what}: raised {_one_line(exc)}") from None
                _check_ancestors(idx, w, what)
                if (idx != j).any():
                    raise _Broken(f"{what}: ancestors {sorted(set(idx.tolist()))[:5]}, "
                                  f"expected all {j}")
    return TrapResult("resampling-one-hot", name, KEPT, f"schemes {', '.join(schemes)}")


# ---------------------------------------------------------------- particle counts

def trap_particles_1_2(name: str) -> TrapResult:
    from .filters import FILTERS
    if not FILTERS[name].particles:
        return TrapResult("particles-1-2", name, NOT_APPLICABLE, "a filter without particles")
    scen = scenario_for(name)
    if scen is None:
        return TrapResult("particles-1-2", name, NOT_APPLICABLE, "no registered scenario it runs on")
    notes = []
    for n in (1, 2):
        try:
            exp = _experiment(name, scen, spec={"particles": n})
        except UserError as exc:
            text = str(exc)
            if "\n" in text.strip():
                raise _Broken(f"N = {n} on {scen}: refused at validation in "
                              f"{len(text.strip().splitlines())} lines, not one") from None
            notes.append(f"N = {n} refused at validation")
            continue
        row = _run_guarded(exp, 0, None, f"N = {n} on {scen}")[0]
        _headline(exp, row, f"N = {n} on {scen}")
        notes.append(f"N = {n} runs")
    return TrapResult("particles-1-2", name, KEPT, f"on {scen}: {'; '.join(notes)}")


def _run_guarded(exp, trial, mutate, what: str) -> list[dict]:
    try:
        return _rows(exp, trial, mutate)
    except Exception as exc:
        from .runner import FilterError
        cause = exc.cause if isinstance(exc, FilterError) and exc.cause is not None else exc
        raise _Broken(f"{what}: raised {_one_line(cause)}") from None


# ---------------------------------------------------------------- log-weights

def _far_step(data, kind: str) -> int | None:
    """A step of ``data`` with a measurement to move: the middle one (scalar), else the middle
    step with an observation."""
    if kind == "scalar":
        return len(data) // 2
    seen = np.flatnonzero(np.asarray(data.obs_n) > 0)
    return int(seen[len(seen) // 2]) if seen.size else None


def _moved(kind: str, to: float | None = None, by: float | None = None):
    """A function of a trial's data that moves one measurement (see _far_step) to ``to`` or by
    ``by`` (the range of every observation of that step, for the robot kinds)."""
    def mutate(data):
        t = _far_step(data, kind)
        if t is None:
            raise _Broken("the generated trial has no observation to move")
        if kind == "scalar":
            y = np.array(data, dtype=float)
            y[t] = to if to is not None else y[t] + by
            return y
        z = np.array(data.obs_z, dtype=float)
        n = int(data.obs_n[t])
        z[t, :n, 0] = to if to is not None else z[t, :n, 0] + by
        return data._replace(obs_z=z) if hasattr(data, "_replace") else _replaced(data, z)
    return mutate


def _replaced(data, z):
    import copy
    import dataclasses
    if dataclasses.is_dataclass(data):
        return dataclasses.replace(data, obs_z=z)
    out = copy.copy(data)
    object.__setattr__(out, "obs_z", z)
    return out


def _weights_scenario(name: str, trap: str):
    from .filters import FILTERS
    from .kinds import kind_of
    if not FILTERS[name].particles:
        return None, None, TrapResult(trap, name, NOT_APPLICABLE, "a filter without particles "
                                   "has no log-weights")
    scen = scenario_for(name)
    if scen is None:
        return None, None, TrapResult(trap, name, NOT_APPLICABLE, "no registered scenario it runs "
                                   "on")
    return scen, kind_of(scen).name, None


def trap_all_inf(name: str) -> TrapResult:
    trap = "log-weights-all-inf"
    scen, kind, na = _weights_scenario(name, trap)
    if na:
        return na
    exp = _experiment(name, scen)
    what = f"on {scen}, one measurement moved to 1e200"
    row = _run_guarded(exp, 0, _moved(kind, to=1e200), what)[0]
    _headline(exp, row, what)
    u = row.get("underflow_steps", 0)
    if kind == "slam":
        # a SLAM filter may take a far observation for a new landmark: finite is the contract
        return TrapResult(trap, name, KEPT, f"{what}: finite; {u:g} underflow step(s) counted (a "
                       "SLAM filter may take the far observation for a new landmark)")
    if not u >= 1:
        raise _Broken(f"{what}: finite, but no underflow step counted (underflow_steps {u!r})")
    return TrapResult(trap, name, KEPT, f"{what}: finite, {u:g} underflow step(s) counted")


FAR = (45.0, 100.0, 1000.0)     # how far (in the measurement's units) the measurement moves


def trap_far_below(name: str) -> TrapResult:
    trap = "log-weights-far-below-0"
    scen, kind, na = _weights_scenario(name, trap)
    if na:
        return na
    exp = _experiment(name, scen)
    for d in FAR:
        what = f"on {scen}, one measurement moved by {d:g}"
        row = _run_guarded(exp, 0, _moved(kind, by=d), what)[0]
        _headline(exp, row, what)
        u = row.get("underflow_steps", 0)
        if u and kind != "slam":
            raise _Broken(f"{what}: {u:g} underflow step(s) counted for finite log-weights "
                          "(weights not normalised from the largest?)")
    return TrapResult(trap, name, KEPT, f"on {scen}, one measurement moved by "
                   f"{', '.join(f'{d:g}' for d in FAR)}: finite, no underflow")


# ---------------------------------------------------------------- resampling modes against the KF

MODES = {"every step": {"resample": "always"},
         "ESS-gated": {"resample": "neff", "neff_ratio": 0.2},
         "never": {"resample": "neff", "neff_ratio": 1e-12}}
KF_TRIALS, KF_PARTICLES, KF_STEPS = 40, 1000, 12
Z = 4.0             # Monte Carlo error allowed, in standard errors of the paired difference
SLACK = 0.05        # and the particle filter's own excess over the optimum, relative


def trap_resample_modes(name: str) -> TrapResult:
    from .filters import FILTERS
    from .scenarios import SCENARIOS
    trap = "resample-every-ess-never"
    ft = FILTERS[name]
    if not {"always", "neff"} <= set(_choices(name, "resample")) or "neff_ratio" not in ft.schema:
        return TrapResult(trap, name, NOT_APPLICABLE, "no 'resample' key with 'always' and 'neff' "
                       "and a 'neff_ratio'")
    if "linear_gaussian" not in SCENARIOS or "kf" not in FILTERS:
        return TrapResult(trap, name, NOT_APPLICABLE, "needs the scenario linear_gaussian and the "
                       "filter kf")
    mod = SCENARIOS["linear_gaussian"]
    why = ft.cannot_run_on("linear_gaussian", mod.KIND, mod)
    if why:
        return TrapResult(trap, name, NOT_APPLICABLE, f"does not run on linear_gaussian: {why}")
    # a filter whose cost grows as N^2 (the swarm PFs) gets fewer particles
    n = KF_PARTICLES if ft.cost == "N" else KF_PARTICLES // 5
    excess = {}
    for mode, keys in MODES.items():
        exp = _experiment(name, "linear_gaussian", spec={"particles": n, **keys},
                          scen={"steps": KF_STEPS}, trials=KF_TRIALS, others={"kf": {}})
        d = []
        for k in range(KF_TRIALS):
            rows = _run_guarded(exp, k, None, f"resampling {mode}")
            d.append((rows[0]["rmse"], rows[-1]["rmse"]))      # the filter's, the KF's
        pf, kf = np.array(d).T
        if not np.isfinite(pf).all():
            raise _Broken(f"resampling {mode}: RMSE {pf.tolist()} on linear_gaussian")
        excess[mode] = pf - kf
    # Resampling every step resets the weights each step, so it cannot overwrite them: its excess
    # over the Kalman filter is the filter's own (a swarm move, say); the other modes may add
    # none beyond Monte Carlo error.
    base = excess["every step"]
    notes = [f"every step {base.mean():+.3f}"]
    for mode in ("ESS-gated", "never"):
        diff = excess[mode] - base
        se = diff.std(ddof=1) / math.sqrt(len(diff))
        if diff.mean() > Z * se + SLACK * kf.mean():
            raise _Broken(f"resampling {mode}: RMSE {excess[mode].mean():+.4f} against the Kalman "
                          f"filter's {kf.mean():.4f}, resampling every step {base.mean():+.4f} "
                          f"(allowed {Z:g} SE = {Z * se:.4f} + {SLACK:g} x KF): weights "
                          "overwritten instead of multiplied between resamplings?")
        notes.append(f"{mode} {excess[mode].mean():+.3f}")
    se = base.std(ddof=1) / math.sqrt(len(base))
    own = (f"; resampling every step is {base.mean():.3f} above the Kalman filter, beyond Monte "
           "Carlo error (the filter itself is not exact on a linear Gaussian model)"
           if base.mean() > Z * se + SLACK * kf.mean() else "")
    return TrapResult(trap, name, KEPT, f"RMSE over the Kalman filter's {kf.mean():.3f}: "
                   f"{', '.join(notes)} ({KF_TRIALS} trials, {n} particles){own}")


# ---------------------------------------------------------------- a world rotated by pi

ROT_TRIALS, ROT_PARTICLES = 8, 200


def trap_rotated_world(name: str) -> TrapResult:
    from .contract import world_file, world_origin
    from .scenarios import SCENARIOS
    trap = "rotated-world"
    scen = scenario_for(name, ("localization", "slam"))
    if scen is None:
        return TrapResult(trap, name, NOT_APPLICABLE, "a filter of no localization or SLAM "
                       "scenario")
    key = SCENARIOS[scen].SCHEMA.get("world")
    if key is None or key.kind != "str":
        return TrapResult(trap, name, NOT_APPLICABLE, f"scenario {scen} reads no world file to "
                       "rotate")
    from .filters import FILTERS
    spec = {"particles": ROT_PARTICLES} if FILTERS[name].particles else {}
    origin = world_origin(scen)
    if origin is None:
        return TrapResult(trap, name, NOT_APPLICABLE, f"scenario {scen} does not take the "
                       "generated world (pfbench.contract.world)")
    # a scenario that can start the filters at the known pose does (global localization's
    # spread would hide a bias behind Monte Carlo error)
    ini = SCENARIOS[scen].SCHEMA.get("initial")
    known = ({"initial": "known"} if ini is not None and ini.kind == "choice"
             and "known" in (ini.choices or ()) else {})
    exps = [_experiment(name, scen, spec=spec, trials=ROT_TRIALS,
                        scen={**known, "world": str(world_file(origin, rotated))})
            for rotated in (False, True)]
    from .kinds import kind_of
    metrics = kind_of(scen).headline
    got = []
    for exp, what in zip(exps, ("the world", "the world turned by pi")):
        rows = []
        for k in range(ROT_TRIALS):
            row = _run_guarded(exp, k, None, f"on {scen}, {what}")[0]
            _headline(exp, row, f"on {scen}, {what}, trial {k}")
            rows.append([row[m] for m in metrics])
        got.append(np.array(rows, dtype=float))
    a, b = got
    if np.array_equal(a, b):
        return TrapResult(trap, name, KEPT, f"on {scen}: the same {', '.join(metrics)}, bit for bit")
    for j, m in enumerate(metrics):
        diff = a[:, j] - b[:, j]
        se = diff.std(ddof=1) / math.sqrt(len(diff))
        tol = Z * se + 1e-9 * (1.0 + abs(a[:, j]).mean())
        if abs(diff.mean()) > tol:
            raise _Broken(f"on {scen}: {m} {a[:, j].mean():.4g} in the world, "
                          f"{b[:, j].mean():.4g} in the world turned by pi (difference "
                          f"{diff.mean():.3g}, allowed {tol:.3g}): headings or bearings not "
                          "wrapped across +-pi?")
    return TrapResult(trap, name, KEPT, f"on {scen}: {', '.join(metrics)} agree within Monte "
                   f"Carlo error over {ROT_TRIALS} trials (not bit for bit)")


# ---------------------------------------------------------------- the KLD bound

def kld_closed_form(k: int, eps: float, z: float) -> float:
    """Fox's (2003) bound, as written: (k - 1) / (2 eps) (1 - 2 / (9 (k - 1)) + sqrt(2 / (9 (k -
    1))) z)^3; 0 for k = 1 (one bin: nothing to bound)."""
    if k <= 1:
        return 0.0
    d = k - 1.0
    return d / (2.0 * eps) * (1.0 - 2.0 / (9.0 * d) + math.sqrt(2.0 / (9.0 * d)) * z) ** 3


def trap_kld_bound(name: str) -> TrapResult:
    trap = "kld-bound"
    if "kld" not in _choices(name, "sampling"):
        return TrapResult(trap, name, NOT_APPLICABLE, "no 'sampling' key offering 'kld'")
    from scipy.stats import chi2
    from .filters.mcl import kld_count, kld_quantile
    for eps in (0.01, 0.05, 0.2):
        for delta in (0.01, 0.05):
            z = kld_quantile(delta)
            for k in (1, 2, 3, 10, 1000, 10 ** 6):
                got, want = kld_count(k, eps, z), kld_closed_form(k, eps, z)
                what = f"kld_count(k = {k}, eps = {eps:g}, delta = {delta:g})"
                if k == 1 and got != 0:
                    raise _Broken(f"{what} = {got}, expected 0 (one bin)")
                if k > 1 and not (want <= got < want + 1 + 1e-9 * want):
                    raise _Broken(f"{what} = {got}, expected ceil({want!r})")
                if k >= 1000:
                    exact = chi2.ppf(1.0 - delta, k - 1) / (2.0 * eps)
                    if abs(got - exact) > 1e-3 * exact + 1:
                        raise _Broken(f"{what} = {got}, the chi-square quantile gives "
                                      f"{exact:.6g}")
    from .filters import FILTERS
    scen = scenario_for(name)
    if scen is None:
        return TrapResult(trap, name, NOT_APPLICABLE, "no registered scenario it runs on")
    notes = []
    for what, keys in (("one bin (k = 1)", {"kld_bin_m": 1e6, "kld_bin_deg": 360.0,
                                            "kld_min": 1}),
                       ("bins of 5 cm x 5 cm x 10 deg (k near N)", {"kld_bin_m": 0.05,
                                                                    "kld_bin_deg": 10.0})):
        keys = {"sampling": "kld", **{k: v for k, v in keys.items()
                                      if k in FILTERS[name].schema}}
        try:
            exp = _experiment(name, scen, spec=keys)
        except UserError as exc:
            raise _Broken(f"sampling kld with {what} does not validate: {exc}") from None
        row = _run_guarded(exp, 0, None, f"sampling kld on {scen}, {what}")[0]
        _headline(exp, row, f"sampling kld on {scen}, {what}")
        notes.append(what)
    return TrapResult(trap, name, KEPT, f"the bound against its closed form at k = 1 .. 10^6; runs "
                   f"on {scen} with {' and '.join(notes)}")


# ---------------------------------------------------------------- the suite

TRAPS: dict[str, Callable[[str], TrapResult]] = {
    "resampling-ulp": trap_resampling_ulp,
    "resampling-one-hot": trap_resampling_one_hot,
    "particles-1-2": trap_particles_1_2,
    "log-weights-all-inf": trap_all_inf,
    "log-weights-far-below-0": trap_far_below,
    "resample-every-ess-never": trap_resample_modes,
    "rotated-world": trap_rotated_world,
    "kld-bound": trap_kld_bound,
}


def run_trap(trap: str, name: str) -> TrapResult:
    """Trap ``trap`` on filter ``name``: its finding (an exception of the filter is BROKEN)."""
    import warnings
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")     # a NaN or an overflow is the finding itself
            return TRAPS[trap](name)
    except _Broken as exc:
        return TrapResult(trap, name, BROKEN, str(exc))
    except Exception as exc:        # a plug-in's error is a finding, not a crash of the check
        return TrapResult(trap, name, BROKEN, f"raised {_one_line(exc)}")


def _traps_child(conn, name: str, chosen: list) -> None:
    try:
        conn.send([run_trap(t, name) for t in chosen])
    except BaseException as exc:    # noqa: BLE001 (a plug-in's exit or interrupt is a finding too)
        conn.send([TrapResult(chosen[0], name, BROKEN, f"raised {_one_line(exc)}")])
    finally:
        conn.close()


def filter_traps(name: str, chosen=None, timeout: float | None = None) -> list[TrapResult]:
    """The traps ``chosen`` (default: every one) on filter ``name``; with ``timeout``, in a child
    process stopped after that many seconds (a filter that never returns, or ends the
    interpreter, is one broken finding naming it), where this platform can fork one."""
    import multiprocessing as mp
    chosen = list(TRAPS) if chosen is None else list(chosen)
    if timeout is None or "fork" not in mp.get_all_start_methods() or mp.current_process().daemon:
        return [run_trap(t, name) for t in chosen]
    from .contract import in_child
    how, got = in_child(_traps_child, (name, chosen), timeout)
    if how == "ok":
        return got
    if how == "ended":
        return [TrapResult(chosen[0], name, BROKEN, "ended the process that ran its traps "
                           f"(exit code {got})")]
    return [TrapResult(chosen[0], name, BROKEN, f"its traps did not finish within {timeout:g} s "
                       "(--probe-timeout); stopped")]


def run_traps(filters=None, traps=None, progress=None, timeout: float | None = None
              ) -> list[TrapResult]:
    """Every trap (or ``traps``) on every registered filter (or ``filters``); ``timeout``: the
    seconds each filter's traps may take (``filter_traps``)."""
    from .filters import FILTERS
    names = list(FILTERS) if filters is None else list(filters)
    out = []
    for i, name in enumerate(names):
        out += filter_traps(name, traps, timeout)
        if progress:
            progress(i + 1, len(names))
    return out
