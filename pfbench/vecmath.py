"""Branch-free sine, cosine, arctangent and exponential that the compiler vectorises.

numba calls the C library for ``math.sin``, ``math.cos``, ``math.atan2`` and ``math.exp``, one
value at a time (about 10 ns for a sine and cosine, 11 for an arctangent, 4 for an exponential
here); the functions below are the classic Cephes polynomials written without branches, so a
loop over an array that calls them compiles to vector instructions (1.0, 1.4 and 1.0 ns per value
on this machine's AVX-512). ``sincos`` evaluates its polynomials in fused multiply-adds (``fma``:
a quarter faster than products and sums, as accurate, and the same bits on every machine). They
are not the library's functions bit for bit: ``sincos`` differs from ``math.sin`` /
``math.cos`` by at most 2.3e-16 for |x| <= 4 pi (1 ulp but next to the zeros), ``atan2`` from
``math.atan2`` by at most 2 ulp, ``exp`` from ``math.exp`` by at most 2 ulp on [-708, 709]
(below, where the library's result is subnormal, it gives 0); the tests check them.

A loop only vectorises when nothing in it can raise: compile it with ``error_model="numpy"`` (a
float division by zero gives inf instead of raising ZeroDivisionError).

``fma`` is a fused multiply-add written out. numba's ``fastmath={"contract"}`` would fuse products
and sums too, but the compiler chooses which, afresh in each context a function is compiled or
inlined in, so a kernel's results would depend on what the process had compiled or loaded from
its cache before (seen: the same trials differed in the last bits between two runs).
"""
from __future__ import annotations

import math

import numpy as np
from llvmlite import ir
from numba import types
from numba.extending import intrinsic
from ._lazy import kernel


@intrinsic
def fma(typingctx, a, b, c):
    """a * b + c rounded once (LLVM's llvm.fma: the processor's fused multiply-add where it has
    one, and the same result bit for bit where it does not); vectorises."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context, builder, signature, args):
        d = ir.DoubleType()
        f = builder.module.declare_intrinsic("llvm.fma", [d], ir.FunctionType(d, [d, d, d]))
        return builder.call(f, args)
    return sig, codegen


# sin and cos on [-pi/4, pi/4] (Cephes sin.c), pi/4 in three parts for the reduction
_S0, _S1, _S2 = 1.58962301576546568060e-10, -2.50507477628578072866e-8, 2.75573136213857245213e-6
_S3, _S4, _S5 = -1.98412698295895385996e-4, 8.33333333332211858878e-3, -1.66666666666666307295e-1
_C0, _C1, _C2 = -1.13585365213876817300e-11, 2.08757008419747316778e-9, -2.75573141792967388112e-7
_C3, _C4, _C5 = 2.48015872888517045348e-5, -1.38888888888730564116e-3, 4.16666666666665929218e-2
_DP1, _DP2, _DP3 = 7.85398125648498535156e-1, 3.77489470793079817668e-8, 2.69515142907905952645e-15
_FOPI = 4.0 / math.pi

# exp (Cephes exp.c): x = n ln 2 + r, |r| <= ln(2) / 2, e^r by a rational function
_LOG2E = 1.4426950408889634073599
_LN2_HI, _LN2_LO = 6.93145751953125e-1, 1.42860682030941723212e-6
_P0, _P1, _P2 = 1.26177193074810590878e-4, 3.02994407707441961300e-2, 9.99999999999999999910e-1
_Q0, _Q1 = 3.00198505138664455042e-6, 2.52448340349684104192e-3
_Q2, _Q3 = 2.27265548208155028766e-1, 2.00000000000000000009e0
# atan (Cephes atan.c) on [0, tan(pi/8)] (after reducing [tan(pi/8), 1]): t + t^3 P(t^2) / Q(t^2)
_A0, _A1 = -8.750608600031904122785e-1, -1.615753718733365076637e1
_A2, _A3, _A4 = -7.500855792314704667340e1, -1.228866684490136173410e2, -6.485021904942025371773e1
_B0, _B1 = 2.485846490142306297962e1, 1.650270098316988542046e2
_B2, _B3, _B4 = 4.328810604912902668951e2, 4.853903996359136964868e2, 1.945506571482613964425e2
_PIO2, _PIO4 = math.pi / 2.0, math.pi / 4.0
_MOREBITS = 6.123233995736765886130e-17   # pi/2 - _PIO2
_TWO_PI = 2.0 * math.pi
_INV_TWO_PI = 1.0 / _TWO_PI
EXP_MIN = -708.0          # exp is 0 below (the library's result is subnormal there)
_EXP_MAX = 709.0


@kernel(types.float64(types.float64, types.float64, types.float64, types.float64, types.float64,
                     types.float64, types.float64), cache=True, inline="always")
def _horner6(x, c0, c1, c2, c3, c4, c5):
    """c0 x^5 + c1 x^4 + ... + c5 by Horner's rule in fused multiply-adds."""
    return fma(fma(fma(fma(fma(c0, x, c1), x, c2), x, c3), x, c4), x, c5)


