"""Config keys shared by several filter families (each family declares its own in its module)."""
from __future__ import annotations

from ..codes import EWA_COPIES
from ..resampling import SCHEMES
from ..schema import Key


def floor_key() -> Key:
    return Key("float", 0.0, "additive floor on the likelihood R^(-1/2) exp(-d^2 / 2R) (0: none; "
               "the Gamma benchmark's reference implementation adds 1e-99, which makes a particle "
               "set with no particle near the measurement weigh all particles equally)", min=0.0)


def pf_keys() -> dict:
    """The resampling and estimate keys of a bootstrap particle filter."""
    return {
        "resampling": Key("choice", "systematic", "resampling scheme", choices=tuple(SCHEMES)),
        "resample": Key("choice", "always", "'always': every step; 'neff': when ESS < neff_ratio * N",
                        choices=("always", "neff")),
        "neff_ratio": Key("float", 0.5, "ESS threshold as a fraction of N (resample: neff)",
                          min=0.0, max=1.0, min_exclusive=True),
        "estimate": Key("choice", "before_resampling", "state estimate: weighted mean before "
                        "resampling, or mean of the resampled particles",
                        choices=("before_resampling", "after_resampling")),
        "likelihood_floor": floor_key(),
    }


def gaussian_noise_keys(what: str) -> dict:
    """The Gaussian noise a filter (``what``) assumes, defaulting to the scenario's."""
    return {
        "process_noise_mean": Key("float", None, f"mean of the Gaussian process noise {what} "
                                  "assumes (default: the scenario's noise mean)", nullable=True),
        "process_noise_var": Key("float", None, "variance of that noise (default: the scenario's "
                                 "noise variance)", min=0.0, min_exclusive=True, nullable=True),
        "measurement_noise_var": Key("float", None, f"measurement noise variance {what} assumes "
                                     "(default: the scenario's)", min=0.0, min_exclusive=True,
                                     nullable=True),
    }


def sigma_keys() -> dict:
    """The scaled unscented transform's keys."""
    return {
        "alpha": Key("float", 1.0, "spread of the sigma points", min=0.0, min_exclusive=True),
        "beta": Key("float", 0.0, "prior-knowledge term of the centre weight (2 is optimal for "
                    "Gaussian priors)"),
        "kappa": Key("float", 2.0, "secondary scaling; needs L + kappa > 0 (L = 3 augmented, 1 "
                     "otherwise)"),
    }


def sigma_check(params) -> tuple[str, str] | None:
    """The unscented transform's rule: L + kappa > 0 (L = 3 with the noise augmented, else 1)."""
    L = 3 if params.get("augmented", True) else 1
    if L + params["kappa"] <= 0:
        return "kappa", f"expected kappa > {-L} (L + kappa > 0 with L = {L}), got {params['kappa']!r}"
    return None


def ewa_keys() -> dict:
    """The keys of ifa2021's stepwise EWA resampling."""
    return {
        "ewa_beta": Key("float", 0.8, "stepwise EWA: weight of the running average (ifa2021: 0.8)",
                        min=0.0, max=1.0, min_exclusive=True),
        "ewa_mu": Key("float", 0.01, "stepwise EWA: mutation scale, x' = x + x mu N(0, 1) "
                      "(ifa2021: 0.01)", min=0.0),
        "ewa_correction": Key("choice", "standard", "stepwise EWA: 'standard' bias correction "
                              "delta_i = v_i / (1 - beta^i), or 'as_printed' (ifa2021 puts it "
                              "inside the recursion)", choices=("standard", "as_printed")),
        "ewa_copies": Key("choice", "ceil", "stepwise EWA: how many particles a kept particle of "
                          "weight W becomes, n = W / delta (ifa2021: 'n = w / delta; n = 1: copied "
                          "once; n > 1: rounded up, copied n times'): 'ceil' ceil(n) in all, the "
                          "kept particle one of them (our reading); 'ceil_plus_one' the kept "
                          "particle and ceil(n) copies (the text read as 'kept, then copied n "
                          "times'); 'floor_plus_one' floor(n) + 1 (the kept particle and one copy "
                          "per whole unit of n; differs from ceil only where n is a whole number)",
                          choices=tuple(EWA_COPIES)),
    }
