"""The virtual rig: the truth plant run through the rig's sensors, sampling, driver and compensator.

Users without a rig, and every test, need experiment data that behaves like
the paper's rig. :class:`VirtualRig` runs the paper's experiments (section 5,
:mod:`iwp.rig.experiments`) on the truth plant (:mod:`iwp.rig.truth`) and
returns what the rig would log: quantised encoder positions sampled every
``Ts``, and the input. The logs are :class:`iwp.data.ExperimentData` (time
series) or :class:`iwp.data.StaticCurve` (figure 2), in the data format that
the rest of iwp reads.

The rig's sensors and actuator
------------------------------
* Optical encoders with ``counts_per_rev = 2000`` (318.31 counts/rad,
  section 5): the logged positions are ``round((q + noise) / step) * step``
  with ``step = 2 pi / counts_per_rev`` exactly (rounding to the nearest
  count, a mid-tread quantiser: zero reads zero and the error is within
  ``+-step/2``; :func:`iwp.models.encoder.quantize`).
* Optional Gaussian measurement noise of standard deviation ``noise_std``
  [rad], added before quantisation, drawn from
  ``numpy.random.default_rng(seed)``: a seed makes every run bitwise
  identical.
* Sampling every ``Ts = 5 ms``; digital controllers run at the same rate,
  see only the quantised positions and hold their output (zero-order hold).
* Input saturation: the driver command ``v`` is clipped to ``+-saturation``.
* Dead-zone compensation (eq. (7)-(8)) is done by the rig's software with
  the paper's ``v_dz = 31`` on both sides: it does *not* know the truth's
  asymmetric thresholds.

What a log contains
-------------------
``t``, the measured ``q1``, ``q2`` and the input: ``u`` (the ideal input) for
compensated experiments, ``v`` (the raw driver input) for uncompensated
ones. No velocities are logged (a real rig has none; differentiate the
positions, as the paper does). For comparison and tests only, the
noise-free, unquantised states of the truth plant are added as extra
columns ``true_q1, true_q2, true_q3, true_q4`` [rad, rad/s]; compensated
logs also carry the driver command after compensation and saturation as
``v_command``. Metadata (``# key: value``) record the experiment, the seed,
the input, the compensation and the truth as one-line JSON.
"""

from __future__ import annotations

import json
import math
from typing import Callable, Mapping

import numpy as np

from ..checks import check_finite, check_nonnegative, check_positive, check_samples
from ..data import ExperimentData, StaticCurve
from ..data.plausibility import MAX_INPUT
from ..errors import InputError
from ..models.encoder import quantize
from ..sim.inputs import CallableController, Constant, Input
from ..sim.options import Feedforward, SimOptions, Tolerances
from ..sim.simulate import simulate
from .controller import EncoderHopfController
from .experiments import (
    PAPER_V_DZ,
    ExperimentSpec,
    RunKind,
    experiment_spec,
    list_experiments,
)
from .run_settings import check_seed, compensation_thresholds, initial_state, law_input
from .truth import RigTruth, check_noise, default_truth

__all__ = ["VirtualRig", "run_experiment", "RIG_RTOL", "RIG_ATOL", "STATIC_WINDOW"]

#: Integration tolerances of the truth plant (the belt play makes it non-smooth).
RIG_RTOL = 1e-8
#: Absolute integration tolerance of the truth plant, per state [rad, rad/s].
RIG_ATOL = 1e-8
#: Window over which the static curves fit the disk velocity [s].
STATIC_WINDOW = 1.0


def _rig_options(pair: tuple[float, float] | None, saturation: float | None) -> SimOptions:
    """The truth plant's simulation options: the feedforward thresholds ``pair`` and the saturation [input units]."""
    return SimOptions(feedforward=None if pair is None else Feedforward(*pair), saturation=saturation,
                      tolerances=Tolerances(rtol=RIG_RTOL, atol=RIG_ATOL))




