"""``iwp report``: a user's own logs compared with a model, as one HTML page.

:func:`report_logs` (the command ``iwp report FILES... --params P.json --out
DIR``) simulates each log with the model and compares it with what was
measured.
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..data import StaticCurve, read_experiment, read_static_curve
from ..errors import DataFormatError, InputError
from ..files import check_output_dir, jsonable, staged_dir
from ..ident.metrics import fit_percent
from ..ident.validation import ValidationOptions, auto_model, held_out_q1_offset, model_input, validate
from ..models.parameters import LumpedParameters
from ..models.plant import Plant, model_info
from ..plotting.report import plot_comparisons, plot_static_curve
from ..sim.inputs import HopfController
from .folder import save_figure
from .page import FigureEntry, Report, Section, Table, fmt, write_html

__all__ = ["report_logs", "LogComparison"]


@dataclass
class LogComparison:
    """One log compared with the model: fits per signal and the figure's name."""

    file: str
    kind: str
    model: str
    fit: dict
    rms: dict
    figure: str | None
    note: str = ""


def report_logs(
    files: Sequence[str | os.PathLike],
    params,
    out: str | os.PathLike,
    *,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
    params_name: str = "",
    held_out_offset: float = 0.0,
    reads_v_as_u: bool = False,
) -> dict:
    """Compare a user's experiment logs with a model; write ``out/report.html`` and the figures.

    Each time-series log (any format :func:`iwp.data.read_experiment` reads)
    is simulated with the compensated model (9) and ``params`` from its
    first measured state: logs with an input ``u`` replay it (zero-order
    hold), logs whose metadata name the Hopf gains ``k1``, ``k2`` are
    simulated in closed loop, logs without input are a free pendulum; a log
    whose metadata say ``pendulum: locked`` is simulated with the pendulum
    clamped and compared on the disk velocity ``q4``. Static curves (CSV
    with ``v,q4`` or ``u,q4``) are drawn with the static line of the model.

    Parameters
    ----------
    files : sequence of paths
    params : LumpedParameters
    out : path
        Output folder (refused if it exists and is not empty, unless ``force``).
    force : bool
    progress : callable, optional
        Called with one line of text per log.
    params_name : str
        Where the parameters came from (shown on the page).
    held_out_offset : float
        The pendulum zero offset [rad] ``iwp fit`` took off its held-out logs
        (:attr:`~iwp.ident.logfit.LogFitResult.held_out_offset`, ``q1_offset``
        in its ``parameters.json``), taken off each log whose metadata say its
        offset is to be estimated (:func:`~iwp.ident.validation.held_out_q1_offset`);
        :func:`~iwp.ident.validation.validate`'s ``q1_offset`` is what is taken
        off one log.
    reads_v_as_u : bool
        The parameters were fitted reading a raw command ``v`` as ``u``
        (``iwp fit``): a log of ``v`` is simulated so (model (9)), not with
        the dead zone of model (6).

    Returns
    -------
    dict
        ``{"report": Path, "comparisons": [LogComparison], "figures": [Path]}``.

    Raises
    ------
    InputError, DataFormatError
        A file that cannot be read (naming it); no files.
    """
    if not files:
        raise InputError("no log files given")
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    paths = [Path(f) for f in files]
    for p in paths:
        if p.is_dir() and (p / "manifest.json").is_file() and (p / "chunks").is_dir():
            raise InputError(f"{p}: a sweep's folder (iwp sweep): iwp report compares logs with a model; the sweep's "
                             "own summary is what iwp sweep printed, its table results.csv or .parquet in it")
        if p.is_dir():
            raise InputError(f"{p}: is a folder; give log files in it (.csv, .parquet, .mat)")
        if not p.is_file():
            raise InputError(f"{p}: no such file")
    # read everything first: a bad file is reported before anything is written
    logs = []
    for p in paths:
        logs.append((p, _read_any(p, read_experiment, read_static_curve)))
    final = check_output_dir(out, force=force)
    # every file is written into a hidden sibling folder and moved into place only when all are written
    with staged_dir(final, force=force) as out_dir:
        say = progress or (lambda msg: None)
        comparisons: list[LogComparison] = []
        figures: list[FigureEntry] = []
        fig_paths: list[Path] = []
        used = set()
        for p, log in logs:
            stem = _unique(_safe_name(p.stem), used)
            if isinstance(log, StaticCurve):
                comp, fig, caption = _compare_static(p, log, params, plot_static_curve)
            else:
                log = model_input(log, "compensated", str(p)) if reads_v_as_u else log
                comp, fig, caption = _compare_series(p, log, params, plot_comparisons,
                                                     held_out_q1_offset(log, held_out_offset))
            svg, written = save_figure(fig, out_dir, stem)
            comp.figure = stem
            fig_paths += written
            figures.append(FigureEntry(stem, f"{p.name}: {comp.kind}", caption, svg,
                                       [str(w.relative_to(out_dir)) for w in written]))
            comparisons.append(comp)
            fits = ", ".join(f"{k} {fmt(v, 3)} %" for k, v in comp.fit.items())
            say(f"{p.name}: {comp.kind}, {comp.model}" + (f", fit {fits}" if fits else ""))
        rows = [[c.file, c.kind, c.model, *(
            [", ".join(f"{k}: {fmt(v, 3)} %" for k, v in c.fit.items()) or "-",
             ", ".join(f"{k}: {fmt(v, 3)}" for k, v in c.rms.items()) or "-"]), c.note] for c in comparisons]
        ptab = Table("Parameters", ["parameter", "value"],
                     [[k, v] for k, v in params.to_dict().items()] +
                     [["p2(1+rho)", params.p2_1rho], ["p3(1+rho)", params.p3_1rho]],
                     note=f"from {params_name}" if params_name else "")
        ftab = Table("Fits", ["log", "kind", "model", "fit (100 (1 - |y - y_sim| / |y - mean y|))", "RMS error",
                              "note"], rows)
        rep = Report(
            title="Model against measured logs",
            subtitle=f"{len(comparisons)} log(s) compared with the compensated model (9) of the paper"
                     + (f"; parameters: {params_name}" if params_name else ""),
            summary=[("logs", ", ".join(str(p) for p in paths)), ("parameters", params_name or "(given)")],
            sections=[Section("Parameters and fits", tables=[ptab, ftab], anchor="fits"),
                      Section("Figures", figures=figures, anchor="figures")],
        )
        write_html(rep, out_dir / "report.html", force=True)
        (out_dir / "comparison.json").write_text(json.dumps(jsonable({
            "parameters": params.to_dict(), "parameters_from": params_name,
            "logs": [c.__dict__ for c in comparisons]}), indent=2) + "\n")
    fig_paths = [final / p.relative_to(out_dir) for p in fig_paths]
    return {"report": final / "report.html", "comparisons": comparisons, "figures": fig_paths}


