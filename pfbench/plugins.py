"""Filters and scenarios found through entry points: the groups ``pfbench.filters`` and
``pfbench.scenarios``.

pfbench's own filters and scenarios are entry points of its own distribution (see its
``pyproject.toml``), so a plug-in package registers exactly as they do:

    [project.entry-points."pfbench.filters"]
    my_pf = "my_package.my_module:MY_PF"        # a pfbench.filters.FilterType

    [project.entry-points."pfbench.scenarios"]
    my_world = "my_package.my_world"            # a module (or object) with NAME, KIND, ...

An entry point that cannot be loaded (its import raises anything, ``SystemExit`` and
``KeyboardInterrupt`` included), whose object is not what its group needs, that takes a name
already registered (pfbench's own come first, in either group), or a filter whose schema
redeclares a key every filter has (``type``, ``label``, ``particles``: the config's value goes to
the run, never to the filter's keys) is left out and named in one line (``PROBLEMS``, printed by
``pfbench list`` and where a config names it); the others keep working. The name a config uses
is the entry point's name.
"""
from __future__ import annotations

import functools
from importlib.metadata import entry_points
from typing import Any, Callable

from .protocols import FILTER_COMMON, KIND_NAMES, NEEDS, REPORTS, SCENARIO_NEEDS, FilterType
from .schema import Key

FILTER_GROUP = "pfbench.filters"
SCENARIO_GROUP = "pfbench.scenarios"

# One line per plug-in left out (group, name, package, why).
PROBLEMS: list[str] = []
# name -> the distribution (package) that registered it, for `pfbench list`
ORIGIN: dict[tuple[str, str], str] = {}


def _dist(ep) -> str:
    """The name of the distribution (package) that registered entry point ``ep`` ('?' unknown)."""
    dist = getattr(ep, "dist", None)
    try:
        return _dist_name(dist)
    except TypeError:           # a distribution object that cannot be a cache key
        return getattr(dist, "name", None) or "?"


@functools.lru_cache(maxsize=None)
def _dist_name(dist) -> str:
    """``dist.name``, read once per distribution: each reading parses its metadata file again
    (a tenth of a second for pfbench's 21 entry points)."""
    return getattr(dist, "name", None) or "?"


def _problem(group: str, ep, why: str) -> None:
    PROBLEMS.append(f"plug-in '{ep.name}' ({group}, package {_dist(ep)}, {ep.value}): {why}")


def discover(group: str, check: Callable[[str, Any], str | None],
             builtin: dict[str, Any]) -> dict[str, Any]:
    """Name -> object of every entry point of ``group`` that loads and passes ``check`` (which
    returns why an object does not fit, or None). pfbench's own entry points come first; a
    plug-in cannot take a name that is already registered. ``builtin`` (name -> object) stands in
    for pfbench's own entry points when its package metadata is not installed (a source tree on
    the path), and for those its installed metadata lacks (a source tree newer than its install)."""
    found: dict[str, Any] = {}
    eps = list(entry_points(group=group))
    own = [ep for ep in eps if _dist(ep).lower() == "pfbench"]
    listed = {ep.name for ep in own}
    unlisted = {name: obj for name, obj in builtin.items() if name not in listed}
    found.update(unlisted)
    ORIGIN.update({(group, name): "pfbench" for name in unlisted})
    for ep in own + [ep for ep in eps if ep not in own]:
        if ep.name in found:
            _problem(group, ep, f"the name '{ep.name}' is taken by package "
                     f"{ORIGIN.get((group, ep.name), '?')}")
            continue
        try:
            obj = ep.load()
        except BaseException as exc:   # anything a plug-in's import raises (sys.exit too) is
            _problem(group, ep, f"cannot be loaded: {_why(exc)}")   # its own, named here
            continue
        try:
            why = check(ep.name, obj)
        except BaseException as exc:   # an object that cannot even be looked at
            why = f"cannot be checked: {_why(exc)}"
        if why:
            _problem(group, ep, why)
            continue
        found[ep.name] = obj
        ORIGIN[(group, ep.name)] = _dist(ep)
    # pfbench's own in their declared order, then the plug-ins in the order found
    ordered = {name: found[name] for name in builtin if name in found}
    ordered.update((name, obj) for name, obj in found.items() if name not in ordered)
    return ordered


def _why(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def problem_for(group: str, name: str) -> str | None:
    """The line that says why plug-in ``name`` of ``group`` was left out, if it was."""
    head = f"plug-in '{name}' ({group},"
    return next((p for p in PROBLEMS if p.startswith(head)), None)


def check_filter(name: str, obj: Any) -> str | None:
    """Why ``obj`` cannot be the filter type ``name``, or None."""
    if not isinstance(obj, FilterType):
        return f"expected a pfbench.filters.FilterType, got {type(obj).__name__}"
    if obj.name != name:
        return f"its FilterType is named '{obj.name}', the entry point '{name}'"
    if not callable(obj.run):
        return "its run is not callable"
    if obj.kind not in KIND_NAMES:
        return f"its kind '{obj.kind}' is not one of {', '.join(KIND_NAMES)}"
    if not isinstance(obj.schema, dict) or not all(isinstance(k, Key) for k in obj.schema.values()):
        return "its schema is not a mapping of key name -> pfbench.schema.Key"
    undocumented = [k for k, key in obj.schema.items() if not key.doc]
    if undocumented:
        return f"key '{undocumented[0]}' of its schema has no doc line"
    common = [k for k in obj.schema if k in FILTER_COMMON]
    if common:
        return (f"its schema declares '{common[0]}', a key every filter has (type, label, "
                "particles): the config's value goes to the run, not to the filter's keys; "
                "drop it from the schema")
    if not isinstance(obj.needs, tuple) or any(n not in NEEDS for n in obj.needs):
        return f"its needs {obj.needs!r} are not a tuple of {', '.join(NEEDS)}"
    if not isinstance(obj.reports, tuple) or any(m not in REPORTS for m in obj.reports):
        return f"its reports {obj.reports!r} are not a tuple of {', '.join(REPORTS)}"
    if obj.check is not None and not callable(obj.check):
        return "its check is not callable"
    if obj.check_scenario is not None and not callable(obj.check_scenario):
        return "its check_scenario is not callable"
    return None


def check_scenario(name: str, obj: Any) -> str | None:
    """Why ``obj`` cannot be the scenario ``name``, or None."""
    missing = [a for a in SCENARIO_NEEDS if not hasattr(obj, a)]
    if missing:
        return f"it has no {', '.join(missing)}"
    if obj.NAME != name:
        return f"its NAME is '{obj.NAME}', the entry point '{name}'"
    if obj.KIND not in KIND_NAMES:
        return f"its KIND '{obj.KIND}' is not one of {', '.join(KIND_NAMES)}"
    if not callable(obj.build) or not callable(obj.simulate):
        return "build and simulate must be callables"
    if not isinstance(obj.SCHEMA, dict) or not all(isinstance(k, Key) for k in obj.SCHEMA.values()):
        return "its SCHEMA is not a mapping of key name -> pfbench.schema.Key"
    if "name" in obj.SCHEMA:
        return "its SCHEMA declares 'name', the key that names the scenario"
    provides = getattr(obj, "PROVIDES", ())
    if not isinstance(provides, tuple) or any(p not in NEEDS for p in provides):
        return f"its PROVIDES {provides!r} is not a tuple of {', '.join(NEEDS)}"
    return None
