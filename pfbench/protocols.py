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

from .schema import Key

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
    needs : what it needs of a scenario beyond its kind, names of ``NEEDS`` ('jacobians'); a
        config that pairs it with a scenario that does not provide one is refused at validation
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

    def runs_on(self, scenario: str, kind: str, module=None) -> bool:
        """Whether it runs on the scenario ``scenario`` of kind ``kind``; what the scenario
        provides as well, read from its ``module`` (default: the registered scenario of that
        name, see ``register_scenarios``)."""
        if module is None:
            module = _SCENARIO_MODULES.get(scenario)
        return self.cannot_run_on(scenario, kind, module) is None

    def cannot_run_on(self, scenario: str, kind: str, module=None, params=None) -> str | None:
        """Why it cannot run on the scenario ``scenario`` (kind ``kind``, its ``module`` when
        known, its validated ``params`` when known), or None when it can."""
        if self.kind != kind:
            return f"runs on {self.kind} scenarios, and '{scenario}' is a {kind} scenario"
        if self.scenarios is not None and scenario not in self.scenarios:
            return f"runs only on scenario {', '.join(self.scenarios)}"
        if module is not None:
            have = provided(module, params, self.needs)
            lacking = [n for n in self.needs if n not in have]
            if lacking:
                return (f"needs {NEEDS[lacking[0]]}, which scenario '{scenario}' does not "
                        f"provide (its PROVIDES: {', '.join(declared(module)) or 'nothing'})")
        return None


# What a filter type may need of a scenario beyond its kind (``FilterType.needs``), which a
# scenario declares it provides (``PROVIDES = ("jacobians",)`` in its module).
NEEDS = {
    "jacobians": "the Jacobians of its model (df/dx and dh/dx: ScalarModel's transition_jac and "
                 "observe_jac)",
    "likelihood": "a log-likelihood of a measurement for any set of states (ScalarModel.loglik)",
}


def declared(module) -> tuple:
    """What a scenario module declares it provides (its ``PROVIDES``; nothing without one)."""
    got = getattr(module, "PROVIDES", ())
    return tuple(got) if isinstance(got, (tuple, list, set, frozenset)) else ()


def _model_has(need: str, model) -> bool:
    if need == "jacobians":
        return (getattr(model, "transition_jac", None) is not None
                and getattr(model, "observe_jac", None) is not None)
    return False


def provided(module, params, needs=()) -> set:
    """What the scenario ``module`` provides of ``needs``: what its ``PROVIDES`` declares; a
    module that declares nothing (a plug-in written before ``PROVIDES``) is asked by building its
    model from ``params`` (its validated keys) and looking."""
    if hasattr(module, "PROVIDES"):
        return set(declared(module))
    if not needs or params is None:
        return set()
    try:
        model = module.build(params)
    except Exception:       # a model that cannot be built provides nothing (the run says why)
        return set()
    return {n for n in needs if _model_has(n, model)}
