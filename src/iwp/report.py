"""Self-contained HTML reports: the reproduction of the paper and comparisons of a user's own logs.

:func:`render_html` turns a :class:`Report` (sections of text, tables,
checked statements and figures) into one HTML page that needs nothing else:
figures are embedded as base64 PNG, styles are inline, nothing is fetched
from the network. :mod:`iwp.reproduce` fills a :class:`Report` from its run;
:func:`report_logs` (the command ``iwp report FILES... --params P.json
--out DIR``) fills one from experiment logs and a parameter set: each log
is simulated with the model and compared with what was measured.

The page carries a small inline script that, once the page has loaded,
marks every image with ``data-loaded="1"`` (or ``"0"`` if it failed) and the
``<body>`` with ``data-images-loaded="N/M"``; a headless browser can check
the page through the DOM.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import json
import math
import os
import platform
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Sequence

import numpy as np

from ._util import prepare_output_file
from .errors import InputError, OutputExistsError

__all__ = [
    "Statement",
    "Table",
    "FigureEntry",
    "Section",
    "Report",
    "render_html",
    "write_html",
    "prepare_output_dir",
    "save_figure",
    "fmt",
    "report_logs",
    "LogComparison",
]


# --------------------------------------------------------------------------
# content
# --------------------------------------------------------------------------
@dataclass
class Statement:
    """One of the paper's statements, checked with the numbers of this run.

    Attributes
    ----------
    key : str
        Short identifier (``"dead-zone"``).
    claim : str
        What the paper says (quoted or paraphrased).
    reference : str
        Where in the paper.
    found : str
        What this run found, with the numbers.
    criterion : str
        The test applied to decide ``passed``.
    passed : bool or None
        ``None``: not checked (a step it needs failed); see ``found``.
    values : dict
        The numbers behind ``found`` (JSON-ready).
    """

    key: str
    claim: str
    reference: str
    found: str = ""
    criterion: str = ""
    passed: bool | None = None
    values: dict = field(default_factory=dict)

    @property
    def verdict(self) -> str:
        return "not checked" if self.passed is None else ("pass" if self.passed else "fail")

    def to_dict(self) -> dict:
        return {"key": self.key, "claim": self.claim, "reference": self.reference, "found": self.found,
                "criterion": self.criterion, "verdict": self.verdict, "values": _jsonable(self.values)}


@dataclass
class Table:
    """A table: ``columns`` and ``rows`` of already formatted cells (str), with an optional note."""

    title: str
    columns: Sequence[str]
    rows: Sequence[Sequence[Any]]
    note: str = ""


@dataclass
class FigureEntry:
    """An embedded figure: the PNG bytes, and the names of the files written next to the page."""

    name: str
    title: str
    caption: str
    png: bytes
    files: Sequence[str] = ()


@dataclass
class Section:
    """A section of the page: a heading, paragraphs, tables and figures, in that order."""

    title: str
    paragraphs: Sequence[str] = ()
    tables: Sequence[Table] = ()
    figures: Sequence[FigureEntry] = ()
    anchor: str = ""


@dataclass
class Report:
    """Everything the page shows."""

    title: str
    subtitle: str = ""
    summary: Sequence[tuple[str, str]] = ()
    statements: Sequence[Statement] = ()
    sections: Sequence[Section] = ()
    footer: str = ""


# --------------------------------------------------------------------------
# formatting
# --------------------------------------------------------------------------
def fmt(x: Any, digits: int = 4) -> str:
    """A number for a table: ``digits`` significant digits, ``-`` for None/NaN."""
    if x is None:
        return "-"
    if isinstance(x, str):
        return x
    try:
        v = float(x)
    except (TypeError, ValueError):
        return str(x)
    if not math.isfinite(v):
        return "-" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    if v == 0:
        return "0"
    if abs(v) >= 1e5 or abs(v) < 1e-4:
        return f"{v:.{digits - 1}e}"
    return f"{v:.{digits}g}"


def _jsonable(obj: Any) -> Any:
    """Turn numpy scalars/arrays and NaN into JSON-ready values (NaN, inf -> None)."""
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return [_jsonable(v) for v in obj.tolist()]
    if isinstance(obj, (bool, np.bool_)):
        return bool(obj)
    if isinstance(obj, (int, np.integer)):
        return int(obj)
    if isinstance(obj, (float, np.floating)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if obj is None or isinstance(obj, str):
        return obj
    return str(obj)


_CSS = """
body{font-family:-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:0 auto;max-width:1100px;padding:1em 2em;
color:#222;background:#fff;line-height:1.4}
h1{font-size:1.6em;margin-bottom:0.2em}h2{border-bottom:2px solid #ddd;padding-bottom:0.2em;margin-top:1.6em}
h3{margin-bottom:0.3em}.sub{color:#555;margin-top:0}
table{border-collapse:collapse;margin:0.6em 0 1em 0;font-size:0.88em}
th,td{border:1px solid #ccc;padding:0.25em 0.55em;text-align:left;vertical-align:top}
th{background:#f0f3f7}td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.pass{background:#e2f5e2;color:#145214;font-weight:bold}.fail{background:#fbe3e3;color:#8a1010;font-weight:bold}
.nc{background:#f3f3f3;color:#666;font-weight:bold}
figure{margin:1em 0 2em 0;padding:0}figure img{max-width:100%;border:1px solid #eee}
figcaption{font-size:0.9em;color:#333;margin-top:0.3em}.note{font-size:0.88em;color:#444}
.summary td:first-child{font-weight:bold}code{background:#f4f4f4;padding:0 0.2em}
nav a{margin-right:0.8em}
"""

_SCRIPT = """
window.addEventListener('load', function () {
  var imgs = document.getElementsByTagName('img'); var ok = 0;
  for (var i = 0; i < imgs.length; i++) {
    var good = imgs[i].complete && imgs[i].naturalWidth > 0;
    imgs[i].setAttribute('data-loaded', good ? '1' : '0'); if (good) { ok++; }
  }
  document.body.setAttribute('data-images-loaded', ok + '/' + imgs.length);
});
"""


def _e(text: Any) -> str:
    return html.escape(str(text), quote=True)


def _cell(value: Any) -> str:
    text = value if isinstance(value, str) else fmt(value)
    num = not isinstance(value, str) or _looks_numeric(text)
    return f'<td class="num">{_e(text)}</td>' if num else f"<td>{_e(text)}</td>"


def _looks_numeric(text: str) -> bool:
    t = text.strip().replace("\u00b1", "").replace(" ", "").replace("%", "")
    if t in ("-", ""):
        return True
    try:
        float(t)
        return True
    except ValueError:
        return False


def _table_html(t: Table) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in t.columns)
    body = "".join("<tr>" + "".join(_cell(c) for c in row) + "</tr>" for row in t.rows)
    note = f'<p class="note">{_e(t.note)}</p>' if t.note else ""
    return f"<h3>{_e(t.title)}</h3><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{note}"


def _figure_html(f: FigureEntry) -> str:
    data = base64.b64encode(f.png).decode("ascii")
    files = ""
    if f.files:
        files = " Files: " + ", ".join(f"<code>{_e(x)}</code>" for x in f.files) + "."
    return (f'<figure id="fig-{_e(f.name)}"><h3>{_e(f.title)}</h3>'
            f'<img alt="{_e(f.title)}" src="data:image/png;base64,{data}">'
            f"<figcaption>{_e(f.caption)}{files}</figcaption></figure>")


def _statements_html(statements: Sequence[Statement]) -> str:
    rows = []
    for i, s in enumerate(statements, 1):
        cls = {"pass": "pass", "fail": "fail"}.get(s.verdict, "nc")
        rows.append(
            f"<tr><td class=\"num\">{i}</td><td>{_e(s.claim)}<br><span class=\"note\">{_e(s.reference)}</span></td>"
            f"<td>{_e(s.found)}</td><td class=\"note\">{_e(s.criterion)}</td>"
            f'<td class="{cls}">{_e(s.verdict.upper())}</td></tr>')
    return ("<table><thead><tr><th>#</th><th>the paper says</th><th>found here</th><th>criterion</th>"
            "<th>verdict</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>")


def render_html(report: Report) -> str:
    """The page as one self-contained HTML string (no external resources)."""
    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        f"<title>{_e(report.title)}</title><style>{_CSS}</style>",
        f"<script>{_SCRIPT}</script></head><body>",
        f"<h1>{_e(report.title)}</h1>",
    ]
    if report.subtitle:
        parts.append(f'<p class="sub">{_e(report.subtitle)}</p>')
    nav = []
    if report.statements:
        nav.append('<a href="#statements">statements</a>')
    for i, s in enumerate(report.sections):
        nav.append(f'<a href="#{_e(s.anchor or f"s{i}")}">{_e(s.title)}</a>')
    if nav:
        parts.append("<nav>" + "".join(nav) + "</nav>")
    if report.summary:
        rows = "".join(f"<tr><td>{_e(k)}</td><td>{_e(v)}</td></tr>" for k, v in report.summary)
        parts.append(f'<table class="summary"><tbody>{rows}</tbody></table>')
    if report.statements:
        parts.append('<h2 id="statements">The paper\'s statements, checked</h2>')
        parts.append(_statements_html(report.statements))
    for i, s in enumerate(report.sections):
        parts.append(f'<h2 id="{_e(s.anchor or f"s{i}")}">{_e(s.title)}</h2>')
        parts.extend(f"<p>{_e(p)}</p>" for p in s.paragraphs)
        parts.extend(_table_html(t) for t in s.tables)
        parts.extend(_figure_html(f) for f in s.figures)
    footer = report.footer or (f"Generated by iwp on {_dt.datetime.now().isoformat(timespec='seconds')} "
                               f"(Python {platform.python_version()}, {platform.system()}).")
    parts.append(f'<hr><p class="note">{_e(footer)}</p></body></html>')
    return "\n".join(parts) + "\n"


def write_html(report: Report, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Render ``report`` and write it to ``path`` (refuses an existing file unless ``force``)."""
    p = prepare_output_file(path, force=force)
    p.write_text(render_html(report), encoding="utf-8")
    return p


# --------------------------------------------------------------------------
# output folder and figures
# --------------------------------------------------------------------------
def prepare_output_dir(path: str | os.PathLike, *, force: bool = False) -> Path:
    """Create the output folder; refuse one that exists and is not empty unless ``force``.

    Raises
    ------
    OutputExistsError
        The folder exists and holds files, and ``force`` is false.
    InputError
        ``path`` is an existing file.
    """
    p = Path(path)
    if p.exists() and not p.is_dir():
        raise InputError(f"{p}: exists and is not a folder; give a folder for --out")
    if p.is_dir() and any(p.iterdir()) and not force:
        raise OutputExistsError(f"{p}: folder exists and is not empty; pass --force to write into it")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"{p}: cannot create the output folder ({exc.strerror or exc})") from None
    return p


def save_figure(fig, out_dir: str | os.PathLike, name: str, *, dpi: int = 110) -> tuple[bytes, list[Path]]:
    """Save ``fig`` as ``out_dir/figures/NAME.png`` and ``.svg``; close it; return the PNG bytes and the paths."""
    import matplotlib.pyplot as plt

    d = Path(out_dir) / "figures"
    d.mkdir(parents=True, exist_ok=True)
    png = d / f"{name}.png"
    svg = d / f"{name}.svg"
    try:
        fig.savefig(png, dpi=dpi)
        if fig.get_layout_engine() is not None:
            fig.set_layout_engine("none")  # keep the layout just computed: the SVG is drawn identically, faster
        fig.savefig(svg)
    finally:
        plt.close(fig)
    return png.read_bytes(), [png, svg]


# --------------------------------------------------------------------------
# iwp report: a user's own logs against a parameter set
# --------------------------------------------------------------------------
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


def _decimate(t: np.ndarray, y: np.ndarray, n_max: int = 4000) -> tuple[np.ndarray, np.ndarray]:
    from .reproduce import decimate

    return decimate(t, y, n_max)


def report_logs(
    files: Sequence[str | os.PathLike],
    params,
    out: str | os.PathLike,
    *,
    force: bool = False,
    progress: Callable[[str], None] | None = None,
    params_name: str = "",
) -> dict:
    """Compare a user's experiment logs with a model; write ``out/report.html`` and the figures.

    Each time-series log (any format :func:`iwp.io.read_experiment` reads)
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

    Returns
    -------
    dict
        ``{"report": Path, "comparisons": [LogComparison], "figures": [Path]}``.

    Raises
    ------
    InputError, DataFormatError
        A file that cannot be read (naming it); no files.
    """
    from .io import StaticCurve, read_experiment, read_static_curve
    from .params import LumpedParameters
    from .plotting_report import plot_comparisons, plot_static_curve

    if not files:
        raise InputError("no log files given")
    if not isinstance(params, LumpedParameters):
        raise InputError(f"params must be LumpedParameters, got {type(params).__name__}")
    paths = [Path(f) for f in files]
    for p in paths:
        if not p.is_file():
            raise InputError(f"{p}: no such file")
    # read everything first: a bad file is reported before anything is written
    logs = []
    for p in paths:
        logs.append((p, _read_any(p, read_experiment, read_static_curve)))
    out_dir = prepare_output_dir(out, force=force)
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
            comp, fig, caption = _compare_series(p, log, params, plot_comparisons)
        png, written = save_figure(fig, out_dir, stem)
        comp.figure = stem
        fig_paths += written
        figures.append(FigureEntry(stem, f"{p.name}: {comp.kind}", caption, png,
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
    report = write_html(rep, out_dir / "report.html", force=True)
    (out_dir / "comparison.json").write_text(json.dumps(_jsonable({
        "parameters": params.to_dict(), "parameters_from": params_name,
        "logs": [c.__dict__ for c in comparisons]}), indent=2) + "\n")
    return {"report": report, "comparisons": comparisons, "figures": fig_paths}


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
    from .errors import DataFormatError

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
    from .validate import fit_percent

    return float(fit_percent(y, yh))


def _compare_series(p: Path, log, params, plot_comparisons):
    from .inputs import HopfController

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
    else:
        kind, signals = f"open loop, input {log.input_name}", ("q1", "q2")
    model, comp = _simulate_log(log, params, locked=locked, controller=controller, signals=signals)
    panels = []
    for s in signals:
        t, ym, ys = comp["t"], comp["measured"][s], comp["simulated"][s]
        panels.append({"measured": _decimate(t, ym), "simulated": (*_decimate(t, ys), f"model ({model})"),
                       "error": (*_decimate(t, ym - ys), "error"), "signal": s,
                       "title": f"{p.name}: {s}", "measured_label": "measured"})
    res = plot_comparisons(panels)
    fit = {s: comp["fit"][s] for s in signals}
    rms = {s: float(np.sqrt(np.mean((comp["measured"][s] - comp["simulated"][s]) ** 2))) for s in signals}
    lc = LogComparison(str(p), kind, model, fit, rms, None, note)
    cap = (f"Measured (solid) and simulated (dashed) {', '.join(signals)}, and their difference; "
           f"the simulation starts from the measured state at t = {log.t[0]:g} s.")
    return lc, res["figure"], cap


def _simulate_log(log, params, *, locked, controller, signals):
    """Simulate ``log`` with :func:`iwp.validate.validate` (model chosen by :func:`iwp.validate.auto_model`)."""
    from .validate import auto_model, validate

    model = auto_model(log)
    r = validate(log, params, model=model, controller=controller, signals=tuple(signals),
                 locked=locked if model in ("compensated", "raw") else None)
    return model, {"t": np.asarray(r.t), "measured": {s: np.asarray(r.measured[s]) for s in signals},
                   "simulated": {s: np.asarray(r.simulated[s]) for s in signals},
                   "fit": {s: float(r.fit[s]) for s in signals}}
