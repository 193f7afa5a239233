"""The vectorisable sine, cosine, exponential and wrap against the C library's."""
import math
import platform
import re

import numpy as np
import pytest
from numba import njit

from pfbench import angles, vecmath


@njit(error_model="numpy")
def _sincos(x, s, c):
    for i in range(x.size):
        s[i], c[i] = vecmath.sincos(x[i])


@njit(error_model="numpy")
def _exp(x, out):
    for i in range(x.size):
        out[i] = vecmath.exp(x[i])


def _ulps(ours, ref):
    return np.abs(ours - ref) / np.spacing(np.abs(ref))


def test_sincos_within_2_3e_16_of_the_library_and_mostly_1_ulp():
    rng = np.random.default_rng(3)
    x = np.concatenate([np.linspace(-4 * np.pi, 4 * np.pi, 1_000_001),
                        rng.uniform(-4 * np.pi, 4 * np.pi, 200_000),
                        np.arange(-8, 9) * np.pi / 4, np.nextafter(np.arange(-8, 9) * np.pi / 4, 9)])
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos(x, s, c)
    for ours, ref in ((s, np.sin(x)), (c, np.cos(x))):
        assert np.abs(ours - ref).max() <= 2.3e-16
        assert np.mean(_ulps(ours, ref) > 1.0) < 1e-4       # only next to the zeros
    assert s.dtype == np.float64 and np.all(np.abs(s) <= 1.0) and np.all(np.abs(c) <= 1.0)


def test_exp_within_2_ulp_and_its_limits():
    rng = np.random.default_rng(4)
    x = np.concatenate([np.linspace(-708.0, 709.0, 1_000_001), -rng.exponential(20.0, 200_000),
                        [0.0, -0.0, -1e-300, 1e-300]])
    out = np.empty_like(x)
    _exp(x, out)
    assert _ulps(out, np.exp(x)).max() <= 2.0
    assert out[-4] == 1.0 and out[-3] == 1.0
    lim = np.array([-708.5, -1000.0, -np.inf, 709.5, np.inf])
    out = np.empty_like(lim)
    _exp(lim, out)
    assert list(out) == [0.0, 0.0, 0.0, np.inf, np.inf]


def test_wrap_agrees_with_the_angle_wrap():
    rng = np.random.default_rng(5)
    for a in np.concatenate([rng.uniform(-3 * np.pi, 3 * np.pi, 20_000),
                             [np.pi, -np.pi, 3 * np.pi, np.nextafter(-np.pi, -4.0)]]):
        w = vecmath.wrap(a)
        assert -math.pi <= w < math.pi
        assert abs(math.remainder(w - angles.wrap(a), 2 * math.pi)) <= 1e-15
        if -math.pi <= a < math.pi:
            assert w == a


@njit
def _wrap_by_division(a):
    w = a - 2.0 * math.pi * math.floor((a + math.pi) / (2.0 * math.pi))
    w = w - 2.0 * math.pi if w >= math.pi else w
    return a if -math.pi <= a < math.pi else w


@njit
def _wrap_mismatches(centres, k):
    """How many of the 2 k doubles around each centre wrap differently from the division."""
    bad = 0
    for c in centres:
        x = c
        for _ in range(k):
            x = np.nextafter(x, -np.inf)
        for _ in range(2 * k):
            bad += vecmath.wrap(x) != _wrap_by_division(x)
            x = np.nextafter(x, np.inf)
    return bad


def test_wrap_is_the_division_form_bit_for_bit():
    """wrap's quotient is a product by 1 / (2 pi); next to the multiples of pi, where a floor
    one off would show, and at random, it gives what the division gives."""
    centres = np.arange(-9, 10) * np.pi
    assert _wrap_mismatches(centres, 20_000) == 0
    rng = np.random.default_rng(8)
    for a in rng.uniform(-1e4, 1e4, 20_000):
        assert vecmath.wrap(a) == _wrap_by_division(a)


@njit(error_model="numpy")
def _atan2(y, x, out):
    for i in range(x.size):
        out[i] = vecmath.atan2(y[i], x[i])


