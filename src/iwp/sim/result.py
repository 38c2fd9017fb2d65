"""What a simulation returns: :class:`SimulationResult` and :class:`BatchResult`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..files import prepare_output_file
from .engine import ST_OK

__all__ = ["SimulationResult", "BatchResult"]


@dataclass(frozen=True, eq=False)
class SimulationResult:
    """The output of :func:`simulate`.

    Attributes
    ----------
    t : ndarray, shape (n,)
        Output times [s].
    x : ndarray, shape (n, 4) or (n, 6)
        States ``[q1, q2, q3, q4 (, delta, w)]`` [rad, rad/s].
    u : ndarray, shape (n,)
        The ideal input (the signal or controller output) [input units].
    command : ndarray, shape (n,)
        What reached the model after the optional feedforward (7)-(8) and
        saturation (``v`` for the raw models) [input units].

        For a continuous input (signal or Hopf law) ``u`` and ``command``
        are functions of ``t`` and ``x``; they are computed on first access,
        so that a caller who only needs the states does not pay for them.
    model : str
    success : bool
    status : int
        0: reached ``t_end``; 1: diverged; 2: step too small; 3: step limit.
    message : str
    nfev : int
        Right-hand-side evaluations.
    n_steps, n_rejected : int
    """

    t: np.ndarray
    x: np.ndarray
    inputs: "tuple[np.ndarray, np.ndarray] | Callable" = field(repr=False)
    model: str
    success: bool
    status: int
    message: str
    nfev: int = 0
    n_steps: int = 0
    n_rejected: int = 0
    metadata: dict = field(default_factory=dict)

    def _input_arrays(self) -> tuple[np.ndarray, np.ndarray]:
        v = self.inputs
        if callable(v):
            v = v(self.t, self.x)
            object.__setattr__(self, "inputs", v)
        return v

    @property
    def u(self) -> np.ndarray:
        """The ideal input [input units]."""
        return self._input_arrays()[0]

    @property
    def command(self) -> np.ndarray:
        """The command after feedforward and saturation [input units]."""
        return self._input_arrays()[1]

    @property
    def q1(self) -> np.ndarray:
        """Pendulum angle [rad]."""
        return self.x[:, 0]

    @property
    def q2(self) -> np.ndarray:
        """Disk angle relative to the arm [rad]."""
        return self.x[:, 1]

    @property
    def q3(self) -> np.ndarray:
        """Pendulum velocity [rad/s]."""
        return self.x[:, 2]

    @property
    def q4(self) -> np.ndarray:
        """Disk velocity relative to the arm [rad/s]."""
        return self.x[:, 3]

    def columns(self) -> dict[str, np.ndarray]:
        """The columns of the CSV: ``t, q1, q2, q3, q4, u`` (and ``v`` if it differs from ``u``)."""
        cols = {"t": self.t, "q1": self.q1, "q2": self.q2, "q3": self.q3, "q4": self.q4, "u": self.u}
        if not np.array_equal(self.command, self.u):
            cols["v"] = self.command
        return cols

    def to_csv(self, path, *, force: bool = False) -> "object":
        """Write the result as CSV with the header ``t,q1,q2,q3,q4,u`` (+ ``v``).

        Metadata lines (``# key: value``) come first. Refuses to overwrite
        an existing file unless ``force``.
        """
        p = prepare_output_file(path, force=force)
        cols = self.columns()
        data = np.column_stack(list(cols.values()))
        meta = {"source": "iwp simulate", "model": self.model, **self.metadata}
        header = "".join(f"# {k}: {v}\n" for k, v in meta.items()) + ",".join(cols)
        np.savetxt(p, data, delimiter=",", header=header, comments="", fmt="%.17g")
        return p

    def plot(self, **kw):
        """Plot the states and the input; see :func:`iwp.plotting.plot_simulation`."""
        from ..plotting import plot_simulation

        return plot_simulation(self, **kw)


@dataclass(frozen=True, eq=False)
class BatchResult:
    """The output of :func:`simulate_batch`.

    Attributes
    ----------
    t : ndarray, shape (n_out,)
    x : ndarray, shape (n_runs, n_out, n_states)
    u, command : ndarray, shape (n_runs, n_out)
    status : ndarray of int, shape (n_runs,)
    nfev : ndarray of int, shape (n_runs,)
    """

    t: np.ndarray
    x: np.ndarray
    u: np.ndarray
    command: np.ndarray
    status: np.ndarray
    nfev: np.ndarray

    @property
    def success(self) -> np.ndarray:
        """Per run: reached ``t_end``."""
        return self.status == ST_OK
