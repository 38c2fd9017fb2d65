"""Optical encoders: the quantisation of a measured angle.

The paper's rig measures both angles with 2000-count encoders (318.31
counts/rad, section 5); :func:`quantize` is the reading of such an encoder,
used by the virtual rig, the observer and the Gymnasium environment.
"""

from __future__ import annotations

import math

import numpy as np


def encoder_step(counts_per_rev: float) -> float:
    """The quantisation step ``2 pi / counts_per_rev`` [rad] of an encoder."""
    return 2.0 * math.pi / float(counts_per_rev)


def quantize(q, step: float) -> np.ndarray:
    """Encoder reading of the angle ``q``: ``round(q / step) * step`` [rad].

    Rounds to the nearest count (mid-tread quantiser), so every value is an
    integer multiple of ``step`` and the error is within ``+-step/2``.
    ``step <= 0`` returns ``q`` unchanged (an ideal sensor).
    """
    q = np.asarray(q, dtype=float)
    if step <= 0:
        return q.copy()
    return np.round(q / step) * step
