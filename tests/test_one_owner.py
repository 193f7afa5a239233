"""One owner per concept: the ziggurat's step, the ESS threshold rule, the stepwise EWA's code
and mutation each live in one function that the kernels call (no copy kept equal by hand), and
the kernels' step functions have names of their own."""
from __future__ import annotations

import ast
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent / "pfbench"


def _sources() -> dict[str, str]:
    return {p.relative_to(ROOT.parent).as_posix(): p.read_text(encoding="utf-8")
            for p in sorted(ROOT.rglob("*.py"))}


def _code(text: str) -> str:
    """A module's code without its comments and docstrings (``ast.unparse``'s spelling: single
    quotes, one space around operators)."""
    tree = ast.parse(text)
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list):
            node.body = [b for b in body if not (isinstance(b, ast.Expr)
                                                 and isinstance(b.value, ast.Constant)
                                                 and isinstance(b.value.value, str))] or [
                ast.Pass()]
    return ast.unparse(tree)


def _where(pattern: str) -> list[str]:
    """The files of pfbench/ whose code (comments and docstrings aside) matches ``pattern``."""
    return [name for name, text in _sources().items() if re.search(pattern, _code(text))]


@pytest.mark.parametrize("pattern, owner", [
    # the ziggurat: its acceptance test reads the thresholds _ZKI (rng.in_layer_rectangle), and
    # the tail and wedge test on a local state is rng.normal_off_rectangle
    (r"_ZKI\[", "pfbench/rng.py"),
    (r"_normal_slow\(", "pfbench/rng.py"),
    # the ESS threshold a filter resamples below: resampling.ess_threshold
    (r"\['neff_ratio'\] \*", "pfbench/resampling.py"),
    # the stepwise EWA's scheme code after the standard ones: codes.STEPWISE_EWA
    (r"\bSTEPWISE_EWA = ", "pfbench/codes.py"),
    # the stepwise EWA's mutation v + v mu z: resampling.ewa_mutant
    (r"ewa_mu\s*\*\s*normal\(|\*\s*mu\s*\*\s*normal\(", "pfbench/resampling.py"),
])
def test_each_concept_is_written_once(pattern, owner):
    assert _where(pattern) == [owner]


def test_the_kernels_steps_do_not_share_names():
    """A name says what it does: no two modules define ``weigh``, ``compare`` or ``Finding``,
    none ``summarise`` beside metrics' ``summarize``, no kernel is a vague '_core'."""
    defined: dict[str, list[str]] = {}
    for name, text in _sources().items():
        for node in ast.walk(ast.parse(text)):
            if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and node.col_offset == 0:
                defined.setdefault(node.name, []).append(name)
    for twice in ("weigh", "compare", "Finding"):
        assert len(defined.get(twice, [])) <= 1, (twice, defined[twice])
    assert "summarise" not in defined
    assert not [n for n in defined if n.endswith("_core")]
    assert not any(re.search(r"\b\w+_core\s*=\s*variant\(", t) for t in _sources().values())


def test_the_ziggurat_step_on_a_local_state_is_normals_draw():
    """rng's ziggurat step on a local state (next_local, _layer, in_layer_rectangle, else
    normal_off_rectangle), the one the kernels' loops write, draws what rng.normal draws and
    leaves the state where normal leaves it (tail and wedge draws included: 20,000 draws pass
    through them about 240 times)."""
    import numba

    from pfbench.rng import (_layer, in_layer_rectangle, load_local, next_local, normal,
                             normal_off_rectangle, state_from_seed, store_local)

    @numba.njit
    def local_draws(s, n):
        out = np.empty(n)
        q = load_local(s)
        for i in range(n):
            r, q = next_local(q)
            layer, rabs, x = _layer(r)
            if not in_layer_rectangle(layer, rabs):
                x, q = normal_off_rectangle(s, q, layer, rabs, x)
            out[i] = x
        store_local(s, q)
        return out

    @numba.njit
    def plain_draws(s, n):
        out = np.empty(n)
        for i in range(n):
            out[i] = normal(s)
        return out

    a = state_from_seed(np.random.SeedSequence(7))
    b = a.copy()
    assert np.array_equal(local_draws(a, 20_000), plain_draws(b, 20_000))
    assert np.array_equal(a, b)


@pytest.mark.parametrize("params, particles, expected", [
    ({"resample": "always", "neff_ratio": 0.5}, 100, np.inf),
    ({"resample": "neff", "neff_ratio": 0.5}, 100, 50.0),
    ({"resample": "neff", "neff_ratio": 1.0}, 7, 7.0),
    ({"resample": "neff", "neff_ratio": 0.0}, 1000, 0.0),
])
def test_ess_threshold(params, particles, expected):
    from pfbench.resampling import ess_threshold
    assert ess_threshold(params, particles) == expected


def test_ewa_mutant_is_v_plus_v_mu_z():
    import numba

    from pfbench.resampling import ewa_mutant
    from pfbench.rng import normal, state_from_seed

    @numba.njit
    def both(s, t, v, mu):
        return ewa_mutant(v, mu, s), v + v * mu * normal(t)

    s = state_from_seed(np.random.SeedSequence(3))
    t = s.copy()
    for v in (0.0, 1.5, -3.25, 1e300):
        a, b = both(s, t, v, 0.01)
        assert a == b or (np.isnan(a) and np.isnan(b))
