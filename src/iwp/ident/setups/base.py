"""What an identification set-up is: its equation rows, its regressor, its parameters.

A :class:`Setup` carries everything that differs between the least-squares
set-ups of section 5: which rows of (10) it uses and with which regressor
columns (:meth:`Setup.regression`), the conditions it needs in the data, how
the measurement noise enters its rows (for the noise covariance), the
parameters it derives (``rho``), how its values fill a parameter set
(:meth:`Setup.parameter_changes`) and what a simulation-error refinement of
its result fits (:attr:`Setup.refine`). The driver
(:func:`iwp.ident.identification.identify`) does the rest the same way for all.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ...errors import InputError
from ..fit_parameters import Parameter
from ..regressors import columns, q3_row, q4_row

__all__ = ["Setup", "Regression", "RefineSpec", "Derived", "PARAMETER_UNITS", "PENDULUM", "LOCK_TOL"]

#: the pendulum parameters of section 3.1 (and ``p1``), over ``I1_hat``
PENDULUM = ("p1", "sigma_a1", "sigma_v1", "sigma_b1")
#: q1 range [rad] above which a "locked" log is reported as not locked
LOCK_TOL = 0.02

#: Units of the identified parameters ("in" = one unit of the input u or v).
PARAMETER_UNITS: dict[str, str] = {
    "p1": "1/s^2",
    "p2": "1/s",
    "p3": "rad/(s^2 in)",
    "rho": "-",
    "sigma_a1": "1/s",
    "sigma_v1": "1/s",
    "sigma_b1": "s/rad^2",
    "p2_1rho": "1/s",
    "p3_1rho": "rad/(s^2 in)",
    "sigma_c2_1rho": "rad/s^2",
    "v_dz_pos": "in",
    "v_dz_neg": "in",
}


@dataclass(frozen=True)
class RefineSpec:
    """What a simulation-error refinement of a set-up's result fits (``refine_identification``).

    Attributes
    ----------
    model : str
        The model simulated (:data:`iwp.models.MODELS`).
    free : tuple of str
        The parameters refined.
    outputs : tuple of str
        The measured signals compared.
    """

    model: str
    free: tuple[str, ...]
    outputs: tuple[str, ...]


@dataclass
class Regression:
    """The least-squares problem (13) of one set-up on the prepared signals.

    Attributes
    ----------
    Phi : ndarray, shape (rows, p)
        Regressor (rows of the first equation of (10) first, then the second).
    phi : ndarray, shape (rows,)
        Target.
    labels : list of str
        Block label of each equation row group (``"q3"``, ``"q4"``).
    blocks : ndarray of int8 or None
        Row -> block (None: one block).
    sample_index : ndarray of int
        Sample number of each row (for the HAC covariance).
    known_sensitivity, known_covariance : ndarray or None
        ``d(target)/d(known parameter)`` and the known parameters' covariance,
        whose uncertainty is propagated into the estimates.
    details, warnings
        Set-up specific notes for the result.
    """

    Phi: np.ndarray
    phi: np.ndarray
    labels: list[str]
    blocks: np.ndarray | None
    sample_index: np.ndarray
    known_sensitivity: np.ndarray | None = None
    known_covariance: np.ndarray | None = None
    details: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


@dataclass
class Derived:
    """Parameters a set-up derives from its estimates (``rho``), with the extended covariance."""

    parameters: dict[str, Parameter]
    names: list[str]
    covariance: np.ndarray
    rho: dict[str, float] | None = None
    details: dict[str, Any] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)


class Setup(ABC):
    """One identification set-up of section 5 (subclasses: one file each)."""

    #: its name (``setup=``, ``--setup``)
    name: str = ""
    #: where it is in the paper
    paper: str = ""
    #: the regressor's columns: the parameters of the least squares
    columns: tuple[str, ...] = ()
    #: the parameters it reports (the columns, then derived ones)
    parameters: tuple[str, ...] = ()
    #: needs the compensated input ``u`` in the logs
    needs_input: bool = False
    #: needs the motor off (no input)
    motor_off: bool = False
    #: assumes the pendulum locked (q1 = q3 = 0)
    locked: bool = False
    #: needs the pendulum swinging
    swinging: bool = False
    #: has the Coulomb column ``sgn q4``
    coulomb: bool = False
    #: identified from a static curve, not a time series
    static: bool = False
    #: takes the free-pendulum parameters (``pendulum=``)
    takes_pendulum: bool = False
    #: takes a known ``p2`` (``p2=``)
    takes_p2: bool = False
    #: what its refinement fits
    refine: RefineSpec | None = None
    #: where a parameter set written from its result takes what it does not identify
    note: str = ""

    def __repr__(self) -> str:
        return f"<set-up {self.name!r}: {self.paper}>"

    def check_options(self, pendulum: Any, p2: Any) -> None:
        """Refuse options this set-up does not use, and ask for the ones it needs."""
        if pendulum is not None and not self.takes_pendulum:
            raise InputError(f"pendulum is used by set-up 'two-step' only, not {self.name!r}", argument="pendulum")
        if pendulum is None and self.takes_pendulum:
            raise InputError(f"pendulum is required by set-up {self.name!r}: the free pendulum's parameters: the "
                             "result of set-up 'free' (CLI: --pendulum FREE.json) or a lumped parameter set",
                             argument="pendulum")
        if p2 is not None and not self.takes_p2:
            raise InputError(f"p2 is used by set-up 'free' only, not {self.name!r}", argument="p2")

    def regression(self, sig, *, pendulum: Any = None, p2: Any = None) -> Regression:
        """The regressor and target of (13) on the prepared signals ``sig`` (:class:`~iwp.ident.signals.Signals`)."""
        raise InputError(f"set-up {self.name!r} is not identified from time series")

    def check_signals(self, sig, sources: Sequence[str]) -> list[str]:
        """Warnings about the data: a pendulum that should be locked moves, or should swing and does not."""
        out = []
        if self.locked:
            moving = [(s, r) for s, r in zip(sources, sig.q1_range) if r > LOCK_TOL]
            if moving:
                out.append(
                    f"set-up {self.name!r} assumes the pendulum locked (q1 = q3 = 0), but q1 moves in "
                    + ", ".join(f"{s} (range {r:.3g} rad)" for s, r in moving)
                    + "; the pendulum row of (9) is then missing from the model and the estimates are biased")
        if self.swinging:
            still = [(s, r) for s, r in zip(sources, sig.q1_range) if r <= LOCK_TOL]
            if still:
                out.append(
                    f"set-up {self.name!r} needs the pendulum swinging, but q1 hardly moves in "
                    + ", ".join(f"{s} (range {r:.3g} rad)" for s, r in still)
                    + ("; with a locked pendulum the first row of (10) does not hold (the clamp's torque is missing)"
                       if self.takes_pendulum else ""))
        return out

    @abstractmethod
    def row_betas(self, vals: Mapping[str, float], pend: Mapping[str, float] | None,
                  p2_known: float) -> dict[str, tuple[int, dict[str, float]]]:
        """How the encoder noise enters each block: (channel 1 = q1 or 2 = q2, coefficient of each term T1..T5).

        The terms of (9) as functions of the measured signals: ``T1 = sin q1``,
        ``T2 = |cos q1| q3``, ``T3 = q3^3``, ``T4 = q3`` (channel q1) and
        ``T5 = q4`` (channel q2); the coefficient is that of the term in the
        block's row ``dq/dt = sum beta_i T_i + (input terms)``.
        """

    def derive(self, values: np.ndarray, covariance: np.ndarray, critical: float) -> Derived | None:
        """Parameters derived from the estimates (``rho``); None when there are none."""
        return None

    def extra_warnings(self, reg: Regression, sig, res, params: Mapping[str, Parameter], ref,
                       p2: Any) -> tuple[list[str], dict[str, Any]]:
        """Warnings and details that interpret this set-up's numbers (after the fit)."""
        return [], {}

    @abstractmethod
    def parameter_changes(self, values: Mapping[str, float], details: Mapping[str, Any],
                          base) -> dict[str, float]:
        """The fields of a :class:`~iwp.models.parameters.LumpedParameters` this set-up's values set."""


