"""Filter registry: each filter type's parameters (schema), kernel runner and compatibility."""
from __future__ import annotations

import time

_t0 = time.perf_counter()

from dataclasses import dataclass
from typing import Callable

from ..resampling import SCHEMES
from ..schema import Key
from . import ekf, fastslam, kalman, mcl, pf, sspf_field, swarm_pf, ukf, upf

# Seconds spent importing the kernels: numba compiles them here (first run) or loads them from the
# disk cache. Reported in meta.json as kernel_load_s, apart from the trials' wall time.
LOAD_SECONDS = time.perf_counter() - _t0


@dataclass(frozen=True)
class FilterType:
    """A filter family as configs see it.

    run(model, y, params, particles, state, diag) -> dict of traces (at least 'xhat') and
    'lik_evals_per_step'; ``particles`` is None for filters without particles.
    scenarios : names of the scenarios it runs on (None: every scalar scenario)
    """

    name: str
    description: str
    schema: dict
    run: Callable
    particles: bool = True
    scenarios: tuple | None = None
    cost: str = "N"       # how the cost of a step grows with the particle count
    kind: str = "scalar"  # the scenario kind it runs on: scalar, slam or localization
    check: Callable | None = None   # params -> (key, message) of a broken cross-key rule, or None


def _floor_key():
    return Key("float", 0.0, "additive floor on the likelihood R^(-1/2) exp(-d^2 / 2R) (0: none; "
               "the Gamma benchmark's reference implementation adds 1e-99, which makes a particle "
               "set with no particle near the measurement weigh all particles equally)", min=0.0)


def _pf_schema():
    return {
        "resampling": Key("choice", "systematic", "resampling scheme", choices=tuple(SCHEMES)),
        "resample": Key("choice", "always", "'always': every step; 'neff': when ESS < neff_ratio * N",
                        choices=("always", "neff")),
        "neff_ratio": Key("float", 0.5, "ESS threshold as a fraction of N (resample: neff)",
                          min=0.0, max=1.0, min_exclusive=True),
        "estimate": Key("choice", "before_resampling", "state estimate: weighted mean before "
                        "resampling, or mean of the resampled particles",
                        choices=("before_resampling", "after_resampling")),
        "likelihood_floor": _floor_key(),
    }


def _gaussian_noise_schema(what: str):
    return {
        "process_noise_mean": Key("float", None, f"mean of the Gaussian process noise {what} "
                                  "assumes (default: the scenario's noise mean)", nullable=True),
        "process_noise_var": Key("float", None, "variance of that noise (default: the scenario's "
                                 "noise variance)", min=0.0, min_exclusive=True, nullable=True),
        "measurement_noise_var": Key("float", None, f"measurement noise variance {what} assumes "
                                     "(default: the scenario's)", min=0.0, min_exclusive=True,
                                     nullable=True),
    }


def _sigma_schema():
    return {
        "alpha": Key("float", 1.0, "spread of the sigma points", min=0.0, min_exclusive=True),
        "beta": Key("float", 0.0, "prior-knowledge term of the centre weight (2 is optimal for "
                    "Gaussian priors)"),
        "kappa": Key("float", 2.0, "secondary scaling; needs L + kappa > 0 (L = 3 augmented, 1 "
                     "otherwise)"),
    }


def _upf_schema(resample: str, mh_steps: int):
    pf_keys = _pf_schema()
    return {
        "resampling": Key("choice", "residual", "resampling scheme", choices=tuple(SCHEMES)),
        "resample": Key("choice", resample, "'always'; 'neff': when ESS < neff_ratio * N; "
                        "'weight_change': when K = sum W_k (W_k - W_{k-1})^2 > sigma / N^2 "
                        "(sspf2008)", choices=("always", "neff", "weight_change")),
        "neff_ratio": pf_keys["neff_ratio"],
        "sigma": Key("float", 1.0, "threshold of the weight-change trigger in units of 1 / N^2 "
                     "(sspf2008 gives no value; 1 / N^2 is the K of weights split evenly over half "
                     "the particles, an ESS of N / 2)", min=0.0, min_exclusive=True),
        "mh_steps": Key("int", mh_steps, "independence Metropolis-Hastings moves per particle "
                        "after each resampling, with the particle's UKF proposal", min=0),
        "estimate": pf_keys["estimate"],
        "likelihood_floor": _floor_key(),
        "prior_argument": Key("choice", "transition", "where the weight's transition density is "
                              "evaluated: 'transition' (w = x_t - f(x_{t-1}), the model) or "
                              "'increment' (x_t - x_{t-1}, as the Gamma benchmark's reference "
                              "implementation does)", choices=("transition", "increment")),
        **_sigma_schema(),
        **_gaussian_noise_schema("the proposal's UKF"),
    }


