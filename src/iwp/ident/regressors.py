"""The regressor (11) of the two rows of (9), written once; each set-up takes the columns it needs.

Model (9) is linear in its parameters (section 4):

    q3' = -xi + p2 q4 - p3 u
    q4' =  xi - p2(1 + rho) q4 + p3(1 + rho) u

with ``xi = p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3``.
The functions below give each row's columns by parameter name, from an
object with the (filtered) terms of the rows as attributes: ``S`` (``sin q1``),
``C`` (``|cos q1| q3``), ``q3``, ``B`` (``q3^3``), ``q4``, ``u`` and, for
the Coulomb column of section 5.1, ``G`` (``sgn q4``) -- the identification's
:class:`~iwp.ident.signals.Signals` or any other source of those terms. A
set-up stacks the columns of its ``theta`` (:func:`columns`).
"""

from __future__ import annotations

from typing import Any, Mapping, Sequence

import numpy as np

__all__ = ["xi_columns", "q3_row", "q4_row", "row_sum", "columns"]


def xi_columns(sig: Any) -> dict[str, np.ndarray]:
    """The pendulum terms ``xi`` of (9) by parameter: ``xi = sum_k theta_k column_k``.

    Parameters
    ----------
    sig : Signals
        Filtered signals, with ``S`` (``K sin q1``), ``C`` (``K |cos q1| q3``), ``q3`` and ``B`` (``K q3^3``).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Columns of ``p1``, ``sigma_a1``, ``sigma_v1``, ``sigma_b1``.
    """
    return {"p1": sig.S, "sigma_a1": sig.C, "sigma_v1": sig.q3, "sigma_b1": sig.B}


def q3_row(sig: Any) -> dict[str, np.ndarray]:
    """The columns of the ``q3'`` row of (11): ``q3' = -xi + p2 q4 - p3 u``.

    Parameters
    ----------
    sig : Signals
        Filtered signals (as :func:`xi_columns`, and ``q4`` [rad/s], ``u`` [in]).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Columns of ``p1``, ``sigma_a1``, ``sigma_v1``, ``sigma_b1``, ``p2`` and ``p3``.
    """
    return {**{k: -v for k, v in xi_columns(sig).items()}, "p2": sig.q4, "p3": -sig.u}


def q4_row(sig: Any) -> dict[str, np.ndarray]:
    """The columns of the ``q4'`` row of (11) (and the Coulomb column ``-sgn q4`` of section 5.1, when ``G`` is known):
    ``q4' = xi - p2(1 + rho) q4 + p3(1 + rho) u - sigma_c2(1 + rho) sgn q4``.

    Parameters
    ----------
    sig : Signals
        Filtered signals (as :func:`xi_columns`, ``q4`` [rad/s], ``u`` [in] and, optionally, ``G`` = ``K sgn q4``).

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Columns of the pendulum terms, ``p2_1rho``, ``p3_1rho`` and, with ``G``, ``sigma_c2_1rho``.
    """
    row = {**xi_columns(sig), "p2_1rho": -sig.q4, "p3_1rho": sig.u}
    if getattr(sig, "G", None) is not None:
        row["sigma_c2_1rho"] = -sig.G
    return row


def row_sum(sig: Any) -> dict[str, np.ndarray]:
    """The columns of the sum of the two rows, free of the pendulum terms: ``q3' + q4' = -rho p2 q4 + rho p3 u``.

    Parameters
    ----------
    sig : Signals
        Filtered signals with ``q4`` [rad/s] and ``u`` [in].

    Returns
    -------
    dict of str to ndarray, shape (n,)
        Columns of ``rho_p2`` and ``rho_p3``.
    """
    return {"rho_p2": -sig.q4, "rho_p3": sig.u}


def columns(row: Mapping[str, np.ndarray], names: Sequence[str], n: int) -> np.ndarray:
    """The regressor of ``row`` for the parameters ``names`` (a column of zeros where the row lacks one).

    Parameters
    ----------
    row : mapping of str to ndarray, shape (n,)
        Columns of a row by parameter name.
    names : sequence of str
        Parameters, in column order.
    n : int
        Number of rows.

    Returns
    -------
    ndarray, shape (n, len(names))
        The regressor.
    """
    return np.column_stack([row[k] if k in row else np.zeros(n) for k in names])
