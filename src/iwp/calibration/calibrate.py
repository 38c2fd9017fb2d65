"""Calibration of the virtual rig by indirect inference: a twin on which the paper's procedures return its numbers.

The paper's Table 1 is what its procedures *returned* on its rig, biased by
the belt, the dead zone, Coulomb friction and the differentiation; it is not
the rig's truth. The twin's truth is found the other way round:

1. the *structural* parameters of the truth plant (:data:`COORDINATES`:
   pendulum, motor-disk friction, dead zone and its start-up jump, Coulomb
   friction, the belt (15), a motor gain that differs by the sign of the
   voltage (section 3.2), the winding resistance of the later session, the
   encoder noise) give a twin;
2. the twin runs the paper's experiments and the paper's procedures are
   applied to its logs exactly as the command line applies them with its
   defaults (:func:`iwp.calibration.statistics.paper_numbers`): these *auxiliary
   statistics* are the twin's version of every published number;
3. the distance between them and the published numbers, each deviation in
   units of its tolerance (:meth:`iwp.calibration.targets.PaperTarget.residual`), is
   minimised over the structural parameters with
   :func:`scipy.optimize.least_squares` (trust-region reflective, bounds, the
   parameters on a log scale, forward differences of 2 % per parameter).

Every evaluation runs the rig with the same noise seed (common random
numbers) and without noise by default, so the objective is a smooth function
of the parameters up to the encoder quantisation, which the 2 % steps step
over. :func:`calibrate` returns a :class:`CalibrationResult`: the truth, the
residual table (published against reproduced, for every target, calibrated
or not), success and message, and the sensitivity of every target to every
parameter (:attr:`CalibrationResult.sensitivity`), from which a target that
no twin of the family reaches is shown to be out of reach
(:meth:`CalibrationResult.reach`). ``iwp rig calibrate`` is the command.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import time
import warnings as _warnings
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any, Mapping, Sequence

import numpy as np

from ..errors import InputError, IwpError
from ..files import atomic_write, jsonable, prepare_output_file
from ..ident.fit_parameters import Parameter, Parameters
from ..ident.jacobian import forward_difference_jacobian
from ..ident.problem import FitProblem, SolverOptions
from ..models.parameters import BeltParameters
from ..models.terms import TERMS
from ..rig.truth import RigTruth, default_truth
from .statistics import paper_numbers
from .targets import PaperTarget, TargetRow, compare_targets, load_targets

__all__ = [
    "TruthCoordinate",
    "COORDINATES",
    "DEFAULT_FREE",
    "CalibrationResult",
    "calibrate",
    "truth_values",
    "truth_with",
    "twin_statistics",
    "PROVENANCE_PAPER",
]


@dataclass(frozen=True)
class TruthCoordinate:
    """One structural parameter of the twin that a calibration can vary (on a log scale, within bounds).

    Attributes
    ----------
    name : str
        ``lumped.FIELD``, ``startup.FIELD``, ``belt.FIELD``, ``belt.b2_share``
        (the disk's viscous friction ``b2/I2`` as a share of the rigid-limit
        damping ``p2 rho``), ``resistance_ratio`` or ``noise_std``.
    low, high : float
        Bounds (both > 0).
    unit : str
    description : str
    """

    name: str
    low: float
    high: float
    unit: str
    description: str


#: The structural parameters of the twin, with their bounds.
COORDINATES: dict[str, TruthCoordinate] = {c.name: c for c in (
    TruthCoordinate("lumped.p1", 20.0, 32.0, "1/s^2", "gravity term (m1 c + m2 l) g / I1_hat"),
    TruthCoordinate("lumped.p2", 0.003, 0.02, "1/s", "disk damping (back-emf and viscous) over I1_hat, rigid limit"),
    TruthCoordinate("lumped.p3", 0.015, 0.045, "rad/(s^2 in)", "motor gain over I1_hat (positive voltage)"),
    TruthCoordinate("lumped.rho", 200.0, 300.0, "-", "inertia ratio I1_hat / I2"),
    TruthCoordinate("lumped.sigma_a1", 1e-4, 0.05, "1/s", "rolling friction |cos q1| q3 of the pendulum"),
    TruthCoordinate("lumped.sigma_v1", 1e-4, 0.05, "1/s", "viscous friction of the pendulum"),
    TruthCoordinate("lumped.sigma_b1", 1e-5, 3e-3, "s/rad^2", "centrifugal rolling friction q3^3 of the pendulum"),
    TruthCoordinate("lumped.v_dz_pos", 10.0, 45.0, "in", "dead-zone threshold v+ (5)"),
    TruthCoordinate("lumped.v_dz_neg", 10.0, 45.0, "in", "dead-zone threshold v- (5)"),
    TruthCoordinate("lumped.sigma_c2", 0.005, 0.5, "rad/s^2", "Coulomb friction of the disk over I1_hat"),
    TruthCoordinate("startup.break_ratio", 1e-3, 3.0, "-", "start-up jump: extra dead zone at rest"),
    TruthCoordinate("startup.omega_s", 0.2, 200.0, "rad/s", "start-up jump: disk speed over which it fades"),
    TruthCoordinate("belt.k_over_I2", 20.0, 1e4, "1/s^2", "belt stiffness over the disk inertia (15)"),
    TruthCoordinate("belt.d", 0.01, 5.0, "rad", "half-width of the belt's play (figure 5)"),
    TruthCoordinate("belt.b2_share", 0.01, 0.9, "-", "the disk's viscous friction b2/I2 as a share of p2 rho"),
    TruthCoordinate("belt.gain_neg", 0.7, 1.4, "-", "motor gain for negative over positive voltage (section 3.2)"),
    TruthCoordinate("resistance_ratio", 0.8, 1.4, "-", "winding resistance in session 5.2 over session 5.1"),
    TruthCoordinate("noise_std", 1e-5, 3e-3, "rad", "encoder noise added before quantisation"),
)}

#: What :func:`calibrate` varies by default: every structural parameter but the encoder noise (the paper gives
#: the encoders' resolution, no noise; adding 1e-3 rad, about one count, moves no graded number of the default
#: twin by more than 0.17 of its tolerance).
DEFAULT_FREE = tuple(n for n in COORDINATES if n != "noise_std")

#: Where the values of a truth that no calibration varies come from (the optional terms' parameters of
#: :data:`iwp.models.terms.TERMS` are 0 unless said otherwise here or calibrated).
PROVENANCE_PAPER = {
    **{f"lumped.{i.name}": f"assumed: 0 ({i.description})" for t in TERMS.values() for i in t.parameters
       if f"lumped.{i.name}" not in COORDINATES},
    "counts_per_rev": "paper, section 5: 2000 counts/rev",
    "Ts": "paper, section 5: sample time 5 ms",
    "belt.N": "paper, section 5.1: N = 13.5 (measured)",
    "saturation": "assumed: the driver's range +-100 input units (the paper's static curve reaches |v| ~ 100)",
    "noise_std": "assumed: the encoders only quantise (section 5 gives their resolution, no noise)",
    "coulomb_eps": "numerical: sgn q4 regularised as tanh(q4/eps)",
    "lumped.sigma_c1": "paper, section 3.1: no Coulomb friction at the pendulum joint",
    "lumped.u_offset": "assumed: no input offset",
}

#: forward-difference step of the Jacobian on the log scale (2 %: beyond the encoder's quantisation)
STEP = 0.02
#: the optimiser's options of a calibration: at most 40 iterations (each runs the twin), tolerance 1e-3
CALIBRATION_OPTIONS = SolverOptions(tol=1e-3, max_nfev=40)
#: residual of an evaluation that failed (the trust region then shrinks)
FAILED = 1e3


# --------------------------------------------------------------------------
# truths and coordinates
# --------------------------------------------------------------------------
def _check_names(names: Sequence[str], what: str) -> tuple[str, ...]:
    names = (names,) if isinstance(names, str) else tuple(names)
    for n in names:
        if n not in COORDINATES:
            raise InputError(f"{what}: unknown parameter {n!r}; choose among {', '.join(COORDINATES)}")
    if len(set(names)) != len(names):
        raise InputError(f"{what} lists a parameter twice: {', '.join(names)}")
    return names


def truth_values(truth: RigTruth, names: Sequence[str] = tuple(COORDINATES)) -> dict[str, float]:
    """The values of the coordinates ``names`` in ``truth``.

    Parameters
    ----------
    truth : RigTruth
        The rig's truth; it must have a belt (15).
    names : sequence of str, default all of COORDINATES
        Coordinate names, keys of :data:`COORDINATES` (``"lumped.p1"``, ``"belt.b2_share"``, ...); a single
        string is one name.

    Returns
    -------
    dict of str to float
        Value of each coordinate, in its unit (:data:`COORDINATES`); ``"belt.b2_share"`` is ``b2/I2`` over
        ``p2 rho``.

    Raises
    ------
    InputError
        A truth without a belt, an unknown name or a name given twice.
    """
    if truth.belt is None:
        raise InputError("the twin needs the belt (15): give a truth with a belt")
    out = {}
    for n in _check_names(names, "names"):
        if n == "belt.b2_share":
            out[n] = truth.belt.b2_over_I2 / (truth.lumped.p2 * truth.lumped.rho)
        elif "." in n:
            sec, f = n.split(".", 1)
            out[n] = float(getattr(getattr(truth, sec), f))
        else:
            out[n] = float(getattr(truth, n))
    return out


def truth_with(base: RigTruth, values: Mapping[str, float]) -> RigTruth:
    """``base`` with the coordinates in ``values`` set; the belt's rigid limit follows the lumped ``p2, p3, rho``.

    ``k_over_gamma`` and ``kTbeta_over_Rgamma`` are derived
    (:meth:`BeltParameters.from_rigid`) so that the belt's rigid limit is the
    lumped ``p2 rho``, ``p3 rho``; ``b2/I2`` keeps its share of ``p2 rho``
    unless ``belt.b2_share`` is given.

    Parameters
    ----------
    base : RigTruth
        The truth to start from; it must have a belt (15).
    values : mapping of str to float
        New values of coordinates (keys of :data:`COORDINATES`), in their units; the others keep ``base``'s.

    Returns
    -------
    RigTruth
        A new truth; ``base`` is not changed.

    Raises
    ------
    InputError
        A truth without a belt, an unknown coordinate name or one given twice.

    Examples
    --------
    A disk 5 % stronger: the belt's gain follows, so that its rigid limit is the new ``p3 rho``:

    >>> from iwp.calibration import truth_with
    >>> from iwp.rig import default_truth
    >>> base = default_truth()
    >>> stronger = truth_with(base, {"lumped.p3": 1.05 * base.lumped.p3})
    >>> round(stronger.belt.kTbeta_over_Rgamma / base.belt.kTbeta_over_Rgamma, 6)
    1.05
    >>> stronger.lumped.p1 == base.lumped.p1  # the other coordinates are kept
    True
    """
    _check_names(list(values), "values")
    current = truth_values(base)
    v = {**current, **{k: float(x) for k, x in values.items()}}
    lumped = base.lumped.replace(**{k[7:]: v[k] for k in v if k.startswith("lumped.")})
    startup = dataclasses.replace(base.startup, **{k[8:]: v[k] for k in v if k.startswith("startup.")})
    p2rho, p3rho = lumped.p2 * lumped.rho, lumped.p3 * lumped.rho
    belt = BeltParameters.from_rigid(p2rho, p3rho, k_over_I2=v["belt.k_over_I2"], d=v["belt.d"], N=base.belt.N,
                                     b2_over_I2=v["belt.b2_share"] * p2rho, gain_neg=v["belt.gain_neg"])
    return base.replace(lumped=lumped, startup=startup, belt=belt, resistance_ratio=v["resistance_ratio"],
                        noise_std=v["noise_std"] if "noise_std" in values else base.noise_std)


def twin_statistics(truth: RigTruth, targets: Sequence[PaperTarget], *, seed: int = 0,
                    overrides: Mapping[str, Mapping[str, Any]] | None = None) -> dict[str, float]:
    """The twin's value of every target's statistic (:func:`iwp.calibration.statistics.paper_numbers`).

    Parameters
    ----------
    truth : RigTruth
        The twin's truth.
    targets : sequence of PaperTarget
        The targets whose statistics are wanted.
    seed : int, default 0
        Seed of the virtual rig's measurement noise.
    overrides : mapping of str to mapping, optional
        Options of the paper's experiments, by experiment name (as :func:`~iwp.calibration.statistics.paper_numbers`).

    Returns
    -------
    dict of str to float
        Value of each target's statistic, by statistic name (in the statistic's unit).

    Examples
    --------
    On shortened experiments, the hand-set start of the calibration reads the static curve's threshold far from
    the paper's ``v+ ~ 31``; the calibrated twin reads it:

    >>> from iwp.calibration import load_targets, twin_statistics
    >>> from iwp.rig import default_truth, uncalibrated_truth
    >>> short = {"static-curve": {"step": 20.0, "duration": 2.0},
    ...          "static-curve-compensated": {"step": 20.0, "duration": 2.0},
    ...          "motor-disk-chirp": {"duration": 5.0}, "full-chirp": {"duration": 5.0},
    ...          "free-pendulum": {"duration": 3.0}, "closed-loop": {"duration": 3.0}}
    >>> targets = [t for t in load_targets() if t.key in ("v_dz_pos", "c_p1")]
    >>> for truth in (uncalibrated_truth(), default_truth()):
    ...     stats = twin_statistics(truth, targets, overrides=short)
    ...     print(round(stats["dead-zone.v_dz_pos"], 2), round(stats["free.p1"], 2))
    38.04 25.99
    30.96 26.36
    """
    numbers = paper_numbers(truth, seed=seed, overrides=overrides)
    return numbers.values(sorted({t.statistic for t in targets}))


# --------------------------------------------------------------------------
# result
# --------------------------------------------------------------------------
@dataclass(eq=False)
class CalibrationResult:
    """The outcome of :func:`calibrate`.

    Attributes
    ----------
    truth : RigTruth
        The calibrated truth.
    start : RigTruth
        Where the calibration started.
    free : tuple of str
        The coordinates varied (:data:`COORDINATES`).
    values, start_values : dict of str to float
        Their values at the optimum and at the start.
    rows, rows_start : list of TargetRow
        Every target (calibrated or not), published against reproduced, at
        the optimum and at the start.
    sensitivity : dict of str to dict of str to float
        ``sensitivity[target][coordinate]``: change of the target's residual
        (its deviation in units of its tolerance) per unit change of the
        coordinate's logarithm (forward differences of 2 % at the optimum);
        ``0.1 x`` that is the change for a 10 % change of the parameter.
    singular_values : ndarray
        Of the calibrated targets' sensitivity matrix: the directions the
        targets determine (small ones: combinations they do not).
    cost, cost_start : float
        ``0.5 sum r^2`` over the calibrated targets at the optimum and start.
    success, message : bool, str
        From :func:`scipy.optimize.least_squares`.
    nfev : int
        Twin evaluations (each runs every experiment and procedure).
    elapsed : float
        Wall time [s].
    warnings : list of str
        Targets outside their tolerance, parameters at a bound, a failed
        optimiser.
    settings : dict
        Seed, experiment overrides and the targets file.
    """

    truth: RigTruth
    start: RigTruth
    free: tuple[str, ...]
    values: dict[str, float]
    start_values: dict[str, float]
    rows: list[TargetRow]
    rows_start: list[TargetRow]
    sensitivity: dict[str, dict[str, float]]
    singular_values: np.ndarray
    cost: float
    cost_start: float
    success: bool
    message: str
    nfev: int
    elapsed: float
    warnings: list[str] = field(default_factory=list)
    settings: dict[str, Any] = field(default_factory=dict)

    @property
    def within(self) -> int:
        """Number of graded targets reproduced within their tolerance."""
        return sum(1 for r in self.rows if r.target.graded and r.within)

    @property
    def graded(self) -> int:
        """Number of graded targets."""
        return sum(1 for r in self.rows if r.target.graded)

    def reach(self, key: str) -> dict[str, float]:
        """How far a target is from reach, to first order: the smallest parameter change that would close it.

        With ``g`` the target's sensitivity row over the free coordinates and
        ``r`` its residual, the least change (in the coordinates' logarithms)
        that brings the residual to the tolerance, ``|r| - 1``, along ``-g``
        is ``(|r| - 1)/|g|``; ``factor = exp`` of it is the factor by which
        the parameters would have to change together. Returns ``residual``,
        ``gradient_norm``, ``log_change`` and ``factor`` (0 and 1 when within).
        """
        row = next((r for r in self.rows if r.target.key == key), None)
        if row is None:
            raise InputError(f"no target {key!r}; targets: {', '.join(r.target.key for r in self.rows)}")
        res = row.target.residual(row.reproduced)
        g = np.array([self.sensitivity[key][c] for c in self.free])
        gn = float(np.linalg.norm(g))
        need = max(abs(res) - 1.0, 0.0)
        change = need / gn if gn > 0 else math.inf
        return {"residual": float(res), "gradient_norm": gn, "log_change": float(change),
                "factor": float(math.exp(change)) if change < 700 else math.inf}

    def table(self) -> str:
        """The residual table as text: published, reproduced, deviation, tolerance, within."""
        lines = [f"{'target':<22} {'published':>17} {'reproduced':>11} {'deviation':>9} {'tol':>5}  within"]
        for r in self.rows:
            t = r.target
            mark = ("yes" if r.within else "NO") + ("" if t.calibrate else " (not calibrated)") + (
                "" if t.graded else " (extra)")
            lines.append(f"{t.key:<22} {t.published_text:>17} {r.reproduced:>11.5g} {100 * r.deviation:>8.2f}% "
                         f"{100 * t.tolerance:>4.0f}%  {mark}")
        return "\n".join(lines)

    def summary(self) -> str:
        head = (f"calibration of the twin by indirect inference: {len(self.free)} parameters, "
                f"{sum(1 for r in self.rows if r.target.calibrate)} calibrated targets; cost {self.cost_start:.4g} -> "
                f"{self.cost:.4g}; {self.nfev} twin evaluations, {self.elapsed:.1f} s; {self.message}")
        vals = "\n".join(f"  {n:<22} {self.start_values[n]:>12.6g} -> {self.values[n]:>12.6g} {COORDINATES[n].unit}"
                         for n in self.free)
        tail = f"{self.within} of {self.graded} graded targets within their tolerance"
        return "\n".join([head, vals, self.table(), tail] + [f"warning: {w}" for w in self.warnings])

    def __str__(self) -> str:
        return self.summary()

    def provenance(self, start_provenance: Mapping[str, str] | None = None) -> dict[str, str]:
        """Where each value of :attr:`truth` came from: the calibration, the paper, an assumption."""
        prov = {**PROVENANCE_PAPER, **(start_provenance or {})}
        for n in self.free:
            if n == "belt.b2_share":
                prov["belt.b2_over_I2"] = "calibration (as the share belt.b2_share of p2 rho)"
            else:
                prov[n] = "calibration"
        prov["belt.k_over_gamma"] = "derived: the belt's rigid limit is the lumped p2 rho, p3 rho"
        prov["belt.kTbeta_over_Rgamma"] = "derived: the belt's rigid limit is the lumped p2 rho, p3 rho"
        return dict(sorted(prov.items()))

    def to_dict(self) -> dict[str, Any]:
        """The calibration record (JSON-ready): settings, values, residual table, sensitivity, outcome."""
        return {
            "method": "indirect inference: least squares of the deviations from the published numbers in units of "
                      "their tolerances, over the twin's structural parameters on a log scale "
                      "(scipy.optimize.least_squares, trust-region reflective, forward differences of 2 %)",
            "settings": self.settings,
            "free": list(self.free),
            "bounds": {n: [COORDINATES[n].low, COORDINATES[n].high] for n in self.free},
            "start": {n: self.start_values[n] for n in self.free},
            "values": {n: self.values[n] for n in self.free},
            "residuals": [r.to_dict() for r in self.rows],
            "within": f"{self.within} of {self.graded} graded targets",
            "cost_start": self.cost_start,
            "cost": self.cost,
            "success": bool(self.success),
            "message": self.message,
            "nfev": int(self.nfev),
            "elapsed_s": round(self.elapsed, 1),
            "sensitivity": {k: {c: round(v, 4) for c, v in row.items()} for k, row in self.sensitivity.items()},
            "singular_values": [float(s) for s in self.singular_values],
            "reach": {r.target.key: self.reach(r.target.key) for r in self.rows if not r.within},
            "warnings": list(self.warnings),
        }

    def write(self, path: str | os.PathLike, *, force: bool = False,
              start_provenance: Mapping[str, str] | None = None, notes: Sequence[str] = ()) -> Path:
        """Write the calibrated truth as a truth file with its record (``provenance``, ``calibration``).

        The file is a valid ``--truth`` file (:meth:`RigTruth.from_json`);
        refuses to overwrite unless ``force``.
        """
        p = prepare_output_file(path, force=force)
        doc = {**self.truth.to_dict(), "provenance": self.provenance(start_provenance),
               "calibration": self.to_dict(), "notes": list(notes)}
        text = json.dumps(jsonable(doc), indent=1) + "\n"
        return atomic_write(p, lambda tmp: tmp.write_text(text), force=force)


# --------------------------------------------------------------------------
# the residual model
# --------------------------------------------------------------------------
class TwinResiduals:
    """The calibration's residual model: the calibrated targets' deviations in units of their tolerances.

    Every evaluation runs the twin's experiments and the paper's procedures
    (:func:`twin_statistics`) for a truth with the coordinates' values; the
    results are kept, so that the Jacobian (forward differences of
    :data:`STEP` on the log scale, :func:`iwp.ident.jacobian.forward_difference_jacobian`)
    and the sensitivity table reuse them.
    """

    #: the Jacobian is taken by forward differences of this step of the log coordinates
    differences = STEP

    def __init__(self, start: RigTruth, targets: Sequence[PaperTarget], free: tuple[str, ...], *, seed: int,
                 overrides, progress):
        self.start, self.targets, self.free = start, list(targets), free
        self.fitted = [t for t in self.targets if t.calibrate]
        self.seed, self.overrides, self.progress = seed, overrides, progress
        self.nfev = 0
        self._cache: dict[tuple, dict[str, float] | None] = {}

    @property
    def n_rows(self) -> int:
        return len(self.fitted)

    def row_blocks(self) -> np.ndarray:
        return np.zeros(self.n_rows, dtype=np.int64)

    def row_used(self) -> np.ndarray:
        return np.ones(self.n_rows, dtype=bool)

    def statistics(self, values: Mapping[str, float]) -> dict[str, float] | None:
        """The twin's statistics for the coordinates' ``values`` (None where the twin fails)."""
        # to 12 digits: the same point reached through log and exp is one evaluation
        key = tuple(sorted((k, float(f"{float(v):.12g}")) for k, v in values.items()))
        if key not in self._cache:
            self.nfev += 1
            try:
                truth = truth_with(self.start, dict(values))
                self._cache[key] = twin_statistics(truth, self.targets, seed=self.seed, overrides=self.overrides)
            except IwpError as exc:  # an unphysical corner of the box: a failed identification or simulation
                self._cache[key] = None
                if self.progress is not None:
                    self.progress(f"evaluation {self.nfev} failed: {exc}")
        return self._cache[key]

    def evaluate(self, values: Mapping[str, float], wrt: Sequence[str] = ()) -> SimpleNamespace:
        s = self.statistics({n: values[n] for n in self.free})
        if s is None:
            r = np.full(self.n_rows, FAILED)
        else:
            r = np.array([t.residual(s[t.statistic]) for t in self.fitted])
            r = np.where(np.isfinite(r), r, FAILED)
            if self.progress is not None:
                self.progress(f"evaluation {self.nfev}: cost {0.5 * float(r @ r):.5g}")
        return SimpleNamespace(r=r, J=None, values=dict(values))

    def sensitivity(self, values: Mapping[str, float], extra: Sequence[str] = ()) -> dict[str, dict[str, float]]:
        """``[target][coordinate]``: change of every target's residual per unit change of the coordinate's logarithm."""
        names = tuple(self.free) + tuple(extra)
        at = {**dict(values), **truth_values(self.start, extra)} if extra else dict(values)
        z = np.log([at[n] for n in names])
        hi = np.log([COORDINATES[n].high for n in names])

        def residuals(zz: np.ndarray) -> np.ndarray:
            s = self.statistics(dict(zip(names, np.exp(zz).tolist())))
            if s is None:
                return np.full(len(self.targets), math.nan)
            return np.array([t.residual(s[t.statistic]) for t in self.targets])

        J = forward_difference_jacobian(residuals, z, STEP, upper=hi)
        return {t.key: {n: float(J[i, j]) for j, n in enumerate(names)} for i, t in enumerate(self.targets)}


# --------------------------------------------------------------------------
# calibrate
# --------------------------------------------------------------------------
def calibrate(
    targets: Sequence[PaperTarget] | str | os.PathLike | None = None,
    *,
    start: RigTruth | None = None,
    free: Sequence[str] = DEFAULT_FREE,
    seed: int = 0,
    overrides: Mapping[str, Mapping[str, Any]] | None = None,
    options: SolverOptions = CALIBRATION_OPTIONS,
    progress=None,
    warn: bool = True,
) -> CalibrationResult:
    """Calibrate the twin's structural parameters so that the paper's procedures return the paper's numbers.

    Parameters
    ----------
    targets : list of PaperTarget, or path, optional
        The numbers to reproduce (default: the paper's,
        :func:`iwp.calibration.targets.load_targets`); those with ``calibrate``
        false are reported, not fitted.
    start : RigTruth, optional
        Starting point (default :func:`iwp.rig.default_truth`); its
        coordinates that are not free keep their values. Must have a belt.
    free : sequence of str
        The coordinates varied (:data:`COORDINATES`; default
        :data:`DEFAULT_FREE`).
    seed : int
        Noise seed of every evaluation (common random numbers).
    overrides : dict, optional
        Options of the experiments per name (e.g. shorter runs for tests);
        default the paper's settings.
    options : SolverOptions
        The optimiser's ``max_nfev`` (most iterations, each one twin
        evaluation and a Jacobian ``len(free)`` more; default 40) and ``tol``
        (``ftol``, ``xtol``, ``gtol``; default 1e-3). The sensitivity to
        coordinates that are not free (e.g. ``noise_std``, to show that the
        targets hardly depend on it) is :meth:`TwinResiduals.sensitivity`.
    progress : callable, optional
        Called with a one-line message after every twin evaluation.
    warn : bool
        Also issue the warnings with :func:`warnings.warn`.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    InputError
        Unknown coordinates, no calibrated target, a start without a belt, a
        start outside the bounds that cannot be clipped.

    Examples
    --------
    The smallest calibration: the twin with its dead zone's ``v+`` set to 28 reads 34.3 on the static curve;
    calibrating ``v+`` alone on shortened experiments brings the reading back to the paper's 31:

    >>> from iwp.calibration import calibrate, load_targets, truth_with
    >>> from iwp.ident import SolverOptions
    >>> from iwp.rig import default_truth
    >>> short = {"static-curve": {"step": 20.0, "duration": 2.0},
    ...          "static-curve-compensated": {"step": 20.0, "duration": 2.0},
    ...          "motor-disk-chirp": {"duration": 5.0}, "full-chirp": {"duration": 5.0},
    ...          "free-pendulum": {"duration": 3.0}, "closed-loop": {"duration": 3.0}}
    >>> targets = [t for t in load_targets() if t.key in ("v_dz_pos", "v_dz_neg")]
    >>> start = truth_with(default_truth(), {"lumped.v_dz_pos": 28.0})
    >>> res = calibrate(targets, start=start, free=["lumped.v_dz_pos"], overrides=short,
    ...                 options=SolverOptions(tol=1e-3, max_nfev=4), warn=False)
    >>> res.success, round(res.values["lumped.v_dz_pos"], 2)  # the truth's v+ [input units]
    (True, 24.75)
    >>> [round(r.reproduced, 2) for r in res.rows_start], [round(r.reproduced, 2) for r in res.rows]
    ([34.26, 30.98], [31.0, 30.98])
    """
    t0 = time.perf_counter()
    if targets is None or isinstance(targets, (str, os.PathLike)):
        target_file = "paper_targets.json (shipped)" if targets is None else str(targets)
        targets = load_targets(targets)
    else:
        target_file = "given"
        targets = list(targets)
    if start is None:
        start = default_truth()
    if not isinstance(start, RigTruth):
        raise InputError(f"start must be a RigTruth, got {type(start).__name__}")
    free = _check_names(free, "free")
    if not free:
        raise InputError("free is empty: give at least one parameter to calibrate")
    fitted = [t for t in targets if t.calibrate]
    if not fitted:
        raise InputError("no target has calibrate = true")
    if options.max_nfev is None:
        raise InputError("options.max_nfev must be given: every iteration runs the twin's experiments")
    twin = TwinResiduals(start, targets, free, seed=seed, overrides=overrides, progress=progress)
    params = Parameters(Parameter(n, v, min=COORDINATES[n].low, max=COORDINATES[n].high, log=True,
                                  unit=COORDINATES[n].unit) for n, v in truth_values(start, free).items())
    if twin.statistics(params.values()) is None:
        raise InputError("the twin's experiments or the paper's procedures fail at the start point; give another "
                         "start truth")
    fit = FitProblem(params, twin, statistics=False).solve(options)
    values = {n: fit.parameters[n].value for n in free}
    truth = truth_with(start, values)
    stats_opt = twin.statistics(values)
    if stats_opt is None:  # the optimiser returns the best point it evaluated, which did not fail
        raise IwpError("the calibration ended on a point where the twin fails")
    sens = twin.sensitivity(values)
    Jfit = np.array([[sens[t.key][n] for n in free] for t in twin.fitted])
    sv = np.linalg.svd(np.nan_to_num(Jfit), compute_uv=False)
    rows = compare_targets(targets, stats_opt)
    rows_start = compare_targets(targets, twin.statistics(params.values()))
    warns = list(fit.warnings)
    for r in rows:
        if not r.within:
            warns.append(f"target {r.target.key} ({r.target.reference}): reproduced {r.reproduced:.5g} against "
                         f"{r.target.published_text}, {100 * r.deviation:+.1f} % (tolerance "
                         f"{100 * r.target.tolerance:.0f} %)" + ("" if r.target.calibrate else "; not calibrated"))
    if warn:
        for w in warns:
            _warnings.warn(w, stacklevel=2)
    return CalibrationResult(
        truth=truth, start=start, free=free, values=values, start_values=truth_values(start, free),
        rows=rows, rows_start=rows_start, sensitivity=sens, singular_values=sv, cost=fit.cost,
        cost_start=fit.cost_start, success=fit.success, message=fit.message, nfev=twin.nfev,
        elapsed=time.perf_counter() - t0, warnings=warns,
        settings={"seed": int(seed), "overrides": {k: dict(v) for k, v in (overrides or {}).items()},
                  "targets": target_file, "max_nfev": int(options.max_nfev), "tol": float(options.tol)},
    )
