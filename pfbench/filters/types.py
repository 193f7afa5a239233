"""What a filter type declares: its name, the kind of scenario it runs on, its keys and its run."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


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

    def runs_on(self, scenario: str, kind: str) -> bool:
        """Whether it runs on the scenario ``scenario`` of kind ``kind``."""
        return self.kind == kind and (self.scenarios is None or scenario in self.scenarios)
