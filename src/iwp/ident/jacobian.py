"""The forward-difference Jacobian: for residuals that are not differentiated along with the simulation.

Simulation-error fits of smooth models take their Jacobian from forward
sensitivities (:func:`iwp.sim.sensitivity.simulate_sensitivities`). Where that
is not possible -- the belt's play (figure 5) makes the response depend on a
parameter through the times the play closes, and the calibration of the twin
differentiates whole identification procedures -- the Jacobian is the forward
difference of whole evaluations, computed here, once for all of iwp.
"""

from __future__ import annotations

from typing import Callable, Sequence

import numpy as np

__all__ = ["forward_difference_jacobian"]


def forward_difference_jacobian(
    fun: Callable[[np.ndarray], np.ndarray],
    z: np.ndarray,
    step: float | Sequence[float],
    *,
    f0: np.ndarray | None = None,
    upper: np.ndarray | None = None,
    refused: type[Exception] | tuple[type[Exception], ...] = (),
) -> np.ndarray:
    """``J[:, j] = (fun(z + h_j e_j) - fun(z)) / h_j``.

    Parameters
    ----------
    fun : callable
        ``z -> residuals`` (1-D).
    z : ndarray
        The point (the optimiser's coordinates).
    step : float or sequence of float
        The step ``h_j`` per coordinate (one for all, or one each).
    f0 : ndarray, optional
        ``fun(z)``, when already known (saves one evaluation).
    upper : ndarray, optional
        Upper bounds of ``z``: a coordinate within ``h_j`` of its bound is
        stepped down (``-h_j``) instead, so that no evaluation leaves the box.
    refused : exception type or tuple of them
        What ``fun`` raises for a point outside its model's domain (a value
        beyond any rig): that coordinate is stepped down instead (a belt fit
        had driven a Coulomb width to just below the 1e9 every parameter is
        refused at, and its step up crashed the fit).

    Returns
    -------
    ndarray, shape (len(f0), len(z))
    """
    z = np.asarray(z, dtype=float)
    f0 = fun(z) if f0 is None else f0
    steps = np.broadcast_to(np.asarray(step, dtype=float), z.shape)
    J = np.empty((np.size(f0), z.size))
    for j in range(z.size):
        h = float(steps[j])
        if upper is not None and z[j] + h > upper[j]:
            h = -h
        zj = z.copy()
        zj[j] += h
        try:
            fj = fun(zj)
        except refused:
            h = -h
            zj[j] = z[j] + h
            fj = fun(zj)
        J[:, j] = (fj - f0) / h
    return J
