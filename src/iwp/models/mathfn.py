"""Sine and cosine for the compiled right-hand sides.

:func:`sincos` is fdlibm's algorithm written out, so that it inlines into the
integrator, overlaps with the stage arithmetic and vectorises across
simulations run side by side (:mod:`iwp.sim.lanes`); libm's ``sin`` and
``cos`` are two library calls that do neither.
"""

from __future__ import annotations

import math

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

#: Largest |angle| [rad] that :func:`sincos` reduces accurately; beyond it
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
