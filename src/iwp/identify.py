"""Parameter identification: every least-squares set-up of the paper, with uncertainty.

From encoder logs (:class:`iwp.io.ExperimentData`) or a static curve
(:class:`iwp.io.StaticCurve`) to the lumped parameters of model (9), as
section 5 of the paper does it, and with standard errors, 95 % intervals,
the correlation of the estimates, the condition number of the regressor,
the residual RMS, the number of samples used, and warnings when the data
cannot support the numbers.

Set-ups (``setup=``, the paper's numbering)
-------------------------------------------
``"full"``
    (10)-(12): both rows of (9), 8 parameters
    ``theta = [p1, sigma_a1, sigma_v1, sigma_b1, p2, p3, p2(1+rho), p3(1+rho)]``
    (section 5.2, eq. (16)). ``rho`` is derived from both ratios.
``"motor-disk"``
    ``theta^a = [p2(1+rho), p3(1+rho)]`` from ``dq4/dt = -p2(1+rho) q4 + p3(1+rho) u``
    with the pendulum locked (section 5.1, eq. (14) after exact compensation).
``"motor-disk-coulomb"``
    ``theta^b = [p2(1+rho), p3(1+rho), sigma~_c2(1+rho)]`` with the Coulomb
    column ``-sgn q4`` (section 5.1); the regressor uses ``u`` where the
    paper prints ``v`` (ERRATA item 6).
``"free"``
    ``theta^c = [p1, sigma_a1, sigma_v1, sigma_b1]`` from the first row of
    (9) with ``u = 0`` (section 5.2, free pendulum).
``"two-step"``
    ``theta^d = [p2, p3, p2(1+rho), p3(1+rho)]`` with
    ``phi^d = [dq3/dt + xi, dq4/dt - xi]`` and
    ``xi = p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3``
    computed from a free-pendulum result (section 5.2). The paper prints the
    rolling-friction term of ``xi`` without its factor ``q3``; by (9) it is
    ``sigma_a1 |cos q1| q3`` (ERRATA item 1), which is what is used.
    ``rho`` is given by both ratios ``rho_1 = theta3/theta1 - 1`` and
    ``rho_2 = theta4/theta2 - 1`` and their mean (ERRATA item 2: the printed
    numbers lack the ``- 1``; the derivation has it).
``"dead-zone"``
    The thresholds ``v+`` and ``v-`` of (5)/(8) from a static curve
    (figure 2a): on each side the straight part of ``q4(v)`` is fitted by a
    line and extrapolated to ``q4 = 0``.

Names in the results: ``p1, p2, p3, rho, sigma_a1, sigma_v1, sigma_b1,
p2_1rho, p3_1rho, sigma_c2_1rho, v_dz_pos, v_dz_neg`` (``sigma_*`` are the
``sigma~`` of the paper, normalised by ``I1_hat``).

The locked pendulum
-------------------
A clamp that holds the pendulum gives ``dq4/dt = rho (-p2 q4 + p3 u)``
(from (4b) with ``q1'' = 0``), whereas the paper's (14) sets ``q1 = q3 = 0``
in the second row of (6) and writes ``1 + rho``. The motor-disk set-ups
keep the paper's names ``p2_1rho``, ``p3_1rho``, ``sigma_c2_1rho``, but on a
clamped rig they estimate ``p2 rho``, ``p3 rho``, ``sigma~_c2 rho`` (0.4 %
apart with Table 1). :meth:`IdentificationResult.to_params` therefore
divides them by ``rho`` (physically right for a clamped rig). In the
two-step and full set-ups the pendulum swings and ``(1 + rho)`` is exact.

How the signals are formed
--------------------------
Each file is windowed (``t_start``, ``t_end``), then differentiated on its
own with one :class:`~iwp.differentiate.Differentiator` ``D`` whose
low-pass filter is ``K`` (default: consistent Savitzky-Golay over 0.5 s,
cubic; chosen by the study in ``docs/identification.md``). The targets are
``dq3/dt = K D2 q1 / Ts^2`` and ``dq4/dt = K D2 q2 / Ts^2`` with ``D2`` the
second difference. The second difference weighs the acceleration over
``+-Ts`` with a triangle (its Peano kernel), so every term ``f`` of the model
enters exactly as ``K S f`` with ``S`` the triangle average
``[1, 10, 1] / 12`` of the term's *point* values. Every regressor column
is built that way, with the same ``K`` as the targets: the term is
evaluated at the measured position and at the point velocity
``(-v[k-1] + 8 v[k] - v[k+1]) / 6`` of the central differences ``v``,
then ``S`` and ``K`` are applied (``K S sin q1``, ``K S (|cos q1| q3)``,
``K S q3``, ``K S q4``, ``K S u``, ``K S sgn q4``). The cube ``q3^3`` is
corrected for the velocity noise, ``E[(v + n)^3] = v^3 + 3 var(n) v``.
Filtering the term rather than evaluating it at the filtered state keeps
the filtered equation exact; with a Savitzky-Golay filter (not flat in its
pass band) the usual way, ``f(K q1, K q3)``, biases ``p1`` by 0.1-0.4 %
and ``sigma_a1`` by 30-300 % (``nonlinear="filtered-states"`` keeps it for
comparison). Discretisation errors are ``O((omega Ts)^4)``.
``max(D.edge_samples_at(Ts), 3)`` samples are dropped at both ends of every
file; the files are then stacked, with sample numbers kept distinct per
file.

The least squares (13) are solved by :func:`iwp.lsq.solve_least_squares`
(column scaling, tall-skinny Householder QR and SVD; no normal matrix is
formed or inverted), with block weights for the two rows of (10).

Uncertainty
-----------
The residuals of differentiated, filtered encoder data are the encoder
noise (quantisation ``step/sqrt(12)`` and sensor noise) passed through known
linear maps: the target's ``K D2 / Ts^2`` and the regressor terms'
``K S (df/dx) ...``. The default covariance (``covariance="noise"``)
propagates white position noise of each encoder through exactly these maps
(adjoint filters, :func:`_noise_covariance`), with the noise level
estimated from the positions' fourth difference. Kernel (HAC) estimators
get this case wrong: the noise spectrum vanishes at low frequency, so
Newey-West overstates the spread of ``p2(1+rho)`` by 1.6x and of ``p1``
by 3x and understates the frictions' by 1.3x on the virtual rig; the noise
covariance gives z scores of unit spread and 93-97 % coverage of the 95 %
intervals (tests). When the residuals are more than twice what the noise
explains (a model misfit: belt, Coulomb friction, dead-zone residue, wrong
known parameters), the HAC covariance is reported instead, with a warning:
the estimates then carry a bias that no standard error shows.
``covariance="hac"`` or ``"ols"`` force the others.

The free pendulum and the disk
------------------------------
With the motor off, the disk still turns as the pendulum swings (``q4`` is
driven by ``xi``; a few rad/s), and the first row of (9) contains
``+ p2 q4``, which ``theta^c`` neglects. On the virtual rig this biases
``sigma_v1`` by tens of per cent (the term acts as extra damping). Give
``p2=`` (a value, or a two-step result) to move ``p2 q4`` into the target;
iterating free -> two-step -> free(p2) -> two-step removes the bias. Without
``p2=`` the set-up is the paper's and a warning estimates the size of the
neglected term with Table 1's ``p2``.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field, replace as dc_replace
from pathlib import Path
from typing import Any, Iterable, Mapping, Sequence

import numpy as np
from numba import njit
from scipy import stats

from ._util import read_json
from .differentiate import Differentiator, central_first
from .errors import IdentificationError, InputError
from .lsq import LeastSquaresResult, ParameterEstimate, lstsq_projection, solve_least_squares

__all__ = [
    "SETUPS",
    "PARAMETER_NAMES",
    "PARAMETER_UNITS",
    "IDENTIFY_DIFFERENTIATOR",
    "DEFAULT_WINDOW_SECONDS",
    "default_differentiator",
    "IdentificationResult",
    "identify",
    "identify_dead_zone",
    "load_pendulum",
]

#: The identification set-ups, in the paper's order (see the module docstring).
SETUPS = ("full", "motor-disk", "motor-disk-coulomb", "free", "two-step", "dead-zone")

#: Parameters each set-up identifies (``rho`` of "full" and "two-step" is derived).
PARAMETER_NAMES: dict[str, tuple[str, ...]] = {
    "full": ("p1", "sigma_a1", "sigma_v1", "sigma_b1", "p2", "p3", "p2_1rho", "p3_1rho", "rho"),
    "motor-disk": ("p2_1rho", "p3_1rho"),
    "motor-disk-coulomb": ("p2_1rho", "p3_1rho", "sigma_c2_1rho"),
    "free": ("p1", "sigma_a1", "sigma_v1", "sigma_b1"),
    "two-step": ("p2", "p3", "p2_1rho", "p3_1rho", "rho"),
    "dead-zone": ("v_dz_pos", "v_dz_neg"),
}

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

#: Length of the default Savitzky-Golay window [s] (101 samples at the rig's Ts = 5 ms).
DEFAULT_WINDOW_SECONDS = 0.5

#: The differentiator used when none is given, for the rig's Ts = 5 ms: the consistent
#: Savitzky-Golay filter ("savgol"), 101 samples (0.5 s), cubic. Chosen by the study of
#: ``benchmarks/diff_study.py`` (table and reasons in ``docs/identification.md``): among the
#: settings whose errors stay within their standard errors, it gives the smallest error and
#: standard error of the friction coefficients on noisy data, and drops only 50 samples at
#: each end. For another sample time see :func:`default_differentiator`.
IDENTIFY_DIFFERENTIATOR = Differentiator("savgol", window=101, polyorder=3)


def default_differentiator(Ts: float) -> Differentiator:
    """The default differentiator for sample time ``Ts`` [s].

    The Savitzky-Golay filter of :data:`IDENTIFY_DIFFERENTIATOR` with the
    same window length in seconds (:data:`DEFAULT_WINDOW_SECONDS`), i.e.
    ``window = 2 round(0.25 / Ts) + 1`` samples (at least 7), cubic.
    """
    if not (isinstance(Ts, (int, float)) and math.isfinite(Ts) and Ts > 0):
        raise InputError(f"Ts must be a positive number of seconds, got {Ts!r}")
    if abs(Ts - 0.005) <= 1e-9:
        return IDENTIFY_DIFFERENTIATOR
    half = max(3, int(round(0.5 * DEFAULT_WINDOW_SECONDS / Ts)))
    return Differentiator("savgol", window=2 * half + 1, polyorder=3)

_PENDULUM = ("p1", "sigma_a1", "sigma_v1", "sigma_b1")
_NEEDS_INPUT = ("full", "motor-disk", "motor-disk-coulomb", "two-step")
_LOCKED = ("motor-disk", "motor-disk-coulomb")
#: q1 range [rad] above which a "locked" log is reported as not locked
_LOCK_TOL = 0.02
#: fewer effectively independent samples per parameter than this -> warning
_MIN_EFF_PER_PARAM = 20
#: |correlation| above which a pair is explained as not separable
_CORR_EXPLAIN = 0.99
#: rows per block of the tall matrix products in the noise covariance
_MATMUL_CHUNK = 512
#: residuals this many times larger than the measurement noise explains -> model misfit (HAC covariance)
_MISFIT_RATIO = 2.0
#: expected signs (for the "unphysical value" warning)
_POSITIVE = ("p1", "p3", "rho", "p3_1rho")
_NONNEG = ("p2", "p2_1rho", "sigma_a1", "sigma_v1", "sigma_b1", "sigma_c2_1rho", "v_dz_pos", "v_dz_neg")


# ---------------------------------------------------------------------------
# result
# ---------------------------------------------------------------------------
def _jf(x: Any) -> float | None:
    x = float(x)
    return x if math.isfinite(x) else None


@dataclass(eq=False)
class IdentificationResult:
    """What an identification gives: values, uncertainty, diagnostics.

    Attributes
    ----------
    setup : str
        One of :data:`SETUPS`.
    samples : int
        Number of samples used (after windowing and dropping the
        differentiator's edge samples, all files together); points of the
        static curve for ``"dead-zone"``.
    parameters : dict of str to ParameterEstimate
        The identified (and derived, e.g. ``rho``) parameters by name, with
        ``value``, ``stderr`` and the 95 % interval ``ci95_low``,
        ``ci95_high``, in the units of :data:`PARAMETER_UNITS`.
    names : tuple of str
        Names of the rows/columns of :attr:`correlation` and
        :attr:`covariance`.
    covariance, correlation : ndarray
        Covariance and correlation of the estimates in :attr:`names`.
        For ``"two-step"`` the covariance includes the uncertainty of the
        pendulum parameters used in ``xi`` (when known).
    condition_number : float
        2-norm condition number of the column-scaled, row-weighted
        regressor (``inf`` if rank deficient; NaN for ``"dead-zone"``,
        which reports the largest of its two line fits).
    residual_rms : dict
        Residual RMS per equation block (``"q3"``: rad/s^2 of the first row
        of (10), ``"q4"``: second row; ``"pos"``, ``"neg"`` [rad/s] for
        ``"dead-zone"``).
    lsq : LeastSquaresResult or None
        The underlying least-squares result (``None`` for ``"dead-zone"``,
        which fits two lines, see :attr:`details`).
    rho : dict or None
        ``{"rho_1", "rho_2", "mean"}`` for ``"full"`` and ``"two-step"``:
        ``rho_1 = p2(1+rho)/p2 - 1``, ``rho_2 = p3(1+rho)/p3 - 1`` and their
        mean (ERRATA item 2).
    warnings : list of str
        Everything that makes the numbers less trustworthy.
    success : bool
        False if some parameter is not identifiable (rank deficiency).
    message : str
        One-line verdict.
    differentiator : dict
        Settings of the differentiator used.
    sources : list of str
        The files (or in-memory sources) used.
    t_start, t_end : float or None
        The time window [s].
    details : dict
        Set-up specific extras (JSON-able), e.g. the pendulum parameters
        used in ``xi``, the dead-zone line fits, samples excluded.
    """

    setup: str
    samples: int
    parameters: dict[str, ParameterEstimate]
    names: tuple[str, ...]
    covariance: np.ndarray
    correlation: np.ndarray
    condition_number: float
    residual_rms: dict[str, float]
    lsq: LeastSquaresResult | None = None
    rho: dict[str, float] | None = None
    warnings: list[str] = field(default_factory=list)
    success: bool = True
    message: str = ""
    differentiator: dict[str, Any] = field(default_factory=dict)
    sources: list[str] = field(default_factory=list)
    t_start: float | None = None
    t_end: float | None = None
    details: dict[str, Any] = field(default_factory=dict)

    # access ------------------------------------------------------------
    def __getitem__(self, name: str) -> ParameterEstimate:
        try:
            return self.parameters[name]
        except KeyError:
            raise KeyError(f"set-up {self.setup!r} has no parameter {name!r}; it has: "
                           f"{', '.join(self.parameters)}") from None

    def __contains__(self, name: object) -> bool:
        return name in self.parameters

    def value(self, name: str) -> float:
        """Value of parameter ``name`` (unit: :data:`PARAMETER_UNITS`)."""
        return self[name].value

    def stderr(self, name: str) -> float:
        """Standard error of parameter ``name``."""
        return self[name].stderr

    def ci95(self, name: str) -> tuple[float, float]:
        """95 % confidence interval ``(low, high)`` of parameter ``name``."""
        p = self[name]
        return (p.ci95_low, p.ci95_high)

    def values(self) -> dict[str, float]:
        """``{name: value}`` of all parameters."""
        return {n: p.value for n, p in self.parameters.items()}

    # export --------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The JSON object printed by ``iwp identify --json`` (NaN/inf -> null).

        Returns
        -------
        dict
            ``{"setup", "samples", "parameters": {name: {"value", "stderr",
            "ci95": [lo, hi], "unit"}}, "rho" (full/two-step), "correlation":
            {name: {name: r}}, "condition_number", "residual_rms", "warnings",
            "success", "message", "differentiator", "files", "t_start",
            "t_end", "details", ...}``.
        """
        params = {
            n: {"value": _jf(p.value), "stderr": _jf(p.stderr), "ci95": [_jf(p.ci95_low), _jf(p.ci95_high)],
                "unit": PARAMETER_UNITS.get(n, "")}
            for n, p in self.parameters.items()
        }
        corr = {a: {b: _jf(self.correlation[i, j]) for j, b in enumerate(self.names)}
                for i, a in enumerate(self.names)}
        out: dict[str, Any] = {
            "setup": self.setup,
            "samples": int(self.samples),
            "parameters": params,
        }
        if self.rho is not None:
            out["rho"] = {k: _jf(v) for k, v in self.rho.items()}
        out.update({
            "correlation": corr,
            "condition_number": _jf(self.condition_number),
            "residual_rms": {str(k): _jf(v) for k, v in self.residual_rms.items()},
            "warnings": list(self.warnings),
            "success": bool(self.success),
            "message": self.message,
            "differentiator": dict(self.differentiator),
            "files": list(self.sources),
            "t_start": self.t_start,
            "t_end": self.t_end,
        })
        if self.lsq is not None:
            out["equations"] = int(self.lsq.n_equations)
            out["covariance"] = self.lsq.covariance_method
            out["bandwidth"] = self.lsq.bandwidth
            out["critical_value"] = _jf(self.lsq.critical_value)
        if self.details:
            out["details"] = _jsonable(self.details)
        return out

    def to_json(self, **kw: Any) -> str:
        """:meth:`to_dict` as a JSON string (keyword arguments go to :func:`json.dumps`)."""
        return json.dumps(self.to_dict(), **kw)

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], *, where: str = "result") -> "IdentificationResult":
        """Rebuild a result (values, stderr, correlation) from :meth:`to_dict` output.

        Used to read a free-pendulum result back for the two-step set-up
        (``iwp identify --setup two-step --pendulum FREE.json``). The
        least-squares details (``lsq``) are not restored.
        """
        if not isinstance(doc, Mapping) or "parameters" not in doc or "setup" not in doc:
            raise InputError(f"{where}: not an identification result (needs 'setup' and 'parameters')")
        setup = doc["setup"]
        pars = doc["parameters"]
        if setup not in SETUPS or not isinstance(pars, Mapping):
            raise InputError(f"{where}: 'setup' must be one of {', '.join(SETUPS)} and 'parameters' an object")
        params: dict[str, ParameterEstimate] = {}
        for n, e in pars.items():
            if not isinstance(e, Mapping) or "value" not in e:
                raise InputError(f"{where}: parameter {n!r} must be an object with 'value' and 'stderr'")
            v = _num(e.get("value"), f"{where}: parameters.{n}.value")
            se = e.get("stderr")
            se = math.nan if se is None else _num(se, f"{where}: parameters.{n}.stderr")
            ci = e.get("ci95") or [None, None]
            lo = math.nan if ci[0] is None else float(ci[0])
            hi = math.nan if ci[1] is None else float(ci[1])
            params[n] = ParameterEstimate(n, v, se, lo, hi)
        names = tuple(params)
        corr_doc = doc.get("correlation") or {}
        k = len(names)
        corr = np.eye(k)
        for i, a in enumerate(names):
            for j, b in enumerate(names):
                r = corr_doc.get(a, {}).get(b) if isinstance(corr_doc.get(a), Mapping) else None
                if r is not None and i != j:
                    corr[i, j] = float(r)
        se = np.array([params[n].stderr for n in names])
        cov = corr * np.outer(se, se)
        cn = doc.get("condition_number")
        return cls(
            setup=setup, samples=int(doc.get("samples", 0)), parameters=params, names=names, covariance=cov,
            correlation=corr, condition_number=math.nan if cn is None else float(cn),
            residual_rms={k2: (math.nan if v2 is None else float(v2)) for k2, v2 in (doc.get("residual_rms") or {}).items()},
            rho=None if doc.get("rho") is None else {k2: (math.nan if v2 is None else float(v2)) for k2, v2 in doc["rho"].items()},
            warnings=list(doc.get("warnings", [])), success=bool(doc.get("success", True)),
            message=str(doc.get("message", "")), differentiator=dict(doc.get("differentiator") or {}),
            sources=list(doc.get("files", [])), t_start=doc.get("t_start"), t_end=doc.get("t_end"),
            details=dict(doc.get("details") or {}),
        )

    def to_params(self, base: Any = None) -> Any:
        """The identified values filled into a parameter set.

        Parameters
        ----------
        base : LumpedParameters, optional
            The parameters not identified by this set-up are taken from it
            (default: :func:`iwp.params.table1`).

        Returns
        -------
        LumpedParameters

        Notes
        -----
        * ``"full"``, ``"two-step"``: ``p2``, ``p3`` and ``rho`` (the mean of
          the two ratios); ``"full"`` also ``p1`` and ``sigma_*``, and
          ``"two-step"`` the pendulum values it used in ``xi``.
        * ``"motor-disk"``, ``"motor-disk-coulomb"`` identify ``p2(1+rho)``,
          ``p3(1+rho)`` (and ``sigma~_c2(1+rho)``) only. They are split with
          ``base.rho``; since on a clamped rig they are ``p2 rho``, ``p3 rho``
          (see the module docstring), ``p2 = p2_1rho / rho`` etc.
        * ``"dead-zone"``: ``v_dz_pos``, ``v_dz_neg`` (for a compensated
          curve ``u -> q4``, the residual thresholds are added to the
          compensation thresholds recorded in the curve's metadata).
        """
        from .params import LumpedParameters, table1

        base = table1() if base is None else base
        if not isinstance(base, LumpedParameters):
            raise InputError(f"base must be LumpedParameters, got {type(base).__name__}")
        vals = self.values()
        ch: dict[str, float] = {}
        s = self.setup
        if s in ("full", "free"):
            ch.update({n: vals[n] for n in _PENDULUM})
        if s in ("full", "two-step"):
            ch.update(p2=vals["p2"], p3=vals["p3"], rho=vals["rho"])
            if s == "two-step":
                ch.update({n: float(v) for n, v in (self.details.get("pendulum") or {}).items() if n in _PENDULUM})
        if s in _LOCKED:
            rho = base.rho
            ch.update(p2=vals["p2_1rho"] / rho, p3=vals["p3_1rho"] / rho)
            if s == "motor-disk-coulomb":
                ch["sigma_c2"] = vals["sigma_c2_1rho"] / rho
        if s == "dead-zone":
            off = self.details.get("compensation") or {}
            ch.update(v_dz_pos=vals["v_dz_pos"] + float(off.get("v_dz_pos", 0.0)),
                      v_dz_neg=vals["v_dz_neg"] + float(off.get("v_dz_neg", 0.0)))
        bad = [n for n, v in ch.items() if not math.isfinite(v)]
        if bad:
            raise IdentificationError(f"set-up {s!r}: {', '.join(bad)} not identified (NaN); cannot build a parameter set")
        if "rho" in ch and ch["rho"] <= 0:
            raise IdentificationError(f"set-up {s!r}: identified rho = {ch['rho']:.4g} <= 0; cannot build a parameter set")
        return dc_replace(base, **ch)

    def summary(self) -> str:
        """A readable table of the estimates and the diagnostics."""
        lines = [f"set-up {self.setup!r}: {self.samples} samples from {len(self.sources)} file(s)"
                 + (f", window [{self.t_start}, {self.t_end}] s" if self.t_start is not None or self.t_end is not None else "")]
        if self.differentiator:
            lines.append("differentiator: " + ", ".join(f"{k}={v}" for k, v in self.differentiator.items()))
        w = max([9] + [len(n) for n in self.parameters])
        lines.append(f"{'parameter':<{w}}  {'value':>12}  {'stderr':>10}  {'95% interval':^27}  unit")
        for n, p in self.parameters.items():
            lines.append(f"{n:<{w}}  {p.value:>12.6g}  {p.stderr:>10.3g}  [{p.ci95_low:>11.5g}, {p.ci95_high:>11.5g}]  "
                         f"{PARAMETER_UNITS.get(n, '')}")
        if self.rho is not None:
            lines.append("rho: " + ", ".join(f"{k} = {v:.6g}" for k, v in self.rho.items()))
        lines.append(f"condition number {self.condition_number:.3g}; residual rms "
                     + ", ".join(f"{k}: {v:.4g}" for k, v in self.residual_rms.items()))
        if self.warnings:
            lines.append("warnings:")
            lines.extend(f"  - {m}" for m in self.warnings)
        lines.append(self.message)
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.summary()


