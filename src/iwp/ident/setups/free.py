"""Set-up (c): the free pendulum, ``theta^c = [p1, sigma_a1, sigma_v1, sigma_b1]`` (section 5.2).

From the first row of (9) with ``u = 0``:
``dq3/dt = -p1 sin q1 - sigma_a1 |cos q1| q3 - sigma_v1 q3 - sigma_b1 q3^3``.

With the motor off the disk still turns as the pendulum swings (``q4`` is
driven by ``xi``), and the first row of (9) contains ``+ p2 q4``, which
``theta^c`` neglects. Give ``p2=`` (a value, or a two-step result) to move
``p2 q4`` into the target; without it the set-up is the paper's and a
warning estimates the size of the neglected term.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from ...errors import InputError
from ...models.parameters import LumpedParameters
from ..lsq import lstsq_projection
from ..regressors import columns, q3_row
from .base import LOCK_TOL, PENDULUM, RefineSpec, Regression, Setup


def known_p2(p2: Any) -> tuple[float, float]:
    """(value, variance) of a known ``p2`` [1/s]: a number, a result with ``p2``, or a parameter set."""
    if isinstance(p2, LumpedParameters):
        return float(p2.p2), 0.0
    if hasattr(p2, "parameters") and hasattr(p2, "setup"):
        if "p2" not in p2.parameters:
            raise InputError(f"p2: the {p2.setup!r} result has no p2; give a 'two-step' or 'full' result")
        se = p2.stderr("p2")
        return p2.value("p2"), (se * se if math.isfinite(se) else 0.0)
    try:
        v = float(p2)
    except (TypeError, ValueError):
        raise InputError(f"p2 must be a number [1/s], the result of set-up 'two-step' or 'full', or a lumped "
                         f"parameter set, got {p2!r}") from None
    if not math.isfinite(v):
        raise InputError(f"p2 must be finite, got {v!r}")
    return v, 0.0


#: the wheel counts as held to the arm when its speed stays below this share of the pendulum's
HELD_WHEEL = 0.01


class FreePendulum(Setup):
    """Set-up (c), the free pendulum of section 5.2."""

    name = "free"
    paper = "theta^c, section 5.2"
    columns = PENDULUM
    parameters = PENDULUM
    motor_off = True
    takes_p2 = True
    note = "p2, p3, rho, dead zone from the base set"
    refine = RefineSpec("free", PENDULUM, ("q1",))

    def regression(self, sig, *, pendulum=None, p2=None) -> Regression:
        reg = Regression(Phi=columns(q3_row(sig), self.columns, sig.n), phi=sig.dq3.copy(),
                         labels=["q3"], blocks=None, sample_index=sig.sidx)
        if p2 is not None:
            p2v, p2var = known_p2(p2)
            reg.phi = reg.phi - p2v * sig.q4
            reg.details["p2_known"] = {"value": p2v, "stderr": math.sqrt(p2var)}
            if p2var > 0:
                reg.known_sensitivity = -sig.q4[:, None]
                reg.known_covariance = np.array([[p2var]])
        return reg

    def check_signals(self, sig, sources) -> list[str]:
        if max(sig.q1_range) <= LOCK_TOL:
            return [f"set-up 'free': the pendulum hardly moves (q1 range {max(sig.q1_range):.3g} rad); "
                    "nothing to identify"]
        return []

    def row_betas(self, vals, pend, p2_known):
        v = vals
        return {"q3": (1, {"T1": -v["p1"], "T2": -v["sigma_a1"], "T3": -v["sigma_b1"], "T4": -v["sigma_v1"],
                           "T5": p2_known})}

    def extra_warnings(self, reg, sig, res, params, ref, p2) -> tuple[list[str], dict]:
        if not res.success:
            return [], {}
        q4max = max(sig.q4_max)
        q3max = float(np.max(np.abs(sig.q3))) if sig.n else 0.0
        if q4max < HELD_WHEEL * q3max:
            # the wheel held to the arm: the arm carries the wheel's inertia, (4a) with q2'' = 0
            k = ref.rho / (1.0 + ref.rho)
            p1 = params["p1"]
            return [f"the wheel is held to the arm during the swing (|q4| below {q4max:.2g} rad/s): the arm carries "
                    f"the wheel's inertia and this row estimates p1 rho/(1 + rho) and the frictions times "
                    f"rho/(1 + rho), not the p1 of model (9); with rho = {ref.rho:.5g} (base set) p1 = "
                    f"{p1.value / k:.6g} +- {p1.stderr / k:.2g}; the refinement with model 'free' fits the held "
                    "wheel itself (iwp identify --refine)"], {"wheel_held": True, "p1_of_model_9": p1.value / k}
        if p2 is not None:
            return [], {}
        bvec = lstsq_projection(reg.Phi, sig.q4[:, None])[:, 0]
        shift = ref.p2 * bvec
        names = [c for c in self.columns if c not in reg.details.get("held", {})]  # the columns of reg.Phi
        big = [(nm, shift[j], params[nm].stderr) for j, nm in enumerate(names)
               if math.isfinite(params[nm].stderr) and abs(shift[j]) > params[nm].stderr]
        details = {"p2_q4_shift_per_unit_p2": {nm: float(bvec[j]) for j, nm in enumerate(names)}}
        if not big:
            return [], details
        return [f"the disk turns during the swing (|q4| up to {q4max:.3g} rad/s): the term p2 q4 of the first row of "
                f"(9), neglected by the paper's theta^c, shifts "
                + ", ".join(f"{nm} by {s:+.3g} ({abs(s) / se:.1f} stderr)" for nm, s, se in big)
                + f" for p2 = {ref.p2:g}; pass p2= (CLI --p2) from a two-step result and identify again"], details

    def parameter_changes(self, values: Mapping[str, float], details, base) -> dict[str, float]:
        return {n: values[n] for n in PENDULUM}
