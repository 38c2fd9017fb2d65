"""The virtual rig as any rig of a rig description: its sensors, input, saturation, sample period and drive.

:class:`DescribedRig` runs a truth plant (model (6) with its dead zone, or
(9), with any :class:`~iwp.models.LumpedParameters`, Coulomb friction of
either joint and an input offset included) with the logged input of a rig
described by a :class:`~iwp.data.RigDescription`, and returns the columns
that rig would log, in its units (:mod:`iwp.rig.sensors`): the pendulum
angle (encoder counts, or an IMU in degrees with its zero anywhere and an
offset), the wheel's angle or speed (at the wheel or the motor shaft, at an
instant or as the mean over the period), the current, and the input as
logged (a controller's output before the driver saturates it, which the
plant sees clipped). Glitches can be injected where a real board makes
them: a first-sample spike of the mean speed, dropouts to 0, and jumps of
the pendulum angle. :func:`write_rig_csv` writes such a log, which
:func:`iwp.data.rig_log.read_rig_log` reads back; the tests run every path of
``iwp fit`` this way with known truth.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..checks import check_nonnegative, check_positive
from ..data.rig_description import RigDescription, load_rig
from ..errors import InputError
from ..files import atomic_write, prepare_output_file
from ..models.parameters import BeltParameters, LumpedParameters
from ..models.plant import Plant, plant_for_kind
from ..sim.inputs import Input, Sampled
from ..sim.options import SimOptions, Tolerances
from ..sim.simulate import simulate
from .run_settings import check_seed, prbs  # defined with the other input laws, exported here too
from .sensors import motor_current, pendulum_reading, time_reading, wheel_reading

__all__ = ["DescribedRig", "RigRun", "write_rig_csv", "prbs"]


@dataclass(frozen=True)
class RigRun:
    """One run of a :class:`DescribedRig`: the logged columns (rig units) and the truth behind them.

    Attributes
    ----------
    columns : dict of str to ndarray
        Column name of the rig -> logged values, in the rig's units.
    t : ndarray
        Sample times [s].
    x : ndarray, shape (N, 4)
        True states ``q1, q2, q3, q4`` at the samples [rad, rad/s].
    w : ndarray
        The model input the plant received (clipped, scaled, before the plant's offset).
    """

    columns: dict[str, np.ndarray]
    t: np.ndarray
    x: np.ndarray
    w: np.ndarray


@dataclass(frozen=True)
class DescribedRig:
    """A virtual rig that logs as the rig of ``rig`` does.

    Parameters
    ----------
    rig : RigDescription or path
        Needs ``sample_period``.
    params : LumpedParameters
        The truth, in the model input units of the description
        (``scale * (clip(x) - offset)`` of the logged ``x``). A dead zone
        (``v_dz_pos``/``v_dz_neg`` > 0) makes it model (6), else (9).
    q1_offset : float
        True zero error of the pendulum sensor [rad] (what ``pendulum.offset`` describes).
    noise_std : float
        Pendulum sensor noise [rad] before quantisation.
    seed : int
        Seed of the noise (``numpy.random.default_rng(seed)``): every run with the same seed draws the same noise,
        so a run is reproducible bitwise; give :meth:`run` its own ``seed`` for runs with independent noise.
    first_sample : float, optional
        The wheel speed the sensor logs at the first sample (its unit), e.g. 2345: the glitch of a
        board whose encoder was not reset.
    dropouts : tuple of int
        Samples at which the wheel speed (or angle) logs 0.
    jumps : tuple of (int, float)
        ``(sample, size)``: from that sample on the pendulum reading is off by ``size`` [rad] more (play).
    amps_per_accel : float
        Current per motor torque over ``I1_hat`` [A per rad s^-2] (:func:`~iwp.rig.sensors.motor_current`).
    p2_emf_fraction : float
        Share of ``p2`` that is back-emf (the rest is viscous friction) for the current.
    belt : BeltParameters, optional
        A belt drive's belt (15) between motor and wheel: the truth is then model
        ``"belt-full"`` ((4a) with (15)), whose disk is driven through the belt
        (``p2`` and ``p3`` do not enter; the belt's rigid limit gives them); its
        ratio ``N`` must be the description's ``drive.ratio``.
    """

    rig: RigDescription
    params: LumpedParameters
    q1_offset: float = 0.0
    noise_std: float = 0.0
    seed: int = 0
    first_sample: float | None = None
    dropouts: tuple[int, ...] = ()
    jumps: tuple[tuple[int, float], ...] = ()
    amps_per_accel: float = 0.05
    p2_emf_fraction: float = 0.8
    rtol: float = 1e-10
    belt: BeltParameters | None = None

    def __post_init__(self):
        object.__setattr__(self, "rig", load_rig(self.rig))
        if self.rig.sample_period is None:
            raise InputError("DescribedRig: the rig description needs 'sample_period'")
        if not isinstance(self.params, LumpedParameters):
            raise InputError(f"DescribedRig: params must be LumpedParameters, got {type(self.params).__name__}")
        self.params.check_physical("DescribedRig.params")
        check_nonnegative("noise_std", self.noise_std)
        check_seed(self.seed)
        if self.belt is not None:
            if not isinstance(self.belt, BeltParameters):
                raise InputError(f"DescribedRig: belt must be BeltParameters, got {type(self.belt).__name__}")
            if self.params.v_dz_pos > 0 or self.params.v_dz_neg > 0:
                raise InputError("DescribedRig: the belt model (15) takes the compensated input; give no dead zone")
            if not math.isclose(self.belt.N, self.rig.drive.ratio, rel_tol=1e-12):
                raise InputError(f"DescribedRig: belt.N = {self.belt.N:g} but the rig's drive.ratio is "
                                 f"{self.rig.drive.ratio:g}")

    @property
    def Ts(self) -> float:
        return float(self.rig.sample_period)

    def plant(self) -> Plant:
        """The truth plant: the belt model with a belt, model (6) with its dead zone when the parameters have one,
        else (9)."""
        p = self.params
        if self.belt is not None:
            return Plant(p, model="belt-full", belt=self.belt)
        dz = p.v_dz_pos > 0 or p.v_dz_neg > 0
        return Plant(p, model="raw", dead_zone=dz)

    def run(self, logged_input=None, *, duration: float, x0=None, kind: str = "free",
            seed: int | None = None, controller: Input | None = None) -> RigRun:
        """Run the rig and log as it logs.

        Parameters
        ----------
        logged_input : Input, array_like or None
            What the rig logs as its input (rig units, before saturation):
            an :mod:`iwp.sim.inputs` signal sampled every ``sample_period``,
            or one value per sample; None: no input (zero), e.g. a free swing.
        duration : float
            Length [s]; ``floor(duration / Ts) + 1`` samples.
        x0 : sequence of 4 floats, optional
            True initial state (default rest hanging down).
        kind : str
            The set-up (:data:`~iwp.models.plant.EXPERIMENT_KINDS`): ``"free"``,
            ``"clamped"`` (the pendulum clamped at 0), ``"wheel-locked"``
            (the wheel locked to the arm: the motor's input does nothing) or
            ``"closed-loop"`` (the input computed by ``controller``).
        seed : int, optional
            Seed of this run's noise (default the rig's ``seed``: every run of the rig draws the same noise).
        controller : Input, optional
            The law of a ``"closed-loop"`` run (an :mod:`iwp.sim.inputs`
            controller, e.g. :class:`~iwp.sim.inputs.HopfController`) on the
            true state, its output the logged input: the description's input
            must be the model's (scale 1, offset 0) and the law must stay
            within its limits.
        """
        Ts = self.Ts
        duration = check_positive("duration", duration)
        n = int(math.floor(duration / Ts + 1e-9)) + 1
        t = Ts * np.arange(n)
        ins = self.rig.input
        if (kind == "closed-loop") != (controller is not None):
            raise InputError("DescribedRig.run: a closed-loop run needs its controller, and only a closed-loop run "
                             "takes one", argument="controller")
        if controller is not None:
            if logged_input is not None:
                raise InputError("DescribedRig.run: a closed-loop run logs its controller's output; give no "
                                 "logged_input", argument="logged_input")
            if ins is None or ins.scale != 1.0 or ins.offset != 0.0:
                raise InputError("DescribedRig.run: a closed-loop run needs a logged input in the model's units "
                                 "(scale 1, offset 0)", argument="controller")
        if logged_input is None:
            x_log = np.zeros(n)
        elif isinstance(logged_input, Input):
            x_log = np.array([logged_input.evaluate(tk) for tk in t])
        else:
            x_log = np.asarray(logged_input, dtype=float).ravel()
            if x_log.size != n:
                raise InputError(f"logged_input has {x_log.size} values for {n} samples")
        if ins is None:
            if logged_input is not None:
                raise InputError("the rig description logs no input; give logged_input=None")
            w = np.zeros(n)
        else:
            xc = np.clip(x_log, *ins.limits) if ins.limits is not None else x_log
            w = ins.scale * (xc - ins.offset)
        x0a = np.zeros(4) if x0 is None else np.asarray(x0, dtype=float)
        plant = plant_for_kind(self.plant(), kind)
        if plant.wheel_held:
            x0a[1] = x0a[3] = 0.0
        if plant.n_states > 4:  # the belt's stretch and play output start relaxed
            x0a = np.concatenate([x0a, np.zeros(plant.n_states - 4)])
        drive = controller if controller is not None else None if plant.wheel_held else Sampled(w, Ts, 0.0)
        res = simulate(plant, x0=x0a, t_end=(n - 1) * Ts, Ts=Ts, input=drive,
                       options=SimOptions(tolerances=Tolerances(rtol=self.rtol, atol=self.rtol)))
        X = np.asarray(res.x, dtype=float)[:n, :4]
        if controller is not None:  # the rig logs the law's output
            w = x_log = np.asarray(res.u, dtype=float)[:n]
            lo, hi = ins.limits if ins.limits is not None else (-math.inf, math.inf)
            if not np.all((x_log >= lo) & (x_log <= hi)):
                raise InputError(f"DescribedRig.run: the controller's output spans [{x_log.min():.4g}, "
                                 f"{x_log.max():.4g}], beyond the input's limits [{lo:g}, {hi:g}]",
                                 argument="controller")
        rng = np.random.default_rng(self.seed if seed is None else check_seed(seed))
        noise = rng.normal(0.0, self.noise_std, n) if self.noise_std > 0 else None
        rig = self.rig
        off = np.full(n, float(self.q1_offset))
        for k, size in self.jumps:
            off[int(k):] += size
        cols: dict[str, np.ndarray] = {}
        if rig.time.column is not None:
            cols[rig.time.column] = time_reading(t, rig)
        cols[rig.pendulum.column] = pendulum_reading(X[:, 0] + off, rig.pendulum, noise=noise)
        wy = wheel_reading(X[:, 1], X[:, 3], rig.wheel, ratio=rig.drive.ratio, Ts=Ts, first_sample=self.first_sample)
        for k in self.dropouts:
            wy[int(k)] = 0.0
        cols[rig.wheel.column] = wy
        if rig.current is not None:
            p = self.params
            cols[rig.current.column] = motor_current(w + p.u_offset, X[:, 3], p3=p.p3,
                                                     p2_emf=self.p2_emf_fraction * p.p2,
                                                     amps_per_accel=self.amps_per_accel, unit=rig.current.unit)
        if ins is not None:
            cols[ins.column] = x_log
        return RigRun(cols, t, X, w)


def write_rig_csv(run: RigRun, path: str | os.PathLike, *, force: bool = False,
                  metadata: dict | None = None) -> Path:
    """Write a run's columns as the rig's CSV log (header of the rig's names, one row per sample).

    Parameters
    ----------
    run : RigRun
        The run of :meth:`DescribedRig.run`, its columns in the rig's units.
    path : str or PathLike
        The CSV file.
    force : bool
        Overwrite an existing file.
    metadata : dict, optional
        ``# key: value`` lines written before the header.

    Returns
    -------
    Path
        The file written.
    """
    p = prepare_output_file(path, force=force)
    names = list(run.columns)
    data = np.column_stack([run.columns[k] for k in names])

    def write(tmp: Path) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            for k, v in (metadata or {}).items():
                fh.write(f"# {k}: {v}\n")
            fh.write(",".join(names) + "\n")
            np.savetxt(fh, data, delimiter=",", fmt="%.17g")

    return atomic_write(p, write, force=force)
