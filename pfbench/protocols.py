"""What a filter type and a scenario are, to the registries and to each other: the record a
filter family declares (``FilterType``, with the keys every filter has), what a scenario module
must have (``SCENARIO_NEEDS``), the kinds both name (``KIND_NAMES``), and what a filter may need
of a scenario beyond its kind (``NEEDS``).

This module sits below the filters, the scenarios and their registries (docs/internals/
layers.md): it imports nothing of pfbench but the schema, so a filter module, a scenario module,
the plug-in checks (pfbench.plugins) and the registries can all read it. The scenario registry
hands its modules down (``register_scenarios``), so that ``FilterType.runs_on`` can ask a
scenario what it provides without importing the registry.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .schema import Key, check_section

# The scenario kinds, in the order pfbench lists them (pfbench.kinds defines what each scores).
KIND_NAMES = ("scalar", "slam", "localization")

# What a scenario module (or object) must have.
SCENARIO_NEEDS = ("NAME", "KIND", "DESCRIPTION", "SCHEMA", "build", "simulate")

# name -> module of every registered scenario, handed down by pfbench.scenarios
_SCENARIO_MODULES: dict = {}


def register_scenarios(modules: dict) -> None:
    """Make the registered scenarios (name -> module) known to ``FilterType.runs_on``."""
    _SCENARIO_MODULES.update(modules)


# The keys every filter has, whatever its type; a filter type's own schema may not declare them.
FILTER_COMMON = {
    "type": Key("str", None, "filter type (default: the filter's key)", nullable=True),
    "label": Key("str", None, "row name in the tables, the paper's name (default: the key)",
                 nullable=True),
    "particles": Key("ints", None, "particle count, or a list: one run per count", min=2,
                     nullable=True),
}


@dataclass(frozen=True)
class FilterType:
    """A filter family as configs see it.

    run(model, y, params, particles, state, diag) -> dict of traces: for a scalar scenario at least
    'xhat' and 'lik_evals_per_step' (pfbench.kinds says what each kind needs); ``particles`` is
    None for filters without particles.
    schema : key name -> pfbench.schema.Key, the keys a config may give it
    scenarios : names of the scenarios it runs on (None: every scenario of its kind)
    cost : how the cost of a step grows with the particle count
    kind : the scenario kind it runs on: scalar, slam or localization
    check : params -> (key, message) of a broken rule across keys, or None
    snapshots : (localization) its run also takes ``snapshots``, steps, and returns
        out['snapshots'] = (steps (S,), particles (S, N, 3), counts (S,)): the particles at those
        steps, for the figures
    check_scenario : (params, scenario params) -> (key, message) of a broken rule that needs the
        scenario's keys too (a histogram over its field), or None
    needs : what it needs of a scenario beyond its kind, names of ``NEEDS`` ('jacobians',
        'gaussian_measurement', 'likelihood', 'linear'); a config, a sweep's cell or an API call
        that pairs it with a scenario that does not provide one is refused at validation, in one
        line naming what is missing
    reports : the consistency metrics its runs report beyond its kind's columns, names of
        ``REPORTS`` ('nees' from its output 'pvar', 'nis' from 'innov' and 'innov_var'); an
        experiment's trials file has those columns when one of its filters reports them
    """

    name: str
    description: str
    schema: dict
    run: Callable
    particles: bool = True
    scenarios: tuple | None = None
    cost: str = "N"
    kind: str = "scalar"
    check: Callable | None = None
    snapshots: bool = False
    needs: tuple = ()
    check_scenario: Callable | None = None
    reports: tuple = ()

    def runs_on(self, scenario: str, kind: str, module=None) -> bool:
        """Whether it runs on the scenario ``scenario`` of kind ``kind``; what the scenario
        provides as well, read from its ``module`` (default: the registered scenario of that
        name, see ``register_scenarios``)."""
        if module is None:
            module = _SCENARIO_MODULES.get(scenario)
        return self.cannot_run_on(scenario, kind, module) is None

    def cannot_run_on(self, scenario: str, kind: str, module=None, params=None) -> str | None:
        """Why it cannot run on the scenario ``scenario`` (kind ``kind``, its ``module`` when
        known, its validated ``params`` when known), or None when it can: one clause naming what
        the scenario lacks."""
        if self.kind != kind:
            return f"runs on {self.kind} scenarios, and '{scenario}' is a {kind} scenario"
        if self.scenarios is not None and scenario not in self.scenarios:
            return f"runs only on scenario {', '.join(self.scenarios)}"
        if module is not None and self.needs:
            have = provided(module, params, self.needs)
            lacking = [n for n in self.needs if n not in have]
            if lacking:
                says = ("its PROVIDES: " + (", ".join(declared(module)) or "nothing")
                        if hasattr(module, "PROVIDES") else
                        "it declares no PROVIDES; its model provides: "
                        + (", ".join(sorted(have)) or "none of them"))
                if hasattr(module, "PROVIDES") and (_asked(module, self.needs)
                                                    or _keyed(module, params, self.needs)):
                    says += ("; its model, with these keys, provides: "
                             + (", ".join(sorted(have)) or "none of them"))
                return (f"needs {need_text(lacking)}, which scenario '{scenario}' does not "
                        f"provide ({says})")
            lying = false_claims(module, params, self.needs)
            if lying:
                return (f"needs {need_text(lying)}, which scenario '{scenario}' declares in its "
                        "PROVIDES but its model lacks")
        return None


# What a filter type may need of a scenario beyond its kind (``FilterType.needs``), which a
# scenario declares it provides (``PROVIDES = ("jacobians", ...)`` in its module). A localization
# or SLAM scenario builds the kind's own record (pfbench.models.field.FieldModel,
# pfbench.models.slam.SlamModel), which fixes the motion and the sensor its filters read; its
# measurement is the Gaussian range (and bearing) sensor, or its own likelihood
# (``FieldModel.loglik``, ``SlamModel.loglik``): such a model says what it provides (its
# ``provides()``), which a scenario that declares neither of ``MEASUREMENT`` has read from it, and
# which withdraws, for a config's keys, what a scenario declares for its keys' defaults.
# FastSLAM's landmark EKFs need the Gaussian measurement and its Jacobians, which the SLAM
# scenarios declare (landmark_world's outliers weighed by their mixture take the first away).
NEEDS = {
    "jacobians": "the Jacobians of its model (df/dx, dh/dx: ScalarModel's transition_jac, "
                 "observe_jac)",
    "gaussian_measurement": "a Gaussian measurement (y = h(x) + v, v ~ N(0, R), R known: "
                            "ScalarModel's observe, noise[3])",
    "likelihood": "the log-likelihood of a measurement at any set of states (its model's own, "
                  "or its Gaussian measurement's)",
    "linear": "a linear model with Gaussian process noise (x_t = a x_{t-1} + w_t, "
              "y_t = c x_t + v_t, theta = [a, c])",
}

# The field of a scalar model that holds its own log-likelihood of a measurement (a model without
# one has the additive Gaussian measurement of ScalarModel's docstring).
OWN_LIKELIHOOD = ("loglik",)


def need_text(needs) -> str:
    """``needs`` (names of ``NEEDS``) in words, each with its name: "the Jacobians of its model
    (...) ['jacobians'] and a Gaussian measurement (...) ['gaussian_measurement']"."""
    words = [f"{NEEDS[n]} ['{n}']" for n in needs]
    return " and ".join([", ".join(words[:-1]), words[-1]] if len(words) > 1 else words)


