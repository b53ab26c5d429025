"""Logarithm and cosine for the compiled passes (numba), free of calls and branches.

The C library's ``log`` and ``cos`` are calls, one element at a time (about 9 and 17 ns
here), and a loop that makes them cannot run in SIMD lanes. These are the same
algorithms as FreeBSD's msun (fdlibm: ``e_log.c``, ``k_cos.c``/``k_sin.c`` with the
medium-argument reduction of ``e_rem_pio2.c``), written with selects instead of branches
so that the compiler inlines them and vectorises the loops around them. Their error is
below one unit in the last place, as the C library's and NumPy's SIMD ones: the result
differs from theirs in the last bit at most (tested, ``tests/core/test_kernel_math.py``),
which moves the compliance (α, its logarithms) and the cosines of the contact (cos β, the
curvature radius) by about 1e-16 of their size; the kernels' agreement with the NumPy
reference is to 1e-13 of each field's scale (:mod:`cyclomesh.core.kernel`). The contact
rotations, where one bit matters, never take them (they take NumPy's arccos and
arctangents, :mod:`cyclomesh.core.kernel_contact`).

:func:`cos` reduces by one Cody–Waite step with π/2 in 33 + 53 bits, exact for
|x| < 2^19·π/2 (about 8e5 rad; the contact's arguments are below 10^3); beyond it the
reduced argument loses bits, so callers pass larger ones to the C library
(:func:`cos_exact_below`).

References
----------
FreeBSD msun, lib/msun/src/e_log.c, k_cos.c, k_sin.c, e_rem_pio2.c (Sun Microsystems'
fdlibm, 1993, and Bruce D. Evans's revisions).
"""

from __future__ import annotations

from functools import cache
from typing import Any

import math

import numpy as np

__all__ = ["compiled", "COS_EXACT_BELOW"]

COS_EXACT_BELOW = 8.0e5
"""|x| [rad] below which :func:`_cos`'s reduction is exact (n·π/2₁ exact for n < 2^20)."""

# e_log.c
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_LG1 = 6.666666666666735130e-01
_LG2 = 3.999999999940941908e-01
_LG3 = 2.857142874366239149e-01
_LG4 = 2.222219843214978396e-01
_LG5 = 1.818357216161805012e-01
_LG6 = 1.531383769920937332e-01
_LG7 = 1.479819860511658591e-01
_TWO54 = 1.80143985094819840000e16
# k_cos.c, k_sin.c
_C1 = 4.16666666666666019037e-02
_C2 = -1.38888888888741095749e-03
_C3 = 2.48015872894767294178e-05
_C4 = -2.75573143513906633035e-07
_C5 = 2.08757232129817482790e-09
_C6 = -1.13596475577881948265e-11
_S1 = -1.66666666666666324348e-01
_S2 = 8.33333333332248946124e-03
_S3 = -1.98412698298579493134e-04
_S4 = 2.75573137070700676789e-06
_S5 = -2.50507602534068634195e-08
_S6 = 1.58969099521155010221e-10
# e_rem_pio2.c: 2/π, π/2 in two parts of 33 bits and the rest
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_2T = 2.02226624879595063154e-21


@cache
def compiled() -> Any:
    """The compiled functions as a namespace (``log``, ``cos``, ``sin``), or None without
    numba."""
    try:
        import numba
        from llvmlite import ir
        from numba.core import types
        from numba.extending import intrinsic
    except ImportError:
        return None

    @intrinsic
    def to_bits(typingctx, x):  # pragma: no cover (compiled)
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.IntType(64))

        return types.int64(types.float64), codegen

    @intrinsic
    def from_bits(typingctx, i):  # pragma: no cover (compiled)
        def codegen(context, builder, signature, args):
            return builder.bitcast(args[0], ir.DoubleType())

        return types.float64(types.int64), codegen

    global _to_bits, _from_bits, _reduce, _kernels  # the functions below call them compiled
    _to_bits, _from_bits = to_bits, from_bits
    jit = numba.njit(cache=True, nogil=True, error_model="numpy", inline="always")
    _reduce, _kernels = jit(_reduce), jit(_kernels)

    class Math:
        log = jit(_log)
        cos = jit(_cos)
        sin = jit(_sin)

    return Math