def _jsonable(x: Any) -> Any:
    if isinstance(x, Mapping):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return [_jsonable(v) for v in x.tolist()]
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return _jf(x)
    return x


def _num(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{what} must be a number, got {v!r}")
    return float(v)


# ---------------------------------------------------------------------------
# signals
# ---------------------------------------------------------------------------
@dataclass
class _Signals:
    """Stacked, filtered signals of one or more files (internal)."""

    q1: np.ndarray  # measured pendulum angle [rad]
    q3: np.ndarray  # filtered pendulum velocity [rad/s]
    q4: np.ndarray  # filtered disk velocity [rad/s]
    dq3: np.ndarray  # filtered pendulum acceleration [rad/s^2]
    dq4: np.ndarray  # filtered disk acceleration [rad/s^2]
    u: np.ndarray  # filtered input [in]
    S: np.ndarray  # K sin q1
    C: np.ndarray  # K |cos q1| q3
    B: np.ndarray  # K q3^3
    G: np.ndarray | None  # K sgn q4
    sidx: np.ndarray  # sample numbers, distinct across files
    n_files: int
    corr_len: float  # correlation length of the filter [samples]
    q1_range: list[float]  # per file, range of the measured q1 [rad]
    input_max: list[float]  # per file, max |input| (raw)
    q4_max: list[float]  # per file, max |filtered q4|
    files: list[dict] = field(default_factory=list)  # per file: n_full, kk, Ts, start, q1, v1 (for the noise covariance)

    @property
    def n(self) -> int:
        return int(self.q1.size)


#: samples dropped at least at each end (reach of the central difference, point correction and _tri3)
_EDGE_MIN = 3


def _point_velocity(v_cd: np.ndarray) -> np.ndarray:
    """Point values of the velocity from central differences: ``(-v[k-1] + 8 v[k] - v[k+1]) / 6``.

    The central difference is the mean of the velocity over two samples,
    ``v_cd = v + (Ts^2 / 6) d2v/dt2 + O(Ts^4)``; subtracting a sixth of its
    second difference removes the ``Ts^2`` term. End samples are left as they
    are (they are dropped).
    """
    out = v_cd.copy()
    out[1:-1] -= (v_cd[2:] - 2.0 * v_cd[1:-1] + v_cd[:-2]) / 6.0
    return out


#: ``||P D1||^2 Ts^2``: noise gain of the point velocity ``P D1`` (taps [-1, 8, 0, -8, 1] / (12 Ts)).
_PD1_GAIN = 130.0 / 144.0


def _position_noise(q: np.ndarray) -> np.ndarray:
    """White-equivalent position noise [rad] per column from the fourth difference.

    ``D4 q = q[k-2] - 4 q[k-1] + 6 q[k] - 4 q[k+1] + q[k+2]`` removes any
    motion of the rig (``Ts^4 d4q/dt4`` is below 1e-4 rad at 5 ms) and
    multiplies white noise by ``sqrt(70)``. Includes the quantisation
    (``step / sqrt(12)`` when the encoder moves by several counts per sample,
    less for slow motion).
    """
    d4 = q[:-4] - 4.0 * q[1:-3] + 6.0 * q[2:-2] - 4.0 * q[3:-1] + q[4:]
    return np.sqrt(np.mean(d4 * d4, axis=0) / 70.0)


def _tri3(x: np.ndarray) -> np.ndarray:
    """Triangle average of samples, ``(x[k-1] + 10 x[k] + x[k+1]) / 12``.

    Equals the continuous average of ``x(t)`` over the triangle of width
    ``2 Ts`` to ``O(Ts^4)``: the weight that the second difference
    ``(q[k+1] - 2 q[k] + q[k-1]) / Ts^2`` gives to the acceleration.
    Regressor terms averaged this way match the differentiated target
    without the ``(omega Ts)^2 / 12`` bias of plain samples (1e-4 at
    10 rad/s).
    """
    out = x.copy()
    out[1:-1] += (x[2:] - 2.0 * x[1:-1] + x[:-2]) / 12.0
    return out


def _convolve_same(X: np.ndarray, kernel: np.ndarray) -> np.ndarray:
    """Columns of ``X`` (n x m, or 1-D) convolved with an odd-length ``kernel``, centred ("same" size).

    One real FFT of the whole length per column (on the transposed, contiguous array), about twice as
    fast as overlap-add for the 60,000-sample logs of section 5; zeros are assumed outside ``X``.
    """
    import scipy.fft as sfft

    one = X.ndim == 1
    XT = np.ascontiguousarray((X[:, None] if one else X).T)
    n, L = XT.shape[1], kernel.size
    nf = sfft.next_fast_len(n + L - 1, real=True)
    Y = sfft.irfft(sfft.rfft(XT, nf, axis=1) * sfft.rfft(kernel, nf)[None, :], nf, axis=1)
    h = (L - 1) // 2
    out = Y[:, h: h + n].T
    return out[:, 0] if one else out


def _derivatives(d: Differentiator, Ts: float, q: np.ndarray):
    """``d.derivatives(Ts, q)``, computed faster for method ``"savgol"``.

    For ``"savgol"`` the outputs are ``K q``, ``D1 K q`` and ``D2 K q / Ts^2``
    (see :mod:`iwp.differentiate`); here ``K`` is applied by FFT
    convolution to the increments ``q[k+1] - q[k]`` (small numbers even when
    the disk has turned thousands of radians, so no digits are lost), which
    gives the same values as ``d.derivatives`` away from the ends (the
    samples identification keeps; checked in the tests), 5-10 times faster
    for a 101-sample window.
    """
    if d.method != "savgol":
        return d.derivatives(Ts, q)
    K = d.smoothing_kernel()
    if q.shape[0] < K.size + 4:
        return d.derivatives(Ts, q)
    Kdq = _convolve_same(np.diff(q, axis=0), K)
    vel = np.empty_like(q)
    acc = np.empty_like(q)
    vel[1:-1] = (Kdq[1:] + Kdq[:-1]) / (2.0 * Ts)
    acc[1:-1] = (Kdq[1:] - Kdq[:-1]) / (Ts * Ts)
    vel[0], vel[-1], acc[0], acc[-1] = vel[1], vel[-2], acc[1], acc[-2]  # end samples are dropped
    pos = q[0] + np.concatenate([np.zeros((1, q.shape[1])), np.cumsum(Kdq, axis=0)])  # K q up to a constant
    return pos, vel, acc


def _corr_len(d: Differentiator, Ts: float) -> float:
    """Rough correlation length [samples] of the filter's output noise."""
    if d.method in ("savgol", "savgol_direct"):
        return float(d.window)
    if d.method == "butter":
        return max(2.0, 0.5 / (d.cutoff * Ts))
    return 2.0


def _as_list(data: Any) -> list:
    if isinstance(data, (list, tuple)):
        if not data:
            raise InputError("data is empty: give at least one experiment log")
        return list(data)
    return [data]


def _prepare(setup: str, datas: list, d: Differentiator, t_start, t_end, *, coulomb: bool,
             n_params: int, nonlinear: str = "filter-terms") -> _Signals:
    from .io import ExperimentData, StaticCurve

    parts = []
    files: list[dict] = []
    offset = 0
    corr = 0.0
    q1_range, in_max, q4_max = [], [], []
    for data in datas:
        if isinstance(data, StaticCurve):
            raise InputError(f"{data.source}: is a static curve (input, q4); set-up {setup!r} needs a time-series "
                             "log (t, q1, q2, ...). Use setup 'dead-zone' for static curves")
        if not isinstance(data, ExperimentData):
            raise InputError(f"data must be ExperimentData (or a list of them), got {type(data).__name__}")
        src = data.source
        if setup in _NEEDS_INPUT and data.input_name != "u":
            if data.input_name is None:
                raise InputError(f"{src}: set-up {setup!r} needs the input column u; the log has no input")
            raise InputError(
                f"{src}: set-up {setup!r} needs the dead-zone-compensated input u (model (9)); the log has the raw "
                "driver input v. Identify v+, v- (set-up 'dead-zone') and log u with the feedforward (7)-(8)")
        if setup == "free" and data.input_name is not None:
            amax = float(np.max(np.abs(data.input))) if data.n_samples else 0.0
            if amax > 0:
                raise InputError(
                    f"{src}: set-up 'free' needs the motor off (u = 0), but the log's input {data.input_name} "
                    f"reaches |{data.input_name}| = {amax:.4g}; use a window where it is zero, or set-up "
                    "'full'/'two-step'")
        try:
            w = data.window(t_start, t_end)
        except InputError as exc:
            raise InputError(f"{src}: {exc}") from None
        Ts = w.Ts
        k = d.edge_samples_at(Ts)
        need = max(d.min_samples(Ts), 4) + 2 * max(k, _EDGE_MIN) + n_params + 1
        if w.n_samples < need:
            win = "" if t_start is None and t_end is None else f" (t_start={t_start}, t_end={t_end})"
            raise InputError(
                f"{src}: {w.n_samples} samples{win}, too few for set-up {setup!r}: the differentiator "
                f"({d.method}) drops {k} at each end and {n_params} parameters need at least {need}")
        dt = np.diff(w.t)
        if float(np.max(np.abs(dt - Ts))) > 0.01 * Ts:
            raise InputError(
                f"{src}: the sampling is not uniform (steps from {dt.min():.6g} to {dt.max():.6g} s); "
                "resample the log first (ExperimentData.resample)")
        q = np.column_stack([w.q1, w.q2])
        pos, vel, acc = _derivatives(d, Ts, q)
        noise_sd = _position_noise(q)
        if nonlinear == "filter-terms":
            # The target K D2 q / Ts^2 equals K (tri * d2q/dt2) exactly, tri the triangle of width
            # 2 Ts (Peano kernel of the second difference). Each term of the model is therefore
            # evaluated at the sample points (position as measured, velocity from the central
            # difference corrected to a point value), triangle-averaged by _tri3 and filtered by K.
            v_pt = _point_velocity(central_first(q, Ts))
            q1r = w.q1
            u_raw = np.asarray(w.input, dtype=float)
            # errors in variables: E[(v + n)^3] = v^3 + 3 var(n) v, removed with the noise of the
            # point velocity estimated from the positions
            var_v = float(noise_sd[0]) ** 2 * _PD1_GAIN / (Ts * Ts)
            cube = v_pt[:, 0] ** 3 - 3.0 * var_v * v_pt[:, 0]
            terms = [np.sin(q1r), np.abs(np.cos(q1r)) * v_pt[:, 0], cube, v_pt[:, 0], v_pt[:, 1], u_raw]
            if coulomb:
                terms.append(np.sign(vel[:, 1]))
            sm = _apply_KS(d, Ts, np.column_stack(terms))
            q3c, q4c = sm[:, 3], sm[:, 4]
            sm = np.delete(sm, [3, 4], axis=1)
        else:  # "filtered-states": f(K q1, K q3), the usual way (for comparison)
            uf = d.smooth(Ts, np.asarray(w.input, dtype=float))
            q1f, q3f = pos[:, 0], vel[:, 0]
            cols = [np.sin(q1f), np.abs(np.cos(q1f)) * q3f, q3f ** 3, uf]
            if coulomb:
                cols.append(np.sign(vel[:, 1]))
            sm = np.column_stack(cols)
            q3c, q4c = vel[:, 0], vel[:, 1]
        kk = max(k, _EDGE_MIN)
        keep = slice(kk, w.n_samples - kk)
        n = w.n_samples - 2 * kk
        files.append(dict(n_full=w.n_samples, kk=kk, Ts=Ts, start=sum(p["sidx"].size for p in parts),
                          noise=noise_sd,
                          q1=np.asarray(w.q1, dtype=float),
                          v1=v_pt[:, 0] if nonlinear == "filter-terms" else None))
        parts.append(dict(
            q1=w.q1[keep], q3=q3c[keep], q4=q4c[keep], dq3=acc[keep, 0], dq4=acc[keep, 1],
            S=sm[keep, 0], C=sm[keep, 1], B=sm[keep, 2], u=sm[keep, 3], G=sm[keep, 4] if coulomb else None,
            sidx=offset + np.arange(n, dtype=np.int64),
        ))
        # the next file's sample numbers start after a gap longer than any HAC bandwidth used
        offset += n + n // 4 + 2 * int(math.ceil(_corr_len(d, Ts))) + 8
        corr = max(corr, _corr_len(d, Ts))
        q1_range.append(float(np.ptp(w.q1)))
        in_max.append(float(np.max(np.abs(w.input))))
        q4_max.append(float(np.max(np.abs(vel[kk : w.n_samples - kk, 1]))))
    cat = {key: (np.concatenate([p[key] for p in parts]) if parts[0][key] is not None else None) for key in parts[0]}
    return _Signals(**cat, n_files=len(parts), corr_len=corr, q1_range=q1_range, input_max=in_max, q4_max=q4_max,
                    files=files)


# ---------------------------------------------------------------------------
# the set-ups
# ---------------------------------------------------------------------------
def _pendulum_values(pendulum: Any) -> tuple[dict[str, float], np.ndarray | None, str]:
    """(values, covariance 4x4 or None, description) of the pendulum parameters for xi."""
    from .params import LumpedParameters

    if pendulum is None:
        raise InputError("set-up 'two-step' needs the free-pendulum parameters: pass pendulum= (an "
                         "IdentificationResult of set-up 'free' or LumpedParameters); CLI: --pendulum FREE.json")
    if isinstance(pendulum, IdentificationResult):
        missing = [n for n in _PENDULUM if n not in pendulum.parameters]
        if missing:
            raise InputError(f"pendulum: the {pendulum.setup!r} result lacks {', '.join(missing)}; "
                             "give a result of set-up 'free'")
        vals = {n: pendulum.value(n) for n in _PENDULUM}
        idx = [pendulum.names.index(n) for n in _PENDULUM] if all(n in pendulum.names for n in _PENDULUM) else None
        cov = None
        if idx is not None:
            cov = np.asarray(pendulum.covariance)[np.ix_(idx, idx)]
            if not np.all(np.isfinite(cov)):
                cov = None
        return vals, cov, f"{pendulum.setup} result from {', '.join(pendulum.sources) or 'memory'}"
    if isinstance(pendulum, LumpedParameters):
        return {n: float(getattr(pendulum, n)) for n in _PENDULUM}, None, "given parameter set (no uncertainty)"
    if isinstance(pendulum, Mapping):
        missing = [n for n in _PENDULUM if n not in pendulum]
        if missing:
            raise InputError(f"pendulum: missing {', '.join(missing)}")
        return {n: float(pendulum[n]) for n in _PENDULUM}, None, "given values (no uncertainty)"
    raise InputError(f"pendulum must be an IdentificationResult of set-up 'free' or LumpedParameters, "
                     f"got {type(pendulum).__name__}")


def _p2_value(p2: Any) -> tuple[float, float]:
    """(value, variance) of a known p2 for the free set-up."""
    from .params import LumpedParameters

    if isinstance(p2, IdentificationResult):
        if "p2" not in p2.parameters:
            raise InputError(f"p2: the {p2.setup!r} result has no p2; give a 'two-step' or 'full' result")
        se = p2.stderr("p2")
        return p2.value("p2"), (se * se if math.isfinite(se) else 0.0)
    if isinstance(p2, LumpedParameters):
        return float(p2.p2), 0.0
    try:
        v = float(p2)
    except (TypeError, ValueError):
        raise InputError(f"p2 must be a number [1/s], a two-step result or LumpedParameters, got {p2!r}") from None
    if not math.isfinite(v):
        raise InputError(f"p2 must be finite, got {v!r}")
    return v, 0.0


def identify(
    data: Any,
    setup: str,
    *,
    pendulum: Any = None,
    t_start: float | None = None,
    t_end: float | None = None,
    differentiator: Differentiator | None = None,
    base: Any = None,
    p2: Any = None,
    covariance: str = "noise",
    nonlinear: str = "filter-terms",
) -> IdentificationResult:
    """Identify the parameters of one set-up of section 5 from logs.

    Parameters
    ----------
    data : ExperimentData, list of ExperimentData, or StaticCurve
        The log(s). Several logs of one set-up are stacked (each is
        windowed and differentiated on its own). ``"dead-zone"`` takes a
        :class:`~iwp.io.StaticCurve` (or a list of them, points pooled).
    setup : str
        One of :data:`SETUPS`: ``"full"`` (10)-(12), ``"motor-disk"``
        (theta^a), ``"motor-disk-coulomb"`` (theta^b), ``"free"``
        (theta^c), ``"two-step"`` (theta^d), ``"dead-zone"`` (v+, v-).
    pendulum : IdentificationResult, LumpedParameters or mapping, optional
        ``"two-step"`` only (required there): ``p1`` and ``sigma_a1``,
        ``sigma_v1``, ``sigma_b1`` for ``xi``, normally the result of the
        ``"free"`` set-up; its covariance is propagated into the two-step
        standard errors.
    t_start, t_end : float, optional
        Time window [s] applied to every log before differentiation.
    differentiator : Differentiator, optional
        Default: :func:`default_differentiator` for the sample time of the
        first log (Savitzky-Golay over 0.5 s, cubic: 101 samples at 5 ms;
        chosen by the study in ``docs/identification.md``).
    base : LumpedParameters, optional
        Reference values for warnings (default Table 1); not used in the fit.
    p2 : float, IdentificationResult or LumpedParameters, optional
        ``"free"`` only: a known ``p2`` [1/s]; the term ``p2 q4`` of the first
        row of (9), neglected by theta^c, is moved to the target (see the
        module docstring). A result's ``p2`` variance is propagated.
    covariance : {"noise", "hac", "ols"}
        ``"noise"`` (default): the encoder noise propagated through the
        differentiator and the model (see the module docstring); falls back
        to ``"hac"`` on a model misfit, for ``"savgol_direct"`` and for
        ``nonlinear="filtered-states"`` (with a warning). ``"hac"``,
        ``"ols"``: the covariances of :func:`iwp.lsq.solve_least_squares`.
    nonlinear : {"filter-terms", "filtered-states"}
        How the nonlinear regressor columns get the filter: ``"filter-terms"``
        (default) filters each term evaluated at the measured position and
        its central-difference velocity, ``K f(q1, q3)``, which keeps the
        filtered equation exact; ``"filtered-states"`` evaluates the term at
        the filtered states, ``f(K q1, K q3)`` (the usual way; biased when
        the filter is not flat over the signal band, kept for comparison).

    Returns
    -------
    IdentificationResult

    Raises
    ------
    InputError
        Unknown set-up, a static curve given to a time-series set-up or vice
        versa, no ``u`` where the set-up needs it, an input in a free-pendulum
        log, ``pendulum`` missing for ``"two-step"``, a window leaving too
        few samples, non-uniform sampling.

    Notes
    -----
    A rank-deficient regressor does not raise: the result has
    ``success=False``, NaN standard errors for the parameters involved and a
    warning naming the collinear columns.
    """
    if setup not in SETUPS:
        raise InputError(f"setup must be one of {', '.join(SETUPS)}, got {setup!r}")
    if covariance not in ("noise", "hac", "ols"):
        raise InputError(f"covariance must be 'noise', 'hac' or 'ols', got {covariance!r}")
    if nonlinear not in ("filter-terms", "filtered-states"):
        raise InputError(f"nonlinear must be 'filter-terms' or 'filtered-states', got {nonlinear!r}")
    datas0 = _as_list(data) if setup != "dead-zone" else []
    if differentiator is None:
        d0 = datas0[0] if datas0 else None
        Ts0 = float(np.median(np.diff(d0.t))) if getattr(d0, "t", None) is not None and len(d0.t) > 1 else 0.005
        d = default_differentiator(Ts0)
    else:
        d = differentiator
    if not isinstance(d, Differentiator):
        raise InputError(f"differentiator must be a Differentiator, got {type(d).__name__}")
    if pendulum is not None and setup != "two-step":
        raise InputError(f"pendulum= is used by set-up 'two-step' only, not {setup!r}")
    if p2 is not None and setup != "free":
        raise InputError(f"p2= is used by set-up 'free' only, not {setup!r}")
    if setup == "dead-zone":
        if t_start is not None or t_end is not None:
            raise InputError("t_start/t_end do not apply to set-up 'dead-zone' (a static curve has no time)")
        return identify_dead_zone(data)
    datas = _as_list(data)
    from .params import table1

    ref = table1() if base is None else base
    n_par = {"full": 8, "motor-disk": 2, "motor-disk-coulomb": 3, "free": 4, "two-step": 4}[setup]
    pend_vals = pend_cov = None
    pend_desc = ""
    if setup == "two-step":
        pend_vals, pend_cov, pend_desc = _pendulum_values(pendulum)
    sig = _prepare(setup, datas, d, t_start, t_end, coulomb=(setup == "motor-disk-coulomb"), n_params=n_par,
                   nonlinear=nonlinear)
    warnings_pre: list[str] = []
    warnings: list[str] = warnings_pre
    details: dict[str, Any] = {}
    n = sig.n
    blocks = None
    sidx = sig.sidx
    # extra target sensitivities for uncertainty propagation: d(target)/d(known parameter)
    sens: np.ndarray | None = None
    known_cov: np.ndarray | None = None

    if setup == "free":
        names = ["p1", "sigma_a1", "sigma_v1", "sigma_b1"]
        Phi = np.column_stack([-sig.S, -sig.C, -sig.q3, -sig.B])
        phi = sig.dq3.copy()
        blk_labels = ["q3"]
        if p2 is not None:
            p2v, p2var = _p2_value(p2)
            phi = phi - p2v * sig.q4
            details["p2_known"] = {"value": p2v, "stderr": math.sqrt(p2var)}
            if p2var > 0:
                sens = -sig.q4[:, None]
                known_cov = np.array([[p2var]])
    elif setup == "full":
        names = ["p1", "sigma_a1", "sigma_v1", "sigma_b1", "p2", "p3", "p2_1rho", "p3_1rho"]
        # (11): rows of dq3/dt first, then rows of dq4/dt
        Phi = np.zeros((2 * n, 8))
        for j, col in enumerate((sig.S, sig.C, sig.q3, sig.B)):
            np.negative(col, out=Phi[:n, j])
            Phi[n:, j] = col
        Phi[:n, 4] = sig.q4
        np.negative(sig.u, out=Phi[:n, 5])
        np.negative(sig.q4, out=Phi[n:, 6])
        Phi[n:, 7] = sig.u
        phi = np.concatenate([sig.dq3, sig.dq4])
        blocks = np.repeat(np.array([0, 1], dtype=np.int8), n)
        sidx = np.concatenate([sig.sidx, sig.sidx])
        blk_labels = ["q3", "q4"]
    elif setup in _LOCKED:
        names = ["p2_1rho", "p3_1rho"]
        cols = [-sig.q4, sig.u]
        if setup == "motor-disk-coulomb":
            names.append("sigma_c2_1rho")
            cols.append(-sig.G)
        Phi = np.column_stack(cols)
        phi = sig.dq4
        blk_labels = ["q4"]
    else:  # two-step
        names = ["p2", "p3", "p2_1rho", "p3_1rho"]
        pv = pend_vals
        Psi = np.column_stack([sig.S, sig.C, sig.q3, sig.B])  # xi = Psi @ theta_c
        xi = np.einsum("ij,j->i", Psi, np.array([pv[k] for k in _PENDULUM]))
        Phi = np.zeros((2 * n, 4))
        Phi[:n, 0] = sig.q4
        np.negative(sig.u, out=Phi[:n, 1])
        np.negative(sig.q4, out=Phi[n:, 2])
        Phi[n:, 3] = sig.u
        phi = np.concatenate([sig.dq3 + xi, sig.dq4 - xi])
        blocks = np.repeat(np.array([0, 1], dtype=np.int8), n)
        sidx = np.concatenate([sig.sidx, sig.sidx])
        blk_labels = ["q3", "q4"]
        details["pendulum"] = dict(pv)
        details["pendulum_source"] = pend_desc
        if isinstance(pendulum, IdentificationResult) and pendulum.setup != "free":
            warnings_pre.append(f"the pendulum parameters come from a {pendulum.setup!r} result; section 5.2 takes "
                                "them from the free pendulum (set-up 'free'), which the paper found far more reliable")
        details["xi"] = "p1 sin q1 + sigma_a1 |cos q1| q3 + sigma_v1 q3 + sigma_b1 q3^3 (ERRATA item 1)"
        if pend_cov is not None:
            sens = np.concatenate([Psi, -Psi])
            known_cov = pend_cov

    # ---- set-up specific checks on the data -------------------------------
    if setup in _LOCKED:
        moving = [(s, r) for s, r in zip(_sources(datas), sig.q1_range) if r > _LOCK_TOL]
        if moving:
            warnings.append(
                f"set-up {setup!r} assumes the pendulum locked (q1 = q3 = 0), but q1 moves in "
                + ", ".join(f"{s} (range {r:.3g} rad)" for s, r in moving)
                + "; the pendulum row of (9) is then missing from the model and the estimates are biased")
    if setup in ("two-step", "full"):
        still = [(s, r) for s, r in zip(_sources(datas), sig.q1_range) if r <= _LOCK_TOL]
        if still:
            warnings.append(
                f"set-up {setup!r} needs the pendulum swinging, but q1 hardly moves in "
                + ", ".join(f"{s} (range {r:.3g} rad)" for s, r in still)
                + ("; with a locked pendulum the first row of (10) does not hold (the clamp's torque is missing)"
                   if setup == "two-step" else ""))
    if setup == "free":
        if max(sig.q1_range) <= _LOCK_TOL:
            warnings.append(f"set-up 'free': the pendulum hardly moves (q1 range {max(sig.q1_range):.3g} rad); "
                            "nothing to identify")

    n_eff = sig.n / max(sig.corr_len, 1.0)
    if n_eff < _MIN_EFF_PER_PARAM * n_par:
        warnings.append(
            f"too few samples for set-up {setup!r}: {sig.n} samples, about {n_eff:.0f} effectively independent "
            f"(the filter correlates ~{sig.corr_len:.0f} neighbours) for {n_par} parameters; values and "
            f"uncertainty are unreliable below ~{int(_MIN_EFF_PER_PARAM * n_par * sig.corr_len)} samples")

    # ---- solve (13) ---------------------------------------------------------
    # the measurement-noise covariance needs only the point estimate from lsq (its cheap "ols" pass);
    # where it does not apply, lsq's HAC covariance is used
    noise_ok = covariance == "noise" and d.method != "savgol_direct" and nonlinear == "filter-terms"
    lsq_cov = "hac" if covariance == "hac" or (covariance == "noise" and not noise_ok) else "ols"
    kw: dict[str, Any] = dict(covariance=lsq_cov, allow_rank_deficient=True)
    if blocks is not None:
        kw.update(blocks=blocks, sample_index=sidx)
    else:
        kw.update(sample_index=sidx)
    def solve(**extra: Any) -> LeastSquaresResult:
        try:
            return solve_least_squares(Phi, phi, names, **{**kw, **extra})
        except InputError as exc:
            raise IdentificationError(f"set-up {setup!r}: {exc}") from None

    res = solve()

    cov = np.array(res.covariance, dtype=float)
    crit = res.critical_value
    cov_method = res.covariance_method
    if covariance == "noise":
        vals0 = {nm: float(res.values[j]) for j, nm in enumerate(names)}
        p2k = float(details.get("p2_known", {}).get("value", 0.0)) if setup == "free" else 0.0
        nc = _noise_covariance(setup, sig, d, Phi, blocks, blk_labels, res, vals0, pend_vals, p2k) if noise_ok else None
        if nc is None and lsq_cov != "hac" and res.success:
            res = solve(covariance="hac")
            cov = np.array(res.covariance, dtype=float)
            crit = res.critical_value
        if nc is None:
            warnings.append("the measurement-noise covariance does not apply here (rank deficiency, method "
                            "'savgol_direct' or nonlinear='filtered-states'); the HAC covariance is reported")
            cov_method = "hac"
        else:
            cov, noise_sd = nc
            cov_method = "noise"
            crit = float(stats.t.ppf(0.975, max(res.dof, 1)))
            details["noise_std"] = noise_sd
            details["noise_std_note"] = ("white-equivalent position noise per encoder [rad] from the fourth difference "
                                         "of the positions (quantisation alone: step/sqrt(12) = 9.1e-4 rad at 2000 "
                                         "counts/rev); from_residuals: the level the residuals of each row would need")
            ratios = {ch: v / noise_sd[ch] for ch, v in noise_sd["from_residuals"].items() if noise_sd[ch] > 0}
            worst = max(ratios, key=ratios.get) if ratios else None
            if worst is not None and ratios[worst] > _MISFIT_RATIO:
                res = solve(covariance="hac")
                cov = np.array(res.covariance, dtype=float)
                crit = res.critical_value
                cov_method = "hac"
                row = {"q1": "first (dq3/dt)", "q2": "second (dq4/dt)"}[worst]
                warnings.append(
                    f"model misfit: the residuals of the {row} row of (10) are {ratios[worst]:.3g} times larger than "
                    f"the measurement noise of encoder {worst} ({noise_sd[worst]:.2g} rad) explains; the model does not "
                    "describe these data exactly (unmodelled friction, belt, dead-zone residue, wrong known "
                    "parameters), so the estimates carry a bias that no standard error shows. Standard errors from "
                    "the model-free HAC covariance")
    details["covariance"] = cov_method
    details["regressor_terms"] = nonlinear
    if sens is not None and known_cov is not None and res.success:
        J = _sensitivity(Phi, sens, blocks, res)
        cov = cov + J @ known_cov @ J.T
        details["stderr_includes"] = ("uncertainty of the pendulum parameters used in xi" if setup == "two-step"
                                      else "uncertainty of the known p2")
    elif setup == "two-step":
        details["stderr_includes"] = "noise of this experiment only (pendulum parameters taken as exact)"

    # the warnings of lsq, with the rows named
    for wmsg in res.warnings:
        warnings.append(wmsg)
    params: dict[str, ParameterEstimate] = {}
    se_all = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    se_all[~np.isfinite(np.diag(cov))] = np.nan
    for j, nm in enumerate(names):
        v = float(res.values[j])
        se = float(se_all[j])
        params[nm] = ParameterEstimate(nm, v, se, v - crit * se, v + crit * se)

    rho_info = None
    out_names = list(names)
    if setup in ("full", "two-step"):
        i2, i3, i2r, i3r = (names.index(k) for k in ("p2", "p3", "p2_1rho", "p3_1rho"))
        a, b, c, e = (res.values[k] for k in (i2r, i2, i3r, i3))
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
        rho_info = {"rho_1": float(r1), "rho_2": float(r2), "mean": float(rho_mean)}
        se_r = np.sqrt(np.clip(np.diag(cov_r), 0.0, None))
        details["rho_stderr"] = {"rho_1": float(se_r[0]), "rho_2": float(se_r[1]), "mean": float(se_r[2])}
        params["rho"] = ParameterEstimate("rho", float(rho_mean), float(se_r[2]),
                                          float(rho_mean - crit * se_r[2]), float(rho_mean + crit * se_r[2]))
        # covariance extended by rho (mean)
        cov = np.block([[cov, (cov @ gm)[:, None]], [(gm @ cov)[None, :], np.array([[gm @ cov @ gm]])]])
        out_names.append("rho")
        diff_var = (g1 - g2) @ cov[: len(names), : len(names)] @ (g1 - g2)
        if math.isfinite(diff_var) and diff_var > 0 and abs(r1 - r2) > 3.0 * math.sqrt(diff_var):
            warnings.append(
                f"the two ratios for rho disagree: rho_1 = {r1:.5g}, rho_2 = {r2:.5g} (difference "
                f"{abs(r1 - r2) / math.sqrt(diff_var):.1f} standard errors); the model (9) does not fit these "
                "data exactly (unmodelled friction, belt, dead-zone residue); their mean is reported")
    se_out = np.sqrt(np.clip(np.diag(cov), 0.0, None))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(se_out, se_out)
    np.fill_diagonal(corr, 1.0)
    corr = np.clip(corr, -1.0, 1.0)

    # ---- interpretation warnings -----------------------------------------------
    warnings.extend(_explain(setup, params, corr, out_names, sig, res))
    if setup == "free" and p2 is None and res.success:
        q4max = max(sig.q4_max)
        bvec = _project(Phi, sig.q4, res)
        shift = ref.p2 * bvec
        big = [(nm, shift[j], params[nm].stderr) for j, nm in enumerate(names)
               if math.isfinite(params[nm].stderr) and abs(shift[j]) > params[nm].stderr]
        details["p2_q4_shift_per_unit_p2"] = {nm: float(bvec[j]) for j, nm in enumerate(names)}
        if big:
            warnings.append(
                f"the disk turns during the swing (|q4| up to {q4max:.3g} rad/s): the term p2 q4 of the first row of "
                f"(9), neglected by the paper's theta^c, shifts "
                + ", ".join(f"{nm} by {s:+.3g} ({abs(s) / se:.1f} stderr)" for nm, s, se in big)
                + f" for p2 = {ref.p2:g}; pass p2= (CLI --p2) from a two-step result and identify again")

    success = bool(res.success)
    if success:
        message = (f"set-up {setup!r}: identified {len(names)} parameter(s) from {sig.n} samples "
                   f"({sig.n_files} file(s), {res.n_equations} equations)")
        if warnings:
            message += f"; {len(warnings)} warning(s)"
    else:
        message = f"set-up {setup!r}: {res.message}"
    if setup in _LOCKED:
        details["note"] = ("on a clamped rig p2_1rho, p3_1rho (, sigma_c2_1rho) estimate p2*rho, p3*rho "
                           "(, sigma_c2*rho); the paper names them with (1 + rho)")
    return IdentificationResult(
        setup=setup, samples=sig.n, parameters=params, names=tuple(out_names), covariance=cov, correlation=corr,
        condition_number=float(res.condition_number), residual_rms={blk_labels[i] if isinstance(k, (int, np.integer))
                                                                    else str(k): float(v)
                                                                    for i, (k, v) in enumerate(res.residual_rms.items())},
        lsq=res, rho=rho_info, warnings=warnings, success=success, message=message,
        differentiator=d.settings(), sources=_sources(datas), t_start=t_start, t_end=t_end, details=details,
    )


# ---------------------------------------------------------------------------
# covariance from the measurement noise, propagated through the differentiator
# ---------------------------------------------------------------------------
# Terms of the model (9) as functions of the measured signals (see _prepare):
# T1 = sin q1, T2 = |cos q1| q3, T3 = q3^3, T4 = q3 (channel q1) and T5 = q4 (channel q2).
# beta[row][Ti]: coefficient of Ti in the row's model  dq/dt = sum beta_i T_i + (input terms)
_TERMS = ("T1", "T2", "T3", "T4", "T5")


def _row_betas(setup: str, vals: Mapping[str, float], pend: Mapping[str, float] | None,
               p2_known: float) -> dict[str, tuple[int, dict[str, float]]]:
    """Per block label: (noise channel 1 = q1 or 2 = q2, beta of each term)."""
    if setup in _LOCKED:
        return {"q4": (2, {"T5": -vals["p2_1rho"]})}
    if setup == "free":
        v = vals
        return {"q3": (1, {"T1": -v["p1"], "T2": -v["sigma_a1"], "T3": -v["sigma_b1"], "T4": -v["sigma_v1"],
                           "T5": p2_known})}
    pv = vals if setup == "full" else pend
    pen = {"T1": pv["p1"], "T2": pv["sigma_a1"], "T3": pv["sigma_b1"], "T4": pv["sigma_v1"]}
    return {"q3": (1, {**{k: -x for k, x in pen.items()}, "T5": vals["p2"]}),
            "q4": (2, {**pen, "T5": -vals["p2_1rho"]})}


def _apply_K(d: Differentiator, Ts: float, X: np.ndarray) -> np.ndarray:
    """The common low-pass ``K`` of the differentiator on columns that are zero near both ends."""
    if d.method == "savgol":
        return _convolve_same(X, d.smoothing_kernel())
    return d.smooth(Ts, X)


def _apply_KS(d: Differentiator, Ts: float, X: np.ndarray) -> np.ndarray:
    """``K`` after the triangle average ``S`` of :func:`_tri3` (one convolution for ``"savgol"``)."""
    if d.method == "savgol":
        KS = np.convolve(d.smoothing_kernel(), np.array([1.0, 10.0, 1.0]) / 12.0)
        return _convolve_same(X, KS)
    return _apply_K(d, Ts, _tri3(X))


def _acc_kernel_norm2(d: Differentiator, Ts: float) -> float:
    """``||f||^2`` of the acceleration operator ``f = K D2 / Ts^2`` (white noise -> target noise)."""
    half = max(d.edge_samples_at(Ts), 3)
    imp = np.zeros(4 * half + 9)
    imp[imp.size // 2] = 1.0
    k = _apply_K(d, Ts, imp[:, None])[:, 0]
    f = np.zeros_like(k)
    f[1:-1] = (k[2:] - 2.0 * k[1:-1] + k[:-2]) / (Ts * Ts)
    return float(f @ f)


@njit(cache=True)
def _noise_moments(KQT, p, chans, beta, cos1, c2, abscos, v3, Ts, s1, s2):  # pragma: no cover - compiled
    """``sum_c sigma_c^2 A_c^T A_c`` for one file (see :func:`_noise_covariance`).

    ``KQT``: ``K`` applied to the weighted ``Q`` columns of each block, one
    row per column (blocks one after the other, ``p`` rows each). For each
    block ``b`` with noise channel ``chans[b]`` and term coefficients
    ``beta[b]`` (T1..T5), ``sv = S K Q_b`` (triangle average) and
    ``acc = D2 K Q_b / Ts^2``; then
    ``A_1 = [target] acc - (beta1 cos q1 + beta2 c2) sv - (P D1)^T g``,
    ``g = (beta2 |cos q1| + beta3 3 q3^2 + beta4) sv`` and
    ``A_2 = [target] acc - (P D1)^T (beta5 sv)``, with
    ``(P D1)^T y = -D1 P y`` (stencils with zeros outside the file).
    """
    n = KQT.shape[1]
    nb = chans.shape[0]
    inv_ts2 = 1.0 / (Ts * Ts)
    A1 = np.zeros((p, n))
    A2 = np.zeros((p, n))
    g = np.zeros((p, n + 4))  # padded by 2 zeros at both ends for the stencils
    h = np.zeros((p, n + 4))
    for b in range(nb):
        tgt1 = chans[b] == 1
        b0, b1, b2, b3, b4 = beta[b, 0], beta[b, 1], beta[b, 2], beta[b, 3], beta[b, 4]
        for j in range(p):
            row = KQT[b * p + j]
            for t in range(n):
                x0 = row[t]
                xm = row[t - 1] if t > 0 else 0.0
                xp = row[t + 1] if t < n - 1 else 0.0
                d2 = xp - 2.0 * x0 + xm
                sv = x0 + d2 / 12.0
                acc = d2 * inv_ts2
                if tgt1:
                    A1[j, t] += acc - (b0 * cos1[t] + b1 * c2[t]) * sv
                else:
                    A2[j, t] += acc
                    A1[j, t] -= (b0 * cos1[t] + b1 * c2[t]) * sv
                g[j, t + 2] += (b1 * abscos[t] + b2 * v3[t] + b3) * sv
                h[j, t + 2] += b4 * sv
    half = 0.5 / Ts
    for j in range(p):
        gj = g[j]
        hj = h[j]
        for t in range(n):
            # (P D1)^T y at t = -(z[t+1] - z[t-1]) / (2 Ts), z = y - (second difference of y) / 6
            i = t + 2
            zgm = gj[i - 1] - (gj[i] - 2.0 * gj[i - 1] + gj[i - 2]) / 6.0
            zgp = gj[i + 1] - (gj[i + 2] - 2.0 * gj[i + 1] + gj[i]) / 6.0
            zhm = hj[i - 1] - (hj[i] - 2.0 * hj[i - 1] + hj[i - 2]) / 6.0
            zhp = hj[i + 1] - (hj[i + 2] - 2.0 * hj[i + 1] + hj[i]) / 6.0
            A1[j, t] -= (zgm - zgp) * half
            A2[j, t] -= (zhm - zhp) * half
    M = np.zeros((p, p))
    for i in range(p):
        for j in range(i, p):
            acc1 = 0.0
            acc2 = 0.0
            ai = A1[i]
            aj = A1[j]
            ci = A2[i]
            cj = A2[j]
            for t in range(n):
                acc1 += ai[t] * aj[t]
                acc2 += ci[t] * cj[t]
            M[i, j] = s1 * acc1 + s2 * acc2
            M[j, i] = M[i, j]
    return M


def _noise_covariance(setup: str, sig: _Signals, d: Differentiator, Phi: np.ndarray, blocks: np.ndarray | None,
                      labels: Sequence[str], res: LeastSquaresResult, vals: Mapping[str, float],
                      pend: Mapping[str, float] | None, p2_known: float) -> tuple[np.ndarray, dict[str, float]] | None:
    """Covariance of the estimates caused by white measurement noise on q1 and q2.

    The residual of each row is, to first order in the position noise
    ``w_c`` (quantisation and sensor noise of encoder ``c``), ``r = J_c w_c``
    with ``J_c`` the known linear map of the differentiator and the model:
    the target's ``K D2 / Ts^2`` minus the noise that reaches the
    regressor terms (e.g. ``p1 K S cos(q1) w_1``; it partly cancels the
    target's, which is why plain formulas overstate the spread of ``p1``).
    With ``Xs = Q R`` the weighted, column-scaled regressor, the estimate
    moves by ``R^-1 Q^T W^(1/2) J w``; its covariance is
    ``R^-1 (sum_c sigma_c^2 A_c^T A_c) R^-T`` with ``A_c = J_c^T W^(1/2) Q``,
    computed with the adjoint (time-reversed) filters. ``sigma_c^2`` is
    estimated from the residuals of the row that measures encoder ``c``:
    ``||r||^2 / ((n - p) ||f||^2)``.

    Returns None when it does not apply (rank deficiency, method
    ``"savgol_direct"``, nonlinear mode ``"filtered-states"``).
    """
    from scipy.linalg import solve_triangular

    from .lsq import _tsqr_augmented

    if not res.success or d.method == "savgol_direct" or any(f["v1"] is None for f in sig.files):
        return None
    n_rows, p = Phi.shape
    n = sig.n
    block_rows = {lab: slice(i * n, (i + 1) * n) for i, lab in enumerate(labels)}
    wb = _block_weights_of(blocks, res, labels)
    # R of the weighted regressor from the blocks' R factors (tall-skinny QR), then column scaling:
    # (W^(1/2) Phi) / D = Q (R_w / D); the big weighted matrices are never formed
    Rb = [wb[lab] * _tsqr_augmented(Phi[rows, :-1], Phi[rows, -1], slice(None), None)
          for lab, rows in block_rows.items()]
    Rw = np.linalg.qr(np.vstack(Rb), mode="r")[:p, :p] if len(Rb) > 1 else Rb[0][:p, :p]
    Dn = np.sqrt(np.einsum("ij,ij->j", Rw, Rw))
    if np.any(Dn == 0):
        return None
    R = Rw / Dn
    if np.any(np.abs(np.diag(R)) <= 1e-12 * np.abs(R).max()):
        return None
    Rinv = solve_triangular(R, np.eye(p))
    # W^(1/2) Q of each block: w_b^2 Phi_b D^-1 R^-1 (one factor w_b from Xs, one from W^(1/2))
    Gmat = {lab: (wb[lab] ** 2) * (Rinv / Dn[:, None]) for lab in block_rows}
    betas = _row_betas(setup, vals, pend, p2_known)
    # noise level per encoder: from the positions (fourth difference), and, for comparison, the level
    # the residuals of the row that measures it would imply if they were measurement noise only
    nsamp = np.array([f["n_full"] for f in sig.files], dtype=float)
    sig2 = {c + 1: float(np.sum(nsamp * np.array([f["noise"][c] ** 2 for f in sig.files])) / nsamp.sum())
            for c in (0, 1)}
    resid_sd: dict[int, float] = {}
    nf = _acc_kernel_norm2(d, sig.files[0]["Ts"])
    for lab, (chan, _) in betas.items():
        r = res.residuals[block_rows[lab]]
        dof = max(r.size - p * r.size / n_rows, 1.0)
        resid_sd[chan] = math.sqrt(float(np.einsum("i,i->", r, r)) / dof / nf)
    labs = list(betas)
    chans = np.array([betas[lab][0] for lab in labs], dtype=np.int64)
    beta = np.array([[betas[lab][1].get(t, 0.0) for t in _TERMS] for lab in labs])
    M = np.zeros((p, p))
    for f in sig.files:
        Ts, n_full, kk, start = f["Ts"], f["n_full"], f["kk"], f["start"]
        nk = n_full - 2 * kk
        q1, v1 = f["q1"], f["v1"]
        Qf = np.zeros((n_full, len(labs) * p))
        for i, lab in enumerate(labs):
            r0 = block_rows[lab].start + start
            for c0 in range(0, nk, _MATMUL_CHUNK):  # small products: no threaded BLAS (it can stall)
                c1 = min(nk, c0 + _MATMUL_CHUNK)
                np.matmul(Phi[r0 + c0: r0 + c1], Gmat[lab], out=Qf[kk + c0: kk + c1, i * p: (i + 1) * p])
        KQT = np.ascontiguousarray(_apply_K(d, Ts, Qf).T)  # K^T = K (zero-phase): one call for all blocks
        cos1 = np.cos(q1)
        M += _noise_moments(KQT, p, chans, beta, cos1, -np.sign(cos1) * np.sin(q1) * v1, np.abs(cos1),
                            3.0 * v1 * v1, Ts, sig2[1], sig2[2])
    cov = (Rinv @ M @ Rinv.T) / np.outer(Dn, Dn)
    return cov, {"q1": math.sqrt(sig2[1]), "q2": math.sqrt(sig2[2]),
                 "from_residuals": {f"q{c}": v for c, v in resid_sd.items()}}


def _sources(datas: Iterable[Any]) -> list[str]:
    return [str(getattr(x, "source", "<memory>")) for x in datas]


def _row_weights(blocks: np.ndarray | None, res: LeastSquaresResult, n_rows: int) -> np.ndarray:
    if blocks is None or len(res.block_sigma) < 2:
        return np.ones(n_rows)
    sig = res.block_sigma
    labels = list(sig)
    smax = max(v for v in sig.values() if math.isfinite(v))
    w = np.ones(n_rows)
    for lab in labels:
        s = sig[lab]
        w[blocks == lab] = 1.0 / max(s if math.isfinite(s) else smax, 1e-8 * smax)
    return w


def _block_weights_of(blocks: np.ndarray | None, res: LeastSquaresResult, labels: Sequence[str]) -> dict[str, float]:
    """Row weight (1 / block sigma) per block label, as the block-weighted least squares used them."""
    if blocks is None or len(res.block_sigma) < 2:
        return {lab: 1.0 for lab in labels}
    sig = list(res.block_sigma.values())
    smax = max(v for v in sig if math.isfinite(v))
    return {lab: 1.0 / max(v if math.isfinite(v) else smax, 1e-8 * smax) for lab, v in zip(labels, sig)}


def _sensitivity(Phi: np.ndarray, targets: np.ndarray, blocks, res: LeastSquaresResult) -> np.ndarray:
    """d theta / d(known) = weighted least-squares projection of the target sensitivities."""
    w = _row_weights(blocks, res, Phi.shape[0])
    return lstsq_projection(Phi, targets, row_scale=None if np.all(w == 1.0) else w)


def _project(Phi: np.ndarray, col: np.ndarray, res: LeastSquaresResult) -> np.ndarray:
    """Least-squares coefficients of ``col`` on the regressor (shift of theta per unit coefficient)."""
    return _sensitivity(Phi, col[:, None], None, res)[:, 0]


def _explain(setup: str, params: Mapping[str, ParameterEstimate], corr: np.ndarray, names: Sequence[str],
             sig: _Signals, res: LeastSquaresResult) -> list[str]:
    """Warnings that interpret the numbers: unphysical signs, undetermined values, inseparable pairs."""
    out: list[str] = []
    undetermined = []
    for nm, p in params.items():
        if not math.isfinite(p.stderr):
            continue
        if p.ci95_low <= 0.0 <= p.ci95_high and (nm in _POSITIVE or nm in _NONNEG):
            undetermined.append(f"{nm} = {p.value:.3g} +- {p.stderr:.2g}")
    if undetermined:
        out.append("not determined by these data (the 95 % interval contains 0): " + ", ".join(undetermined))
    unphys = [f"{nm} = {p.value:.4g}" for nm, p in params.items()
              if (nm in _POSITIVE and p.value <= 0) or (nm in _NONNEG and p.value < 0 and p.ci95_high < 0)]
    if unphys:
        out.append("unphysical estimate(s) (negative friction or gain, significantly): " + ", ".join(unphys)
                   + "; the model does not describe these data (see the paper's eq. (16))")
    idx = {nm: i for i, nm in enumerate(names)}
    if setup in ("free", "full") and "sigma_a1" in idx and "sigma_v1" in idx:
        r = corr[idx["sigma_a1"], idx["sigma_v1"]]
        if math.isfinite(r) and abs(r) > _CORR_EXPLAIN:
            qmax = 0.5 * max(sig.q1_range)
            why = (f"; the swing (about +-{qmax:.2g} rad) keeps |cos q1| near 1, so the columns |cos q1| q3 and q3 "
                   "hardly differ: release the pendulum from a larger angle" if qmax < 0.6 else
                   "; the data move them together")
            out.append(
                f"sigma_a1 and sigma_v1 are not separable (correlation of the estimates {r:+.4f}): only a "
                f"combination of the two is determined, each alone carries the large standard error shown{why}")
    if not res.success:
        out.append(f"rank-deficient regressor for set-up {setup!r}: the data do not excite all parameters; "
                   "the values reported for them are not estimates")
    return out


# ---------------------------------------------------------------------------
# dead zone from a static curve
# ---------------------------------------------------------------------------
def identify_dead_zone(curve: Any, *, min_fraction: float = 0.2) -> IdentificationResult:
    """Dead-zone thresholds ``v+`` and ``v-`` of (5) from a static curve (figure 2a).

    On each side separately, the *straight part* of the curve -- the points
    where the disk turns in the input's direction with ``|q4|`` at least
    ``min_fraction`` of that side's largest ``|q4|`` -- is fitted by the line
    ``q4 = a (v - v0)`` (ordinary least squares of ``q4 = a v + b``), and the
    line is extrapolated to ``q4 = 0``: ``v_dz_pos = v0`` on the positive
    side, ``v_dz_neg = -v0`` on the negative side (both positive numbers, as
    in (5)). Points with ``q4 = 0`` (the dead zone) and the break-away region
    just after the disk starts (figure 2a's discontinuity) are excluded by
    the fraction.

    Parameters
    ----------
    curve : StaticCurve or list of StaticCurve
        Input ``v`` [in] (or ``u`` for a compensated curve) and steady disk
        velocity ``q4`` [rad/s]; several curves are pooled.
    min_fraction : float
        Lower end of the straight part, as a fraction of the side's largest
        ``|q4|`` (default 0.2).

    Returns
    -------
    IdentificationResult
        ``v_dz_pos``, ``v_dz_neg`` [in] with standard errors from the delta
        method on the line fit (white residuals: each point is a separate
        steady state). ``details`` holds each side's slope ``a`` [rad/s/in]
        (the static gain ``p3/p2`` of (9)), intercept, points used and
        residual RMS.

    Notes
    -----
    The extrapolated threshold is where the *static* curve meets ``q4 = 0``:
    with Coulomb friction at the disk it is ``v+ + sigma~_c2/p3`` (the
    Coulomb torque acts like extra dead zone), which is what a compensation
    (7)-(8) must cancel. For a compensated curve (input ``u``) the result is
    the residual dead zone after the compensation.
    """
    from .io import ExperimentData, StaticCurve

    curves = _as_list(curve)
    for c in curves:
        if isinstance(c, ExperimentData):
            raise InputError(f"{c.source}: is a time-series log; set-up 'dead-zone' needs a static curve "
                             "(columns v,q4 or u,q4, one row per steady state)")
        if not isinstance(c, StaticCurve):
            raise InputError(f"set-up 'dead-zone' needs a StaticCurve, got {type(c).__name__}")
    names_in = {c.input_name for c in curves}
    if len(names_in) > 1:
        raise InputError("the static curves mix the raw input v and the compensated input u; give one kind")
    mf = float(min_fraction)
    if not 0.0 <= mf < 1.0:
        raise InputError(f"min_fraction must be in [0, 1), got {min_fraction!r}")
    x = np.concatenate([c.input for c in curves])
    y = np.concatenate([c.q4 for c in curves])
    src = ", ".join(c.source for c in curves)
    warnings: list[str] = []
    params: dict[str, ParameterEstimate] = {}
    details: dict[str, Any] = {}
    rms: dict[str, float] = {}
    conds = []
    used_total = 0
    for side, sgn, name in (("pos", 1.0, "v_dz_pos"), ("neg", -1.0, "v_dz_neg")):
        moving = (sgn * x > 0) & (sgn * y > 0)
        if not np.any(moving):
            raise IdentificationError(f"{src}: the disk never turns on the {'positive' if sgn > 0 else 'negative'} "
                                      "side; the static curve does not reach beyond the dead zone there")
        ymax = float(np.max(sgn * y[moving]))
        sel = moving & (sgn * y >= mf * ymax)
        m = int(np.count_nonzero(sel))
        if m < 3:
            raise IdentificationError(
                f"{src}: only {m} point(s) on the straight part of the {side} side (|q4| >= {mf:g} x {ymax:.4g} rad/s); "
                "need at least 3 to fit the line and estimate its uncertainty")
        X = np.column_stack([x[sel], np.ones(m)])
        r = solve_least_squares(X, y[sel], ["a", "b"], covariance="ols", weights="none", allow_rank_deficient=True)
        a, b = r.values
        if not r.success or not a > 0:
            raise IdentificationError(f"{src}: the {side} side's straight part has no usable slope (a = {a:.4g})")
        v0 = -b / a
        g = np.array([b / a ** 2, -1.0 / a])  # d v0 / d(a, b)
        var = float(g @ r.covariance @ g)
        se = math.sqrt(max(var, 0.0))
        val = sgn * v0
        crit = r.critical_value
        params[name] = ParameterEstimate(name, float(val), se, float(val - crit * se), float(val + crit * se))
        rms[side] = float(r.residual_rms[0]) if r.residual_rms else math.nan
        conds.append(r.condition_number)
        used_total += m
        # break-away: points between the jump and the straight part
        excluded = moving & ~sel
        first = x[moving][np.argmin(sgn * x[moving])]
        details[side] = {
            "slope": float(a), "intercept": float(b), "points": m, "excluded_moving_points": int(np.count_nonzero(excluded)),
            "input_range": [float(np.min(x[sel])), float(np.max(x[sel]))], "first_moving_input": float(first),
            "residual_rms": rms[side],
        }
        if m < 5:
            warnings.append(f"{side} side: only {m} points on the straight part; the threshold's uncertainty is rough")
        # points of the straight part that deviate from the line near its low end (curvature)
        resid = y[sel] - (a * x[sel] + b)
        lo = np.argmin(sgn * x[sel])
        others = float(np.sqrt(np.mean(np.delete(resid, lo) ** 2))) if m >= 4 else math.inf
        if m >= 4 and abs(resid[lo]) > 3.0 * others and abs(resid[lo]) > 0.01 * abs(y[sel][lo]):
            warnings.append(f"{side} side: the lowest point of the straight part (input {x[sel][lo]:.4g}) is off the "
                            f"line by {resid[lo]:+.3g} rad/s; the curve bends there, raise min_fraction")
        gap = abs(first - val * sgn)
        details[side]["jump_above_threshold"] = float(gap)
    corr = np.eye(2)
    se = np.array([params["v_dz_pos"].stderr, params["v_dz_neg"].stderr])
    cov = np.diag(se ** 2)
    comp = {}
    c0 = curves[0]
    if c0.input_name == "u":
        md = c0.metadata
        try:
            comp = {"v_dz_pos": float(md.get("v_dz_pos", "nan")), "v_dz_neg": float(md.get("v_dz_neg", "nan"))}
        except ValueError:
            comp = {}
        if not comp or not all(math.isfinite(v) for v in comp.values()):
            comp = {}
        warnings.append("compensated curve (input u): v_dz_pos and v_dz_neg are the residual dead zone after the "
                        "compensation" + (f" v_dz = ({comp['v_dz_pos']:g}, {comp['v_dz_neg']:g})" if comp else
                                          " (its thresholds are not in the metadata)"))
        if comp:
            details["compensation"] = comp
    details["method"] = (f"straight part: |q4| >= {mf:g} x max|q4| per side; line q4 = a v + b, "
                         "threshold = -b/a; stderr by the delta method")
    ok = True
    message = (f"set-up 'dead-zone': v_dz_pos = {params['v_dz_pos'].value:.4g} +- {params['v_dz_pos'].stderr:.2g}, "
               f"v_dz_neg = {params['v_dz_neg'].value:.4g} +- {params['v_dz_neg'].stderr:.2g} from {used_total} points")
    return IdentificationResult(
        setup="dead-zone", samples=used_total, parameters=params, names=("v_dz_pos", "v_dz_neg"), covariance=cov,
        correlation=corr, condition_number=float(max(conds)), residual_rms=rms, lsq=None, rho=None,
        warnings=warnings, success=ok, message=message, differentiator={}, sources=[c.source for c in curves],
        details=details,
    )


# ---------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------
def load_pendulum(path: str | os.PathLike) -> Any:
    """Read the pendulum parameters for the two-step set-up from a file.

    Accepts the JSON printed by ``iwp identify --setup free --json`` (an
    :class:`IdentificationResult` with uncertainties), the parameter file
    written by ``--out`` (whose ``"identification"`` entry carries the same,
    so uncertainties are kept), or any lumped parameter file / built-in name
    (values only).

    Returns
    -------
    IdentificationResult or LumpedParameters
    """
    from .params import load_params

    p = Path(path)
    if p.is_file():
        doc = read_json(p)
        if isinstance(doc, Mapping):
            if "setup" in doc and "parameters" in doc:
                return IdentificationResult.from_dict(doc, where=str(p))
            ident = doc.get("identification")
            if isinstance(ident, Mapping) and "setup" in ident:
                return IdentificationResult.from_dict(ident, where=f"{p}: identification")
    params = load_params(str(path), physical_check=False)
    if hasattr(params, "to_lumped"):
        params = params.to_lumped()
    return params
