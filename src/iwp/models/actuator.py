"""The actuator: dead zone (5), its break-away, feedforward compensation (7)-(8), saturation.

The dead zone of section 3.2 is a friction torque that depends on the
driver command ``v``: ``tau~_dz = p3 f(v)`` with ``f`` the saturation of (5),
so the net input that reaches the disk is ``p3 (v - f(v))``. The feedforward
(7)-(8) adds the thresholds to the ideal input ``u``:
``v = u + v+`` for ``u > 0``, ``u - v-`` for ``u < 0``, ``0`` for ``u = 0``.
The command that reaches the plant is the feedforward output, clipped by
the driver's saturation (:func:`command`).

Each law is one compiled scalar function; the vectorised Python functions
(:func:`dead_zone`, :func:`dead_zone_output`, :func:`feedforward`) apply it
element-wise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError
from ..jit import jit
from .layout import BRK, C_FF, C_FFNEG, C_FFPOS, C_SATHI, C_SATLO, DZ, UOFF, VNEG, VPOS, WS

__all__ = ["StartupFriction", "dead_zone", "dead_zone_output", "feedforward", "saturate", "command_vector"]


@dataclass(frozen=True)
class StartupFriction:
    """Break-away of the disk: the start-up discontinuity of figure 2(a).

    At rest the dead-zone thresholds are ``(1 + break_ratio) v+`` and
    ``(1 + break_ratio) v-``; they fall to ``v+`` and ``v-`` as the disk
    speeds up, ``v(q4) = v (1 + break_ratio exp(-(q4/omega_s)^2))``. The
    static curve then jumps when the disk starts (figure 2a).

    Parameters
    ----------
    break_ratio : float
        Extra threshold at rest, relative to ``v+``/``v-`` [-].
    omega_s : float
        Stribeck velocity [rad/s].
    """

    break_ratio: float = 0.0  # [-]
    omega_s: float = 1.0  # [rad/s]

    def __post_init__(self) -> None:
        if not (math.isfinite(self.break_ratio) and self.break_ratio >= 0):
            raise InputError(f"StartupFriction.break_ratio must be finite and >= 0, got {self.break_ratio!r}")
        if not (math.isfinite(self.omega_s) and self.omega_s > 0):
            raise InputError(f"StartupFriction.omega_s must be finite and > 0, got {self.omega_s!r}")


# --------------------------------------------------------------------------
# compiled laws
# --------------------------------------------------------------------------
@jit
def dead_zone_saturation(v, vpos, vneg):
    """The saturation ``f(v)`` of the dead zone (5), in input units."""
    if v > vpos:
        return vpos
    if v < -vneg:
        return -vneg
    return v


@jit
def dead_zone_net(v, vpos, vneg):
    """Net input ``v - f(v)`` that passes the dead zone (5): ``p3 v - tau~_dz = p3 (v - f(v))``."""
    return v - dead_zone_saturation(v, vpos, vneg)


@jit
def breakaway_scale(q4, break_ratio, omega_s):
    """Factor ``1 + break_ratio exp(-(q4/omega_s)^2)`` of the thresholds (:class:`StartupFriction`)."""
    if break_ratio > 0.0:
        r = q4 / omega_s
        return 1.0 + break_ratio * math.exp(-r * r)
    return 1.0


@jit
def effective_input(w, q4, P):
    """The input that reaches the disk: ``w + u_offset``, through the dead zone when the plant has it
    active (models (6), (14) raw)."""
    w = w + P[UOFF]
    if P[DZ] == 0.0:
        return w
    scale = breakaway_scale(q4, P[BRK], P[WS])
    return dead_zone_net(w, P[VPOS] * scale, P[VNEG] * scale)


@jit
def feedforward_law(u, vpos, vneg):
    """Dead-zone feedforward (7)-(8): ``v = u + v+`` (u > 0), ``u - v-`` (u < 0), 0 (u = 0)."""
    if u > 0.0:
        return u + vpos
    if u < 0.0:
        return u - vneg
    return 0.0


@jit
def saturate(w, lo, hi):
    """``w`` clipped to ``[lo, hi]`` (the driver's limits)."""
    if w > hi:
        return hi
    if w < lo:
        return lo
    return w


@jit
def command(u, command_params):
    """The command sent to the plant: the feedforward (7)-(8) if enabled, then the saturation.

    ``command_params`` is the command vector of :func:`command_vector`.
    """
    w = u
    if command_params[C_FF] != 0.0:
        w = feedforward_law(u, command_params[C_FFPOS], command_params[C_FFNEG])
    return saturate(w, command_params[C_SATLO], command_params[C_SATHI])


@jit
def _feedforward_array(u, vpos, vneg, out):
    for i in range(u.size):
        out[i] = feedforward_law(u[i], vpos, vneg)


@jit
def _dead_zone_array(v, vpos, vneg, out, net):
    for i in range(v.size):
        out[i] = dead_zone_net(v[i], vpos, vneg) if net else dead_zone_saturation(v[i], vpos, vneg)


# --------------------------------------------------------------------------
# Python API (element-wise)
# --------------------------------------------------------------------------
def _apply(kernel, x, *args):
    a = np.asarray(x, dtype=float)
    flat = np.ascontiguousarray(a.ravel())
    out = np.empty_like(flat)
    kernel(flat, *args, out)
    return out.reshape(a.shape) if a.ndim else float(out[0])


def dead_zone(v, v_dz_pos: float, v_dz_neg: float):
    """The dead-zone saturation ``f(v)`` of (5) in input units (element-wise).

    Parameters
    ----------
    v : float or array_like
        Commanded input ``v`` [input units].
    v_dz_pos : float
        Threshold ``v+`` of the dead zone for positive inputs [input units].
    v_dz_neg : float
        Threshold ``v-`` for negative inputs, as a magnitude (``f(v) = -v-`` below ``-v-``) [input units].

    Returns
    -------
    float or ndarray
        ``f(v)``: ``v`` clipped to ``[-v-, v+]`` [input units]; a float for a scalar ``v``, else an array of
        ``v``'s shape.

    Examples
    --------
    >>> from iwp import dead_zone
    >>> dead_zone([10.0, 40.0, -50.0], 31.0, 31.0)
    array([ 10.,  31., -31.])
    """
    return _apply(lambda x, out: _dead_zone_array(x, float(v_dz_pos), float(v_dz_neg), out, False), v)


def dead_zone_output(v, v_dz_pos: float, v_dz_neg: float):
    """The net input ``v - f(v)`` that reaches the disk through the dead zone (5) (element-wise).

    Parameters
    ----------
    v : float or array_like
        Commanded input ``v`` [input units].
    v_dz_pos : float
        Threshold ``v+`` of the dead zone for positive inputs [input units].
    v_dz_neg : float
        Threshold ``v-`` for negative inputs, as a magnitude [input units].

    Returns
    -------
    float or ndarray
        ``v - f(v)`` [input units]: zero inside ``[-v-, v+]``, ``v - v+`` above and ``v + v-`` below; a float
        for a scalar ``v``, else an array of ``v``'s shape.

    See Also
    --------
    dead_zone : The part ``f(v)`` the dead zone swallows.
    feedforward : The command whose net input is a wanted ``u``.

    Examples
    --------
    With Table 1's thresholds (31 input units), a command of 40 moves the disk like 9:

    >>> from iwp import table1
    >>> from iwp.models import dead_zone_output
    >>> p = table1()
    >>> dead_zone_output([-40.0, 20.0, 40.0], p.v_dz_pos, p.v_dz_neg)
    array([-9.,  0.,  9.])
    >>> dead_zone_output(40.0, p.v_dz_pos, p.v_dz_neg)
    9.0
    """
    return _apply(lambda x, out: _dead_zone_array(x, float(v_dz_pos), float(v_dz_neg), out, True), v)


def feedforward(u, v_dz_pos: float, v_dz_neg: float | None = None):
    """Dead-zone feedforward (7)-(8): ``v = u + tau~_c(u)/p3`` (element-wise).

    ``v = u + v+`` for ``u > 0``, ``u - v-`` for ``u < 0`` and ``0`` for
    ``u = 0``, with asymmetric thresholds (``v_dz_neg`` defaults to
    ``v_dz_pos``; the paper uses ``v+ = v- = 31``).

    Parameters
    ----------
    u : float or array_like
        Input ``u`` the controller asks for [input units].
    v_dz_pos : float
        Threshold ``v+`` added for ``u > 0`` [input units].
    v_dz_neg : float or None, optional
        Threshold ``v-`` subtracted for ``u < 0``, as a magnitude [input units]; ``None`` (default): ``v_dz_pos``.

    Returns
    -------
    float or ndarray
        Command ``v`` (8) [input units]; a float for a scalar ``u``, else an array of ``u``'s shape.

    Examples
    --------
    >>> from iwp import dead_zone, feedforward
    >>> feedforward([-20.0, 0.0, 20.0], 31.0)
    array([-51.,   0.,  51.])
    >>> v = feedforward(20.0, 31.0)
    >>> v - dead_zone(v, 31.0, 31.0)  # what passes the dead zone is u again
    20.0
    """
    if v_dz_neg is None:
        v_dz_neg = v_dz_pos
    return _apply(lambda x, out: _feedforward_array(x, float(v_dz_pos), float(v_dz_neg), out), u)


def command_vector(feedforward_thresholds=None, saturation: float | None = None) -> np.ndarray:
    """The command vector read by :func:`command`.

    Parameters
    ----------
    feedforward_thresholds : (float, float) or None
        ``(v+, v-)`` of the feedforward (7)-(8) [input units]; ``None``: off.
    saturation : float or None
        Clip the command to ``[-saturation, saturation]`` [input units].
    """
    c = np.array([0.0, 0.0, 0.0, -math.inf, math.inf])
    if feedforward_thresholds is not None:
        c[C_FF], c[C_FFPOS], c[C_FFNEG] = 1.0, float(feedforward_thresholds[0]), float(feedforward_thresholds[1])
    if saturation is not None:
        c[C_SATLO], c[C_SATHI] = -float(saturation), float(saturation)
    return c
