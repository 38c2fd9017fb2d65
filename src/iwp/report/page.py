"""The page: a self-contained HTML report of sections, tables, checked statements and figures.

:func:`render_html` turns a :class:`Report` into one HTML page that needs
nothing else: figures are embedded as base64 SVG (the files written beside it), styles are inline, nothing
is fetched from the network. The page carries a small inline script that,
once the page has loaded, marks every image with ``data-loaded="1"`` (or
``"0"`` if it failed) and the ``<body>`` with ``data-images-loaded="N/M"``;
a headless browser can check the page through the DOM.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import os
import platform
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

from ..files import jsonable, prepare_output_file
from .words import ERRATA_SOURCE

__all__ = ["Statement", "Part", "Table", "FigureEntry", "Section", "Report", "render_html", "write_html", "fmt",
           "fmt_interval"]


# --------------------------------------------------------------------------
# content
# --------------------------------------------------------------------------
@dataclass
class Part:
    """One part of a statement's claim, graded on its own.

    Attributes
    ----------
    what : str
        The part and what this run found for it, with the numbers.
    passed : bool or None
        ``None``: not checked (the number it needs is missing).
    row : str
        The key of the row of the paper's numbers (``paper_targets.json``) it is graded on, so that the
        statement and the numbers table cannot disagree; ``""`` when the paper prints no number for it and
        iwp's criterion grades it.
    """

    what: str
    passed: bool | None
    row: str = ""

    def to_dict(self) -> dict:
        return {"what": self.what, "passed": self.passed, "row": self.row or None}


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
    parts : list of Part
        The claim's parts, each graded (:meth:`grade`); empty for a claim checked as one.
    """

    key: str
    claim: str
    reference: str
    found: str = ""
    criterion: str = ""
    passed: bool | None = None
    values: dict = field(default_factory=dict)
    parts: list = field(default_factory=list)

    def grade(self) -> None:
        """The verdict from the parts: fail if one fails, else not checked if one is not checked, else pass."""
        verdicts = [p.passed for p in self.parts]
        self.passed = False if False in verdicts else (None if None in verdicts else True)

    @property
    def verdict(self) -> str:
        return "not checked" if self.passed is None else ("pass" if self.passed else "fail")

    def to_dict(self) -> dict:
        return {"key": self.key, "claim": self.claim, "reference": self.reference, "found": self.found,
                "criterion": self.criterion, "verdict": self.verdict, "values": jsonable(self.values),
                "parts": [p.to_dict() for p in self.parts]}


@dataclass
class Table:
    """A table: ``columns`` and ``rows`` of already formatted cells (str), with an optional note."""

    title: str
    columns: Sequence[str]
    rows: Sequence[Sequence[Any]]
    note: str = ""


@dataclass
class FigureEntry:
    """An embedded figure: the SVG bytes, and the names of the files written next to the page."""

    name: str
    title: str
    caption: str
    svg: bytes
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
    #: the paper's errata by item number, listed at the end and linked from every "ERRATA item N" on the page
    errata: dict = field(default_factory=dict)


# --------------------------------------------------------------------------
# formatting
# --------------------------------------------------------------------------
def fmt(x: Any, digits: int = 4) -> str:
    """A number for a table: ``digits`` significant digits, ``-`` for None/NaN.

    Parameters
    ----------
    x : object
        A number (a string is returned as it is, anything else not a number as ``str(x)``).
    digits : int, default 4
        Significant digits; scientific notation for ``|x| >= 1e5`` or ``|x| < 1e-4``.

    Returns
    -------
    str
        The text; ``"-"`` for None and NaN, ``"inf"``/``"-inf"``, ``"0"`` for zero.

    Examples
    --------
    >>> from iwp.report import fmt
    >>> fmt(26.0954321), fmt(247.24, digits=6), fmt(0.0000286), fmt(float("nan"))
    ('26.1', '247.24', '2.860e-05', '-')
    """
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


