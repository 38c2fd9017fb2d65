"""Set-up (10)-(12): the complete model (9), both rows, eight parameters (section 5.2, eq. (16)).

``theta = [p1, sigma_a1, sigma_v1, sigma_b1, p2, p3, p2(1+rho), p3(1+rho)]``;
``rho`` is derived from both ratios (:func:`~.base.rho_from_ratios`).
"""

from __future__ import annotations

from .base import PENDULUM, RefineSpec, Regression, Setup, rho_from_ratios, two_row_regression

_COLUMNS = PENDULUM + ("p2", "p3", "p2_1rho", "p3_1rho")


class Full(Setup):
    """Set-up (10)-(12) on both rows of (9)."""

    name = "full"
    paper = "(10)-(12), section 5.2, eq. (16)"
    columns = _COLUMNS
    parameters = _COLUMNS + ("rho",)
    needs_input = True
    swinging = True
    note = "dead zone from the base set"
    refine = RefineSpec("compensated", ("p1", "p2", "p3", "rho", "sigma_a1", "sigma_v1", "sigma_b1"), ("q1", "q4"))

    def regression(self, sig, *, pendulum=None, p2=None) -> Regression:
        # (11): rows of dq3/dt first, then rows of dq4/dt
        return two_row_regression(sig, self.columns, sig.dq3, sig.dq4)

    def row_betas(self, vals, pend, p2_known):
        pen = {"T1": vals["p1"], "T2": vals["sigma_a1"], "T3": vals["sigma_b1"], "T4": vals["sigma_v1"]}
        return {"q3": (1, {**{k: -x for k, x in pen.items()}, "T5": vals["p2"]}),
                "q4": (2, {**pen, "T5": -vals["p2_1rho"]})}

    def derive(self, values, covariance, critical):
        return rho_from_ratios(self.columns, values, covariance, critical)

    def parameter_changes(self, values, details, base):
        return {**{n: values[n] for n in PENDULUM}, "p2": values["p2"], "p3": values["p3"], "rho": values["rho"]}