def _safe_name(stem: str) -> str:
    s = "".join(c if c.isalnum() or c in "-_" else "_" for c in stem)
    return s or "log"


def _unique(name: str, used: set) -> str:
    cand, i = name, 2
    while cand in used:
        cand, i = f"{name}_{i}", i + 1
    used.add(cand)
    return cand


def _read_any(p: Path, read_experiment, read_static_curve):
    """A time series, or (for a CSV with a ``q4`` column and no ``t``) a static curve."""
    if p.suffix.lower() in (".csv", ".txt"):
        with open(p, encoding="utf-8", errors="replace") as fh:
            header = next((ln for ln in fh if ln.strip() and not ln.lstrip().startswith("#")), "")
        names = [h.strip().lower() for h in header.replace(";", ",").split(",")]
        if "t" not in names and "q4" in names and ("v" in names or "u" in names):
            return read_static_curve(p)
    try:
        return read_experiment(p)
    except DataFormatError:
        raise
    except InputError as exc:
        msg = str(exc)
        raise InputError(msg if str(p) in msg else f"{p}: {msg}") from None


def _compare_static(p: Path, curve, params, plot_static_curve):
    x = np.asarray(curve.input, dtype=float)
    y = np.asarray(curve.q4, dtype=float)
    gain = params.p3 / params.p2 if params.p2 > 0 else float("nan")
    xs = np.linspace(x.min(), x.max(), 201)
    if curve.input_name == "u":
        line = gain * xs
        lab = r"model (9): $q_4 = (p_3/p_2)\,u$"
        pred = gain * x
    else:
        vp, vn = params.v_dz_pos, params.v_dz_neg
        line = gain * np.where(xs > vp, xs - vp, np.where(xs < -vn, xs + vn, 0.0))
        lab = r"model (6): dead zone $v^+$, $v^-$"
        pred = gain * np.where(x > vp, x - vp, np.where(x < -vn, x + vn, 0.0))
    res = plot_static_curve(x, y, input_name=curve.input_name, lines=[(xs, line, lab)],
                            title=f"{p.name}: static curve", label="measured")
    fit = {"q4": _fit_percent(y, pred)}
    rms = {"q4": float(np.sqrt(np.mean((y - pred) ** 2)))}
    comp = LogComparison(str(p), "static curve", "static line of the model", fit, rms, None)
    return comp, res["figure"], "Measured steady disk velocities and the model's static relation."