def rho_from_ratios(columns: Sequence[str], values: np.ndarray, cov: np.ndarray, critical: float) -> Derived:
    """``rho`` from both ratios, ``rho_1 = p2(1+rho)/p2 - 1``, ``rho_2 = p3(1+rho)/p3 - 1``, and their mean.

    ERRATA item 2: the printed numbers lack the ``- 1``; the derivation has
    it. The covariance is extended by the mean (delta method); a warning
    when the two ratios differ by more than three standard errors.
    """
    names = list(columns)
    i2, i3, i2r, i3r = (names.index(k) for k in ("p2", "p3", "p2_1rho", "p3_1rho"))
    a, b, c, e = (values[k] for k in (i2r, i2, i3r, i3))
    with np.errstate(divide="ignore", invalid="ignore"):
        r1 = a / b - 1.0
        r2 = c / e - 1.0
        g1 = np.zeros(len(names))
        g2 = np.zeros(len(names))
        g1[i2r], g1[i2] = 1.0 / b, -a / b ** 2
        g2[i3r], g2[i3] = 1.0 / e, -c / e ** 2
    gm = 0.5 * (g1 + g2)
    G = np.vstack([g1, g2, gm])
    cov_r = G @ cov @ G.T
    rho_mean = 0.5 * (r1 + r2)
    se_r = np.sqrt(np.clip(np.diag(cov_r), 0.0, None))
    params = {"rho": Parameter.estimate("rho", float(rho_mean), float(se_r[2]), critical)}
    cov_ext = np.block([[cov, (cov @ gm)[:, None]], [(gm @ cov)[None, :], np.array([[gm @ cov @ gm]])]])
    warnings = []
    diff_var = (g1 - g2) @ cov @ (g1 - g2)
    if math.isfinite(diff_var) and diff_var > 0 and abs(r1 - r2) > 3.0 * math.sqrt(diff_var):
        warnings.append(
            f"the two ratios for rho disagree: rho_1 = {r1:.5g}, rho_2 = {r2:.5g} (difference "
            f"{abs(r1 - r2) / math.sqrt(diff_var):.1f} standard errors); the model (9) does not fit these "
            "data exactly (unmodelled friction, belt, dead-zone residue); their mean is reported")
    return Derived(parameters=params, names=names + ["rho"], covariance=cov_ext,
                   rho={"rho_1": float(r1), "rho_2": float(r2), "mean": float(rho_mean)},
                   details={"rho_stderr": {"rho_1": float(se_r[0]), "rho_2": float(se_r[1]), "mean": float(se_r[2])}},
                   warnings=warnings)


def two_row_regression(sig, names: Sequence[str], phi_q3: np.ndarray, phi_q4: np.ndarray) -> Regression:
    """A regression on both rows of (10) for the parameters ``names``: rows of ``dq3/dt`` first, then of
    ``dq4/dt``, with the columns of (11) (:mod:`iwp.ident.regressors`)."""
    n = sig.n
    Phi = np.vstack([columns(q3_row(sig), names, n), columns(q4_row(sig), names, n)])
    return Regression(Phi=Phi, phi=np.concatenate([phi_q3, phi_q4]), labels=["q3", "q4"],
                      blocks=np.repeat(np.array([0, 1], dtype=np.int8), n),
                      sample_index=np.concatenate([sig.sidx, sig.sidx]))
