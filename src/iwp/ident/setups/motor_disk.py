"""Set-ups (a) and (b): the motor-disk subsystem with the pendulum locked (section 5.1, eq. (14)).

(a) ``theta^a = [p2(1+rho), p3(1+rho)]`` from
``dq4/dt = -p2(1+rho) q4 + p3(1+rho) u`` (exact compensation assumed);
(b) adds the Coulomb column ``-sgn q4``:
``theta^b = [p2(1+rho), p3(1+rho), sigma~_c2(1+rho)]``; the paper prints
``v`` in its regressor where the model it identifies uses ``u`` (ERRATA
item 6).

The locked pendulum: a clamp that holds the pendulum gives
``dq4/dt = rho (-p2 q4 + p3 u)`` (from (4b) with ``q1'' = 0``), whereas the
paper's (14) writes ``1 + rho``. These set-ups keep the paper's names
``p2_1rho``, ``p3_1rho``, ``sigma_c2_1rho``, but on a clamped rig they
estimate ``p2 rho``, ``p3 rho``, ``sigma~_c2 rho`` (0.4 % apart with Table
1); :meth:`MotorDisk.parameter_changes` divides them by ``rho``.
"""

from __future__ import annotations

from ..regressors import columns, q4_row
from .base import RefineSpec, Regression, Setup

_NOTE = ("on a clamped rig p2_1rho, p3_1rho (, sigma_c2_1rho) estimate p2*rho, p3*rho (, sigma_c2*rho); "
         "the paper names them with (1 + rho)")


class MotorDisk(Setup):
    """Set-up (a), theta^a of section 5.1."""

    name = "motor-disk"
    paper = "theta^a, section 5.1, eq. (14)"
    columns = ("p2_1rho", "p3_1rho")
    parameters = columns
    needs_input = True
    locked = True
    note = "p2, p3 (, sigma_c2) split from p2_1rho, p3_1rho with the base rho (clamped rig: / rho)"
    refine = RefineSpec("motor-disk", ("p2", "p3"), ("q4",))

    def regression(self, sig, *, pendulum=None, p2=None) -> Regression:
        return Regression(Phi=columns(q4_row(sig), self.columns, sig.n), phi=sig.dq4, labels=["q4"], blocks=None,
                          sample_index=sig.sidx, details={"note": _NOTE})

    def row_betas(self, vals, pend, p2_known):
        return {"q4": (2, {"T5": -vals["p2_1rho"]})}

    def parameter_changes(self, values, details, base):
        rho = base.rho
        ch = {"p2": values["p2_1rho"] / rho, "p3": values["p3_1rho"] / rho}
        if self.coulomb:
            ch["sigma_c2"] = values["sigma_c2_1rho"] / rho
        return ch


class MotorDiskCoulomb(MotorDisk):
    """Set-up (b), theta^b of section 5.1: with the Coulomb friction of the disk."""

    name = "motor-disk-coulomb"
    paper = "theta^b, section 5.1"
    columns = ("p2_1rho", "p3_1rho", "sigma_c2_1rho")
    parameters = columns
    coulomb = True
    note = "p2, p3, sigma_c2 split from the (1+rho) products with the base rho (/ rho)"
    refine = RefineSpec("motor-disk", ("p2", "p3", "sigma_c2"), ("q4",))
