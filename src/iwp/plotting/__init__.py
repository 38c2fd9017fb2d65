"""Figures. Plot functions draw what they are given and compute nothing.

Every function takes an optional ``ax=`` (or ``axes=``) and returns the
matplotlib artists it made, as python-control's plotting does. Result
objects' ``.plot()`` methods delegate here.

=====================  =====================================================
module                 figures
=====================  =====================================================
:mod:`.simulation`     a simulation's signals; measured against simulated
:mod:`.report`         the paper's figures: static curves, comparison panels, errors
:mod:`.validation`     validation of a model on a log; correlation of estimates
:mod:`.control`        bifurcation diagram, swing-up, animation
:mod:`.robust`         an outcome over parameter draws; capture probabilities
:mod:`.base`           labels, stacked panels, saving
:mod:`.records`        long records as envelopes per pixel column; zoom windows
:mod:`.legends`        legends in a corner free of data, else above the axes
=====================  =====================================================
"""

from __future__ import annotations

from .base import SIGNAL_LABELS, savefig, stacked_axes
from .control import animate_pendulum, plot_bifurcation, plot_branch_details, plot_swingup
from .report import plot_comparison_panel, plot_comparisons, plot_dead_zone, plot_errors, plot_static_curve
from .robust import plot_capture, plot_distribution
from .simulation import plot_comparison, plot_simulation
from .validation import plot_correlation, plot_validation

__all__ = [
    "SIGNAL_LABELS",
    "animate_pendulum",
    "plot_bifurcation",
    "plot_branch_details",
    "plot_capture",
    "plot_comparison",
    "plot_comparison_panel",
    "plot_comparisons",
    "plot_correlation",
    "plot_dead_zone",
    "plot_distribution",
    "plot_errors",
    "plot_simulation",
    "plot_static_curve",
    "plot_swingup",
    "plot_validation",
    "savefig",
    "stacked_axes",
]
