"""How well the rigid model (9) predicts the virtual rig: the error ``e`` of figures 3 and 4."""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..models.plant import Plant
from ..sim.options import SimOptions, Tolerances
from ..sim.simulate import simulate
from .experiments import EXPERIMENTS
from .run_settings import open_loop_input
from .truth import RigTruth
from .virtual import RIG_ATOL, RIG_RTOL, VirtualRig

__all__ = ["rigid_fit_error"]


def rigid_fit_error(name: str, *, truth: RigTruth | None = None, seed: int = 0, skip: float = 5.0,
                    **overrides) -> float:
    """Normalised RMS error of the rigid model (9) predicting the disk velocity of an experiment.

    Runs the experiment ``name`` (one with an open-loop input, e.g.
    ``"sine-60"``) on the virtual rig, simulates the compensated model (9)
    with the truth's lumped parameters (same input, same clamp, exact
    dead-zone compensation, Coulomb term included, rigid coupling) and
    returns ``std(q4_rigid - q4_true) / std(q4_true)`` over ``t >= skip``
    [s], with ``q4_true`` the truth's disk velocity (column ``true_q4``):
    the error ``e`` of figures 3 and 4 in relative form.

    Parameters
    ----------
    name : str
        Experiment with an open-loop input.
    truth : RigTruth, optional
        The virtual rig's truth (default: :func:`default_truth`).
    seed : int, default 0
        Seed of the rig's noise.
    skip : float, default 5.0
        Start of the compared part [s].
    **overrides
        Options of the experiment (as :meth:`VirtualRig.run`).

    Returns
    -------
    float
        The relative error [-].

    Raises
    ------
    InputError
        An experiment without an open-loop input, or a bad option.

    Examples
    --------
    The rigid model misses the belt's dynamics more at a small amplitude (figures 3 and 4), here on 8 s logs:

    >>> from iwp.rig import rigid_fit_error
    >>> round(rigid_fit_error("sine-60", duration=8.0, skip=2.0), 3)
    0.116
    >>> round(rigid_fit_error("sine-20", duration=8.0, skip=2.0), 3)
    0.378
    """
    rig = VirtualRig(truth, seed=seed)
    log = rig.run(name, **overrides)
    s = {**EXPERIMENTS[name].settings, **overrides}
    inp = open_loop_input(name, s)
    if inp is None:
        raise InputError(f"rigid_fit_error needs an experiment with an open-loop input, not {name!r}")
    rigid = Plant(rig.truth.lumped, model="compensated", coulomb_eps=rig.truth.coulomb_eps,
                  locked=bool(s.get("locked")))
    res = simulate(rigid, t_end=float(log.t[-1]), Ts=rig.truth.Ts, input=inp,
                   options=SimOptions(tolerances=Tolerances(rtol=RIG_RTOL, atol=RIG_ATOL)))
    m = log.t >= skip
    q4 = log.extra["true_q4"][m]
    return float(np.std(res.q4[m] - q4) / np.std(q4))