# The consistency metrics a filter type may report (``FilterType.reports``): the scalar kind's
# columns that only experiments with such a filter have (pfbench.kinds, pfbench.metrics).
REPORTS = ("nees", "nis")


def declared(module) -> tuple:
    """What a scenario module declares it provides (its ``PROVIDES``; nothing without one)."""
    got = getattr(module, "PROVIDES", ())
    return tuple(got) if isinstance(got, (tuple, list, set, frozenset)) else ()


def own_likelihood(model) -> bool:
    """Whether the scalar ``model`` brings its own log-likelihood of a measurement."""
    return any(getattr(model, name, None) is not None for name in OWN_LIKELIHOOD)


def _model_has(need: str, model) -> bool:
    """Whether ``model`` (a scenario's built model) shows that it provides ``need``: what a
    scenario without ``PROVIDES`` is credited with; a model with a ``provides()`` method (the
    localization and SLAM kinds' records) says it. A linear model is never inferred (the model's
    functions do not say it); a scenario that has one declares it."""
    says = getattr(model, "provides", None)
    if callable(says):
        return need in says()
    if need == "jacobians":
        return (getattr(model, "transition_jac", None) is not None
                and getattr(model, "observe_jac", None) is not None)
    gaussian = (getattr(model, "observe", None) is not None
                and getattr(model, "noise", None) is not None and not own_likelihood(model))
    if need == "gaussian_measurement":
        return gaussian
    if need == "likelihood":
        return gaussian or own_likelihood(model)
    return False


def default_params(module) -> dict | None:
    """A scenario's keys at their defaults (validated), or None when one is required or its
    ``resolve`` (files it names) is needed: the model ``provided`` builds when no config gives
    the keys."""
    if getattr(module, "resolve", None) is not None:
        return None
    try:
        return check_section({}, module.SCHEMA, "scenario")
    except Exception:       # a required key, a broken schema: no model to ask
        return None


# What a scalar model gives of its measurement: a scenario whose PROVIDES names neither (one
# written when the scalar kind assumed the additive Gaussian measurement) has these read from its
# model, as a scenario without PROVIDES has every need.
MEASUREMENT = ("gaussian_measurement", "likelihood")


def _build(module, params):
    """The model of scenario ``module`` from ``params`` (None: its keys' defaults), or None when
    it cannot be built (the run says why)."""
    if params is None:
        params = default_params(module)
        if params is None:
            return None
    try:
        return module.build(params)
    except (Exception, SystemExit):     # a model that cannot be built provides nothing
        return None


