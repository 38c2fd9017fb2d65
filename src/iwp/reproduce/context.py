"""The state a reproduction run carries from step to step, and what it records."""

from __future__ import annotations

import dataclasses
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

from ..errors import SimulationError
from ..files import jsonable
from ..ident.metrics import fit_percent
from ..ident.validation import UninformativeValidation, ValidationOptions, validate
from ..report import save_figure
from ..rig import write_result
from .paper import PAPER

_ALL_EXPERIMENTS = ("static-curve", "static-curve-compensated", "motor-disk-chirp", "sine-60", "sine-40",
                    "sine-20", "free-pendulum", "full-chirp", "closed-loop")

_QUICK_SETTINGS: dict[str, dict[str, float]] = {
    "static-curve": {"step": 5.0, "duration": 2.0},
    "static-curve-compensated": {"step": 4.0, "duration": 2.0},
    "motor-disk-chirp": {"duration": 60.0},
    "sine-60": {"duration": 8.0},
    "sine-40": {"duration": 8.0},
    "sine-20": {"duration": 8.0},
    "free-pendulum": {"duration": 20.0},
    "full-chirp": {"duration": 90.0},
    "closed-loop": {"duration": 30.0},
}

def experiment_settings(quick: bool = False) -> dict[str, dict[str, float]]:
    """Return the overrides of :meth:`iwp.rig.VirtualRig.run` per experiment (shorter runs for ``quick``).

    Examples
    --------
    >>> from iwp.reproduce import experiment_settings
    >>> full = experiment_settings()
    >>> list(full)[:4], full["full-chirp"]  # the paper's settings: no overrides
    (['static-curve', 'static-curve-compensated', 'motor-disk-chirp', 'sine-60'], {})
    >>> quick = experiment_settings(quick=True)
    >>> quick["full-chirp"], quick["static-curve"]  # [s], [input units]
    ({'duration': 90.0}, {'step': 5.0, 'duration': 2.0})
    """
    return {name: dict(_QUICK_SETTINGS[name]) if quick else {} for name in _ALL_EXPERIMENTS}


def log_command(name: str, *, quick: bool = False, seed: int = 0) -> str:
    """The command that writes the log of experiment ``name`` as a reproduction runs it (same rig, seed, options).

    Parameters
    ----------
    name : str
        An experiment of the reproduction.
    quick : bool, default False
        The reduced run's shorter experiment.
    seed : int, default 0
        The rig's noise seed.

    Returns
    -------
    str
        ``iwp rig run NAME --seed S [--duration D] [--step X] --out NAME.csv``.

    Examples
    --------
    >>> from iwp.reproduce import log_command
    >>> log_command("sine-60")
    'iwp rig run sine-60 --seed 0 --out sine-60.csv'
    >>> log_command("static-curve", quick=True, seed=3)  # the reduced run's static curve
    'iwp rig run static-curve --seed 3 --step 5 --duration 2 --out static-curve.csv'
    """
    flags = "".join(f" --{k} {v:g}" for k, v in experiment_settings(quick)[name].items())
    return f"iwp rig run {name} --seed {seed}{flags} --out {name}.csv"


# --------------------------------------------------------------------------
# records
# --------------------------------------------------------------------------
@dataclass
class StepRecord:
    """What happened to one step."""

    name: str
    title: str
    reference: str
    status: str = "pending"  # pending | ok | failed | skipped
    seconds: float = 0.0  # the step's own work [s], compilation excluded
    message: str = ""
    detail: str = ""  # traceback of a failure
    compile_seconds: float = 0.0  # numba compiling kernels on their first use during the step [s]

    def to_dict(self) -> dict:
        return {"name": self.name, "title": self.title, "reference": self.reference, "status": self.status,
                "seconds": round(self.seconds, 3), "compile_seconds": round(self.compile_seconds, 3),
                "message": self.message}


@dataclass
class FigureRecord:
    """A figure written to ``DIR/figures``."""

    name: str
    title: str
    caption: str
    step: str
    svg: bytes
    files: list[Path]
    section: str = ""


@dataclass
class FitRecord:
    """One comparison of a simulation with a log."""

    figure: str
    experiment: str
    model: str
    params: str
    signal: str
    fit: float
    rms: float
    note: str = ""

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


@dataclass
class ProgressEvent:
    """A progress report: ``kind`` is ``start``, ``done``, ``failed``, ``skipped`` or ``info``."""

    kind: str
    step: str
    index: int
    total: int
    title: str = ""
    message: str = ""
    seconds: float = 0.0


