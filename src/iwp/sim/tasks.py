"""The ``iwp simulate`` task: build the input, simulate, write the log (and a figure).

The command line parses its arguments into one :class:`SimulationTask` and calls
:func:`write_simulation`."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from ..data import write_experiment
from ..errors import InputError, SimulationError
from ..files import FIGURE_SUFFIXES, LOG_SUFFIXES, check_output_file, write_all
from ..models.plant import Plant
from .options import CommandChain, SimOptions, Tolerances
from .result import SimulationResult
from .simulate import simulate
from .uncertainty import BandOptions, ParameterUncertainty, prediction_band

__all__ = ["SimulationTask", "write_simulation", "physical_range_message"]

#: A pendulum faster than this many times the speed of a free swing from the upright has left
#: the physically possible range (no input of the rig can pump that much energy into it).
SPEED_MARGIN = 10.0


def physical_range_message(plant: Plant, q3: np.ndarray) -> str | None:
    """Why a run's pendulum speed is physically impossible, or None.

    A free swing from the upright reaches ``|q3| = 2 sqrt(p1)`` at the bottom
    (energy conservation of (4) without friction); a rig's pendulum stays
    within a few times that. Beyond :data:`SPEED_MARGIN` times, the parameter
    set is not a pendulum's (e.g. negative damping held only by the cubic term).

    Parameters
    ----------
    plant : Plant
        The simulated plant (its ``p1`` [1/s^2]).
    q3 : ndarray
        The run's pendulum speed [rad/s].

    Returns
    -------
    str or None
        The message, or None when the speed is within range (or ``p1`` is not positive).
    """
    p1 = plant.lumped.p1
    if not (p1 > 0.0):
        return None
    reach = 2.0 * math.sqrt(p1)
    top = float(np.max(np.abs(q3))) if q3.size else 0.0
    if top > SPEED_MARGIN * reach:
        return (f"the pendulum reaches |q3| = {top:.3g} rad/s, {top / reach:.0f} times the speed of a free swing "
                f"from the upright ({reach:.3g} rad/s): the parameter set leaves the physically possible range "
                "(check the friction signs and the input's units)")
    return None


@dataclass(frozen=True)
class SimulationTask:
    """One simulation as ``iwp simulate`` runs it: the plant, its input, the span and the tolerances.

    Parameters
    ----------
    plant : Plant
    command : CommandChain
        The input (an open-loop input or a controller, :func:`~iwp.sim.inputs.make_input`; None: zero),
        the dead-zone feedforward (7)-(8) (:class:`~iwp.sim.options.Feedforward`, e.g.
        ``Feedforward.of_plant(plant)``) and the saturation [input units].
    x0 : sequence of float, optional
        Initial state ``q1, q2, q3, q4`` [rad, rad, rad/s, rad/s] (default rest).
    t0, t_end, Ts : float
        Initial and final time, output sample time [s].
    tolerances : Tolerances
        Of the integration (``rtol`` [-], ``atol`` [state units], ``max_step`` [s], ``max_steps``).
    uncertainty : ParameterUncertainty, optional
        The fit's parameters and covariance (:func:`~iwp.sim.uncertainty.load_uncertainty`): with ``band``,
        the 95 % parameter and prediction bands are computed and written beside the log.
    band : BandOptions, optional
        How the band is computed (:func:`~iwp.sim.uncertainty.prediction_band`: linearised, or by Monte Carlo
        with its draws and seed); None: no band.
    """

    plant: Plant
    command: CommandChain = field(default_factory=CommandChain)
    x0: Sequence[float] | None = None
    t0: float = 0.0
    t_end: float = 10.0
    Ts: float = 0.005
    tolerances: Tolerances = field(default_factory=Tolerances)
    uncertainty: ParameterUncertainty | None = None
    band: BandOptions | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.command, CommandChain):
            raise InputError(f"command must be an iwp.sim.CommandChain, got {type(self.command).__name__}",
                             argument="command")
        if not isinstance(self.tolerances, Tolerances):
            raise InputError(f"tolerances must be an iwp.sim.Tolerances, got {type(self.tolerances).__name__}",
                             argument="tolerances")
        if self.band is not None and not isinstance(self.band, BandOptions):
            raise InputError(f"band must be an iwp.sim.uncertainty.BandOptions or None, got {type(self.band).__name__}",
                             argument="band")
        if self.band is not None and self.uncertainty is None:
            raise InputError("band needs the fit's uncertainty: the parameters.json that iwp fit writes",
                             argument="band")

    def run(self) -> SimulationResult:
        """Simulate; a run that stops short or gives NaN is an error (nothing to write), an unphysical one a warning."""
        c, tol = self.command, self.tolerances
        res = simulate(self.plant, input=c.input, x0=self.x0, t0=self.t0, t_end=self.t_end, Ts=self.Ts,
                       options=SimOptions(feedforward=c.feedforward, saturation=c.saturation, tolerances=tol))
        if not res.success:
            raise SimulationError(f"the simulation stopped at t = {res.t[-1]:g} s: {res.message}; nothing written")
        if not all(np.all(np.isfinite(c)) for c in res.to_experiment().as_columns().values()):
            raise SimulationError("the simulation gave NaN or inf; nothing written")
        note = physical_range_message(self.plant, res.q3)
        if note is not None:
            warnings.warn(note, UserWarning, stacklevel=2)
        return res


def write_simulation(task: SimulationTask, out, *, plot=None, force: bool = False) -> str:
    """Run ``task`` and write its log (and figure); return a summary line.

    Both outputs are checked before the simulation and written together
    (nothing is written when anything fails). The log's format follows its
    extension (``.csv``/``.txt``, ``.parquet``/``.pq``, ``.mat``).

    Parameters
    ----------
    task : SimulationTask
        The run (with its prediction band when ``task.band`` is set).
    out : str or PathLike
        The log to write.
    plot : str or PathLike, optional
        The figure to write beside it.
    force : bool
        Replace existing files.

    Returns
    -------
    str
        The summary line ``iwp simulate`` prints.

    Raises
    ------
    InputError
        An output that exists without ``force``, of an unknown format, or the figure on the log's path.
    """
    out = check_output_file(out, force=force, argument="out", suffixes=LOG_SUFFIXES)
    if plot is not None:
        plot = check_output_file(plot, force=force, argument="plot", suffixes=FIGURE_SUFFIXES)
        if plot.resolve() == out.resolve():
            raise InputError(f"plot {plot}: is the same file as --out", argument="plot")
    res = task.run()
    log = res.to_experiment()
    band = None
    if task.band is not None:
        band = prediction_band(task.plant, task.uncertainty, input=task.command.input, x0=task.x0, t_eval=res.t,
                               signals=tuple(s for s in ("q1", "q2", "q3", "q4") if s in task.plant.outputs),
                               options=task.band)
        log = replace(log, extra={**log.extra, **band.columns()},
                      metadata={**log.metadata, "band": f"{band.method}, 95 %" + (
                          f", {band.draws} draws" if band.draws else "")})
    writes = [(out, lambda tmp: write_experiment(log, tmp, format=LOG_SUFFIXES[out.suffix.lower()], force=True))]
    msg = (f"wrote {out} ({res.t.size} samples, t = {res.t[0]:g}..{res.t[-1]:g} s, "
           f"max |q1| = {abs(res.q1).max():.4g} rad)")
    if plot is not None:
        from ..plotting import plot_simulation, savefig  # plotting only when a figure is asked for

        fig = plot_simulation(res, band=band)["figure"]
        writes.append((plot, lambda tmp: savefig(fig, tmp)))
        msg += f"; figure {plot}"
    write_all(writes, force=force)
    return msg