def test_atan2_within_2_ulp_and_its_special_cases():
    rng = np.random.default_rng(6)
    n = 1_000_000
    x = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 6, n)
    y = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 6, n)
    out = np.empty(n)
    _atan2(y, x, out)
    ref = np.arctan2(y, x)
    assert _ulps(out, ref).max() <= 2.0
    z = 0.0
    special = np.array([(z, 1.0), (z, -1.0), (-z, -1.0), (-z, 1.0), (1.0, z), (-1.0, z), (z, z),
                        (z, -z), (-z, -z), (1.0, 1.0), (-1.0, -1.0), (3.0, -3.0), (1e-300, -1.0)])
    out = np.empty(len(special))
    _atan2(special[:, 0].copy(), special[:, 1].copy(), out)
    ref = np.arctan2(special[:, 0], special[:, 1])
    assert np.array_equal(np.signbit(out), np.signbit(ref))
    assert np.all(_ulps(out, ref)[ref != 0] <= 2.0) and np.all(out[ref == 0] == 0)


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"), reason="x86 assembly")
def test_the_loops_vectorise():
    """What the module is for: a loop calling them compiles to packed (vector) instructions."""
    x = np.linspace(0.1, 1.0, 16)
    _exp(x, np.empty_like(x))
    _sincos(x, np.empty_like(x), np.empty_like(x))
    _atan2(x, x, np.empty_like(x))
    for f in (_exp, _sincos, _atan2):
        asm = f.inspect_asm(f.signatures[0])
        assert re.search(r"\bv?(mul|add|fmadd\w*)pd\b", asm), f


@njit(error_model="numpy")
def _fma(a, b, c, out):
    for i in range(a.size):
        out[i] = vecmath.fma(a[i], b[i], c[i])


def test_fma_rounds_once():
    """fma(a, b, c) is a b + c rounded once: exact where the product and sum are, and the low
    bits that a rounded product loses are kept (a b + c with a b = 1 - 2^-60 in exact
    arithmetic)."""
    from fractions import Fraction
    a = np.array([1.0 + 2.0**-30, 3.0, 0.1, -2.5, 1e300])
    b = np.array([1.0 - 2.0**-30, 4.0, 0.3, 1e-300, 10.0])
    c = np.array([-1.0, 5.0, -0.03, 0.0, -np.inf])
    out = np.empty(5)
    _fma(a, b, c, out)
    assert out[0] == -2.0**-60 and (a[0] * b[0] + c[0]) == 0.0
    assert out[1] == 17.0 and out[4] == -np.inf
    for i in (2, 3):
        exact = Fraction(a[i]) * Fraction(b[i]) + Fraction(c[i])
        assert out[i] == float(exact)          # the exact value, rounded once
    x = np.linspace(0.1, 1.0, 16)
    _fma(x, x, x, np.empty_like(x))
    if platform.machine() in ("x86_64", "AMD64"):
        asm = _fma.inspect_asm(_fma.signatures[0])
        assert re.search(r"\bvfmadd\w*pd\b", asm) or "fma" in asm


def _fma_exact(a, b, c):
    """a b + c rounded once, in exact rational arithmetic."""
    from fractions import Fraction
    return float(Fraction(a) * Fraction(b) + Fraction(c))


def _sincos_reference(x):
    """vecmath.sincos step by step in Python, each fused multiply-add rounded once exactly."""
    v = vecmath
    ax = abs(x)
    j = int(ax * v._FOPI)
    j += j & 1
    y = float(j)
    z = _fma_exact(-y, v._DP3, _fma_exact(-y, v._DP2, _fma_exact(-y, v._DP1, ax)))
    zz = z * z

    def horner(cs):
        acc = cs[0]
        for ck in cs[1:]:
            acc = _fma_exact(acc, zz, ck)
        return acc
    ps = _fma_exact(z * zz, horner((v._S0, v._S1, v._S2, v._S3, v._S4, v._S5)), z)
    pc = _fma_exact(zz * zz, horner((v._C0, v._C1, v._C2, v._C3, v._C4, v._C5)),
                    _fma_exact(-0.5, zz, 1.0))
    s, c = (pc, ps) if j & 2 else (ps, pc)
    s = -s if bool(j & 4) != (x < 0.0) else s
    c = -c if (j + 2) & 4 else c
    return s, c


def test_sincos_is_its_fused_formula_bit_for_bit():
    """sincos's bits are those of its formula with every multiply-add rounded once, whatever the
    machine (a compiler that split a fused operation, or one that fused another, would fail)."""
    rng = np.random.default_rng(9)
    x = np.concatenate([rng.uniform(-4 * np.pi, 4 * np.pi, 3000), np.arange(-16, 17) * np.pi / 4])
    s, c = np.empty_like(x), np.empty_like(x)
    _sincos(x, s, c)
    for i, xi in enumerate(x):
        assert (s[i], c[i]) == _sincos_reference(float(xi)), xi
