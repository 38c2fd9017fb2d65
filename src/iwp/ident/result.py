"""What an identification returns: :class:`IdentificationResult`."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from ..errors import IdentificationError, InputError
from ..files import json_float, jsonable
from ..models.parameters import LumpedParameters, table1
from .fit_parameters import Parameter, closing_lines, parameter_table
from .lsq import LeastSquaresResult
from .setups import PARAMETER_UNITS, SETUPS

__all__ = ["IdentificationResult"]


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
    parameters : dict of str to Parameter
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
    parameters: dict[str, Parameter]
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
    def __getitem__(self, name: str) -> Parameter:
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
            n: {"value": json_float(p.value), "stderr": json_float(p.stderr),
                "ci95": [json_float(p.ci95_low), json_float(p.ci95_high)], "unit": PARAMETER_UNITS.get(n, "")}
            for n, p in self.parameters.items()
        }
        corr = {a: {b: json_float(self.correlation[i, j]) for j, b in enumerate(self.names)}
                for i, a in enumerate(self.names)}
        out: dict[str, Any] = {
            "setup": self.setup,
            "samples": int(self.samples),
            "parameters": params,
        }
        if self.rho is not None:
            out["rho"] = {k: json_float(v) for k, v in self.rho.items()}
        out.update({
            "correlation": corr,
            "condition_number": json_float(self.condition_number),
            "residual_rms": {str(k): json_float(v) for k, v in self.residual_rms.items()},
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
            # the covariance the standard errors come from (the solver's own, unless the set-up replaced it)
            out["covariance"] = (self.details or {}).get("covariance", self.lsq.covariance_method)
            out["bandwidth"] = self.lsq.bandwidth
            out["critical_value"] = json_float(self.lsq.critical_value)
        if self.details:
            out["details"] = jsonable(self.details)
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
        params: dict[str, Parameter] = {}
        for n, e in pars.items():
            if not isinstance(e, Mapping) or "value" not in e:
                raise InputError(f"{where}: parameter {n!r} must be an object with 'value' and 'stderr'")
            v = _num(e.get("value"), f"{where}: parameters.{n}.value")
            se = e.get("stderr")
            se = math.nan if se is None else _num(se, f"{where}: parameters.{n}.stderr")
            ci = e.get("ci95") or [None, None]
            lo = math.nan if ci[0] is None else float(ci[0])
            hi = math.nan if ci[1] is None else float(ci[1])
            params[n] = Parameter(n, v, stderr=se, ci95=(lo, hi), note=str(e.get("note", "")))
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

        def floats(d):
            return {k2: (math.nan if v2 is None else float(v2)) for k2, v2 in (d or {}).items()}

        return cls(
            setup=setup, samples=int(doc.get("samples", 0)), parameters=params, names=names, covariance=cov,
            correlation=corr, condition_number=math.nan if cn is None else float(cn),
            residual_rms=floats(doc.get("residual_rms")),
            rho=None if doc.get("rho") is None else floats(doc["rho"]),
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
            (default: :func:`iwp.models.parameters.table1`).

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
        base = table1() if base is None else base
        if not isinstance(base, LumpedParameters):
            raise InputError(f"base must be LumpedParameters, got {type(base).__name__}")
        s = self.setup
        ch = SETUPS[s].parameter_changes(self.values(), self.details, base)
        bad = [n for n, v in ch.items() if not math.isfinite(v)]
        if bad:
            raise IdentificationError(f"set-up {s!r}: {', '.join(bad)} not identified (NaN); "
                                      "cannot build a parameter set")
        if "rho" in ch and ch["rho"] <= 0:
            raise IdentificationError(f"set-up {s!r}: identified rho = {ch['rho']:.4g} <= 0; "
                                      "cannot build a parameter set")
        return base.replace(**ch)

    def summary(self) -> str:
        """A readable table of the estimates and the diagnostics."""
        window = self.t_start is not None or self.t_end is not None
        lines = [f"set-up {self.setup!r}: {self.samples} samples from {len(self.sources)} file(s)"
                 + (f", window [{self.t_start}, {self.t_end}] s" if window else "")]
        if self.differentiator:
            lines.append("differentiator: " + ", ".join(f"{k}={v}" for k, v in self.differentiator.items()))
        notes = self.details.get("input_hold_note") or []
        if notes and len(set(notes)) == 1:
            lines.append(notes[0] + ("" if len(notes) == 1 else f" (all {len(notes)} files)"))
        else:
            lines += [f"{src}: {note}" for src, note in zip(self.sources, notes)]
        lines += parameter_table(self.parameters.values(), units=PARAMETER_UNITS)
        if self.rho is not None:
            lines.append("rho: " + ", ".join(f"{k} = {v:.6g}" for k, v in self.rho.items()))
        zero = self.details.get("q1_zero_offset")
        if zero:
            lines.append("the pendulum angle's zero, logged minus true [mrad]: "
                         + ", ".join(f"{1e3 * d:+.3f}" for d in zero) + " (per file, estimated)")
        lines.append(f"condition number {self.condition_number:.3g}; residual rms "
                     + ", ".join(f"{k}: {v:.4g}" for k, v in self.residual_rms.items()))
        return "\n".join(lines + closing_lines(self.warnings, self.message))

    def __str__(self) -> str:
        return self.summary()



def _num(v: Any, what: str) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise InputError(f"{what} must be a number, got {v!r}")
    return float(v)