def _fit_percent(y, yh) -> float:
    return float(fit_percent(y, yh))


def _compare_series(p: Path, log, params, plot_comparisons, q1_offset: float):
    meta = log.metadata
    locked = meta.get("pendulum", "").strip().lower() == "locked"
    controller = None
    if "k1" in meta and "k2" in meta:
        try:
            controller = HopfController(float(meta["k1"]), float(meta["k2"]), Ts=log.Ts)
        except (ValueError, InputError):
            controller = None
    if log.input_name == "v":
        note = "raw input v: simulated with the dead zone of the parameters (model (6))"
    else:
        note = ""
    if locked:
        kind, signals = "pendulum locked", ("q4",)
    elif controller is not None:
        kind, signals = f"closed loop k1 = {controller.k1:g}, k2 = {controller.k2:g}", ("q1",)
    elif log.input_name is None:
        kind, signals = "free pendulum (no input)", ("q1",)
    else:  # the wheel's own signal: its angle, or the speed a rig logs without it
        kind, signals = f"open loop, input {log.input_name}", ("q1", "q2" if log.q2 is not None else "q4")
    if q1_offset:
        note = "; ".join(n for n in (note, f"q1 less the pendulum zero offset {q1_offset:+.4g} rad of the fit") if n)
    model, comp = _simulate_log(log, params, locked=locked, controller=controller, signals=signals,
                                q1_offset=q1_offset)
    panels = []
    for s in signals:
        t, ym, ys = comp["t"], comp["measured"][s], comp["simulated"][s]
        panels.append({"measured": (t, ym), "simulated": (t, ys, f"model ({model})"), "error": (t, ym - ys, "error"),
                       "signal": s,
                       "title": f"{p.name}: {s}", "measured_label": "measured"})
    res = plot_comparisons(panels)
    fit = {s: comp["fit"][s] for s in signals}
    rms = {s: float(np.sqrt(np.mean((comp["measured"][s] - comp["simulated"][s]) ** 2))) for s in signals}
    lc = LogComparison(str(p), kind, model, fit, rms, None, note)
    cap = (f"Measured (solid) and simulated (dashed) {', '.join(signals)}, and their difference; "
           f"the simulation starts from the measured state at t = {log.t[0]:g} s.")
    return lc, res["figure"], cap


def _simulate_log(log, params, *, locked, controller, signals, q1_offset):
    """Simulate ``log`` with :func:`iwp.ident.validation.validate`, the model chosen by ``auto_model``."""
    model = auto_model(log)
    plant = Plant(params, model=model, locked=locked and model_info(model).clampable)
    r = validate(log, plant, controller=controller, signals=tuple(signals),
                 options=ValidationOptions(q1_offset=q1_offset))
    return model, {"t": np.asarray(r.t), "measured": {s: np.asarray(r.measured[s]) for s in signals},
                   "simulated": {s: np.asarray(r.simulated[s]) for s in signals},
                   "fit": {s: float(r.fit[s]) for s in signals}}
