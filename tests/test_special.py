"""pfbench._special: the t, normal and chi-square functions of the intervals and verdicts, loaded
without scipy.special's package (its array-API layer), the same functions scipy exports."""
from __future__ import annotations

import subprocess
import sys

import pytest

from .conftest import ROOT

PROGRAM = """
import sys
first = sys.argv[1] == "package-first"
if first:
    import scipy.special  # noqa: F401
from pfbench._special import functions
f = functions()
alone = ["scipy.special" in sys.modules, "scipy._lib._array_api" in sys.modules]
values = [f.stdtrit(5, 0.975), f.stdtr(4, -2.0), f.ndtri(0.975), f.chdtri(3, 0.025)]
import scipy.special as sp
from scipy import stats
same = [sp.stdtrit is f.stdtrit, sp.chdtri is f.chdtri, functions() is f, callable(sp.gamma)]
expected = [stats.t.ppf(0.975, 5), stats.t.cdf(-2.0, 4), stats.norm.ppf(0.975),
            stats.chi2.isf(0.025, 3)]
print("imported", *alone, "same", *same, "equal", *[a == b for a, b in zip(values, expected)])
"""


@pytest.mark.parametrize("how", ["alone", pytest.param("package-first", marks=pytest.mark.slow)])
def test_the_distribution_functions_load_without_scipy_special_and_agree_with_scipy_stats(how):
    """Loaded alone, neither scipy.special's package nor scipy's array-API layer is imported; the
    functions are the very objects scipy.special exports once it is imported afterwards (which
    works as usual), and give scipy.stats' t, normal and chi-square values bit for bit. Where
    scipy.special is imported first, its module is the one used."""
    res = subprocess.run([sys.executable, "-c", PROGRAM, how], capture_output=True, text=True,
                         cwd=ROOT, timeout=600)
    assert res.returncode == 0 and "Traceback" not in res.stderr, res.stderr
    first = "True" if how == "package-first" else "False"
    assert res.stdout.split() == ["imported", first, first, "same"] + ["True"] * 4 + [
        "equal"] + ["True"] * 4, res.stdout


def test_the_bare_package_hands_on_the_real_one():
    """Code that picks up the bare package module in the moment it stands in for scipy.special
    finds the real package's names through it; the bare module itself answers no name."""
    from pfbench import _special
    import scipy.special
    assert _special._real_attribute("gamma") is scipy.special.gamma
    with pytest.raises(AttributeError):
        _special._real_attribute("__wrapped__")


def test_the_bare_package_answers_nothing_while_it_stands_in(monkeypatch):
    """While the bare module is still scipy.special (the moment of the load), it answers no
    name rather than asking itself again."""
    import types

    from pfbench import _special
    bare = types.ModuleType("scipy.special")
    bare.__getattr__ = _special._real_attribute
    monkeypatch.setitem(sys.modules, "scipy.special", bare)
    with pytest.raises(AttributeError):
        _special._real_attribute("gamma")
