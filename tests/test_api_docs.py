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

#: the functions whose docstrings must hold an Examples section that runs (module, name): the ``iwp`` top level first,
#: then the subpackages' own (a function exported from two modules is listed once)
WITH_EXAMPLES: tuple[tuple[str, str], ...] = (
    ("iwp", "table1"), ("iwp", "load_params"), ("iwp", "save_params"), ("iwp", "paper_belt"),
    ("iwp", "linearize"), ("iwp", "energy"), ("iwp", "feedforward"), ("iwp", "dead_zone"),
    ("iwp", "simulate"), ("iwp", "simulate_batch"), ("iwp", "simulate_scipy"), ("iwp", "simulate_sensitivities"),
    ("iwp", "read_experiment"), ("iwp", "write_experiment"), ("iwp", "read_static_curve"), ("iwp", "convert"),
    ("iwp", "identify"), ("iwp", "validate"), ("iwp", "fit_percent"),
    ("iwp", "hopf_point"), ("iwp", "design_hopf"), ("iwp", "lqr_balance"),
    ("iwp", "default_truth"),
    ("iwp", "refine"), ("iwp", "refine_identification"), ("iwp", "refine_belt"), ("iwp", "continue_hopf"),
    ("iwp", "find_orbit"), ("iwp", "swing_up"), ("iwp", "robust_hopf"), ("iwp", "robust_balance"),
    ("iwp", "robust_swingup"), ("iwp", "open_rig"), ("iwp", "run_on_rig"), ("iwp", "run_control"),
    ("iwp.models", "dead_zone_output"), ("iwp.models", "encoder_step"), ("iwp.models", "model_info"),
    ("iwp.models", "named_params"), ("iwp.models", "pendulum_energy"), ("iwp.models", "quantize"),
    ("iwp.models", "to_statespace"),
    ("iwp.sim", "make_input"),
    ("iwp.ident", "as_experiments"), ("iwp.ident", "auto_model"), ("iwp.ident", "held_out_q1_offset"),
    ("iwp.ident", "model_input"), ("iwp.ident", "default_differentiator"), ("iwp.ident", "fit_plant"),
    ("iwp.ident", "get_setup"), ("iwp.ident", "identify_dead_zone"), ("iwp.ident", "load_pendulum"),
    ("iwp.ident", "solve_least_squares"), ("iwp.ident", "validation_plant"),
    ("iwp.control", "closed_loop_matrix"), ("iwp.control", "simulated_amplitude"), ("iwp.control", "wilson_interval"),
    ("iwp.rig", "check_output_path"), ("iwp.rig", "list_experiments"), ("iwp.rig", "rigid_fit_error"),
    ("iwp.rig", "run_experiment"), ("iwp.rig", "truth_record"), ("iwp.rig", "uncalibrated_truth"),
    ("iwp.rig", "write_result"),
    ("iwp.data", "check_distinct"), ("iwp.data", "format_of"), ("iwp.data", "read_angle_log"),
    ("iwp.data", "read_csv"), ("iwp.data", "read_mat"), ("iwp.data", "read_parquet"), ("iwp.data", "write_csv"),
    ("iwp.data", "write_mat"), ("iwp.data", "write_parquet"), ("iwp.data", "write_static_curve"),
    ("iwp.device", "connect"), ("iwp.device", "run_loop"),
    ("iwp.calibration", "calibrate"), ("iwp.calibration", "compare_targets"), ("iwp.calibration", "load_targets"),
    ("iwp.calibration", "paper_numbers"), ("iwp.calibration", "truth_with"), ("iwp.calibration", "twin_statistics"),
    ("iwp.report", "fmt"), ("iwp.report", "fmt_interval"), ("iwp.report", "prepare_output_dir"),
    ("iwp.report", "render_html"), ("iwp.report", "save_figure"), ("iwp.report", "write_html"),
    ("iwp.plotting", "animate_pendulum"), ("iwp.plotting", "plot_bifurcation"),
    ("iwp.plotting", "plot_branch_details"), ("iwp.plotting", "plot_capture"), ("iwp.plotting", "plot_comparison"),
    ("iwp.plotting", "plot_comparison_panel"), ("iwp.plotting", "plot_comparisons"),
    ("iwp.plotting", "plot_correlation"), ("iwp.plotting", "plot_dead_zone"), ("iwp.plotting", "plot_distribution"),
    ("iwp.plotting", "plot_errors"), ("iwp.plotting", "plot_simulation"), ("iwp.plotting", "plot_static_curve"),
    ("iwp.plotting", "plot_swingup"), ("iwp.plotting", "plot_validation"), ("iwp.plotting", "savefig"),
    ("iwp.plotting", "stacked_axes"),
    ("iwp.reproduce", "experiment_settings"), ("iwp.reproduce", "log_command"),
    ("iwp.reproduce", "check_statements"), ("iwp.reproduce", "reproduce"),
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


def test_every_public_function_has_examples_that_this_file_runs():
    """Every function in the ``__all__`` of iwp and its subpackages has an Examples section, and one of its names is
    in :data:`WITH_EXAMPLES` (so that the section runs here)."""
    import importlib

    listed = {id(getattr(importlib.import_module(m), n)) for m, n in WITH_EXAMPLES}
    missing = []
    for sub in ("iwp", "iwp.models", "iwp.sim", "iwp.ident", "iwp.control", "iwp.rig", "iwp.data", "iwp.device",
                "iwp.calibration", "iwp.report", "iwp.plotting", "iwp.reproduce"):
        mod = importlib.import_module(sub)
        for name in mod.__all__:
            obj = getattr(mod, name)
            if inspect.isfunction(obj) and ("\nExamples\n" not in (inspect.getdoc(obj) or "") or id(obj) not in listed):
                missing.append(f"{sub}.{name}")
    assert missing == []


def test_each_package_table_names_exactly_its_modules():
    """ident/__init__.py's table named .parameters and .fit, which no longer existed, and left out structure.py."""
    import re
    from pathlib import Path

    import iwp.ident

    root = Path(iwp.ident.__file__).parent
    named = set(re.findall(r":mod:`\.([a-z_]+)`", (root / "__init__.py").read_text()))
    present = {p.stem for p in root.glob("*.py") if p.stem != "__init__"} | {
        p.name for p in root.iterdir() if (p / "__init__.py").is_file()}
    assert named == present
