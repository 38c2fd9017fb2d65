"""Optical encoders: the quantisation of a measured angle.

The paper's rig measures both angles with 2000-count encoders (318.31
counts/rad, section 5); :func:`quantize` is the reading of such an encoder,
used by the virtual rig, the observer and the Gymnasium environment.
"""

from __future__ import annotations

import math

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