def _asked(module, needs) -> list:
    """The needs of ``needs`` that the scenario ``module`` does not declare either way, and that
    its model is asked for (see ``provided``)."""
    if not hasattr(module, "PROVIDES"):
        return list(needs)
    if set(declared(module)) & set(MEASUREMENT):
        return []
    return [n for n in needs if n in MEASUREMENT]


# The kinds whose models are the kind's own record (FieldModel, SlamModel), which says what it
# provides (its ``provides()``) as a config's keys build it.
RECORD_KINDS = ("slam", "localization")


def _keyed(module, params, needs) -> list:
    """The needs of ``needs`` of the measurement's (``MEASUREMENT``) that a localization or SLAM
    scenario ``module`` declares in its ``PROVIDES``, when a config gives its keys (``params``):
    its ``PROVIDES`` says what its keys' defaults provide, and keys may take the Gaussian
    measurement away (outliers weighed by their mixture), which its model, the kind's record,
    says (see ``provided``)."""
    if params is None or getattr(module, "KIND", None) not in RECORD_KINDS:
        return []
    return [n for n in needs if n in MEASUREMENT and n in declared(module)]


def provided(module, params, needs=()) -> set:
    """What the scenario ``module`` provides of ``needs``: what its ``PROVIDES`` declares. What
    it does not declare is read from its model, built from ``params`` (its validated keys; None:
    its keys' defaults): every need for a module without ``PROVIDES`` (a plug-in written before
    it), the measurement's (``MEASUREMENT``) for one whose ``PROVIDES`` names neither. A
    localization or SLAM scenario's ``PROVIDES`` is what its keys' defaults provide: given its
    keys, the measurement's needs it declares are also asked of its model (the kind's record),
    which withdraws those its keys take away (``_keyed``)."""
    have = set(declared(module))
    ask = _asked(module, needs)
    keyed = _keyed(module, params, needs)
    if ask or keyed:
        model = _build(module, params)
        if model is not None:
            have |= {n for n in ask if _model_has(n, model)}
            have -= {n for n in keyed if not _model_has(n, model)}
    return have


def _model_lacks(need: str, model) -> bool:
    """Whether ``model`` shows it lacks ``need`` (only what a model shows: its Jacobians, the
    observe function and noise of a Gaussian measurement; a model with ``provides()``, what it
    says)."""
    says = getattr(model, "provides", None)
    if callable(says):
        return need not in says()
    if need == "jacobians":
        return not _model_has("jacobians", model)
    if need == "gaussian_measurement":
        return getattr(model, "observe", None) is None or getattr(model, "noise", None) is None
    return False


def false_claims(module, params, needs=()) -> list[str]:
    """The needs of ``needs`` that the scenario ``module`` declares in its ``PROVIDES`` but its
    model, built from ``params``, shows it lacks (its Jacobians, a Gaussian measurement's observe
    and noise): a plug-in's claim checked before a run relies on it. pfbench's own scenarios are
    not built here (their claims are tested)."""
    checkable = [n for n in needs if n in ("jacobians", "gaussian_measurement")
                 and n in declared(module)]
    if (not checkable or params is None
            or getattr(module, "__name__", "").startswith("pfbench.scenarios.")):
        return []
    model = _build(module, params)
    if model is None:
        return []
    return [n for n in checkable if _model_lacks(n, model)]


# Cells of ``compatibility``: a filter type names the scenarios it runs on (``scenarios``), and
# this is not one of them; the scenario's model, to be asked what it provides, cannot be built
# from its keys' defaults (a required key, a file its ``resolve`` reads: a config says).
NOT_NAMED = "not named"
UNKNOWN = "unknown"


def compatibility(filters: dict, scenarios: dict) -> dict:
    """The compatibility matrix of filter types (name -> FilterType) and scenarios (name ->
    module), kind by kind: kind -> (scenario names, filter names, {(scenario, filter): what the
    scenario lacks}), where what it lacks is () when the filter runs on it, the names of ``NEEDS``
    it lacks, (``NOT_NAMED``,) when the filter names the scenarios it runs on and not this one,
    or (``UNKNOWN``,) when the scenario's model would be asked (see ``provided``) and cannot be
    built from its keys' defaults; a filter and a scenario of different kinds are not paired."""
    out = {}
    for kind in KIND_NAMES:
        scens = [s for s, m in scenarios.items() if getattr(m, "KIND", None) == kind]
        filts = [f for f, ft in filters.items() if ft.kind == kind]
        if not scens and not filts:
            continue
        wanted = tuple(dict.fromkeys(n for f in filts for n in filters[f].needs))
        cells = {}
        for s in scens:
            mod = scenarios[s]
            have = provided(mod, None, wanted)
            unknown = set(_asked(mod, wanted)) - have
            if unknown and _build(mod, None) is not None:
                unknown = set()
            for f in filts:
                ft = filters[f]
                lacking = tuple(n for n in ft.needs if n not in have)
                if ft.scenarios is not None and s not in ft.scenarios:
                    cells[s, f] = (NOT_NAMED,)
                elif unknown & set(lacking):
                    cells[s, f] = (UNKNOWN,)
                else:
                    cells[s, f] = lacking
        out[kind] = (scens, filts, cells)
    return out
