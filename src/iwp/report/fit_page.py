"""``iwp fit --out DIR``: the fitted model, its uncertainty and its fits, as files and one HTML page.

:func:`write_fit_report` writes into the folder (new or empty, unless
``force``; written to a hidden sibling first and moved in when complete,
so that a failure leaves no partial output):

* ``fit.json``: :meth:`iwp.ident.logfit.LogFitResult.to_dict` (parameters
  with stderr and 95 % intervals, correlations, fits per log and signal,
  warnings, the rig description);
* ``parameters.json``: the refined parameters, readable by ``--params``;
* ``report.html``: one self-contained page like ``iwp report``'s, with the
  parameter and fit tables, the warnings, the correlation matrix and, for
  every log, measured against simulated signals with the error below;
* ``figures/*.svg`` (the page embeds them).

The figures are drawn by :mod:`iwp.plotting` from series prepared here, at
full resolution (long records are drawn as envelopes with a zoom); plotting
computes nothing.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from ..files import jsonable, staged_dir
from ..ident.fit_ladder import BAND_HOLDS
from ..ident.metrics import JUDGED
from ..models.parameters import save_params
from ..models.plant import model_info
from ..plotting.report import plot_comparisons
from ..plotting.validation import plot_correlation
from ..sim.uncertainty import uncertainty_record
from .folder import save_figure
from .page import FigureEntry, Report, Section, Table, fmt, fmt_interval, write_html
from .words import intervals_in_words

__all__ = ["write_fit_report"]


def _safe(stem: str, used: set) -> str:
    s = "".join(c if c.isalnum() or c in "-_" else "_" for c in stem) or "log"
    cand, i = s, 2
    while cand in used:
        cand, i = f"{s}_{i}", i + 1
    used.add(cand)
    return cand


def _log_figure(f, out_dir: Path, name: str) -> tuple[bytes, list[Path]]:
    panels = []
    for o in f.measured:
        m = f.used[o]
        t = f.t[m]
        ym, ys = f.measured[o][m], f.simulated[o][m]
        panels.append({"measured": (t, ym), "simulated": (t, ys, "model"), "error": (t, ym - ys, "error"), "signal": o,
                       "title": f"{Path(f.source).name} ({f.role}): {o}, fit {fmt(f.fit[o], 3)} %",
                       "measured_label": "measured"})
    res = plot_comparisons(panels)  # laid out to settle its legends
    return save_figure(res["figure"], out_dir, name, laid_out=True)


def _sample_time(fits: list) -> float | None:
    """The median sample time of the first log [s] (None without one)."""
    if not fits or len(fits[0].t) < 2:
        return None
    return float(np.median(np.diff(np.asarray(fits[0].t, dtype=float))))


#: held-out logs drawn at most (the worst and the best half each); fit.json and the table hold every log
MAX_HELD_OUT_FIGURES = 4


def _shown(fits: list) -> list:
    """The held-out logs drawn: all of them, or the worst and the best fits of ``q1``."""
    if len(fits) <= MAX_HELD_OUT_FIGURES:
        return list(fits)
    def q1_fit(i: int) -> float:  # a failed simulation (NaN) counts as the worst
        v = fits[i].fit.get("q1", float("nan"))
        return v if math.isfinite(v) else -math.inf

    order = sorted(range(len(fits)), key=lambda i: (q1_fit(i), i))
    half = MAX_HELD_OUT_FIGURES // 2
    keep = set(order[:half]) | set(order[-half:])
    return [f for i, f in enumerate(fits) if i in keep]


def _parameter_table(result) -> Table:
    """The refined parameters with their uncertainty, and how the intervals were computed, in words."""
    r = result.refinement
    rows = []
    for n in r.free:
        pe = r.parameters[n]
        ls = result.least_squares.get(n)
        rows.append([n, fmt(pe.value, 6), fmt(pe.stderr, 2), fmt_interval(pe.ci95_low, pe.ci95_high, 5),
                     fmt(result.start_value(n), 5), fmt(ls, 5) if ls is not None else "-"])
    note = ("no uncertainty estimated" if r.reliability is None else r.reliability.describe()) + "; start: " \
        + result.start_method
    if r.reliability is not None:
        note += ". " + intervals_in_words(r.reliability.method, _sample_time(result.train))
    return Table("Parameters (simulation-error fit on all training logs)",
                 ["parameter", "value", "stderr", "95 % interval", "start", "least squares"], rows, note=note)


def write_fit_report(result, out: str | os.PathLike, *, force: bool = False) -> dict:
    """Write the files of a :class:`~iwp.ident.logfit.LogFitResult` into the folder ``out`` (see the module).

    Parameters
    ----------
    result : LogFitResult
        What :func:`~iwp.ident.logfit.fit_logs` returned.
    out : str or path-like
        Output folder: ``report.html``, ``fit.json``, ``parameters.json`` and ``figures/``. The files are written
        into a hidden sibling and moved into place only when all are written.
    force : bool, default False
        Allow writing into an existing folder that is not empty.

    Returns
    -------
    dict
        ``{"folder": Path, "report": Path, "json": Path, "parameters": Path, "figures": [Path]}``.

    Raises
    ------
    InputError
        ``out`` exists and is not empty, without ``force``.
    """
    out = Path(out)
    r = result.refinement
    with staged_dir(out, force=force) as tmp:
        figures: list[FigureEntry] = []
        fig_paths: list[Path] = []
        used: set = set()
        shown = _shown(result.validation)
        for f in result.train + shown:
            name = _safe(f"{f.role}_{Path(f.source).stem}", used)
            svg, written = _log_figure(f, tmp, name)
            fig_paths += [out / w.relative_to(tmp) for w in written]
            cap = ("Measured (solid) and simulated (dashed) signals and their difference; "
                   + ("training log, at the joint optimum with its estimated initial state."
                      if f.role == "train" else "held-out log, simulated from its measured initial state "
                      "without re-fitting.")
                   + (f" Glitches: {'; '.join(f.glitches)}." if f.glitches else ""))
            figures.append(FigureEntry(name, f"{Path(f.source).name} ({f.role})", cap, svg,
                                       [str(w.relative_to(tmp)) for w in written]))
        corr_fig = []
        if len(r.free) > 1:
            cres = plot_correlation(list(r.free), np.nan_to_num(r.correlation, nan=np.nan))
            svg, written = save_figure(cres["figure"], tmp, "correlation")
            fig_paths += [out / w.relative_to(tmp) for w in written]
            corr_fig.append(FigureEntry("correlation", "Correlation of the estimates",
                                        "Pairs above 0.95 in magnitude (bold) are not separated by these data.",
                                        svg, [str(w.relative_to(tmp)) for w in written]))
        ptab = _parameter_table(result)
        frows = []
        sigs = result.predicted  # the outputs fitted, and the held-out logs' judged signals
        for f in result.train + result.validation:
            role = f.role if f.kind == "free" else f"{f.role} ({f.kind})"
            frows.append([Path(f.source).name, role] + [fmt(f.fit.get(o), 4) for o in sigs]
                         + [fmt(f.rms.get(o), 3) for o in sigs] + [fmt(f.q1_offset, 3)]
                         + [fmt(100 * f.coverage[o], 3) + (" (does not hold)" if o in f.band_misses else "")
                            if o in f.coverage else "-" for o in sigs])
        ftab = Table("Fits per log and signal",
                     ["log", "role"] + [f"fit {o} [%]" for o in sigs]
                     + [f"RMS {o}" for o in sigs] + ["q1 offset [rad]"]
                     + [f"in band {o} [%]" for o in sigs], frows,
                     note="fit = 100 (1 - |y - y_sim| / |y - mean y|); replaced glitch samples left out; a held-out "
                          f"log is judged on {' and '.join(JUDGED)}, the pendulum's angle and the wheel's speed (the "
                          "wheel's angle enters no equation: its error is the integral of the speed's); in band: the "
                          "share of a held-out log's samples inside the fit's 95 % prediction band (parameters, "
                          "measured initial state and the residuals' spread); a judged signal below "
                          f"{100 * BAND_HOLDS:.0f} % inside: the band does not hold for this model (it misses what "
                          "the log shows)")
        tables = [ptab, ftab]
        if result.structures is not None:
            lad = result.structures
            sel = lad.selection
            outs = list(JUDGED)
            lrows = [[("chosen: " if i == sel.chosen else "best: " if i == sel.best else "") + o.rung.label,
                      str(o.n_params)] + [fmt(o.fit.get(k), 4) for k in outs] + [fmt(o.score, 4),
                      fmt(sel.difference[i], 3), fmt(o.bic, 6), "yes" if o.success else "no"]
                     for i, o in enumerate(lad.outcomes)]
            tables.insert(0, Table(
                f"Model structures, ranked on {lad.scored_on} ({lad.n_scored} logs)",
                ["structure", "free parameters"] + [f"fit {k} [%]" for k in outs]
                + ["score", "ln(score / best)", "BIC (training)", "converged"], lrows,
                note="score: the mean over the signals of 1 - fit/100 on each scoring log, geometric mean over the "
                     "logs; best: the lowest score; chosen: the "
                     "simplest structure whose log ratio to the best is not significantly above zero (one-sided "
                     f"t-test at 5 %, {sel.method}); BIC (Bayesian information criterion: the training misfit plus a "
                     "penalty that grows with the number of parameters) assumes white residuals and is shown for "
                     "comparison only"))
        if len(shown) < len(result.validation):
            tables[-1].note += (f"; figures are drawn for the training logs and {len(shown)} of the "
                                f"{len(result.validation)} held-out logs (the worst and the best fits of q1)")
        warn_par = [f"Warning: {w}" for w in result.warnings] or ["No warnings."]
        span = result.validation_range()
        rep = Report(
            title="Model fitted to a rig's logs and validated on held-out logs",
            subtitle=f"model {result.model} {model_info(result.model).equation}, "
                     f"outputs {', '.join(result.outputs)}",
            summary=[("rig", result.rig.name or result.rig.source if result.rig is not None else "(iwp logs)"),
                     ("training logs", ", ".join(Path(f.source).name for f in result.train)),
                     ("held-out logs", ", ".join(Path(f.source).name for f in result.validation) or "none"),
                     ("validation fit", ", ".join(
                         f"{k} mean {fmt(v, 4)} %" + (f" (from {fmt(span[k][0], 4)} to {fmt(span[k][1], 4)} %)"
                                                      if len(result.validation) > 1 else "")
                         for k, v in result.validation_fit.items())),
                     ("time", f"{result.elapsed:.3g} s")],
            sections=[Section("Parameters and fits", tables=tables, anchor="fits"),
                      Section("Warnings", paragraphs=warn_par, anchor="warnings"),
                      Section("Figures", figures=corr_fig + figures, anchor="figures")],
        )
        write_html(rep, tmp / "report.html", force=True)
        doc = result.to_dict()
        (tmp / "fit.json").write_text(json.dumps(jsonable(doc), indent=2) + "\n")
        save_params(result.params, tmp / "parameters.json", force=True,
                    extra={"model": result.model, "source": "iwp fit",
                           **({"belt": result.belt.to_dict()} if result.belt is not None else {}),
                           # what iwp validate takes off a log whose offset is to be estimated, as fit did, and
                           # how far a run's own zero strays from it (its bands)
                           **(result.held_out_zero.to_dict() if result.held_out_offset else {}),
                           **({"reads_v_as_u": True} if model_info(result.model).reads_v_as_u else {}),
                           "stderr": {n: r.parameters[n].stderr for n in r.free},
                           "covariance": uncertainty_record(r, result.held_priors)})
    return {"folder": out, "report": out / "report.html", "json": out / "fit.json",
            "parameters": out / "parameters.json", "figures": fig_paths}
