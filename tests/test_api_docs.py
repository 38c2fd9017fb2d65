"""The API reference a scientist reads: every public name has a real summary, and examples that run.

The names are those of the reference (``docs/_ext/iwp_api.py``: every
``__all__`` of the modules of each part of the paper), resolved as the site
resolves them: a constant by its ``#:`` comment in the module that defines
it, not its type's docstring (``float``: "Convert a string or number to a
floating point number"). The summary is what the reference's tables show
(autosummary's first sentence): it must be a whole sentence.

Examples: every function of :data:`WITH_EXAMPLES` (the top-level ``iwp``
API, first) has an ``Examples`` section, and each runs here as a doctest, in
an empty folder. The list only grows: a function leaves it when its Examples
do, which this test refuses.
"""

from __future__ import annotations

import doctest
import importlib
import inspect
import sys
import warnings
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "docs" / "_ext"))

from iwp_api import constant_doc, is_data, public_names  # noqa: E402

#: the functions whose docstrings must hold an Examples section that runs (module, name): the ``iwp`` top level
WITH_EXAMPLES: tuple[tuple[str, str], ...] = (
    ("iwp", "table1"), ("iwp", "load_params"), ("iwp", "save_params"), ("iwp", "paper_belt"),
    ("iwp", "linearize"), ("iwp", "energy"), ("iwp", "feedforward"), ("iwp", "dead_zone"),
    ("iwp", "simulate"), ("iwp", "simulate_batch"), ("iwp", "simulate_scipy"), ("iwp", "simulate_sensitivities"),
    ("iwp", "read_experiment"), ("iwp", "write_experiment"), ("iwp", "read_static_curve"), ("iwp", "convert"),
    ("iwp", "identify"), ("iwp", "validate"), ("iwp", "fit_percent"),
    ("iwp", "hopf_point"), ("iwp", "design_hopf"), ("iwp", "lqr_balance"),
    ("iwp", "default_truth"),
)
#: abbreviations a summary may not end on (a sentence cut at its first full stop)
CUT = ("e.g.", "i.e.", "cf.", "etc.", "vs.", "approx.", "eq.", "Eq.", "fig.", "Fig.", "no.", "No.", "resp.")


def _summary(text: str) -> str:
    from docutils.frontend import get_default_settings
    from docutils.parsers.rst import Parser
    from sphinx.ext.autosummary import extract_summary

    return extract_summary(inspect.cleandoc(text).splitlines(), get_default_settings(Parser))


def _own_doc(module: str, name: str, obj) -> str | None:
    """The documentation the reference shows for ``module.name``: never one inherited from Python's types."""
    if is_data(obj):
        return constant_doc(module, name)
    doc = obj.__doc__ if (inspect.isroutine(obj) or "__doc__" in vars(obj)) else None
    if not doc or not doc.strip():
        return None
    if inspect.isclass(obj) and doc.startswith(f"{obj.__name__}("):  # a dataclass's generated signature
        return None
    return doc


NAMES = public_names()


def test_the_reference_lists_the_api():
    assert len(NAMES) > 250
    parts = {part for part, *_ in NAMES}
    assert {"models", "simulation", "identification", "control", "rig", "data"} <= parts
    listed = {name for _, _, name, _ in NAMES}
    import iwp

    # every top-level name is in some part's table
    assert set(iwp.__all__) - {"__version__"} <= listed


def test_every_public_name_has_its_own_whole_sentence_summary():
    bad = []
    for _, module, name, obj in NAMES:
        doc = _own_doc(module, name, obj)
        if doc is None:
            bad.append(f"{module}.{name}: no documentation of its own")
            continue
        s = _summary(doc)
        if not s or len(s.split()) < 3 or not s.endswith((".", "?", "!")) or s.endswith(CUT):
            bad.append(f"{module}.{name}: summary {s!r}")
    assert bad == []


def test_constants_read_their_comment_not_their_type():
    # the case of the issue: a re-exported float constant
    doc = constant_doc("iwp.models", "COULOMB_EPS")
    assert doc and "floating point" not in doc
    assert doc != float.__doc__


def _function(module: str, name: str):
    return getattr(importlib.import_module(module), name)


@pytest.mark.parametrize("module,name", WITH_EXAMPLES, ids=[n for _, n in WITH_EXAMPLES])
def test_examples_run(module, name, tmp_path, monkeypatch):
    func = _function(module, name)
    doc = inspect.getdoc(func) or ""
    assert "\nExamples\n--------\n" in doc, f"{module}.{name} has no Examples section"
    tests = doctest.DocTestFinder(recurse=False).find(func, f"{module}.{name}", globs={})
    examples = [ex for t in tests for ex in t.examples]
    assert examples, f"{module}.{name}: its Examples hold no >>> line"
    monkeypatch.chdir(tmp_path)
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for t in tests:
            runner.run(t)
    assert runner.failures == 0, f"{module}.{name}: {runner.failures} example(s) failed (output above)"