def _swarm_schema(resampling: str, **own):
    pf_keys = _pf_schema()
    return {
        "iterations": Key("int", 1, "swarm iterations per step (each evaluates the likelihood of "
                          "every moved particle)", min=0),
        **own,
        "resampling": Key("choice", resampling, "resampling scheme; 'stepwise_ewa' is ifa2021's "
                          "stepwise EWA resampling", choices=tuple(SCHEMES) + ("stepwise_ewa",)),
        "resample": pf_keys["resample"],
        "neff_ratio": pf_keys["neff_ratio"],
        "estimate": pf_keys["estimate"],
        "ewa_beta": Key("float", 0.8, "stepwise EWA: weight of the running average (ifa2021: 0.8)",
                        min=0.0, max=1.0, min_exclusive=True),
        "ewa_mu": Key("float", 0.01, "stepwise EWA: mutation scale, x' = x + x mu N(0, 1) "
                      "(ifa2021: 0.01)", min=0.0),
        "ewa_correction": Key("choice", "standard", "stepwise EWA: 'standard' bias correction "
                              "delta_i = v_i / (1 - beta^i), or 'as_printed' (ifa2021 puts it "
                              "inside the recursion)", choices=("standard", "as_printed")),
    }


def _firefly_keys(with_alpha: bool):
    keys = {
        "beta0": Key("float", 1.0, "maximum attractiveness (ifa2021: 1)", min=0.0),
        "gamma": Key("float", 1.0, "light absorption, per squared state unit (ifa2021: 1)", min=0.0),
    }
    if with_alpha:
        keys["alpha"] = Key("float", 0.2, "fixed random-step size (FA-PF's reference gives none; "
                            "our default)", min=0.0)
    return keys


def _fastslam_schema():
    pf_keys = _pf_schema()
    swarm = {k: v for k, v in FILTERS_SWARM_KEYS.items()}
    return {
        "refine": Key("choice", "none", "swarm refinement of the predicted poses at each "
                      "observation (ifa2021: BA-, FA-, IFA-FastSLAM; afsa2014: PSO-, AFSA-FastSLAM)",
                      choices=("none", "fa", "ifa", "ba", "pso", "afsa")),
        "iterations": Key("int", 1, "swarm iterations per observation", min=0),
        **swarm,
        "predict_noise": Key("bool", True, "each particle draws its own noisy controls (FastSLAM "
                             "1.0 needs it; the classic simulator's default turns it off)"),
        "speed_noise_mps": Key("float", None, "speed noise the particles draw (default: the "
                               "scenario's)", min=0.0, nullable=True),
        "steer_noise_deg": Key("float", None, "steering noise the particles draw (default: the "
                               "scenario's)", min=0.0, nullable=True),
        "range_noise_m": Key("float", None, "range noise the filter assumes (default: the "
                             "scenario's)", min=0.0, min_exclusive=True, nullable=True),
        "bearing_noise_deg": Key("float", None, "bearing noise the filter assumes (default: the "
                                 "scenario's)", min=0.0, min_exclusive=True, nullable=True),
        "association": Key("choice", "known", "data association: 'known' (the sensor reports "
                           "landmark identities) or 'nearest' (nearest neighbour in Mahalanobis "
                           "distance, with the two gates)", choices=("known", "nearest")),
        "gate_reject": Key("float", 4.0, "nearest: squared Mahalanobis distance up to which an "
                           "observation joins a landmark (the classic simulator's 4)", min=0.0,
                           min_exclusive=True),
        "gate_augment": Key("float", 25.0, "nearest: squared distance beyond which it starts a new "
                            "landmark; in between it is dropped (the classic simulator's 25)",
                            min=0.0, min_exclusive=True),
        "gate_pose": Key("bool", True, "nearest: the gates' distance includes the pose "
                         "uncertainty each particle gained since its last update (motion noise, "
                         "a resampled copy's noise); false: the plain FastSLAM 1.0 distance, "
                         "which rejects true matches when the motion noise exceeds the sensor's"),
        "max_landmarks": Key("int", 0, "nearest: map capacity per particle (0: three times the "
                             "world's landmarks)", min=0),
        "update": Key("choice", "joseph", "landmark covariance update: 'joseph' form or "
                      "'symmetric' ((I - KH) P, symmetrised)", choices=("joseph", "symmetric")),
        "resampling": Key("choice", "systematic", "resampling scheme ('stepwise_ewa': ifa2021's; "
                          "'directional': afsa2014's bulletin-board resampling)",
                          choices=tuple(SCHEMES) + ("stepwise_ewa", "directional")),
        "directional_noise_m": Key("float", 0.05, "directional resampling: position noise of the "
                                   "board's copies (afsa2014 gives none; our default)", min=0.0),
        "directional_noise_deg": Key("float", 0.5, "directional resampling: heading noise of the "
                                     "board's copies", min=0.0),
        "resample": Key("choice", "neff", "'neff': when ESS < neff_ratio * N; 'always'",
                        choices=("neff", "always")),
        "neff_ratio": pf_keys["neff_ratio"],
        "ewa_beta": _swarm_schema("systematic")["ewa_beta"],
        "ewa_mu": _swarm_schema("systematic")["ewa_mu"],
        "ewa_correction": _swarm_schema("systematic")["ewa_correction"],
    }


