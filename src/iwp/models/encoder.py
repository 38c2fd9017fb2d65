"""Optical encoders: the quantisation of a measured angle, and its zero.

The paper's rig measures both angles with 2000-count encoders (318.31
counts/rad, section 5); :func:`quantize` is the reading of such an encoder,
used by the virtual rig, the observer and the Gymnasium environment.
:class:`EncoderZero` is where a run zeroed its pendulum encoder, as a log
that no fit saw can know it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence

import numpy as np


def encoder_step(counts_per_rev: float) -> float:
    """The quantisation step ``2 pi / counts_per_rev`` [rad] of an encoder.

    See Also
    --------
    quantize : The reading of an encoder with this step.

    Examples
    --------
    The rig's 2000-count encoders (section 5):

    >>> from iwp.models import encoder_step
    >>> round(encoder_step(2000), 6)  # [rad]
    0.003142
    >>> round(1 / encoder_step(2000), 2)  # counts/rad
    318.31
    """
    return 2.0 * math.pi / float(counts_per_rev)


def quantize(q, step: float) -> np.ndarray:
    """Encoder reading of the angle ``q``: ``round(q / step) * step`` [rad].

    Rounds to the nearest count (mid-tread quantiser), so every value is an
    integer multiple of ``step`` and the error is within ``+-step/2``.
    ``step <= 0`` returns ``q`` unchanged (an ideal sensor).

    See Also
    --------
    encoder_step : The step of an encoder from its counts per revolution.

    Examples
    --------
    A 2000-count encoder reads 0.1234 rad as 39 counts, and -0.002 rad as -1:

    >>> from iwp.models import encoder_step, quantize
    >>> step = encoder_step(2000)
    >>> q = quantize([0.1234, -0.0020], step)
    >>> q.round(5), (q / step).round()  # [rad], counts
    (array([ 0.12252, -0.00314]), array([39., -1.]))
    >>> float(quantize(0.1234, 0.0))  # step <= 0: an ideal sensor
    0.1234
    """
    q = np.asarray(q, dtype=float)
    if step <= 0:
        return q.copy()
    return np.round(q / step) * step


@dataclass(frozen=True)
class EncoderZero:
    """The zero of a held-out log's pendulum angle: the training logs' mean offset, and how far a run's own
    zero strays from it.

    Each run zeroes its encoder where the pendulum happens to hang, anywhere
    within a count (or where friction held it), so a logged angle is the
    model's plus a constant ``d``. A fit estimates each training log's ``d``;
    a held-out log gets their mean :attr:`value`, and its own zero differs
    from that with variance ``max(s^2, step^2 / 12) (1 + 1/n)``: ``s^2`` the
    training offsets' sample variance (0 below two logs), ``step`` the
    held-out log's encoder count, ``1/n`` the mean's own share (0 when the
    rig gives the offset). The prediction band carries it
    (:class:`iwp.sim.uncertainty.StartUncertainty`).

    Attributes
    ----------
    value : float
        The offset taken off a held-out log's angle [rad].
    spread : float
        The training offsets' sample variance [rad^2] (0 below two logs, or when the rig gives the offset).
    n : int
        How many training offsets :attr:`value` averages (0: the rig gives it).

    Examples
    --------
    Three training logs zeroed 2 mrad apart, and a 2000-count encoder (a count's own spread is 8.2e-7 rad^2):

    >>> from iwp.models import EncoderZero, encoder_step
    >>> zero = EncoderZero.of([0.002, -0.002, 0.0])
    >>> round(zero.value, 6), round(zero.spread, 9), zero.n
    (0.0, 4e-06, 3)
    >>> round(zero.variance(encoder_step(2000)), 10)  # [rad^2]: 4e-6 x (1 + 1/3)
    5.3e-06
    """

    value: float = 0.0
    spread: float = 0.0
    n: int = 0

    @classmethod
    def of(cls, offsets: Sequence[float], given: bool = False) -> "EncoderZero":
        """From the training logs' estimated offsets [rad]; ``given``: the rig's offset is already taken off
        every log (value 0, a run's own count left)."""
        offs = np.asarray(offsets, dtype=float)
        if given or offs.size == 0:
            return cls()
        return cls(float(offs.mean()), float(offs.var(ddof=1)) if offs.size > 1 else 0.0, int(offs.size))

    def variance(self, step: float) -> float:
        """The variance of a held-out log's own zero about :attr:`value` [rad^2], ``step`` its encoder's count
        [rad] (0 for an unquantised angle)."""
        return max(self.spread, step * step / 12.0) * (1.0 + (1.0 / self.n if self.n else 0.0))

    def to_dict(self) -> dict[str, Any]:
        """``{"q1_offset": value, "q1_offset_spread": spread, "q1_offset_logs": n}``, as ``parameters.json``
        holds them."""
        return {"q1_offset": self.value, "q1_offset_spread": self.spread, "q1_offset_logs": self.n}