class VirtualRig:
    """The virtual inertia wheel pendulum rig.

    Parameters
    ----------
    truth : RigTruth, optional
        The truth plant and sensors (default: :func:`default_truth`).
    seed : int
        Seed of the measurement noise (``numpy.random.default_rng``); runs
        with the same truth, seed and options are bitwise identical.

    Examples
    --------
    >>> rig = VirtualRig(seed=1)
    >>> log = rig.run("sine-60", duration=5.0)       # ExperimentData
    >>> curve = rig.run("static-curve")               # StaticCurve
    >>> write_experiment(log, "sine60.csv")
    """

    def __init__(self, truth: RigTruth | None = None, seed: int = 0):
        if truth is None:
            truth = default_truth()
        if not isinstance(truth, RigTruth):
            raise InputError(f"truth must be a RigTruth, got {type(truth).__name__}")
        self.truth = truth
        self.seed = check_seed(seed)

    def __repr__(self) -> str:
        return f"VirtualRig(seed={self.seed}, model={self.truth.model!r})"

    # ------------------------------------------------------------------
    @staticmethod
    def list_experiments() -> list[ExperimentSpec]:
        """The paper's experiments (see :func:`iwp.rig.list_experiments`)."""
        return list_experiments()

    def run(self, name: str, **overrides):
        """Run one of the paper's experiments.

        Parameters
        ----------
        name : str
            One of :func:`iwp.rig.list_experiments` (``iwp rig list``).
        **overrides
            Only those the experiment lists in ``options``:

            amplitude : float
                Input amplitude [input units] (static curves: the largest
                ``|v|`` or ``|u|`` of the sweep).
            step : float
                Static curves: spacing of the input values [input units].
            duration : float
                Length of the log [s] (static curves: how long each input is
                held before the velocity is read [s], >= 2).
            seed : int
                Noise seed (default: the rig's).
            noise_std : float
                Position noise [rad] (default: the truth's).
            k1, k2 : float
                Hopf gains [input units s/rad, s^3/rad^3].
            x0 : float or sequence of 4 floats
                Initial ``q1`` or ``[q1, q2, q3, q4]`` [rad, rad/s].
            v_dz : float or (float, float), or None
                Thresholds of the rig's dead-zone compensation (7)-(8);
                ``None`` switches it off.
            filter_tau : float
                Time constant of the velocity filter of the controller [s].

        Returns
        -------
        ExperimentData or StaticCurve

        Raises
        ------
        InputError
            Unknown experiment (the message lists the valid names), an
            option the experiment does not take, or a bad value.

        Notes
        -----
        The experiment runs as its kind says (:attr:`ExperimentSpec.kind`: open loop with its input law,
        static curve, release or closed loop; clamped or free), whatever its name.
        The experiment runs on the truth of its session
        (:attr:`ExperimentSpec.session`, :meth:`RigTruth.for_session`); the
        log's metadata ``truth`` is that session's truth.
        """
        spec = experiment_spec(name)
        bad = sorted(set(overrides) - set(spec.options))
        if bad:
            raise InputError(
                f"experiment {name!r} does not take {bad[0]!r}; it takes: {', '.join(spec.options)}")
        session_truth = self.truth.for_session(spec.session)
        if session_truth is not self.truth:  # the truth of the experiment's session (RigTruth.resistance_ratio)
            return VirtualRig(session_truth, seed=self.seed).run(name, **overrides)
        s = dict(spec.settings)
        s.update({k: v for k, v in overrides.items()})
        seed = self.seed if overrides.get("seed") is None else check_seed(overrides["seed"])
        noise = self.truth.noise_std if overrides.get("noise_std") is None else check_noise(overrides["noise_std"])
        if "amplitude" in s and s["amplitude"] is not None:
            a = check_finite("amplitude", s["amplitude"])
            if abs(a) > MAX_INPUT:
                raise InputError(f"amplitude = {a:g}: beyond any rig's input (|amplitude| <= {MAX_INPUT:g}); the "
                                 "driver saturates far below", argument="amplitude")
        kind = spec.kind
        if kind.run is RunKind.STATIC_CURVE:
            return self._static_curve(spec, s, seed, noise)
        duration = check_positive("duration", s["duration"])
        v_dz = compensation_thresholds(s.get("v_dz"))
        meta = {"experiment": name, "reference": spec.reference, "description": spec.description,
                "session": spec.session}
        x0 = initial_state(s["x0"]) if "x0" in s else None
        if kind.run is RunKind.RELEASE:  # the motor off: no compensation, no input logged
            return self.record(None, duration=duration, x0=x0, locked=kind.locked, v_dz=None, seed=seed,
                               noise_std=noise, metadata=meta, log_input=None)
        if kind.run is RunKind.CLOSED_LOOP:
            k1 = check_finite("k1", s["k1"])
            k2 = check_finite("k2", s["k2"])
            tau = check_nonnegative("filter_tau", s["filter_tau"])
            ctrl = EncoderHopfController(k1, k2, self.truth.Ts, tau)
            meta.update(k1=repr(k1), k2=repr(k2), filter_tau=repr(tau),
                        controller="u = k1 q3^ + k2 q3^3, q3^ = first-order filtered backward difference of the "
                                   "measured q1, sampled every Ts and held")
            return self.record(None, controller=ctrl, duration=duration, x0=x0, locked=kind.locked, v_dz=v_dz,
                               seed=seed, noise_std=noise, metadata=meta)
        inp = law_input(kind.law, s, self.truth.Ts)
        if not isinstance(inp, Input):
            raise InputError(f"experiment {name!r}: the virtual rig simulates sine and chirp inputs, not "
                             f"{kind.law.value}")
        return self.record(inp, duration=duration, x0=x0, locked=kind.locked, v_dz=v_dz, seed=seed,
                           noise_std=noise, metadata=meta)

    # ------------------------------------------------------------------
    def record(
        self,
        input: Input | None = None,
        *,
        controller: Callable[[float, np.ndarray], float] | None = None,
        duration: float,
        x0=None,
        locked: bool = False,
        v_dz=(PAPER_V_DZ, PAPER_V_DZ),
        seed: int | None = None,
        noise_std: float | None = None,
        metadata: Mapping[str, str] | None = None,
        log_input: str | None = "auto",
    ) -> ExperimentData:
        """Run the truth plant with any input or digital controller and log it as the rig does.

        Parameters
        ----------
        input : iwp.sim.inputs signal, optional
            Open-loop ideal input ``u(t)`` (or ``v(t)`` when ``v_dz`` is None)
            [input units]. ``None``: zero.
        controller : callable, optional
            Digital controller ``controller(t, y) -> u`` called every ``Ts``
            with the measured (noisy, quantised) positions ``y = [q1, q2]``
            [rad]; its output is held until the next sample. Exclusive with
            ``input``.
        duration : float
            Length of the log [s]; the log has ``floor(duration/Ts) + 1`` samples.
        x0 : float or sequence of 4 floats, optional
            Initial ``q1`` or ``[q1, q2, q3, q4]`` of the truth (belt relaxed).
            Default: rest at the bottom.
        locked : bool
            Clamp the pendulum at ``q1 = q3 = 0`` (section 5.1).
        v_dz : float, (float, float) or None
            Thresholds of the rig's feedforward (7)-(8); default the paper's
            31. ``None``: no compensation, the input is the raw ``v``.
        seed : int, optional
            Noise seed (default: the rig's).
        noise_std : float, optional
            Position noise [rad] (default: the truth's).
        metadata : dict, optional
            Extra metadata entries.
        log_input : {'auto', 'u', 'v', None}
            The name of the logged input: ``'auto'`` logs ``u`` when
            compensated and ``v`` otherwise; ``None`` logs no input (the
            iwp convention for a free pendulum with the motor off).

        Returns
        -------
        ExperimentData
        """
        truth = self.truth
        duration = check_positive("duration", duration)
        if duration < 10 * truth.Ts:
            raise InputError(f"duration must be at least 10 samples ({10 * truth.Ts:g} s), got {duration!r} s")
        seed = self.seed if seed is None else check_seed(seed)
        noise = truth.noise_std if noise_std is None else check_noise(noise_std)
        pair = compensation_thresholds(v_dz)
        if input is not None and controller is not None:
            raise InputError("give either input or controller, not both")
        if controller is not None and not callable(controller):
            raise InputError(f"controller must be callable, got {type(controller).__name__}")
        x = np.zeros(4) if x0 is None else initial_state(x0)
        if locked and (x[0] != 0.0 or x[2] != 0.0):
            raise InputError(f"a locked pendulum starts at q1 = q3 = 0, got x0 = {x.tolist()}")

        n = check_samples(np.floor(duration / truth.Ts + 1e-9) + 1.0, argument="duration",
                          what=f"duration {duration:.6g} s at Ts = {truth.Ts:g} s")
        rng = np.random.default_rng(seed)
        noise_arr = rng.normal(0.0, noise, size=(n, 2)) if noise > 0 else np.zeros((n, 2))
        step = truth.step
        seen: dict[int, np.ndarray] = {}
        sim_input = input
        if controller is not None:
            Ts = truth.Ts

            def sampled(t: float, xs: np.ndarray) -> float:
                k = int(round(t / Ts))
                y = quantize(xs[:2] + noise_arr[min(k, n - 1)], step)
                seen[k] = y
                return controller(t, y.copy())

            sim_input = CallableController(sampled, Ts=Ts)
        # the belt starts relaxed: its states (delta, w) are 0
        res = simulate(truth.plant(locked=locked), x0=x, t_end=(n - 1) * truth.Ts, Ts=truth.Ts, input=sim_input,
                       options=_rig_options(pair, truth.saturation))
        X = res.x
        meas = quantize(X[:, :2] + noise_arr[: X.shape[0]], step)
        for k, y in seen.items():  # what the controller saw is what the rig logged
            if k < meas.shape[0]:
                meas[k] = y
        compensated = pair is not None
        if log_input not in ("auto", "u", "v", None):
            raise InputError(f"log_input must be 'auto', 'u', 'v' or None, got {log_input!r}")
        name = ("u" if compensated else "v") if log_input == "auto" else log_input
        extra = {f"true_q{i + 1}": X[:, i].copy() for i in range(4)}
        if compensated:
            extra["v_command"] = res.command.copy()
        inputs = {} if name is None else {name: res.u.copy() if compensated else res.command.copy()}
        meta = {k: str(v) for k, v in (metadata or {}).items()}
        fixed = {
            "source": "iwp virtual rig",
            "seed": str(seed),
            "input": "controller" if controller is not None else (input.describe() if input is not None else "zero"),
            "compensated": "yes" if compensated else ("no" if name is not None else "no (motor off, v = 0)"),
            "v_dz_pos": repr(pair[0]) if compensated else "",
            "v_dz_neg": repr(pair[1]) if compensated else "",
            "pendulum": "locked" if locked else "free",
            "x0": json.dumps([float(e) for e in x]),
            "duration": repr(float(res.t[-1])),
            "Ts": repr(truth.Ts),
            "counts_per_rev": str(truth.counts_per_rev),
            "noise_std": repr(noise),
            "saturation": repr(truth.saturation),
            "columns": "q1, q2: quantised encoder positions [rad]; true_q1..true_q4: noise-free truth states "
                       "[rad, rad/s], not available on a real rig"
                       + ("; v_command: driver command after compensation and saturation" if compensated else ""),
            "truth": truth.replace(noise_std=noise).to_json_line(),
            # how the input acted between samples (iwp identify reads it): held by a controller or a sampled
            # array, else evaluated continuously (the twin's chirps and sines)
            "input_hold": "zoh" if controller is not None or (input is not None and input.sampled_period)
            else "continuous",
        }
        if not compensated:
            del fixed["v_dz_pos"], fixed["v_dz_neg"]
        for k, v in fixed.items():
            meta.setdefault(k, v)
        return ExperimentData(t=res.t, q1=meas[:, 0], q2=meas[:, 1], extra=extra, metadata=meta,
                              source=f"virtual rig: {meta.get('experiment', 'record')}", **inputs)

    # ------------------------------------------------------------------
    def _static_curve(self, spec: ExperimentSpec, s: dict, seed: int, noise: float) -> StaticCurve:
        """Figure 2: hold each input from rest, read the steady disk velocity from the measured q2."""
        truth = self.truth
        amplitude = check_positive("amplitude", s["amplitude"])
        step_in = check_positive("step", s["step"])
        hold = check_finite("duration", s["duration"])
        if hold < 2 * STATIC_WINDOW:
            raise InputError(f"duration (hold time per point) must be >= {2 * STATIC_WINDOW:g} s, got {hold!r} s")
        m = int(math.floor(amplitude / step_in + 1e-9))
        if m > 10_000:
            raise InputError(f"amplitude/step gives {2 * m + 1} points; at most 20001 are allowed")
        grid = step_in * np.arange(-m, m + 1)
        compensated = spec.kind.compensated
        pair = compensation_thresholds(s.get("v_dz")) if compensated else None
        if compensated and pair is None:
            raise InputError(f"{spec.name} needs v_dz (use static-curve for no compensation)")
        rng = np.random.default_rng(seed)
        Ts = truth.Ts
        n = check_samples(np.floor(hold / Ts + 1e-9) + 1.0, argument="duration",
                          what=f"duration {hold:.6g} s per point at Ts = {Ts:g} s")
        check_samples(float(n) * grid.size, argument=("duration", "amplitude", "step"),
                      what=f"{grid.size} points of {n} samples")
        t = Ts * np.arange(n)
        win = t >= t[-1] - STATIC_WINDOW - 1e-9
        plant = truth.plant(locked=True)
        q4 = np.empty(grid.size)
        for i, val in enumerate(grid):
            res = simulate(plant, t_end=(n - 1) * Ts, Ts=Ts, input=Constant(val),
                           options=_rig_options(pair, truth.saturation))
            q2 = res.x[:, 1]
            if noise > 0:
                q2 = q2 + rng.normal(0.0, noise, size=q2.size)
            q2m = quantize(q2, truth.step)
            tw = t[win] - t[win].mean()
            q4[i] = float(np.dot(tw, q2m[win] - q2m[win].mean()) / np.dot(tw, tw)) + 0.0  # no -0.0
        meta = {
            "experiment": spec.name,
            "reference": spec.reference,
            "description": spec.description,
            "source": "iwp virtual rig",
            "seed": str(seed),
            "compensated": "yes" if compensated else "no",
            "pendulum": "locked",
            "hold": repr(hold),
            "velocity": f"least-squares slope of the quantised q2 over the last {STATIC_WINDOW:g} s of each hold, "
                        "each point started from rest",
            "Ts": repr(Ts),
            "counts_per_rev": str(truth.counts_per_rev),
            "noise_std": repr(noise),
            "saturation": repr(truth.saturation),
            "truth": truth.replace(noise_std=noise).to_json_line(),
        }
        if compensated:
            meta.update(v_dz_pos=repr(pair[0]), v_dz_neg=repr(pair[1]))
        return StaticCurve(input_name="u" if compensated else "v", input=grid, q4=q4, metadata=meta,
                           source=f"virtual rig: {spec.name}")


