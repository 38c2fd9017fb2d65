"""What a simulation returns: :class:`SimulationResult` and :class:`BatchResult`."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..data import ExperimentData, write_experiment
from ..models.plant import MODELS
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
        """Every signal of the run by name: ``t, q1..q4, u`` and ``v`` (the command) where it differs from ``u``."""
        cols = {"t": self.t, "q1": self.q1, "q2": self.q2, "q3": self.q3, "q4": self.q4, "u": self.u}
        if not np.array_equal(self.command, self.u):
            cols["v"] = self.command
        return cols

    def to_experiment(self):
        """The run as a log (:class:`~iwp.data.ExperimentData`) that iwp's readers and identification take.

        One input column, named as the model's input (``u``, or ``v`` for the
        raw models) and holding what reached the model (:attr:`command`, after
        the optional feedforward and saturation), so that replaying the log
        reproduces the run. Motor-disk runs carry ``pendulum: locked``.
        """
        info = MODELS[self.model]
        meta = {"source": "iwp simulate", "model": self.model}
        if info.input is not None and info.pendulum_locked:
            meta["pendulum"] = "locked"
        meta.update({str(k): str(v) for k, v in self.metadata.items()})
        x = self.x
        cols = dict(t=self.t, q1=x[:, 0], q2=x[:, 1], q3=x[:, 2], q4=x[:, 3])
        if info.input is not None:
            cols[info.input] = self.command
        return ExperimentData(**cols, metadata=meta, source="iwp simulate")

    def to_csv(self, path, *, force: bool = False):
        """Write the run as an iwp CSV (:meth:`to_experiment`, exact round trip); no overwrite without ``force``."""
        return write_experiment(self.to_experiment(), path, format="csv", force=force)

    def plot(self, **kw):
        """Plot the states and the input; see :func:`iwp.plotting.plot_simulation`."""
        from ..plotting import plot_simulation  # plotting only when asked: iwp.sim imports no matplotlib

        return plot_simulation(self, **kw)


@dataclass(frozen=True, eq=False)
class BatchResult:
    """The output of :func:`simulate_batch`.

    Attributes
    ----------
    t : ndarray, shape (n_out,)
        The output times [s] (those the summary runs over with ``store="summary"``).
    x : ndarray, shape (n_runs, n_out, n_states), or None
        States ``q1, q2, q3, q4`` [rad, rad, rad/s, rad/s] (belt models: and
        the belt's two states) at the output times (``store="samples"``).
    u, command : ndarray, shape (n_runs, n_out), or None
        The input ``u`` of (9) and the command applied after the feedforward
        (7)-(8) and the saturation [input units] (``store="samples"``).
    status : ndarray of int, shape (n_runs,)
        0 for a run that reached ``t_end``; else why it stopped (its samples
        after the failure are NaN).
    nfev : ndarray of int, shape (n_runs,)
        Evaluations of the right-hand side per run.
    x_final : ndarray, shape (n_runs, n_states)
        The state each run reached (at ``t_end`` when it succeeded) [rad, rad/s].
    summary : dict of str to ndarray, shape (n_runs, n_states), or None
        ``store="summary"``: ``min``, ``max``, ``mean`` and ``rms`` of each
        state over the output times (NaN for a failed run).
    store : str
        What was kept: ``"samples"``, ``"final"`` or ``"summary"``.
    """

    t: np.ndarray
    x: np.ndarray | None
    u: np.ndarray | None
    command: np.ndarray | None
    status: np.ndarray
    nfev: np.ndarray
    x_final: np.ndarray | None = None
    summary: dict | None = None
    store: str = "samples"

    @property
    def success(self) -> np.ndarray:
        """Per run: reached ``t_end``."""
        return self.status == ST_OK
