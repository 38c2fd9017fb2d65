"""Sphinx configuration of iwp's documentation site.

Build (warnings are errors; the gallery's examples run during the build)::

    pip install '.[docs]'
    sphinx-build -W --keep-going -b html docs docs/_build/html
"""

from __future__ import annotations

import importlib
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
os.environ.setdefault("MPLBACKEND", "Agg")

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

import iwp  # noqa: E402

#: the API reference: every public name of these modules (their ``__all__``), once, where it is exported first
API_MODULES = {
    "iwp.models": "The paper's equations, laws, parameters and the Plant",
    "iwp.sim": "Simulation: the one integration engine, inputs, controllers",
    "iwp.sim.sensitivity": "Forward sensitivities",
    "iwp.sim.uncertainty": "Parameter and prediction bands",
    "iwp.data": "Experiment logs",
    "iwp.data.rig_description": "Rig descriptions",
    "iwp.data.rig_log": "Other rigs' logs",
    "iwp.ident": "Identification (section 5), refinement, validation",
    "iwp.ident.logfit": "Logs to a validated model (iwp fit)",
    "iwp.control": "Hopf design and continuation, balance, swing-up",
    "iwp.sweep": "Sweeps: many closed loops over gains, parameters, initial states",
    "iwp.rig": "The virtual rig",
    "iwp.rig.described": "The virtual rig as any rig",
    "iwp.calibration": "The calibrated twin",
    "iwp.device": "The rig in the loop",
    "iwp.reproduce": "The paper end to end",
    "iwp.report": "HTML reports",
    "iwp.plotting": "Figures",
    "iwp.gym_env": "The Gymnasium environment",
    "iwp.errors": "Errors",
}


def write_api_page(path: Path) -> None:
    """docs/api.rst: one autosummary table per module of API_MODULES (generated, not committed)."""
    seen: set[int] = set()
    lines = ["API reference", "=============", "",
             "Every public name, generated from its docstring (numpydoc). ``from iwp import ...`` gives the",
             "most used ones (:mod:`iwp`); the tables below list each where its subpackage exports it.", ""]
    for name, title in API_MODULES.items():
        module = importlib.import_module(name)
        names = []
        for n in getattr(module, "__all__", []):
            obj = getattr(module, n)
            if id(obj) in seen and not isinstance(obj, (int, float, str, tuple, dict, frozenset)):
                continue
            seen.add(id(obj))
            names.append(n)
        if not names:
            continue
        heading = f"{title} (``{name}``)"
        lines += [heading, "-" * len(heading), "", f".. automodule:: {name}", "   :no-members:", "",
                  f".. currentmodule:: {name}", "", ".. autosummary::", "   :toctree: generated/", ""]
        lines += [f"   {n}" for n in names] + [""]
    text = "\n".join(lines)
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


write_api_page(HERE / "api.rst")

project = "iwp"
author = "the iwp developers"
copyright = "2026, the iwp developers"
version = release = iwp.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "numpydoc",
    "myst_parser",
    "sphinx_gallery.gen_gallery",
    "iwp_cli",
]

source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"
exclude_patterns = ["_build", "examples/README.txt", "**.ipynb_checkpoints", "auto_examples/*.ipynb",
                    "auto_examples/*.py", "auto_examples/*.zip", "auto_examples/*.json"]
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