def _mcl_schema():
    pf_keys = _pf_schema()
    return {
        "resampling": pf_keys["resampling"],
        "resample": pf_keys["resample"],
        "neff_ratio": pf_keys["neff_ratio"],
        "reset": Key("choice", "none", "particle injection: 'none' (MCL), 'srl' (sensor "
                     "resetting), 'asrl' (adaptive sensor resetting, asrl2008), 'augmented' "
                     "(augmented MCL with alpha_slow / alpha_fast)",
                     choices=("none", "srl", "asrl", "augmented")),
        "srl_fraction": Key("float", 0.1, "srl: fraction of the particles replaced by sensor "
                            "draws when the mean likelihood is below srl_threshold", min=0.0,
                            max=1.0),
        "srl_threshold": Key("float", 0.01, "srl: mean-likelihood threshold (a density in the "
                             "measurement's units)", min=0.0),
        "asrl_mu": Key("float", 1.0, "asrl: gain mu of n_s = N max(0, 1 - p_mean / (mu "
                       "p_t^c))", min=0.0, min_exclusive=True),
        "asrl_pt": Key("float", 0.5, "asrl: per-component likelihood threshold p_t", min=0.0,
                       min_exclusive=True),
        "alpha_slow": Key("float", 0.05, "augmented: rate of the long-term likelihood average",
                          min=0.0, max=1.0),
        "alpha_fast": Key("float", 0.5, "augmented: rate of the short-term average (> "
                          "alpha_slow)", min=0.0, max=1.0),
        "inject": Key("choice", "uniform", "augmented: injected poses uniform over the field or "
                      "drawn from the sensor model", choices=("uniform", "sensor")),
        "sampling": Key("choice", "fixed", "'fixed': the particle count stays at 'particles'; "
                        "'kld': KLD-sampling (Fox 2003), the count adapts each step, at most "
                        "'particles' (with reset none or augmented)", choices=("fixed", "kld")),
        "kld_epsilon": Key("float", 0.05, "kld: bound epsilon on the Kullback-Leibler error",
                           min=0.0, min_exclusive=True),
        "kld_delta": Key("float", 0.01, "kld: probability delta that the error exceeds it",
                         min=0.0, max=0.5, min_exclusive=True),
        "kld_bin_m": Key("float", 0.5, "kld: histogram bin size in x and y (Fox 2003: 0.5 m)",
                         min=0.0, min_exclusive=True),
        "kld_bin_deg": Key("float", 10.0, "kld: histogram bin size in heading (Fox 2003: 10 deg)",
                           min=0.0, max=360.0, min_exclusive=True),
        "kld_min": Key("int", 50, "kld: fewest particles a step draws", min=1),
    }


