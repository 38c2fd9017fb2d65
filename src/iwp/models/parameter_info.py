"""What iwp knows about one model parameter (:class:`ParameterInfo`).

A module of its own so that the parameter sets (:mod:`iwp.models.parameters`)
and the optional terms that bring parameters (:mod:`iwp.models.terms`) both
describe their parameters with it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

from ..errors import InputError

__all__ = ["ParameterInfo", "MAX_MAGNITUDE", "check_fields", "names_with_sign", "info_table"]

#: Largest magnitude of any parameter: a guard against overflow in the models, far beyond any rig's value.
MAX_MAGNITUDE = 1e9


@dataclass(frozen=True)
class ParameterInfo:
    """What iwp knows about one model parameter: the one place a fit, a report or a check looks it up.

    Attributes
    ----------
    name : str
        Field name in :class:`LumpedParameters` or :class:`BeltParameters`.
    owner : {"lumped", "belt"}
        The parameter set that holds it.
    unit : str
        Its unit ("in" is one unit of the input ``u`` or ``v``).
    typical : float
        A typical magnitude (Table 1, section 5.1): the scale of fits and of
        difference steps when a value is 0.
    sign : {"positive", "nonnegative", "signed"}
        The physical sign (:meth:`LumpedParameters.check_physical`), and so
        the default bounds of a fit.
    description : str
    fit_range : (float, float) or None
        Bounds of a fit on a log scale (the belt's parameters and the disk's
        Coulomb friction, fitted by simulation error from the disk velocity);
        None: the parameter is not fitted on a log scale.
    floor : float
        The lowest value a fit on a linear scale may give (default 0). The
        Coulomb signs' smoothing widths have 1e-3 rad/s: thirty times finer
        than the speed resolution of any logged rig (one count per sample:
        0.03 rad/s for 4,096 counts at 50 ms), so a narrower width is not
        told apart by data, and it makes the model stiff (a width of 3e-7
        rad/s took a fit of 100 s instead of 2 s).
    """

    name: str
    owner: str
    unit: str
    typical: float
    sign: str
    description: str
    fit_range: tuple[float, float] | None = None
    floor: float = 0.0

    def default_bounds(self, log: bool = False) -> tuple[float, float]:
        """Default ``(low, high)`` of a fit: ``fit_range`` on a log scale, else from the physical sign."""
        if log:
            if self.fit_range is None:
                raise InputError(f"parameter {self.name!r} is not fitted on a log scale")
            return self.fit_range
        if self.sign == "positive":
            return (1e-12 * self.typical, math.inf)
        if self.sign == "nonnegative":
            return (self.floor, math.inf)
        return (-math.inf, math.inf)


def info_table(owner: str, rows) -> dict[str, ParameterInfo]:
    """``{name: ParameterInfo}`` of ``rows`` ``(name, unit, typical, sign, description[, fit_range[, floor]])``
    held by ``owner``."""
    return {r[0]: ParameterInfo(r[0], owner, *r[1:]) for r in rows}


def names_with_sign(infos: dict[str, ParameterInfo], sign: str) -> tuple[str, ...]:
    """The names in ``infos`` whose physical sign is ``sign`` (``"positive"``, ``"nonnegative"``)."""
    return tuple(n for n, i in infos.items() if i.sign == sign)


def check_fields(obj, where: str, positive: tuple[str, ...], nonneg: tuple[str, ...]) -> None:
    """Each field of dataclass ``obj`` a finite number within :data:`MAX_MAGNITUDE`, those named in ``positive``
    above 0 and in ``nonneg`` at least 0; a one-line error naming ``where`` and the field otherwise."""
    for f in fields(obj):
        val = getattr(obj, f.name)
        if isinstance(val, bool) or not isinstance(val, (int, float)):
            raise InputError(f"{where}: field {f.name!r} must be a number, got {val!r}")
        if not math.isfinite(val):
            raise InputError(f"{where}: field {f.name!r} must be finite, got {val!r}")
        if abs(val) > MAX_MAGNITUDE:
            raise InputError(f"{where}: field {f.name!r} = {val:.3g} is beyond +-{MAX_MAGNITUDE:.0e}, "
                             "no rig of this kind has such a value (check the units)")
    for name in positive:
        val = getattr(obj, name)
        if val <= 0.0:
            raise InputError(f"{where}: field {name!r} must be > 0, got {val!r}")
    for name in nonneg:
        val = getattr(obj, name)
        if val < 0.0:
            raise InputError(f"{where}: field {name!r} must be >= 0, got {val!r}")