@dataclass
class ReproduceResult:
    """The state and outcome of a reproduction run (also the context the steps share).

    Attributes
    ----------
    out : Path
        Output folder.
    quick : bool
    seed : int
    truth : RigTruth
    steps : list of StepRecord
    data : dict
        Experiment logs by name (ExperimentData or StaticCurve).
    ident : dict
        Identification results by set-up name.
    params : dict
        Parameter sets by name (``truth``, ``table1``, ``least-squares``,
        ``refined``, ``motor-disk``, ``coulomb``, ``full-setup``).
    numbers : dict
        The numbers behind the statements.
    fits : list of FitRecord
    figures : list of FigureRecord
    statements : list of iwp.report.Statement
    notes : list of str
    files : list of Path
        Every file written.
    elapsed : float
        Wall time of the run [s].
    keep_logs : bool
        Write every experiment's log to ``DIR/data/NAME.csv`` (the logs of a full run are about 20 MB; each is
        written again, bit for bit, by the command :func:`log_command` gives).
    """

    out: Path
    quick: bool = False
    seed: int = 0
    truth: Any = None
    steps: list[StepRecord] = field(default_factory=list)
    data: dict = field(default_factory=dict)
    ident: dict = field(default_factory=dict)
    params: dict = field(default_factory=dict)
    numbers: dict = field(default_factory=dict)
    fits: list[FitRecord] = field(default_factory=list)
    figures: list[FigureRecord] = field(default_factory=list)
    statements: list = field(default_factory=list)
    notes: list[str] = field(default_factory=list)
    files: list[Path] = field(default_factory=list)
    elapsed: float = 0.0
    keep_logs: bool = False
    extra: dict = field(default_factory=dict)
    _rig: Any = None
    _progress: Callable[[ProgressEvent], None] | None = None
    _current: str = ""

    # ------------------------------------------------------------------
    @property
    def ok(self) -> bool:
        """True if every step completed."""
        return all(s.status == "ok" for s in self.steps)

    @property
    def failed_steps(self) -> list[StepRecord]:
        return [s for s in self.steps if s.status == "failed"]

    @property
    def report_path(self) -> Path:
        return self.out / "report.html"

    def step(self, name: str) -> StepRecord:
        return next(s for s in self.steps if s.name == name)

    def statement(self, key: str):
        return next(s for s in self.statements if s.key == key)

    @property
    def restart_time(self) -> float:
        """The restart time of figure 9(b): 200 s, or two thirds of a shortened chirp."""
        d = self.data.get("full-chirp")
        dur = float(d.t[-1]) if d is not None else 300.0
        return PAPER["restart_time"] if dur > 250.0 else round(2.0 * dur / 3.0, 3)

    def info(self, message: str) -> None:
        """Report progress within the current step."""
        if self._progress is not None:
            self._progress(ProgressEvent("info", self._current, 0, 0, message=message))

    # ------------------------------------------------------------------
    def experiment(self, name: str):
        """Run one experiment on the rig (once); with ``keep_logs`` write its log to ``DIR/data/NAME.csv``."""
        if name not in self.data:
            overrides = experiment_settings(self.quick)[name]
            log = self._rig.run(name, **overrides)
            if self.keep_logs:
                path = self.out / "data" / f"{name}.csv"
                path.parent.mkdir(parents=True, exist_ok=True)
                write_result(log, path, force=True)
                self.files.append(path)
            self.data[name] = log
        return self.data[name]

    def figure(self, name: str, fig, *, title: str, caption: str, section: str = "") -> FigureRecord:
        """Write ``fig`` as ``DIR/figures/NAME.svg`` and keep it for the page."""
        svg, files = save_figure(fig, self.out, name)
        self.files.extend(files)
        rec = FigureRecord(name, title, caption, self._current, svg, files, section or self._current)
        self.figures = [f for f in self.figures if f.name != name] + [rec]
        return rec

    def add_fit(self, figure: str, experiment: str, model: str, params: str, signal: str, measured, simulated,
                note: str = "") -> FitRecord:
        """Record the fit and RMS error of ``simulated`` against ``measured``."""
        m = np.asarray(measured, dtype=float)
        s = np.asarray(simulated, dtype=float)
        rec = FitRecord(figure, experiment, model, params, signal, fit_of(m, s), rms_of(m - s), note)
        self.fits.append(rec)
        return rec

    def to_dict(self) -> dict:
        """Steps, fits, statements and numbers, JSON-ready."""
        return jsonable({
            "quick": self.quick,
            "seed": self.seed,
            "elapsed": round(self.elapsed, 3),
            "steps": [s.to_dict() for s in self.steps],
            "fits": [f.to_dict() for f in self.fits],
            "statements": [s.to_dict() for s in self.statements],
            "numbers": self.numbers,
            "figures": [{"name": f.name, "title": f.title, "files": [str(p.relative_to(self.out)) for p in f.files]}
                        for f in self.figures],
            "notes": self.notes,
        })


# --------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------
def fit_of(y: np.ndarray, yh: np.ndarray) -> float:
    """Fit [%] ``100 (1 - |y - yh| / |y - mean y|)`` (:func:`iwp.ident.metrics.fit_percent`)."""
    n = min(y.size, yh.size)
    return float(fit_percent(y[:n], yh[:n]))


def rms_of(e) -> float:
    """Root mean square of ``e``."""
    e = np.asarray(e, dtype=float)
    return float(np.sqrt(np.mean(e * e))) if e.size else float("nan")


def rel_diff(a: float, b: float) -> float:
    """``|a - b| / |b|``."""
    return abs(a - b) / abs(b) if b != 0 else float("inf")


def val(res, name: str) -> float:
    """A result's value of parameter ``name``."""
    return float(res.value(name))


def series(t, y, label: str | None = None):
    """A series ``(t, y[, label])`` for a figure, at full resolution (plotting draws long ones as envelopes)."""
    tt, yy = np.asarray(t, dtype=float), np.asarray(y, dtype=float)
    return (tt, yy) if label is None else (tt, yy, label)


def compare(data, params, *, model: str, signals, restart_times=(), controller=None):
    """Run :func:`iwp.ident.validation.validate` and return ``(t, measured, simulated, fit)`` as plain arrays."""
    with warnings.catch_warnings():  # the report tabulates every fit, and says when a simulation failed
        warnings.simplefilter("ignore", UninformativeValidation)
        warnings.filterwarnings("ignore", message=".*the simulation stopped", category=UserWarning)
        r = validate(data, params, model=model, signals=tuple(signals), controller=controller,
                     options=ValidationOptions(restart_times=tuple(restart_times)))
    if r.failed:
        raise SimulationError(r.failed)
    t = np.asarray(r.t, dtype=float)
    meas = {s: np.asarray(r.measured[s], dtype=float) for s in signals}
    sim = {s: np.asarray(r.simulated[s], dtype=float) for s in signals}
    return t, meas, sim, {s: float(r.fit[s]) for s in signals}

