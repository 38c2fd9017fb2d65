"""Sphinx configuration of iwp's documentation site.

Build (warnings are errors; the gallery's examples run during the build)::

    pip install '.[docs]'
    sphinx-build -W --keep-going -b html docs docs/_build/html
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")
# the gallery's kernels cache outside the source tree (as the tests', conftest.py): a wheel must not pack them
os.environ.setdefault(
    "NUMBA_CACHE_DIR", str(Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "iwp" / "numba"))

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

from iwp_api import write_api_pages  # noqa: E402  (docs/_ext)

import iwp  # noqa: E402

# the API reference: one page per part of the paper, its narrative (docs/_api) and its names (generated)
write_api_pages(HERE)

project = "iwp"
author = "the iwp developers"
copyright = "2026, the iwp developers"
version = release = iwp.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "iwp_cli",
    "iwp_api",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "_api", "_intersphinx", "examples/README.txt", "**.ipynb_checkpoints",
                    "auto_examples/*.ipynb", "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.json"]
templates_path = ["_templates"]

# --- API reference: one page per public name, from the docstrings (numpydoc)
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"members": False}
autodoc_typehints = "none"  # the numpydoc sections carry types and units
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
#: numpydoc's checks that every public docstring passes; the build (warnings as errors) keeps it so:
#: no prose read as a parameter (PR02, PR10), parameters in the signature's order (PR03), sections in order
#: (GL07), described parameters (PR08, PR09). Constants (upper-case names) carry no numpydoc sections.
numpydoc_validation_checks = {"PR02", "PR03", "PR10", "GL07", "PR08", "PR09"}
#: methods inherited from collections.abc (a frozen module in Python 3.11: no source to validate) are not iwp's
numpydoc_validation_exclude = {r"\.[A-Z][A-Z0-9_]*$", r"\.(get|items|keys|values|count|index)$"}

# --- links to the libraries iwp's signatures name (numpy arrays, scipy results, matplotlib figures, python-control)
#: project -> (its documentation, the host its inventory is fetched from)
INTERSPHINX = {
    "python": "https://docs.python.org/3/",
    "numpy": "https://numpy.org/doc/stable/",
    "scipy": "https://docs.scipy.org/doc/scipy/",
    "matplotlib": "https://matplotlib.org/stable/",
    "control": "https://python-control.readthedocs.io/en/latest/",
}


def _reachable(url: str, timeout: float = 3.0) -> bool:
    """Whether the host of ``url`` answers on its port (the build may run offline: then no inventory)."""
    import socket
    from urllib.parse import urlsplit

    parts = urlsplit(url)
    try:
        socket.create_connection((parts.hostname, parts.port or 443), timeout=timeout).close()
    except OSError:
        return False
    return True


def _inventories() -> dict:
    """intersphinx_mapping: an inventory shipped in docs/_intersphinx/NAME.inv (or the system's Python docs) is
    used offline; otherwise the online one where its host answers; otherwise none (the links are left out, and the
    build still passes with warnings as errors)."""
    local = {name: HERE / "_intersphinx" / f"{name}.inv" for name in INTERSPHINX}
    local["python"] = next((p for p in (local["python"], Path("/usr/share/doc/python3/html/objects.inv"),
                                        Path(f"/usr/share/doc/python3.{sys.version_info.minor}/html/objects.inv"))
                            if p.is_file()), local["python"])
    mapping, skipped = {}, []
    for name, url in INTERSPHINX.items():
        if local[name].is_file():
            mapping[name] = (url, str(local[name]))
        elif _reachable(url):
            mapping[name] = (url, None)
        else:
            skipped.append(name)
    if skipped:
        print(f"intersphinx: no inventory for {', '.join(skipped)} (offline, none in docs/_intersphinx): "
              "their names are not linked")
    return mapping


intersphinx_mapping = _inventories()
intersphinx_timeout = 10

# --- the Markdown pages of the user guide (MyST)
myst_enable_extensions = ["dollarmath", "colon_fence"]
myst_heading_anchors = 3
suppress_warnings = ["myst.header"]

# --- the gallery: every example runs at build time, its figures captured
sphinx_gallery_conf = {
    "examples_dirs": ["examples"],
    "gallery_dirs": ["auto_examples"],
    "filename_pattern": r"/plot_",
    "abort_on_example_error": True,
    "download_all_examples": False,
    "remove_config_comments": True,
    "within_subsection_order": "FileNameSortKey",
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "show_memory": False,
    "min_reported_time": 1,
    "capture_repr": (),
}

html_theme = "pydata_sphinx_theme"
html_title = f"iwp {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "header_links_before_dropdown": 4,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_show_sourcelink = False
