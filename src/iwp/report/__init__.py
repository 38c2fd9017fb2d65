"""Self-contained HTML reports: the reproduction of the paper and comparisons of a user's own logs.

:func:`render_html` turns a :class:`Report` (sections of text, tables,
checked statements and figures) into one HTML page that needs nothing else:
figures are embedded as base64 SVG, styles are inline, nothing is fetched
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

from .folder import prepare_output_dir, save_figure
from .page import FigureEntry, Part, Report, Section, Statement, Table, fmt, fmt_interval, render_html, write_html

__all__ = [
    "FigureEntry",
    "Report",
    "Section",
    "Statement",
    "Part",
    "Table",
    "fmt",
    "fmt_interval",
    "prepare_output_dir",
    "render_html",
    "save_figure",
    "write_html",
]
