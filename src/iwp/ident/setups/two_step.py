"""Set-up (d), the two-step identification: ``theta^d = [p2, p3, p2(1+rho), p3(1+rho)]`` (section 5.2).

``phi^d = [dq3/dt + xi, dq4/dt - xi]`` with
``xi = p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3``
computed from a free-pendulum result. The paper prints the rolling-friction
term of ``xi`` without its factor ``q3``; by (9) it is
``sigma_a1 |cos q1| q3`` (ERRATA item 1), which is what is used. ``rho`` is
given by both ratios and their mean (ERRATA item 2).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from ...errors import InputError
from ...models.parameters import LumpedParameters
from ..regressors import columns, xi_columns
from .base import PENDULUM, RefineSpec, Regression, Setup, rho_from_ratios, two_row_regression


def pendulum_values(pendulum: Any) -> tuple[dict[str, float], np.ndarray | None, str]:
    """(values, covariance 4x4 or None, description) of the pendulum parameters for ``xi``.

    ``pendulum``: an identification result of set-up ``"free"`` (its
    covariance is kept), a :class:`LumpedParameters` or a mapping of values.
    """
    if pendulum is None:
        raise InputError("set-up 'two-step' needs the free-pendulum parameters: pass pendulum= (the "
                         "result of set-up 'free', or a lumped parameter set); CLI: --pendulum FREE.json")
    if isinstance(pendulum, LumpedParameters):
        return {n: float(getattr(pendulum, n)) for n in PENDULUM}, None, "given parameter set (no uncertainty)"
    if hasattr(pendulum, "parameters") and hasattr(pendulum, "covariance") and hasattr(pendulum, "setup"):
        missing = [n for n in PENDULUM if n not in pendulum.parameters]
        if missing:
            raise InputError(f"pendulum: the {pendulum.setup!r} result lacks {', '.join(missing)}; "
                             "give a result of set-up 'free'")
        vals = {n: pendulum.value(n) for n in PENDULUM}
        cov = None
        if all(n in pendulum.names for n in PENDULUM):
            idx = [pendulum.names.index(n) for n in PENDULUM]
            cov = np.asarray(pendulum.covariance)[np.ix_(idx, idx)]
            if not np.all(np.isfinite(cov)):
                cov = None
        return vals, cov, f"{pendulum.setup} result from {', '.join(pendulum.sources) or 'memory'}"
    if isinstance(pendulum, Mapping):
        missing = [n for n in PENDULUM if n not in pendulum]
        if missing:
            raise InputError(f"pendulum: missing {', '.join(missing)}")
        return {n: float(pendulum[n]) for n in PENDULUM}, None, "given values (no uncertainty)"
    raise InputError(f"pendulum must be the result of set-up 'free' or a lumped parameter set, got {pendulum!r}"[:300])


class TwoStep(Setup):
    """Set-up (d) of section 5.2: the disk parameters with the pendulum terms known."""

    name = "two-step"
    paper = "theta^d, section 5.2"
    columns = ("p2", "p3", "p2_1rho", "p3_1rho")
    parameters = columns + ("rho",)
    needs_input = True
    swinging = True
    takes_pendulum = True
    note = "p1, sigma_* from --pendulum; dead zone from the base set"
    refine = RefineSpec("compensated", ("p2", "p3", "rho"), ("q1", "q4"))

    def regression(self, sig, *, pendulum=None, p2=None) -> Regression:
        pv, pcov, desc = pendulum_values(pendulum)
        Psi = columns(xi_columns(sig), PENDULUM, sig.n)  # xi = Psi @ theta_c
        xi = np.einsum("ij,j->i", Psi, np.array([pv[k] for k in PENDULUM]))
        reg = two_row_regression(sig, self.columns, sig.dq3 + xi, sig.dq4 - xi)
        reg.details.update(
            pendulum=dict(pv), pendulum_source=desc,
            xi="p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3 (ERRATA item 1)")
        if hasattr(pendulum, "setup") and pendulum.setup != "free":
            reg.warnings.append(f"the pendulum parameters come from a {pendulum.setup!r} result; section 5.2 takes "
                                "them from the free pendulum (set-up 'free'), which the paper found far more reliable")
        if pcov is not None:
            reg.known_sensitivity = np.concatenate([Psi, -Psi])
            reg.known_covariance = pcov
        return reg

    def row_betas(self, vals, pend, p2_known):
        pen = {"T1": pend["p1"], "T2": pend["sigma_a1"], "T3": pend["sigma_b1"], "T4": pend["sigma_v1"]}
        return {"q3": (1, {**{k: -x for k, x in pen.items()}, "T5": vals["p2"]}),
                "q4": (2, {**pen, "T5": -vals["p2_1rho"]})}

    def derive(self, values, covariance, critical):
        return rho_from_ratios(self.columns, values, covariance, critical)

    def parameter_changes(self, values, details, base):
        ch = {"p2": values["p2"], "p3": values["p3"], "rho": values["rho"]}
        ch.update({n: float(v) for n, v in (details.get("pendulum") or {}).items() if n in PENDULUM})
        return ch
