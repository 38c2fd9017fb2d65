"""The ``iwp simulate`` task: build the input, simulate, write the log (and a figure).

The command line only parses its arguments and calls :func:`simulate_command`."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np

from ..checks import check_finite
from ..data import write_experiment
from ..errors import InputError, SimulationError
from ..files import FIGURE_SUFFIXES, LOG_SUFFIXES, check_output_file, write_all
from ..models.plant import Plant
from ..plotting import plot_simulation, savefig
from .inputs import make_input
from .simulate import simulate

__all__ = ["simulate_command", "physical_range_message"]

#: A pendulum faster than this many times the speed of a free swing from the upright has left
#: the physically possible range (no input of the rig can pump that much energy into it).
SPEED_MARGIN = 10.0


def physical_range_message(plant: Plant, q3: np.ndarray) -> str | None:
    """Why a run's pendulum speed is physically impossible, or None.

    A free swing from the upright reaches ``|q3| = 2 sqrt(p1)`` at the bottom
    (energy conservation of (4) without friction); a rig's pendulum stays
    within a few times that. Beyond :data:`SPEED_MARGIN` times, the parameter
    set is not a pendulum's (e.g. negative damping held only by the cubic term).
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


def simulate_command(*, params, model, controller, input_name, k1, k2, sampled, amplitude, omega, w0, tau, t_step,
                     x0, t0, t_end, Ts, feedforward, saturation, rtol, atol, out: Path, plot: Path | None,
                     force: bool) -> str:
    """Run one simulation as ``iwp simulate`` does; write the log (and figure); return a summary line.

    Both outputs are checked before the simulation and written together
    (nothing is written when anything fails). The log's format follows its
    extension (``.csv``/``.txt``, ``.parquet``/``.pq``, ``.mat``).
    """
    for name, value in (("amplitude", amplitude), ("omega", omega), ("w0", w0), ("tau", tau), ("t_step", t_step),
                        ("k1", k1), ("k2", k2)):
        check_finite(name, value)
    if controller is not None:
        if controller.lower() != "hopf":
            raise InputError(f"controller {controller!r}: unknown; choose one of: hopf", argument="controller")
        inp = make_input("hopf", k1=k1, k2=k2, Ts=Ts if sampled else None)
    else:
        inp = make_input(input_name or "zero", amplitude=amplitude, omega=omega, w0=w0, tau=tau, t_step=t_step)
    out = check_output_file(out, force=force, argument="out", suffixes=LOG_SUFFIXES)
    if plot is not None:
        plot = check_output_file(plot, force=force, argument="plot", suffixes=FIGURE_SUFFIXES)
        if plot.resolve() == out.resolve():
            raise InputError(f"plot {plot}: is the same file as --out", argument="plot")
    plant = Plant(params, model=model)
    res = simulate(plant, x0=x0, t0=t0, t_end=t_end, Ts=Ts, input=inp,
                   feedforward=True if feedforward else None, saturation=saturation, rtol=rtol, atol=atol)
    if not res.success:
        raise SimulationError(f"the simulation stopped at t = {res.t[-1]:g} s: {res.message}; nothing written")
    log = res.to_experiment()
    if not all(np.all(np.isfinite(c)) for c in log.as_columns().values()):
        raise SimulationError("the simulation gave NaN or inf; nothing written")
    note = physical_range_message(plant, res.q3)
    if note is not None:
        warnings.warn(note, UserWarning, stacklevel=2)
    writes = [(out, lambda tmp: write_experiment(log, tmp, format=LOG_SUFFIXES[out.suffix.lower()], force=True))]
    msg = (f"wrote {out} ({res.t.size} samples, t = {res.t[0]:g}..{res.t[-1]:g} s, "
           f"max |q1| = {abs(res.q1).max():.4g} rad)")
    if plot is not None:
        fig = plot_simulation(res)["figure"]
        writes.append((plot, lambda tmp: savefig(fig, tmp)))
        msg += f"; figure {plot}"
    write_all(writes)
    return msg
