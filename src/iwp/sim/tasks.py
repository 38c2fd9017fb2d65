"""The ``iwp simulate`` task: build the input, simulate, write the log (and a figure).

The command line only parses its arguments and calls :func:`simulate_command`."""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError
from ..files import prepare_output_file
from ..models.plant import Plant
from .inputs import make_input
from .simulate import simulate


def simulate_command(*, params, model, controller, input_name, k1, k2, sampled, amplitude, omega, w0, tau, t_step,
                     x0, t0, t_end, Ts, feedforward, saturation, rtol, atol, out: Path, plot: Path | None,
                     force: bool) -> str:
    """Run one simulation as ``iwp simulate`` does; write the CSV (and figure); return a summary line."""
    if controller is not None:
        if controller.lower() != "hopf":
            raise InputError(f"unknown controller {controller!r}; choose one of: hopf")
        inp = make_input("hopf", k1=k1, k2=k2, Ts=Ts if sampled else None)
    else:
        inp = make_input(input_name or "zero", amplitude=amplitude, omega=omega, w0=w0, tau=tau, t_step=t_step)
    # check both outputs before the (possibly long) simulation
    prepare_output_file(out, force=force)
    if plot is not None:
        prepare_output_file(plot, force=force)
    res = simulate(Plant(params, model=model), x0=x0, t0=t0, t_end=t_end, Ts=Ts, input=inp,
                   feedforward=True if feedforward else None, saturation=saturation, rtol=rtol, atol=atol)
    res.to_csv(out, force=True)
    msg = (f"wrote {out} ({res.t.size} samples, t = {res.t[0]:g}..{res.t[-1]:g} s, "
           f"max |q1| = {abs(res.q1).max():.4g} rad)")
    if plot is not None:
        from ..plotting import plot_simulation, savefig

        h = plot_simulation(res)
        savefig(h["figure"], plot)
        msg += f"; figure {plot}"
    return msg