def _sspf_field_schema():
    upf_keys = _upf_schema("weight_change", 1)
    return {
        **{k: upf_keys[k] for k in ("resampling", "resample", "neff_ratio", "sigma", "mh_steps")},
        **_sigma_schema(),
        "init_std_m": Key("float", 1.0, "initial position standard deviation of every particle's "
                          "UKF (the particles start uniform over the field; our choice)", min=0.0,
                          min_exclusive=True),
        "init_std_deg": Key("float", 30.0, "initial heading standard deviation of every "
                            "particle's UKF (our choice)", min=0.0, min_exclusive=True),
        "jitter_m": Key("float", 0.05, "position noise added to the motion model's (the weight's "
                        "transition density needs it: odometry moves a pose along a surface)",
                        min=0.0, min_exclusive=True),
        "jitter_deg": Key("float", 1.0, "heading noise added likewise", min=0.0,
                          min_exclusive=True),
    }


def _mcl_check(params: dict) -> tuple[str, str] | None:
    """Cross-key rules of mcl: (key, message) of the first one broken."""
    if params["sampling"] == "kld" and params["reset"] in ("srl", "asrl"):
        return "reset", ("KLD-sampling resamples while it draws; it combines with reset 'none' "
                         "or 'augmented', not with sensor resetting")
    if params["reset"] == "augmented" and params["alpha_fast"] <= params["alpha_slow"]:
        return "alpha_fast", (f"expected alpha_fast > alpha_slow ({params['alpha_slow']!r}), "
                              f"got {params['alpha_fast']!r}")
    return None


def _ukf_schema():
    return {
        **_sigma_schema(),
        "augmented": Key("bool", True, "augment the state with the process and measurement noise"),
        **_gaussian_noise_schema("the UKF"),
    }


# The swarm parameters FastSLAM's refinement takes (the same names as the scalar swarm filters).
FILTERS_SWARM_KEYS = {
    **_firefly_keys(True),
    "freq_min": Key("float", 0.0, "BA: lowest frequency"),
    "freq_max": Key("float", 1.0, "BA: highest frequency"),
    "loudness": Key("float", 1.0, "BA: initial loudness", min=0.0),
    "pulse_rate": Key("float", 0.5, "BA: pulse rate r0", min=0.0, max=1.0),
    "loudness_decay": Key("float", 0.9, "BA: loudness decay", min=0.0, max=1.0),
    "pulse_growth": Key("float", 0.9, "BA: pulse-rate growth", min=0.0),
    "visual": Key("float", 1.0, "AFSA: visual range, in units of the predicted cloud's spread",
                  min=0.0, min_exclusive=True),
    "step": Key("float", 0.5, "AFSA: largest move per behaviour, in the same units", min=0.0),
    "crowding": Key("float", 0.618, "AFSA: crowding factor delta", min=0.0),
    "tries": Key("int", 5, "AFSA: neighbours tried by prey before a random step", min=1),
    "greedy": Key("bool", True, "AFSA: keep a fish where it is when no behaviour improves it"),
    "inertia": Key("float", 0.7, "PSO: velocity inertia", min=0.0),
    "c1": Key("float", 1.5, "PSO: pull toward the particle's best", min=0.0),
    "c2": Key("float", 1.5, "PSO: pull toward the swarm's best", min=0.0),
}

# (type a config names, scenario kind) -> the filter type that implements it for that kind
KIND_TYPES = {("sspf", "localization"): "sspf_field"}