@kernel(types.UniTuple(types.float64, 2)(types.float64), cache=True, inline="always")
def sincos(x):
    """(sin x, cos x) for |x| <= 4 pi (beyond, the three-part reduction loses accuracy)."""
    ax = abs(x)
    j = np.int64(ax * _FOPI)
    j += j & 1                           # the nearest even octant: |z| <= pi / 4
    y = float(j)
    z = fma(-y, _DP3, fma(-y, _DP2, fma(-y, _DP1, ax)))
    zz = z * z
    ps = fma(z * zz, _horner6(zz, _S0, _S1, _S2, _S3, _S4, _S5), z)
    pc = fma(zz * zz, _horner6(zz, _C0, _C1, _C2, _C3, _C4, _C5), fma(-0.5, zz, 1.0))
    swap = (j & 2) != 0                  # octants 2 and 6: sin and cos trade places
    s = pc if swap else ps
    c = ps if swap else pc
    s = -s if ((j & 4) != 0) != (x < 0.0) else s
    c = -c if ((j + 2) & 4) != 0 else c
    return s, c


@kernel(types.float64(types.float64), cache=True, inline="always")
def exp(x):
    """e^x: 0 below EXP_MIN, inf above 709 (the library's overflows above 709.78)."""
    xc = x if x > EXP_MIN else EXP_MIN
    xc = xc if xc < _EXP_MAX else _EXP_MAX
    n = np.floor(_LOG2E * xc + 0.5)         # a float: no conversion back from an integer
    r = (xc - n * _LN2_HI) - n * _LN2_LO
    rr = r * r
    px = r * ((_P0 * rr + _P1) * rr + _P2)
    e = 1.0 + 2.0 * (px / ((((_Q0 * rr + _Q1) * rr + _Q2) * rr + _Q3) - px))
    v = e * np.int64((np.int64(n) + 1023) << 52).view(np.float64)
    v = v if x <= _EXP_MAX else math.inf
    return v if x >= EXP_MIN else 0.0


@kernel(types.float64(types.float64, types.float64), cache=True, inline="always")
def atan2(y, x):
    """The angle of (x, y) in [-pi, pi], as math.atan2 (signed zeros included)."""
    ax, ay = abs(x), abs(y)
    steep = ay > ax
    num = ax if steep else ay               # t = min / max in [0, 1]
    den = ay if steep else ax
    t = num / den if den > 0.0 else 0.0
    mid = t > 0.66                          # atan(t) = pi/4 + atan((t - 1) / (t + 1))
    z = (t - 1.0) / (t + 1.0) if mid else t
    zz = z * z
    p = (zz * ((((_A0 * zz + _A1) * zz + _A2) * zz + _A3) * zz + _A4)
         / (((((zz + _B0) * zz + _B1) * zz + _B2) * zz + _B3) * zz + _B4))
    a = z * p + z
    a = (_PIO4 + 0.5 * _MOREBITS) + a if mid else a
    a = (_PIO2 + _MOREBITS) - a if steep else a     # the angle of (|x|, |y|) in [0, pi/2]
    a = math.pi - a if x < 0.0 or (x == 0.0 and math.copysign(1.0, x) < 0.0) else a
    return math.copysign(a, y)


@kernel(types.float64(types.float64), cache=True, inline="always")
def wrap(a):
    """a wrapped to [-pi, pi) without a branch the vectoriser cannot follow: exact for an angle
    already inside; outside, a - 2 pi floor((a + pi) / 2 pi) (pfbench.angles.wrap takes the
    remainder instead; the two may differ in the last bit). The quotient is a product by
    1 / (2 pi): a division cost the move a seventh of its time, and the product's floor was the
    quotient's at every angle tried (all within 200,000 ulps of each multiple of pi up to 9 pi,
    and millions drawn up to 1e4). Where a + pi itself rounds up to a multiple of 2 pi (at
    a = 5 pi, say) the result falls one ulp below -pi, as the division's did."""
    w = a - _TWO_PI * np.floor((a + math.pi) * _INV_TWO_PI)
    w = w - _TWO_PI if w >= math.pi else w
    return a if -math.pi <= a < math.pi else w
