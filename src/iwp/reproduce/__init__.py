"""Reproduce the paper end to end on the virtual rig: ``iwp reproduce --out DIR``.

:func:`reproduce` runs the paper's experiments (section 5) on the virtual
rig (:mod:`iwp.rig`), identifies the model the way the paper does
(:func:`iwp.identify`), compares simulations with the logs
(:mod:`iwp.validate`), refines the parameters by simulation error
(:func:`iwp.refine`) and writes a report a researcher could hand in:

* ``DIR/report.html`` -- one self-contained page: the figures (embedded),
  the parameters (virtual-rig truth, least squares, refined, the paper's
  Table 1), the fits, and the paper's statements checked one by one with
  the numbers found here;
* ``DIR/figures/NAME.svg`` for every figure (the page embeds the same file);
* ``DIR/parameters.json`` -- the final parameter set in the format of
  :func:`iwp.models.parameters.load_params` (so ``--params DIR/parameters.json`` works
  in every command), with the other sets, the identification results and
  the refinement beside it;
* ``DIR/results.json`` -- steps, fits and checked statements, for machines;
* with ``keep_logs=True``, ``DIR/data/NAME.csv`` -- every experiment log
  (about 20 MB for a full run); without, the page gives for each log the
  command that writes it again, bit for bit (:func:`log_command`).

The steps, in the paper's order (one function each, ``step_*``):

==============  ==========================================================  ===========
step            what                                                         paper
==============  ==========================================================  ===========
dead-zone       static curves, dead-zone thresholds, compensated linearity   fig. 2
motor-disk      motor-disk chirp, ``p2(1+rho)``, ``p3(1+rho)``               sec. 5.1
sines           A = 60, 40, 20 against the rigid and the flexible belt       figs. 3, 4
coulomb         the Coulomb variant and its comparison                       figs. 6, 7
full-setup      the 8-parameter set-up (16) and why it is poor               eq. (16)
free-pendulum   the free pendulum                                            fig. 8
two-step        the two-step set-up, ``rho_1``, ``rho_2``                    Table 1
full-chirp      the full chirp without and with the restart at t = 200 s     fig. 9
closed-loop     Hopf anticontrol ``k1 = -10``, ``k2 = 0.1``                  fig. 10
paper-numbers   every published number against this run's (calibration)      sec. 5
refine          refinement by simulation error, what it changes              --
report          checked statements, parameters.json, report.html             --
==============  ==========================================================  ===========

A step that fails is recorded with its name and message; the run goes on
with the steps that do not need it (those that do are skipped), and the
report is written with what was completed. Files already written stay in
place.

``quick=True`` runs shorter experiments and a smaller refinement (for tests);
the statements are checked the same way.
"""


from __future__ import annotations

from .context import (
    FigureRecord,
    FitRecord,
    ProgressEvent,
    ReproduceResult,
    StepRecord,
    experiment_settings,
    log_command,
)
from .paper import PAPER
from .pipeline import STEPS, Step, reproduce
from .statements import STATEMENTS, check_statements

__all__ = [
    "STEPS",
    "PAPER",
    "Step",
    "StepRecord",
    "FigureRecord",
    "FitRecord",
    "ProgressEvent",
    "ReproduceResult",
    "STATEMENTS",
    "check_statements",
    "reproduce",
    "experiment_settings",
    "log_command",
]