def run_experiment(name: str, *, truth: RigTruth | None = None, seed: int = 0, **overrides):
    """``VirtualRig(truth, seed).run(name, **overrides)``: one experiment of the default rig.

    Parameters
    ----------
    name : str
        Experiment name (:func:`iwp.rig.list_experiments`).
    truth : RigTruth, optional
        The rig's truth (default: :func:`default_truth`).
    seed : int, default 0
        Seed of the rig's noise.
    **overrides
        Options of the experiment (see :meth:`VirtualRig.run`).

    Returns
    -------
    ExperimentData or StaticCurve
        The log, or a static curve.

    Raises
    ------
    InputError
        Unknown experiment, an option it does not take, or a bad value.

    Examples
    --------
    Two seconds of figure 3(a)'s sinusoid ``u = 60 sin(5 t)``, pendulum locked:

    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("sine-60", duration=2.0)
    >>> log.n_samples, round(log.Ts, 3), log.metadata["pendulum"]
    (401, 0.005, 'locked')
    >>> round(float(abs(log.extra["true_q4"]).max()), 1)  # the disk's peak speed [rad/s]
    100.8

    The static curve of figure 2(a), coarsely (every 20 input units, held 2 s):

    >>> curve = run_experiment("static-curve", step=20.0, duration=2.0)
    >>> curve.input[6:], curve.q4[6:].round(1)  # v [input units], steady q4 [rad/s]: the dead zone
    (array([ 20.,  40.,  60.,  80., 100.]), array([  0. ,  27.7,  89.7, 151.5, 213.3]))
    """
    return VirtualRig(truth, seed=seed).run(name, **overrides)
