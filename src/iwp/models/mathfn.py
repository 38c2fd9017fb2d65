"""Sine, cosine, logarithm and exponential for compiled code that vectorises.

:func:`sincos` is fdlibm's algorithm written out, so that it inlines into the
integrator, overlaps with the stage arithmetic and vectorises across
simulations run side by side (:mod:`iwp.sim.lanes`); libm's ``sin`` and
``cos`` are two library calls that do neither. :func:`log_vec` and
:func:`exp_vec` do the same for the step-size controller
(:mod:`iwp.sim.step_size`), whose factor every lane computes after every
step: exponent and mantissa taken apart by their bits, a series on the
reduced argument.
"""

from __future__ import annotations

import math

from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

from ..jit import jit

# pi/2 in three parts (the first two with trailing zero bits) and 2/pi (fdlibm)
_INVPIO2 = 6.36619772367581382433e-01
_PIO2_1 = 1.57079632673412561417e00
_PIO2_2 = 6.07710050630396597660e-11
_PIO2_3 = 2.02226624871116645580e-21
# fdlibm's minimax coefficients of sin and cos on [-pi/4, pi/4]
_S1, _S2, _S3 = -1.66666666666666324348e-01, 8.33333333332248946124e-03, -1.98412698298579493134e-04
_S4, _S5, _S6 = 2.75573137070700676789e-06, -2.50507602534068634195e-08, 1.58969099521155010221e-10
_C1, _C2, _C3 = 4.16666666666666019037e-02, -1.38888888888741095749e-03, 2.48015872894767294178e-05
_C4, _C5, _C6 = -2.75573143513906633035e-07, 2.08757232129817482790e-09, -1.13596475577881948265e-11

#: Largest magnitude of an angle [rad] that :func:`sincos` reduces accurately; beyond it
#: (and for inf or NaN) it returns NaN, which the simulator reports as a
#: diverged run.
SINCOS_MAX = 1.0e9


@jit(exact=True)
def sincos(x):
    """``(sin x, cos x)``, within 2 ulp of libm for ``|x| <= SINCOS_MAX`` (NaN beyond).

    Cody-Waite reduction by pi/2 in three parts, the minimax polynomials of
    fdlibm's ``__kernel_sin`` and ``__kernel_cos`` and a branch-free choice
    of quadrant. Compiled without reassociation, which would undo the
    reduction and the compensated sum of the cosine.
    """
    x = x if abs(x) <= SINCOS_MAX else math.nan
    fn = math.floor(x * _INVPIO2 + 0.5)
    r = ((x - fn * _PIO2_1) - fn * _PIO2_2) - fn * _PIO2_3
    z = r * r
    w = z * z
    s = r + z * r * (_S1 + z * (_S2 + z * (_S3 + z * (_S4 + z * (_S5 + z * _S6)))))
    cr = z * (_C1 + z * (_C2 + z * _C3)) + w * w * (_C4 + z * (_C5 + z * _C6))
    hz = 0.5 * z
    wc = 1.0 - hz
    c = wc + (((1.0 - wc) - hz) + z * cr)
    # quadrant fn mod 4 (NaN, whose conversion to an integer is undefined, as 0)
    n = int(fn if fn == fn else 0.0)
    odd = (n & 1) != 0
    sq = c if odd else s
    cq = s if odd else c
    if n & 2:
        sq = -sq
    if (n + 1) & 2:
        cq = -cq
    return sq, cq


@intrinsic
def float_bits(typingctx, x):
    """The IEEE 754 bits of a float64 as an int64 (a reinterpretation, no conversion)."""
    if x != types.float64:
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.IntType(64))

    return types.int64(x), codegen


@intrinsic
def bits_float(typingctx, i):
    """The float64 whose IEEE 754 bits are the int64 ``i`` (the inverse of :func:`float_bits`)."""
    if i != types.int64:
        return None

    def codegen(context, builder, sig, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(i), codegen


_LN2 = 6.93147180559945286227e-01
# ln 2 in two parts (the first with trailing zero bits), for the exponential's reduction (fdlibm)
_LN2_HI = 6.93147180369123816490e-01
_LN2_LO = 1.90821492927058770002e-10
_MANTISSA = (1 << 52) - 1
_ONE_BITS = 1023 << 52
#: the arguments :func:`exp_vec` takes: beyond them it saturates at exp(+-EXP_VEC_MAX)
EXP_VEC_MAX = 700.0


@jit(inline=True)
def log_vec(x):
    """``ln x`` for a positive normal float64 ``x``, within 1e-15 of libm relative to ``max(|ln x|, 1)`` (branch-free).

    ``x = 2^e m`` with ``m`` in [sqrt(1/2), sqrt(2)) from the bits;
    ``ln m = 2 atanh(s)``, ``s = (m - 1)/(m + 1)`` with ``|s| < 0.172``, by
    its series to ``s^17``. For 0, a subnormal, inf or NaN the result is
    meaningless: the caller keeps such values away.
    """
    b = float_bits(x)
    e = (b >> 52) - 1023
    m = bits_float((b & _MANTISSA) | _ONE_BITS)
    big = m > 1.4142135623730951
    m = 0.5 * m if big else m
    e = e + 1 if big else e
    s = (m - 1.0) / (m + 1.0)
    z = s * s
    p = 1.0 + z * (1.0 / 3 + z * (1.0 / 5 + z * (1.0 / 7 + z * (1.0 / 9 + z * (1.0 / 11 + z * (
        1.0 / 13 + z * (1.0 / 15 + z * (1.0 / 17))))))))
    return e * _LN2 + 2.0 * s * p


@jit(inline=True)
def exp_vec(y):
    """``exp y`` for ``|y| <= EXP_VEC_MAX``, within 4e-16 relative of libm (branch-free; ``y`` beyond is clipped).

    ``y = k ln 2 + r`` with ``|r| <= ln 2 / 2`` (Cody-Waite, two-part ``ln 2``),
    ``exp r`` by its Taylor series to ``r^13``, ``2^k`` from the bits.
    """
    y = min(max(y, -EXP_VEC_MAX), EXP_VEC_MAX)
    k = math.floor(y * (1.0 / _LN2) + 0.5)
    r = (y - k * _LN2_HI) - k * _LN2_LO
    p = 1.0 + r * (1.0 + r * (1.0 / 2 + r * (1.0 / 6 + r * (1.0 / 24 + r * (1.0 / 120 + r * (1.0 / 720 + r * (
        1.0 / 5040 + r * (1.0 / 40320 + r * (1.0 / 362880 + r * (1.0 / 3628800 + r * (1.0 / 39916800 + r * (
            1.0 / 479001600 + r * (1.0 / 6227020800)))))))))))))
    # 2^k in two halves, so that k down to -1010 stays a normal power
    k1 = int(k) // 2
    k2 = int(k) - k1
    return p * bits_float((k1 + 1023) << 52) * bits_float((k2 + 1023) << 52)
