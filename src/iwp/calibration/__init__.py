"""The calibrated twin: the paper's procedures applied to the virtual rig, so that they return the paper's numbers.

The paper's Table 1 is what its procedures returned on its rig, not the
rig's truth. This subpackage finds a truth for the virtual rig
(:mod:`iwp.rig`) on which the paper's identification procedures
(:mod:`iwp.ident`) return the published numbers; it sits above both.

======================  ===========================================================
module                  what
======================  ===========================================================
:mod:`.targets`         :func:`load_targets`, :class:`PaperTarget`: the paper's published numbers
                        (``paper_targets.json``) with their precision and tolerance
:mod:`.statistics`      :func:`paper_numbers`: the paper's procedures applied to the rig's logs as
                        the CLI applies them; the statistics that reproduce each number
:mod:`.calibrate`       :func:`calibrate`: the truth by indirect inference, so that the paper's
                        procedures return the paper's numbers (``iwp rig calibrate``)
======================  ===========================================================
"""

from __future__ import annotations

from .calibrate import COORDINATES, DEFAULT_FREE, CalibrationResult, calibrate, truth_with, twin_statistics
from .statistics import PaperNumbers, paper_numbers
from .targets import TARGETS_FILE, PaperTarget, TargetRow, compare_targets, load_targets

__all__ = [
    "COORDINATES",
    "CalibrationResult",
    "DEFAULT_FREE",
    "PaperNumbers",
    "PaperTarget",
    "TARGETS_FILE",
    "TargetRow",
    "calibrate",
    "compare_targets",
    "load_targets",
    "paper_numbers",
    "truth_with",
    "twin_statistics",
]
