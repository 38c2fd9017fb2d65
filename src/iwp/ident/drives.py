"""How a fit of a drive model starts and is bounded: the belt (15) in place of a rigid drive's ``p2, p3``.

A term of :mod:`iwp.models.terms` with a :class:`~iwp.models.terms.DriveModel`
(the belt) puts a model of its own in place of rigid parameters; the model
says what it replaces and which parameters it has. How ``iwp fit`` fits it
is here (:data:`DRIVE_FITS`, by the drive's name): from how many of the
richest rigid fits it starts (:data:`BELT_STARTS`), its start from a rigid
fit (:func:`belt_start`: the rigid limit is the fit's disk), the bounds of
its parameters on logs sampled every ``Ts`` (:func:`belt_bounds`) and the
tolerance its fits' simulations need (:data:`BELT_RTOL`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from ..errors import InputError
from ..models.belt_parameters import BELT_INFO, BeltParameters
from ..models.parameters import LumpedParameters
from ..models.terms import BELT_FREE, DriveModel

__all__ = ["DriveFit", "DRIVE_FITS", "fit_policy", "belt_start", "belt_bounds", "BELT_STARTS", "BELT_START_PLAY",
           "BELT_BAND", "BELT_SPEED_RANGE", "BELT_RTOL"]


#: A belt's fit starts from the fits of this many of the richest rigid structures (``widths``, then
#: ``pendulum-coulomb``) and keeps the lowest cost: its forward-difference fit stops where those differences find no
#: descent, and where it stops depends on the start (``docs/fit.md``).
BELT_STARTS = 2
#: the play half-width a belt's fit starts from [rad]
BELT_START_PLAY = 0.05
#: a belt's fit keeps its resonance ``sqrt(k/I2)`` and its motor's relaxation rate ``(k/gamma)/N^2`` below this
#: many times the logs' Nyquist frequency ``pi/Ts``
BELT_BAND = 4.0
#: a belt's fit keeps its motor's speed per input unit within this factor of its start's
BELT_SPEED_RANGE = 1000.0
#: the relative tolerance of a belt's fits: the play makes the simulation error non-smooth, and the forward
#: differences of its Jacobian need simulations this exact (``docs/fit.md``: 132/140 true values inside their
#: intervals at 1e-10, 42/140 at 1e-6)
BELT_RTOL = 1e-10


def belt_start(params: LumpedParameters, *, ratio: float, Ts: float) -> BeltParameters:
    """The belt (15) a fit with the belt starts from: its rigid limit is ``params``' disk.

    Parameters
    ----------
    params : LumpedParameters
        A rigid structure's fit: the rigid limit's damping and gain are its ``p2 rho`` and ``p3 rho``.
    ratio : float
        The drive's ratio ``N`` [-] (the rig description's ``drive.ratio``).
    Ts : float
        The logs' sample period [s].

    Returns
    -------
    BeltParameters
        ``k/I2`` puts ``sqrt(k/I2)`` at a quarter of the logs' Nyquist frequency
        (``pi / (4 Ts)`` rad/s), or lower where the motor's relaxation rate
        ``(k/gamma)/N^2 = (k/I2)/(p2 rho - b2/I2)`` would exceed the Nyquist
        frequency: stiff enough to keep the slower motion the rigid fit found,
        inside the band the logs resolve (:func:`belt_bounds`); the play
        :data:`BELT_START_PLAY`; ``b2/I2`` a tenth of the rigid damping. A
        rigid fit with so little damping that this belt would lie outside
        :func:`belt_bounds` gives a start moved inside them (whose rigid limit
        then differs from the fit's).
    """
    p2rho, p3rho = params.p2 * params.rho, params.p3 * params.rho
    b2 = 0.1 * p2rho
    nyquist = math.pi / Ts
    top = BELT_BAND * nyquist
    k = min(max(min((nyquist / 4.0) ** 2, (p2rho - b2) * nyquist), 2.0 * BELT_INFO["k_over_I2"].fit_range[0]),
            0.5 * top ** 2)
    # BeltParameters.from_rigid's relations; the motor's relaxation rate k / gamma / N^2 at most half its bound
    gamma_over_I2 = max((p2rho - b2) / ratio ** 2, 2.0 * k / (top * ratio ** 2))
    values = {"k_over_I2": k, "d": BELT_START_PLAY, "b2_over_I2": b2, "k_over_gamma": k / gamma_over_I2,
              "kTbeta_over_Rgamma": p3rho / ratio / gamma_over_I2}
    bounds = belt_bounds(ratio=ratio, Ts=Ts, speed_per_input=values["kTbeta_over_Rgamma"])
    return BeltParameters(N=ratio, **{n: min(max(values[n], 2.0 * lo), 0.5 * hi) for n, (lo, hi) in bounds.items()})


def belt_bounds(*, ratio: float, Ts: float, speed_per_input: float) -> dict[str, tuple[float, float]]:
    """The bounds of a belt's fit on logs sampled every ``Ts`` [s] with the drive ratio ``ratio``.

    Parameters
    ----------
    ratio : float
        The drive's ratio ``N`` [-].
    Ts : float
        The logs' sample period [s].
    speed_per_input : float
        The start's ``kTbeta_over_Rgamma`` [rad/s per input unit] (its rigid limit's).

    Returns
    -------
    dict of str to (float, float)
        For each of :data:`BELT_FREE`: its fit range,
        except that a belt whose resonance ``sqrt(k/I2)`` or whose motor's
        relaxation rate ``(k/gamma)/N^2`` is far above the logs' Nyquist
        frequency ``pi/Ts`` looks rigid in them, and the rigid rungs cover it;
        there its stiffness is not determined, and the simulations' cost grows
        with it (a fit that drifted there took minutes per evaluation): both are
        kept below :data:`BELT_BAND` times ``pi/Ts``. The motor's speed per input
        unit depends on the input's unit (duty, volts, DAC counts): it is kept
        within a factor :data:`BELT_SPEED_RANGE` of the start's.
    """
    top = BELT_BAND * math.pi / Ts
    out = {n: BELT_INFO[n].fit_range for n in BELT_FREE}
    out["k_over_I2"] = (out["k_over_I2"][0], top ** 2)
    out["k_over_gamma"] = (out["k_over_gamma"][0], top * ratio ** 2)
    out["kTbeta_over_Rgamma"] = (speed_per_input / BELT_SPEED_RANGE, speed_per_input * BELT_SPEED_RANGE)
    return out


@dataclass(frozen=True)
class DriveFit:
    """How a fit of one drive model starts and is bounded.

    Attributes
    ----------
    starts : int
        Its fit starts from the fits of this many of the richest rigid structures, and keeps the lowest cost.
    rtol : float
        Relative (and absolute) tolerance of its fits' simulations.
    start : callable
        ``start(params, ratio=N, Ts=Ts)``: its parameters from a rigid fit.
    bounds : callable
        ``bounds(ratio=N, Ts=Ts, speed_per_input=...)``: the bounds of its free parameters.
    """

    starts: int
    rtol: float
    start: Callable[..., BeltParameters]
    bounds: Callable[..., dict[str, tuple[float, float]]]


#: How each drive model of :mod:`iwp.models.terms` is fitted, by its name.
DRIVE_FITS = {"belt": DriveFit(BELT_STARTS, BELT_RTOL, belt_start, belt_bounds)}


def fit_policy(drive: DriveModel) -> DriveFit:
    """How ``drive`` is fitted (:data:`DRIVE_FITS`); an InputError for a drive model no fit knows."""
    if drive.name not in DRIVE_FITS:
        raise InputError(f"no fit knows the drive model {drive.name!r} (known: {', '.join(DRIVE_FITS)})")
    return DRIVE_FITS[drive.name]