# pfbench's own filter types: each is an entry point of group pfbench.filters (pyproject.toml),
# reached as a module attribute named in capitals (pfbench.filters:PF; the lower-case names are
# the submodules).
BUILTIN = {
    f.name: f
    for f in (
        FilterType("pf", "bootstrap particle filter (SIR)", _pf_schema(), pf.run),
        FilterType("ukf", "unscented Kalman filter (scaled sigma points, optional noise "
                   "augmentation)", _ukf_schema(), ukf.run, particles=False, cost="1"),
        FilterType("pfmh", "bootstrap PF with Metropolis-Hastings moves after resampling (PF+MH)",
                   {**_pf_schema(), "mh_steps": Key("int", 1, "MH moves per particle after each "
                                                    "resampling (proposal: the transition prior)",
                                                    min=1)}, pf.run),
        FilterType("upf", "unscented particle filter (a UKF per particle as the proposal)",
                   _upf_schema("always", 0), upf.run),
        FilterType("sspf", "SSPF (sspf2008): UPF + weight-change-triggered residual resampling + "
                   "MH move", _upf_schema("weight_change", 1), upf.run),
        FilterType("fa", "firefly-algorithm PF (FA-PF): fireflies toward brighter (likelier) "
                   "particles; O(N^2) per iteration",
                   _swarm_schema("systematic", **_firefly_keys(True)), swarm_pf.make_run("fa"),
                   cost="N^2"),
        FilterType("ifa", "improved firefly PF (IFA-PF, ifa2021): distance brightness, adaptive "
                   "step, stepwise EWA resampling; O(N^2) per iteration",
                   _swarm_schema("stepwise_ewa", **_firefly_keys(False), brightness=Key(
                       "choice", "gaussian", "how the distance d (measurement and predicted state, "
                       "each in units of its noise standard deviation) becomes a brightness: "
                       "'gaussian' exp(-d^2 / 2) or 'inverse' 1 / (1 + d); ifa2021 leaves it open",
                       choices=("gaussian", "inverse"))),
                   swarm_pf.make_run("ifa"), cost="N^2"),
        FilterType("ba", "bat-algorithm PF (BA-PF): frequency-tuned velocities, loudness and pulse "
                   "rate", _swarm_schema("systematic", **{
                       "freq_min": Key("float", 0.0, "lowest frequency"),
                       "freq_max": Key("float", 1.0, "highest frequency"),
                       "loudness": Key("float", 1.0, "initial loudness A0 (acceptance probability)",
                                       min=0.0),
                       "pulse_rate": Key("float", 0.5, "pulse rate r0 (1 - r: chance of a local "
                                         "walk around the best bat)", min=0.0, max=1.0),
                       "loudness_decay": Key("float", 0.9, "A <- decay A on acceptance", min=0.0,
                                             max=1.0),
                       "pulse_growth": Key("float", 0.9, "r <- r0 (1 - exp(-growth k)) at iteration "
                                           "k on acceptance", min=0.0)}), swarm_pf.make_run("ba")),
        FilterType("pso", "particle-swarm PF (PSO-PF): moves toward personal and global best "
                   "likelihood", _swarm_schema("systematic", **{
                       "inertia": Key("float", 0.7, "velocity inertia w", min=0.0),
                       "c1": Key("float", 1.5, "pull toward the particle's own best", min=0.0),
                       "c2": Key("float", 1.5, "pull toward the swarm's best", min=0.0)}),
                   swarm_pf.make_run("pso")),
        FilterType("afsa", "artificial-fish-swarm PF (AFSA-PF): prey, swarm and follow behaviours; "
                   "O(N^2) per iteration", _swarm_schema("systematic", **{
                       "visual": Key("float", 1.0, "visual range (state units)", min=0.0,
                                     min_exclusive=True),
                       "step": Key("float", 0.5, "largest move per behaviour", min=0.0),
                       "crowding": Key("float", 0.618, "crowding factor delta", min=0.0),
                       "tries": Key("int", 5, "prey: neighbours tried before a random step", min=1),
                       "greedy": Key("bool", True, "keep a fish where it is when no behaviour "
                                     "improves it")}), swarm_pf.make_run("afsa"), cost="N^2"),
        FilterType("fastslam", "FastSLAM 1.0 with per-landmark EKFs, optional swarm pose "
                   "refinement (FA, IFA, BA, PSO)", _fastslam_schema(), fastslam.run, kind="slam"),
        FilterType("mcl", "Monte Carlo localization, optionally with sensor resetting (SRL, "
                   "ASRL) or augmented-MCL injection, or KLD-sampling", _mcl_schema(), mcl.run,
                   kind="localization", check=_mcl_check),
        FilterType("sspf_field", "SSPF for localization (sspf2008): a UKF proposal per particle "
                   "(pose and odometry noise), weight-change-triggered residual resampling, MH "
                   "move; 'type: sspf' on a localization scenario", _sspf_field_schema(),
                   sspf_field.run, kind="localization"),
        FilterType("ekf", "extended Kalman filter", _gaussian_noise_schema("the EKF"), ekf.run,
                   particles=False, cost="1"),
        FilterType("kf", "exact Kalman filter (linear_gaussian scenario only)", {}, kalman.run,
                   particles=False, scenarios=("linear_gaussian",), cost="1"),
    )
}
globals().update({name.upper(): f for name, f in BUILTIN.items()})

# Every filter type: pfbench's own and the plug-ins', found through entry points.
from ..plugins import FILTER_GROUP, check_filter, discover  # noqa: E402

FILTERS = discover(FILTER_GROUP, check_filter, BUILTIN)
