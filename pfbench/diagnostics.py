"""Which per-step diagnostics an experiment computes, and why: the one place that decides it.

Some outputs of a filter run cost time at every step and are read only by some experiments:

- ``distinct_frac`` (output ``distinct``): the fraction of distinct particles right after each
  resampling. Read by the tables of every experiment whose kind has the column (the console's
  diagnostics table and table.md print it as 'Distinct'), so it is computed for scalar and SLAM
  experiments. It costs a pass over the ancestors (see pfbench.filters._common.distinct_count).
- ``diversity_l1`` (output ``div_l1``): the mean pairwise L1 distance of the particles right
  after each resampling, averaged over the steps that resampled. Exact, through a sort of the
  particles at each of those steps, so it is computed only where something reads it: the
  paper file's table (a quantity, its per-run table or that table's ``also``, a finding that
  cites the column) or the config's ``diagnostics`` key.
- ``lm_trace`` (SLAM): the map error after each observation, which the SLAM figures draw. It is
  computed in the trials whose trace is kept for the figures (the first FIGURE_TRIALS), and in
  every trial when the ``diagnostics`` key asks for it. It reads the particles and draws no
  random number, and no metric reads it: a traced trial's metrics are those it has untraced.
- ``nees`` (scalar; output ``pvar``): a particle filter's posterior variance at each step, the
  variance of the cloud its estimate is the mean of (the weighted particles before resampling,
  or the resampled ones with ``estimate: after_resampling``), from which its NEES is scored. It
  costs a pass over the particles per step, so it is computed only where something reads it:
  the paper file (a quantity, a per-run table, a finding on the nees column) or the config's
  ``diagnostics`` key; an experiment that computes it has the nees column in its trials (with
  the chi-square bounds in its table.csv). The Kalman family (kf, ekf, ukf) reports its
  variance on its own (``FilterType.reports``), asked or not.

A diagnostic not computed is absent from the filter's output, so its metric is NaN: blank in
trials.csv and table.csv, '-' in the tables (the nees column is absent altogether where no
filter reports it and nothing asks for it). A filter's ``run`` receives the diagnostics as a
:class:`Diag` (an ``int`` of flags): ``bool(diag)`` is whether any is asked, so a filter written
for the older ``run(..., diag: bool)`` still works; the runner drops the diagnostic outputs a run
returns that were not asked for, so that what an experiment holds never depends on the filter.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .diag import ALL, KEY_WORDS, NAMES, Diag, flags, outputs_of  # noqa: F401  (this module's API)
from .kinds import kind_of


@dataclass(frozen=True)
class Plan:
    """What an experiment computes: ``every`` in every trial, ``traced`` in addition in the trials
    whose trace its kind keeps for the figures; ``why``: name -> the reasons, in words;
    ``offered``: the diagnostics its kind has."""
    every: Diag
    traced: Diag
    why: dict = field(default_factory=dict)
    offered: tuple = ()
    own: tuple = ()         # of those not computed, what some filters report of their own

    def for_trial(self, keeps_trace: bool) -> Diag:
        """The diagnostics of a trial (``keeps_trace``: its kind keeps its trace)."""
        return self.every | self.traced if keeps_trace else self.every

    @property
    def names(self) -> tuple[str, ...]:
        """The diagnostics computed in some trial, in NAMES' order."""
        on = self.every | self.traced
        return tuple(n for n, (f, _) in NAMES.items() if f & on)

    def describe(self) -> str:
        """One line: each diagnostic computed and why, and those its kind has that are not."""
        parts = []
        for n in self.names:
            where = "" if NAMES[n][0] & self.every else " in the trials kept for the figures"
            parts.append(f"{n}{where} ({'; '.join(self.why[n])})")
        left = [n for n in self.offered if n not in self.names]
        text = "per-step diagnostics: " + (", ".join(parts) or "none")
        if left:
            text += "; not computed: " + ", ".join(
                f"{n} (the filters that report their own {n} give it)" if n in self.own else n
                for n in left)
            text += " (blank in the tables; the 'diagnostics' key adds them)"
        elif not self.offered:
            text += " (its kind has none)"
        return text


KEY_REASON = "the config's diagnostics key"


def plan(exp) -> Plan:
    """The diagnostics experiment ``exp`` computes, and why (see the module)."""
    kind = kind_of(exp.scenario)
    have = kind.diagnostics
    why: dict[str, list[str]] = {}

    def need(name: str, reason: str) -> None:
        if name in have and reason not in why.setdefault(name, []):
            why[name].append(reason)

    if "distinct_frac" in have:
        need("distinct_frac", "the tables' Distinct column")
    table = exp.reported
    if table is not None:
        where = f"paper {exp.paper} {exp.table}"
        for q in table.quantities:
            if q.metric in NAMES:
                need(q.metric, f"{where}: quantity {q.key}")
        pt = table.per_trial
        if pt is not None:
            if pt.metric in NAMES:
                need(pt.metric, f"{where}: its per-run table")
            for m in pt.also:
                if m in NAMES:
                    need(m, f"{where}: its per-run table's 'also'")
    if exp.reference is not None:
        for finding in exp.reference.findings:
            for ref in finding.refs:
                if ref.config == exp.name and ref.column in NAMES:
                    need(ref.column, f"paper {exp.paper}: a finding cites {ref.column}")
    key = exp.diagnostics
    for name in (have if key == "all" else () if key == "auto" else key):
        need(name, KEY_REASON)
    every = Diag.NONE
    for name in why:
        every |= NAMES[name][0]
    traced = Diag.NONE
    if kind.tracer is not None:
        for name in kind.figure_diagnostics:
            if not every & NAMES[name][0]:
                need(name, f"the {kind.name} figures")
                traced |= NAMES[name][0]
    own = tuple(n for n in have if n not in why and n in _reported_by_filters(exp))
    return Plan(every, traced, {n: why[n] for n in NAMES if n in why}, have, own)


def _reported_by_filters(exp) -> set[str]:
    """The metrics some filter of ``exp`` reports of its own (``FilterType.reports``: the
    Kalman family's NEES)."""
    from .filters import FILTERS
    return {m for f in exp.filters for m in getattr(FILTERS.get(f.type), "reports", ())}


def reported_metrics(exp) -> tuple[str, ...]:
    """The metric columns of experiment ``exp``'s trials: its scenario kind's metrics, and the
    consistency metrics (NEES, NIS) its kind has when one of its filters reports them
    (``FilterType.reports``) or when the experiment computes one as a per-step diagnostic (the
    particle filters' NEES, ``plan``)."""
    return kind_of(exp.scenario).experiment_metrics(_reported_by_filters(exp)
                                                    | set(plan(exp).names))
