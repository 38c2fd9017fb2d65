"""Sphinx extension: iwp's API reference grouped by the paper's sections, and its constants' documentation.

The reference is one page per part of the paper (models, simulation,
identification, control, the rig and the device, data) plus one for what
serves them all: a short narrative (``docs/_api/<part>.rst``, written by
hand) and then a table of every public name of the part's modules (their
``__all__``, generated, so that it cannot drift from the code).

A constant re-exported by a package (``iwp.models.COULOMB_EPS``) has no
docstring of its own: autodoc shows its type's (``float``: "Convert a string
or number to a floating point number"). Its documentation is the ``#:``
comment above its definition, in the module that defines it;
:func:`constant_doc` finds it there and the ``autodoc-process-docstring``
hook puts it in place of the type's text. ``tests/test_api_docs.py`` uses
the same functions, so that what it checks is what the site shows.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from functools import lru_cache
from pathlib import Path

#: part -> (title, modules whose ``__all__`` it lists); the narrative is ``docs/_api/<part>.rst``
SECTIONS: dict[str, tuple[str, tuple[str, ...]]] = {
    "models": ("Models: equations of motion, friction, dead zone (sections 2-4)",
               ("iwp.models",)),
    "simulation": ("Simulation: the integrator, inputs, sensitivities, bands, sweeps",
                   ("iwp.sim", "iwp.sim.sensitivity", "iwp.sim.uncertainty", "iwp.sweep")),
    "identification": ("Identification and validation (section 5)",
                       ("iwp.ident", "iwp.ident.logfit", "iwp.calibration")),
    "control": ("Control: Hopf anticontrol (section 5.3), balance, swing-up",
                ("iwp.control",)),
    "rig": ("The rig: the virtual twin, a rig in the loop, the Gymnasium environment",
            ("iwp.rig", "iwp.rig.described", "iwp.device", "iwp.gym_env")),
    "data": ("Data: experiment logs, rig descriptions, other rigs' logs",
             ("iwp.data", "iwp.data.rig_description", "iwp.data.rig_log")),
    "results": ("The paper end to end, reports, figures, errors",
                ("iwp.reproduce", "iwp.report", "iwp.plotting", "iwp.errors")),
}
#: the types whose instances are documented as data (by their ``#:`` comment), not by their own docstring
DATA_TYPES = (int, float, complex, str, bytes, tuple, list, dict, set, frozenset, type(None))


def is_data(obj) -> bool:
    """Whether ``obj`` is a constant (a value documented by its ``#:`` comment), not a class, routine or module."""
    return isinstance(obj, DATA_TYPES) or not (inspect.isclass(obj) or inspect.isroutine(obj)
                                              or inspect.ismodule(obj) or callable(obj))


@lru_cache(maxsize=None)
def _attr_docs() -> dict[str, list[tuple[str, str]]]:
    """Name -> [(module, ``#:`` text)] for every module-level ``#:`` comment of iwp's modules."""
    from sphinx.pycode import ModuleAnalyzer

    import iwp

    out: dict[str, list[tuple[str, str]]] = {}
    names = ["iwp"] + [m.name for m in pkgutil.walk_packages(iwp.__path__, "iwp.")]
    for name in names:
        if name.endswith("__main__"):
            continue
        try:
            docs = ModuleAnalyzer.for_module(name).find_attr_docs()
        except Exception:  # noqa: BLE001 - a module without source (none in iwp) has no comments
            continue
        for (cls, attr), lines in docs.items():
            if cls == "":
                out.setdefault(attr, []).append((name, "\n".join(lines).strip()))
    return out


def constant_doc(module: str, name: str) -> str | None:
    """The ``#:`` documentation of constant ``module.name``, from the module that defines it (None: none).

    Where several modules document a constant of that name, the one that defines the value ``module`` exports
    wins.
    """
    found = _attr_docs().get(name, [])
    value = getattr(importlib.import_module(module), name)
    for where, text in found:
        mod = importlib.import_module(where)
        if text and name in vars(mod) and vars(mod)[name] is value:
            return text
    return next((text for _, text in found if text), None)


def public_names() -> list[tuple[str, str, str, object]]:
    """(part, module, name, object) for every public name of the reference, each once, where first exported."""
    seen: set[int] = set()
    out = []
    for part, (_, modules) in SECTIONS.items():
        for module in modules:
            mod = importlib.import_module(module)
            for name in getattr(mod, "__all__", []):
                obj = getattr(mod, name)
                if id(obj) in seen and not is_data(obj):
                    continue
                seen.add(id(obj))
                out.append((part, module, name, obj))
    return out


def write_api_pages(docs: Path) -> None:
    """``docs/api.rst`` (the overview) and ``docs/api/<part>.rst`` (generated, not committed)."""
    folder = docs / "api"
    folder.mkdir(exist_ok=True)
    by_part: dict[str, dict[str, list[str]]] = {}
    for part, module, name, _ in public_names():
        by_part.setdefault(part, {}).setdefault(module, []).append(name)
    overview = ["API reference", "=============", "",
                "``from iwp import ...`` gives the most used names (:mod:`iwp`); the pages below follow the",
                "paper's parts, each with a short guide to its names and then every public name of its",
                "modules, generated from the docstrings (numpydoc; units in brackets).", "",
                ".. toctree::", "   :maxdepth: 1", ""]
    for part, (title, modules) in SECTIONS.items():
        overview.append(f"   api/{part}")
        lines = [title, "=" * len(title), "", f".. currentmodule:: {modules[0]}", "",
                 f".. include:: ../_api/{part}.rst", ""]
        for module in modules:
            names = by_part.get(part, {}).get(module, [])
            if not names:
                continue
            heading = f"``{module}``"
            lines += [heading, "-" * len(heading), "", f".. automodule:: {module}", "   :no-members:", "",
                      f".. currentmodule:: {module}", "", ".. autosummary::", "   :toctree: ../generated/", ""]
            lines += [f"   {n}" for n in names] + [""]
        _write(folder / f"{part}.rst", "\n".join(lines))
    _write(docs / "api.rst", "\n".join(overview) + "\n")


def _write(path: Path, text: str) -> None:
    if not path.exists() or path.read_text() != text:
        path.write_text(text)


def _constant_docstring(app, what, name, obj, options, lines):
    """autodoc-process-docstring: a constant's ``#:`` comment in place of its type's docstring."""
    if what not in ("data", "attribute") or "." not in name:
        return
    module, _, attr = name.rpartition(".")
    try:
        text = constant_doc(module, attr)
    except (ImportError, AttributeError):
        return
    if text is not None:
        lines[:] = text.splitlines()


def setup(app):
    app.connect("autodoc-process-docstring", _constant_docstring)
    return {"parallel_read_safe": True, "parallel_write_safe": True, "version": "1"}