def _to_bits(x):  # pragma: no cover (replaced by the intrinsic)
    raise NotImplementedError


def _from_bits(i):  # pragma: no cover (replaced by the intrinsic)
    raise NotImplementedError


def _log(x):  # pragma: no cover (compiled)
    """ln x as e_log.c (error below 1 ulp), branch-free: 0 → −inf, x < 0 or NaN → NaN,
    +inf → +inf, subnormals scaled by 2^54 first."""
    tiny = x < 2.2250738585072014e-308  # subnormal (or 0, negative, handled below)
    xs = x * _TWO54 if tiny else x
    ix = _to_bits(xs)
    hx = (ix >> 32) & 0x000FFFFF
    k = ((ix >> 52) & 0x7FF) - 1023 - (54 if tiny else 0)
    i = (hx + 0x95F64) & 0x100000
    # the mantissa scaled to [√2/2, √2)
    m = _from_bits(((hx | (i ^ 0x3FF00000)) << 32) | (ix & 0xFFFFFFFF))
    k = k + (i >> 20)
    f = m - 1.0
    hfsq = 0.5 * f * f
    s = f / (2.0 + f)
    dk = float(k)
    z = s * s
    w = z * z
    t1 = w * (_LG2 + w * (_LG4 + w * _LG6))
    t2 = z * (_LG1 + w * (_LG3 + w * (_LG5 + w * _LG7)))
    r = t2 + t1
    j = (hx - 0x6147A) | (0x6B851 - hx)
    near = dk * _LN2_HI - ((hfsq - (s * (hfsq + r) + dk * _LN2_LO)) - f)
    far = dk * _LN2_HI - ((s * (f - r) - dk * _LN2_LO) - f)
    y = near if j > 0 else far
    y = y if x < 1.7976931348623157e308 else x  # +inf (NaN falls through below)
    y = y if x > 0.0 else (-np.inf if x == 0.0 else np.nan)
    return y


def _reduce(x):  # pragma: no cover (compiled)
    """x = n·π/2 + (y0 + y1), |y0| ≤ π/4, by one Cody–Waite step (e_rem_pio2.c's medium
    case with its second round always taken); returns (n mod 4 as a float, y0, y1)."""
    fn = float(math.floor(x * _INVPIO2 + 0.5))
    t = x - fn * _PIO2_1  # exact: fn·π/2₁ has at most 53 bits
    w = fn * _PIO2_2  # exact as well
    r = t - w
    w = fn * _PIO2_2T - ((t - r) - w)
    y0 = r - w
    y1 = (r - y0) - w
    return fn - 4.0 * math.floor(0.25 * fn), y0, y1  # fn mod 4, exact


def _kernels(y0, y1):  # pragma: no cover (compiled)
    """(cos, sin) of y0 + y1 on [−π/4, π/4]: k_cos.c and k_sin.c."""
    z = y0 * y0
    w = z * z
    rc = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    w1 = 1.0 - hz
    kc = w1 + (((1.0 - w1) - hz) + (z * rc - y0 * y1))
    rs = _S2 + z * (_S3 + z * _S4) + z * w * (_S5 + z * _S6)
    v = z * y0
    ks = y0 - ((z * (0.5 * y1 - v * rs) - y1) - v * _S1)
    return kc, ks


def _cos(x):  # pragma: no cover (compiled)
    """cos x for |x| < :data:`COS_EXACT_BELOW` (error below 1 ulp), branch-free: x = n·π/2
    + (y0 + y1), then k_cos or ±k_sin of (y0, y1) by n mod 4."""
    n, y0, y1 = _reduce(x)
    kc, ks = _kernels(y0, y1)
    return kc if n == 0.0 else (-ks if n == 1.0 else (-kc if n == 2.0 else ks))


def _sin(x):  # pragma: no cover (compiled)
    """sin x for |x| < :data:`COS_EXACT_BELOW` (error below 1 ulp), as :func:`_cos`."""
    n, y0, y1 = _reduce(x)
    kc, ks = _kernels(y0, y1)
    return ks if n == 0.0 else (kc if n == 1.0 else (-ks if n == 2.0 else -kc))