def fmt_interval(low: Any, high: Any, digits: int = 4) -> str:
    """An interval ``[low, high]`` for a table, with the digits that show its width (at least ``digits``).

    A narrow interval of a large value keeps the significant digits that
    tell its ends apart, its width to two digits: ``[26.3596, 26.3604]``,
    not ``[26.36, 26.36]``.

    Parameters
    ----------
    low, high : float or None
        The ends.
    digits : int, default 4
        The least significant digits.

    Returns
    -------
    str

    Examples
    --------
    The 95 % interval of a well-determined ``p1`` and of a friction coefficient:

    >>> from iwp.report import fmt_interval
    >>> fmt_interval(26.3596, 26.3604), fmt_interval(0.0122, 0.0151)
    ('[26.3596, 26.3604]', '[0.0122, 0.0151]')
    """
    try:
        lo, hi = float(low), float(high)
    except (TypeError, ValueError):
        return f"[{fmt(low, digits)}, {fmt(high, digits)}]"
    width = hi - lo
    scale = max(abs(lo), abs(hi))
    if math.isfinite(width) and width > 0 and math.isfinite(scale) and scale > 0:
        digits = max(digits, min(15, math.ceil(math.log10(scale / width)) + 2))
    return f"[{fmt(lo, digits)}, {fmt(hi, digits)}]"



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
ul.parts{margin:.3em 0 0 1.1em;padding:0}ul.parts li{margin:.1em 0}.part-yes{color:#145214;font-weight:bold}
.part-no{color:#8a1010;font-weight:bold}.part-nc{color:#666;font-weight:bold}
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


_ERRATA_REF = re.compile(r"ERRATA( item|) (\d+)")


def _linked(text: Any, errata) -> str:
    """``text`` escaped, each "ERRATA item N" of a listed item a link to its explanation."""
    out = _e(text)
    if not errata:
        return out
    return _ERRATA_REF.sub(lambda m: (f'<a href="#errata-{m.group(2)}">errata item {m.group(2)}</a>'
                                      if int(m.group(2)) in errata else m.group(0)), out)


def _errata_html(errata, source: str) -> str:
    items = "".join(f'<li id="errata-{n}" value="{n}">{_e(errata[n])}</li>' for n in sorted(errata))
    return ('<h2 id="errata">The paper\'s errata</h2><p>Where the paper disagrees with itself, iwp follows the '
            f"derivation; the page cites these items as \u201cerrata item N\u201d (the table is {_e(source)} in "
            f"iwp's source).</p><ol>{items}</ol>")


def _cell(value: Any, errata=None) -> str:
    text = value if isinstance(value, str) else fmt(value)
    num = not isinstance(value, str) or _looks_numeric(text)
    return f'<td class="num">{_e(text)}</td>' if num else f"<td>{_linked(text, errata)}</td>"


def _looks_numeric(text: str) -> bool:
    t = text.strip().replace("\u00b1", "").replace(" ", "").replace("%", "")
    if t in ("-", ""):
        return True
    try:
        float(t)
        return True
    except ValueError:
        return False


def _table_html(t: Table, errata=None) -> str:
    head = "".join(f"<th>{_e(c)}</th>" for c in t.columns)
    body = "".join("<tr>" + "".join(_cell(c, errata) for c in row) + "</tr>" for row in t.rows)
    note = f'<p class="note">{_linked(t.note, errata)}</p>' if t.note else ""
    return f"<h3>{_e(t.title)}</h3><table><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>{note}"


def _figure_html(f: FigureEntry, errata=None) -> str:
    data = base64.b64encode(f.svg).decode("ascii")
    files = ""
    if f.files:
        files = " Files: " + ", ".join(f"<code>{_e(x)}</code>" for x in f.files) + "."
    return (f'<figure id="fig-{_e(f.name)}"><h3>{_e(f.title)}</h3>'
            f'<img alt="{_e(f.title)}" src="data:image/svg+xml;base64,{data}">'
            f"<figcaption>{_linked(f.caption, errata)}{files}</figcaption></figure>")


def _parts_html(parts: Sequence[Part], errata=None) -> str:
    """A statement's parts as a list: verdict, what was found, and the numbers-table row it is graded on."""
    if not parts:
        return ""
    items = []
    for p in parts:
        verdict = "not checked" if p.passed is None else ("yes" if p.passed else "no")
        cls = {"yes": "part-yes", "no": "part-no"}.get(verdict, "part-nc")
        where = f" (row <code>{_e(p.row)}</code>)" if p.row else " (no published number: iwp's criterion)"
        items.append(f'<li><span class="{cls}">{verdict}</span>: {_linked(p.what, errata)}{where}</li>')
    return '<ul class="parts">' + "".join(items) + "</ul>"


def _statements_html(statements: Sequence[Statement], errata=None) -> str:
    rows = []
    for i, s in enumerate(statements, 1):
        cls = {"pass": "pass", "fail": "fail"}.get(s.verdict, "nc")
        rows.append(
            f"<tr><td class=\"num\">{i}</td><td>{_e(s.claim)}<br><span class=\"note\">"
            f"{_linked(s.reference, errata)}</span></td>"
            f"<td>{_linked(s.found, errata)}{_parts_html(s.parts, errata)}</td>"
            f"<td class=\"note\">{_e(s.criterion)}</td>"
            f'<td class="{cls}">{_e(s.verdict.upper())}</td></tr>')
    return ("<table><thead><tr><th>#</th><th>the paper says</th><th>found here</th><th>criterion</th>"
            "<th>verdict</th></tr></thead><tbody>" + "".join(rows) + "</tbody></table>")


def render_html(report: Report) -> str:
    """The page as one self-contained HTML string (no external resources).

    Parameters
    ----------
    report : Report
        The page's content.

    Returns
    -------
    str
        The HTML document, CSS and script inline, figures as embedded images.

    Examples
    --------
    >>> from iwp.report import Report, Section, Table, fmt, render_html
    >>> table = Table("free pendulum", ["parameter", "value"], [["p1", fmt(26.3612)]])
    >>> page = render_html(Report("Set-up (c)", sections=[Section("Parameters", tables=[table])]))
    >>> page.startswith("<!DOCTYPE html>"), '<td class="num">26.36</td>' in page, 'src="http' in page
    (True, True, False)
    """
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
    if report.errata:
        nav.append('<a href="#errata">errata</a>')
    if nav:
        parts.append("<nav>" + "".join(nav) + "</nav>")
    if report.summary:
        rows = "".join(f"<tr><td>{_e(k)}</td><td>{_e(v)}</td></tr>" for k, v in report.summary)
        parts.append(f'<table class="summary"><tbody>{rows}</tbody></table>')
    if report.statements:
        parts.append('<h2 id="statements">The paper\'s statements, checked</h2>')
        parts.append(_statements_html(report.statements, report.errata))
    for i, s in enumerate(report.sections):
        parts.append(f'<h2 id="{_e(s.anchor or f"s{i}")}">{_e(s.title)}</h2>')
        parts.extend(f"<p>{_linked(p, report.errata)}</p>" for p in s.paragraphs)
        parts.extend(_table_html(t, report.errata) for t in s.tables)
        parts.extend(_figure_html(f, report.errata) for f in s.figures)
    if report.errata:
        parts.append(_errata_html(report.errata, ERRATA_SOURCE))
    footer = report.footer or (f"Generated by iwp on {_dt.datetime.now().isoformat(timespec='seconds')} "
                               f"(Python {platform.python_version()}, {platform.system()}).")
    parts.append(f'<hr><p class="note">{_e(footer)}</p></body></html>')
    return "\n".join(parts) + "\n"


def write_html(report: Report, path: str | os.PathLike, *, force: bool = False) -> Path:
    """Render ``report`` and write it to ``path`` (refuses an existing file unless ``force``).

    Parameters
    ----------
    report : Report
        The page's content.
    path : str or path-like
        Output file; its folder must exist.
    force : bool, default False
        Allow overwriting an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    InputError
        ``path`` exists (without ``force``), is a folder, or its folder does not exist.

    Examples
    --------
    >>> from iwp.report import Report, Section, write_html
    >>> report = Report("Free pendulum", sections=[Section("Swing", paragraphs=["5 s of figure 8."])])
    >>> write_html(report, "page.html").name
    'page.html'
    >>> write_html(report, "page.html")
    Traceback (most recent call last):
    ...
    iwp.errors.OutputExistsError: out page.html: file exists; pass --force to overwrite it
    >>> write_html(report, "page.html", force=True).stat().st_size > 1000
    True
    """
    p = prepare_output_file(path, force=force)
    p.write_text(render_html(report), encoding="utf-8")
    return p

