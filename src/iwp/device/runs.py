"""The paper's experiments and the user's inputs on a rig in the loop.

:func:`run_on_rig` runs one of the paper's experiments (section 5, the names
of :mod:`iwp.rig.experiments`, with their settings) or a user input
(:data:`USER_INPUTS`: a chirp, a PRBS, steps, a sine, a release with the
wheel held) on any :class:`~iwp.device.connection.Rig`, and returns the log as the
virtual rig returns it (:class:`~iwp.data.ExperimentData`, or a
:class:`~iwp.data.StaticCurve` for the static curves), marked
``interrupted`` if it stopped early.

Each run sets the device's feedforward (7)-(8) (``v_dz``; 0 for a raw input
``v``), arranges the pendulum (clamped at rest, hanging still, or held at an
angle) with the emulated rig's hands (FIXTURE) or by asking the operator
(``operator``), zeroes the encoders with the pendulum hanging at rest, then
runs the loop (:func:`~iwp.device.loop.run_loop`). A static curve holds each
input for ``duration`` seconds from rest, reads the wheel speed as the
least-squares slope of ``q2`` over the last second (as the virtual rig
does), and waits for the wheel to stop before the next input.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Callable

import numpy as np

from ..checks import check_finite, check_nonnegative, check_positive
from ..data import ExperimentData, StaticCurve
from ..errors import InputError
from ..rig.controller import EncoderHopfController
from ..rig.experiments import (
    EXPERIMENTS,
    ExperimentKind,
    InputLaw,
    RunKind,
    experiment_spec,
)
from ..rig.run_settings import compensation_thresholds, initial_state, law_input
from ..rig.virtual import STATIC_WINDOW
from .connection import Rig
from .errors import DeviceError, LinkLost
from .loop import DeviceLaw, HostLaw, HostLimits, LoopCommand, LoopResult, OpenLoop, jitter_warning, run_loop
from .protocol import FLOAT32_MAX, PARAMS, float32_text
from .record import loop_log

__all__ = ["run_on_rig", "RigRun", "USER_INPUTS", "USER_INPUT_KINDS", "RUN_NAMES", "PAPER_SERIES", "run_kind",
           "arrange", "hold_at", "releaser", "settle", "default_operator", "prepare", "latched", "GUARD_PARAMS",
           "Clearing", "run_settings"]

#: User inputs and the options each takes (with their defaults).
USER_INPUTS: dict[str, dict[str, Any]] = {
    "chirp": {"amplitude": 60.0, "w0": 3.0, "tau": 100.0, "duration": 60.0, "locked": False, "v_dz": 31.0},
    "sine": {"amplitude": 40.0, "omega": 5.0, "duration": 20.0, "locked": False, "v_dz": 31.0},
    "prbs": {"amplitude": 40.0, "hold_time": 0.3, "seed": 0, "duration": 30.0, "locked": False, "v_dz": 31.0},
    "steps": {"levels": (40.0, 0.0, -40.0, 0.0), "step_time": 2.0, "duration": 16.0, "locked": False,
              "v_dz": 31.0},
    "release": {"x0": -1.0, "duration": 30.0},
}
#: How each user input runs (compensated by default: ``v_dz = none`` switches it off; ``locked`` by default
#: free, the option ``locked`` clamps it).
USER_INPUT_KINDS: dict[str, ExperimentKind] = {
    "chirp": ExperimentKind(RunKind.OPEN_LOOP, InputLaw.CHIRP, compensated=True),
    "sine": ExperimentKind(RunKind.OPEN_LOOP, InputLaw.SINE, compensated=True),
    "prbs": ExperimentKind(RunKind.OPEN_LOOP, InputLaw.PRBS, compensated=True),
    "steps": ExperimentKind(RunKind.OPEN_LOOP, InputLaw.STEPS, compensated=True),
    "release": ExperimentKind(RunKind.RELEASE),
}
#: Every name :func:`run_on_rig` takes.
RUN_NAMES = tuple(EXPERIMENTS) + tuple(USER_INPUTS)
#: The paper's time-series experiments.
PAPER_SERIES = tuple(n for n, spec in EXPERIMENTS.items() if spec.kind.run is not RunKind.STATIC_CURVE)
#: Options that only the virtual rig's simulation has.
_SIMULATION_ONLY = ("seed", "noise_std")
#: Time for the device's velocity estimates to settle after the pendulum is put somewhere [s].
_SETTLE = 0.2
#: Wheel at rest: no count for this long [s] (static curves) ...
_STILL = 0.5
#: ... within this long [s].
_STILL_MAX = 30.0


@dataclass
class RigRun:
    """One run on a rig: the log (None if nothing was recorded) and how it ended."""

    log: ExperimentData | StaticCurve | None
    interrupted: bool = False
    reason: str = "complete"
    error: BaseException | None = None
    loops: list[LoopResult] = field(default_factory=list)

    @property
    def stop_confirmed(self) -> bool | None:
        """Whether the device acknowledged every stop of the run's loops (None: no loop armed the motor)."""
        said = [lp.stop_confirmed for lp in self.loops if lp.stop_confirmed is not None]
        return None if not said else all(said)

    @property
    def _metadata(self) -> dict:
        """The log's metadata ({} without a log)."""
        return getattr(self.log, "metadata", {}) if self.log is not None else {}

    def _meta(self, key: str) -> dict:
        """A JSON entry of the log's metadata (``link``, ``timing``, ``device``), or {}."""
        meta = self._metadata
        try:
            value = json.loads(meta[key]) if key in meta else {}
        except ValueError:
            return {}
        return value if isinstance(value, dict) else {}

    @property
    def watchdog_ms(self) -> float | None:
        """The device's watchdog during the run [ms], as its log records it (None where it does not)."""
        value = self._meta("device").get("params", {}).get("watchdog_ms")
        return float(value) if isinstance(value, (int, float)) else None

    def link_notes(self) -> list[tuple[str, str]]:
        """What the run's log says of the link and the loop's timing: ``(kind, text)`` lines, ``kind``
        ``"warning"`` (samples filled in, ticks unevenly spaced) or ``"note"`` (frames refused outside the run)."""
        link = self._meta("link")
        out = []
        filled = int(self._metadata.get("filled_samples", 0) or 0)
        if filled:
            out.append(("warning", f"{filled} samples of the log were lost on the link or carried a value that is "
                                   f"not a number ({link.get('lost', 0)} lost, {link.get('corrupt', 0)} corrupt "
                                   "frames): they are filled in between their neighbours, marked in its 'filled' "
                                   "column and 'gaps' metadata, and left out of every fit; check the cable and the "
                                   "baud rate"))
        elif link.get("corrupt", 0) or link.get("lost", 0):
            out.append(("note", f"the link lost {link.get('lost', 0)} telemetry samples and refused "
                                f"{link.get('corrupt', 0)} corrupt frames outside the run (connecting, clearing a "
                                "fault): the log has no gap"))
        timing = self._meta("timing")
        if timing:
            warning = jitter_warning(timing)
            if warning:
                out.append(("warning", warning))
        return out


def default_operator(message: str) -> None:
    """No operator: a rig without emulated hands cannot be arranged.

    Parameters
    ----------
    message : str
        What the operator would be asked to do.

    Raises
    ------
    DeviceError
        Always, naming ``message``.
    """
    raise DeviceError(f"this rig has no emulated hands: {message}, then run again with an operator "
                      "(the command line asks you)")


def run_kind(name: str) -> ExperimentKind:
    """How experiment or user input ``name`` runs.

    Parameters
    ----------
    name : str
        One of the paper's experiments (:data:`~iwp.rig.EXPERIMENTS`) or of :data:`USER_INPUTS`.

    Returns
    -------
    ExperimentKind
        The experiment's :attr:`~iwp.rig.ExperimentSpec.kind`, or the user input's (:data:`USER_INPUT_KINDS`).

    Raises
    ------
    InputError
        An unknown name (the message lists the valid ones).
    """
    if name in EXPERIMENTS:
        return EXPERIMENTS[name].kind
    if name in USER_INPUT_KINDS:
        return USER_INPUT_KINDS[name]
    raise InputError(f"unknown experiment or input {name!r}; valid: {', '.join(RUN_NAMES)}", argument="name")


def run_on_rig(rig: Rig, name: str, *, fast: bool = False,
               operator: Callable[[str], None] | None = None, progress: Callable[[dict], None] | None = None,
               limits: HostLimits | None = None, clearing: Clearing | None = None, **options) -> RigRun:
    """Run experiment or input ``name`` on ``rig``.

    Parameters
    ----------
    rig : Rig
    name : str
        One of the paper's experiments (``iwp rig list``) or :data:`USER_INPUTS`.
    fast : bool
        Run by the host's clock (devices with caps ``HOST_CLOCK``: the emulator).
    operator : callable, optional
        ``operator(message)`` asks a person to arrange the pendulum when the rig has no emulated hands.
    progress : callable, optional
        See :func:`~iwp.device.loop.run_loop`.
    limits : HostLimits, optional
        The host's check (default: the device's own limits).
    clearing : Clearing, optional
        Clear a fault left on the device, restore its changed limits (see :func:`prepare`; without them a run
        refuses to start on such a device).
    **options
        The experiment's options (``iwp rig list``; for user inputs :data:`USER_INPUTS`); a closed loop's also
        ``where``: ``"device"`` (default) or ``"host"``, where its Hopf law runs.

    Notes
    -----
    It runs as its kind says (:func:`run_kind`: open loop with its input law, static curve, release or
    closed loop), whatever its name.

    Examples
    --------
    Two seconds of figure 3(a)'s sinusoid on the twin, the pendulum clamped by its emulated hands:

    >>> import numpy as np
    >>> from iwp import open_rig, run_on_rig
    >>> with open_rig("twin", fast=True) as rig:
    ...     run = run_on_rig(rig, "sine-60", fast=True, duration=2.0)
    >>> run.reason, run.log.n_samples, run.log.metadata["pendulum"]
    ('complete', 401, 'locked')
    >>> round(float(np.abs(run.log.extra["q4_device"]).max()), 1)  # the device's peak disk speed [rad/s]
    101.2
    """
    if name not in RUN_NAMES:
        raise InputError(f"unknown experiment or input {name!r}; valid: {', '.join(RUN_NAMES)}", argument="name")
    kind = run_kind(name)
    s = _settings(name, kind, options)
    duration = check_positive("duration", s["duration"])
    Ts = rig.info.params["period_us"] * 1e-6
    # every setting checked before the motor moves: the law's values over the whole run, the gains as the wire
    # carries them (a float32)
    inp = checked_law(kind.law, s, Ts, duration) if kind.run is RunKind.OPEN_LOOP else None
    if kind.run is RunKind.CLOSED_LOOP:
        for key in ("k1", "k2", "filter_tau"):
            wire_float(key, s[key])
    operator = operator or default_operator
    if fast:
        if not rig.has("HOST_CLOCK"):
            raise DeviceError(f"{rig.port}: this device runs in real time only (no HOST_CLOCK); drop --fast")
    prepare(rig, fast, clearing)
    compensated = s.get("v_dz") is not None
    pair = compensation_thresholds(s.get("v_dz")) if compensated else (0.0, 0.0)
    rig.set_params(v_dz_pos=pair[0], v_dz_neg=pair[1])
    if limits is None:
        limits = HostLimits(rig.info.params["q1_max"], rig.info.params["q4_max"])
    meta: dict[str, Any] = {"experiment": name}
    if name in EXPERIMENTS:
        spec = experiment_spec(name)
        meta.update(reference=spec.reference, description=spec.description, session=spec.session)
    meta["settings"] = ", ".join(f"{k}={v}" for k, v in s.items())
    if kind.run is RunKind.STATIC_CURVE:
        return _static_curve(rig, name, s, compensated, operator, progress, limits, meta)
    locked = bool(s.get("locked", kind.locked))
    meta["pendulum"] = "locked" if locked else "free"
    x0 = initial_state(s["x0"]) if "x0" in s else None
    if x0 is not None and not abs(x0[0]) < limits.q1_max:
        raise InputError(f"x0 = {x0[0]:g} rad is beyond the angle limit q1_max = {limits.q1_max:g} rad: the run "
                         "would stop at its first sample", argument="x0")
    arrange(rig, locked, operator)
    on_start = None
    if x0 is not None and x0[0] != 0.0:
        meta["x0"] = json_list(x0)
        hold_at(rig, float(x0[0]), operator)
        on_start = releaser(rig)
    command: LoopCommand = None
    arm = True
    input_name = "u" if compensated else "v"
    if kind.run is RunKind.RELEASE:
        arm, input_name = False, None
    elif kind.run is RunKind.CLOSED_LOOP:
        k1, k2 = check_finite("k1", s["k1"]), check_finite("k2", s["k2"])
        tau = check_nonnegative("filter_tau", s["filter_tau"])
        controller = s.get("where", "device")
        meta.update(k1=repr(k1), k2=repr(k2), filter_tau=repr(tau), controller=controller)
        if controller == "device":
            rig.set_params(k1=k1, k2=k2, filter_tau=tau)
            rig.mode("HOPF")
            command = DeviceLaw()
        elif controller == "host":
            command = HostLaw(EncoderHopfController(k1, k2, rig.info.params["period_us"] * 1e-6, tau))
        else:
            raise InputError(f"where must be 'device' or 'host', got {controller!r}", argument="where")
    else:
        command = OpenLoop(lambda t: inp.evaluate(t))
    if kind.run is not RunKind.CLOSED_LOOP:
        rig.mode("HOST")
    res = run_loop(rig, duration=duration, command=command, arm=arm,
                   limits=limits, progress=progress, on_start=on_start)
    log = loop_log(res, rig.info, rig.link.stats, input_name=input_name, metadata=meta,
                   source=f"{name} on {rig.port}")
    return RigRun(log, res.interrupted, res.reason, res.error, [res])


#: the settings of an input law (:func:`~iwp.rig.run_settings.law_input`), named when its values cannot be sent
LAW_SETTINGS = ("amplitude", "omega", "w0", "tau", "hold_time", "levels", "step_time", "seed")


def wire_float(name: str, value: Any) -> float:
    """``value`` as a finite number the wire's float32 field carries, else :class:`InputError` naming ``name``."""
    v = check_finite(name, value)
    if abs(v) > FLOAT32_MAX:
        raise InputError(f"{name} = {v:g} is beyond what the device's float32 carries (|x| <= {FLOAT32_MAX:.4g})",
                         argument=name)
    return v


def checked_law(law, settings: dict, Ts: float, duration: float):
    """The input law of an open-loop run (:func:`~iwp.rig.run_settings.law_input`), evaluated at every tick of the
    run (and the loop's lead beyond it) before the motor moves: every value finite and within what the wire's
    float32 carries, else :class:`InputError` naming the law's settings (an input that cannot be computed is bad
    input, refused before arming, not a run that stops at its first NaN)."""
    inp = law_input(law, settings, Ts)
    t = np.arange(int(math.ceil(duration / Ts)) + 16) * Ts
    with np.errstate(all="ignore"):
        u = np.array([inp.evaluate(float(x)) for x in t], dtype=float)
    bad = ~np.isfinite(u) | (np.abs(u) > FLOAT32_MAX)
    if bad.any():
        k = int(np.argmax(bad))
        given = [key for key in LAW_SETTINGS if key in settings]
        said = ", ".join(f"{key} = {settings[key]}" for key in given)
        why = ("not a number" if not np.isfinite(u[k])
               else f"beyond what the device's float32 carries ({FLOAT32_MAX:.4g})")
        raise InputError(f"the input of {said} is {u[k]:g} at t = {t[k]:g} s, {why}: nothing was sent to the "
                         "device", argument=tuple(given))
    return inp


def json_list(x) -> str:
    return "[" + ", ".join(repr(float(e)) for e in x) + "]"


# --------------------------------------------------------------------------
# settings
# --------------------------------------------------------------------------
def run_settings(name: str, options: dict) -> dict:
    """The settings :func:`run_on_rig` runs ``name`` with: its defaults, overridden by ``options`` (None: the
    default).

    Parameters
    ----------
    name : str
        As for :func:`run_on_rig`.
    options : dict
        As for :func:`run_on_rig`.

    Returns
    -------
    dict
        Every setting of the run (``v_dz`` None: no compensation).

    Raises
    ------
    InputError
        An unknown name, or an option the run does not take.
    """
    return _settings(name, run_kind(name), options)


def _settings(name: str, kind: ExperimentKind, options: dict) -> dict:
    if name in EXPERIMENTS:
        spec = experiment_spec(name)
        allowed = [o for o in spec.options if o not in _SIMULATION_ONLY]
        s = dict(spec.settings)
    else:
        allowed = list(USER_INPUTS[name])
        s = dict(USER_INPUTS[name])
    if kind.run is RunKind.CLOSED_LOOP:  # where its law runs: a setting of the loop, not of the experiment
        allowed.append("where")
    given = {k: v for k, v in options.items() if v is not None}
    for k in given:
        if k in _SIMULATION_ONLY and name in EXPERIMENTS:
            raise InputError(f"{k} is a setting of the virtual rig's simulation, not of a rig in the loop",
                             argument=k)
        if k not in allowed:
            raise InputError(f"{name!r} does not take {k!r}; it takes: {', '.join(allowed)}", argument=k)
    s.update(given)
    if "v_dz" in given and given["v_dz"] == "none":
        s["v_dz"] = None
    if kind.run is RunKind.STATIC_CURVE and not kind.compensated:
        s["v_dz"] = None
    return s


# --------------------------------------------------------------------------
# the set-up: the operator's hands
# --------------------------------------------------------------------------
#: The device's parameters that bound every run and that no run sets: left changed by another client (e.g.
#: ``q4_max`` 20), a run refuses to start until ``reset_params`` (``--reset-params``) puts them back.
GUARD_PARAMS = ("watchdog_ms", "v_max", "q1_max", "q4_max", "sat_ms_max")


def latched(rig: Rig) -> tuple[str | None, dict[str, float]]:
    """What an earlier run or another client left on the device: a latched fault, and changed limits.

    Parameters
    ----------
    rig : Rig
        The connected rig.

    Returns
    -------
    fault : str or None
        ``"FAULT (Q4_LIMIT)"``, ``"ESTOP"``, ... (the state of its latest telemetry), or None.
    params : dict of str to float
        The parameters of :data:`GUARD_PARAMS` that differed from their defaults (as float32) when the rig was
        connected (:attr:`Rig.params_found`: this connection's own changes are its own), with their values.
    """
    rig.stream(1)  # telemetry may be off (the live view's prediction turns it off while the model runs)
    seen, s = rig.last_seq, None  # the state of a tick after this call (not of telemetry queued before it)
    for _ in range(4):
        got = [x for x in rig.samples(0.25) if x.seq > seen]
        if got:
            s = got[-1]
            break
    fault = None
    if s is not None and s.state in ("FAULT", "ESTOP"):
        fault = s.state + (f" ({s.fault})" if s.fault not in ("NONE", "ESTOP") else "")
    found = rig.params_found
    changed = {k: found[k] for k in GUARD_PARAMS if k in found and found[k] != float(np.float32(PARAMS[k].default))}
    return fault, changed


@dataclass(frozen=True)
class Clearing:
    """What a run may clear that an earlier run or another client left on the device (:func:`prepare`), and the
    watchdog it asks for.

    Attributes
    ----------
    clear_fault : bool
        Clear a latched fault or emergency stop (``--clear-fault``).
    reset_params : bool
        Put changed limits (:data:`GUARD_PARAMS`) back to their defaults (``--reset-params``).
    watchdog_ms : float, optional
        The device's watchdog for this run [ms] (``--watchdog-ms``), put back when the rig is closed
        (:meth:`~iwp.device.connection.Rig.set_params_until_close`); None: the device's own (100 ms by default).
        A host without real-time scheduling can be held off longer than 100 ms by another program starting
        (docs/live.md).
    """

    clear_fault: bool = False
    reset_params: bool = False
    watchdog_ms: float | None = None

    def __post_init__(self) -> None:
        if self.watchdog_ms is not None:
            p = PARAMS["watchdog_ms"]
            ms = check_finite("watchdog_ms", self.watchdog_ms)
            if not p.lo <= ms <= p.hi:
                raise InputError(f"watchdog_ms must be from {p.lo:g} to {p.hi:g} ms (the device's range), got "
                                 f"{ms:g}", argument="watchdog_ms")
            object.__setattr__(self, "watchdog_ms", ms)


def prepare(rig: Rig, fast: bool, clearing: Clearing | None = None) -> None:
    """Before a run: refuse a latched fault or changed limits unless told to clear them; disarm, stream every
    tick, set the clock.

    Parameters
    ----------
    rig : Rig
        The connected rig.
    fast : bool
        By the host's clock (the device's ``host_clock``).
    clearing : Clearing, optional
        Clear a fault or emergency stop left on the device (:func:`latched`); put its changed limits back to
        their defaults (default: neither; such a device refuses the run).

    Raises
    ------
    DeviceError
        A fault or emergency stop is latched and ``clear_fault`` is False, or limits were changed and
        ``reset_params`` is False (one line naming them and the argument that clears them).
    """
    clearing = Clearing() if clearing is None else clearing
    fault, changed = latched(rig)
    if fault is not None and not clearing.clear_fault:
        raise DeviceError(f"{rig.port}: the device is in {fault}, latched by an earlier run or another client; "
                          "check the rig, then run again with clear_fault", argument="clear_fault")
    if changed and not clearing.reset_params:
        what = ", ".join(f"{k} = {float32_text(v)} (default {float32_text(PARAMS[k].default)})"
                         for k, v in changed.items())
        raise DeviceError(f"{rig.port}: the device's limits were changed by an earlier run or another client: "
                          f"{what}; run again with reset_params to restore the defaults", argument="reset_params")
    if fault is not None:
        rig.clear()
    rig.disarm()
    if changed:
        rig.set_params(**{k: PARAMS[k].default for k in changed})
        rig.params_found.update({k: rig.info.params[k] for k in changed})
    if clearing.watchdog_ms is not None:
        rig.set_params_until_close(watchdog_ms=clearing.watchdog_ms)
    rig.stream(1)
    rig.set_params(host_clock=1.0 if fast else 0.0)


def arrange(rig: Rig, locked: bool, operator) -> None:
    """Clamp the pendulum at rest, or hold it still hanging down; then zero the encoders there.

    Parameters
    ----------
    rig : Rig
        The connected rig.
    locked : bool
        True: clamp the pendulum (a clamped experiment); False: hold it hanging still, then release it.
    operator : callable
        ``operator(message)``, asked to do by hand what the rig's emulated hands cannot (a real rig).
    """
    if locked:
        if rig.fixture("CLAMP") is None:
            operator("clamp the pendulum at rest, hanging down")
    elif rig.fixture("HOLD", 0.0) is None:
        operator("let the pendulum hang still, free")
    rig.zero()
    if not locked:
        rig.fixture("RELEASE")


def hold_at(rig: Rig, q1: float, operator) -> None:
    """Hold the pendulum at ``q1`` [rad], the wheel still (the emulated hands, or the operator's), and let the
    device's velocity estimates settle there.

    Parameters
    ----------
    rig : Rig
        The connected rig.
    q1 : float
        Pendulum angle to hold, 0 hanging down [rad].
    operator : callable
        ``operator(message)``, asked to hold the pendulum when the rig has no emulated hands.

    Raises
    ------
    LinkLost
        No telemetry while the estimates settle.
    """
    if rig.fixture("HOLD", q1) is not None:
        settle(rig, _SETTLE)
    else:
        count = round(q1 / (2 * math.pi) * rig.info.params["counts1"])
        operator(f"hold the pendulum at q1 = {q1:g} rad (count {count}), the wheel still, and let it go when the run "
                 "starts")


def settle(rig: Rig, seconds: float) -> None:
    """Let ``seconds`` of device time pass (heartbeats allow the ticks with the host clock).

    Parameters
    ----------
    rig : Rig
        The connected rig.
    seconds : float
        Device time to let pass [s], counted in sample periods.

    Raises
    ------
    LinkLost
        No telemetry within 1 s.
    """
    Ts = rig.info.params["period_us"] * 1e-6
    n = 0
    while n * Ts < seconds:
        got = rig.samples(1.0)
        if not got:
            raise LinkLost(f"link lost: no telemetry from {rig.port}")
        for x in got:
            rig.heartbeat(x.seq + 2)
        n += len(got)


def releaser(rig: Rig):
    """``on_start`` of :func:`~iwp.device.loop.run_loop` that lets the held pendulum go.

    Parameters
    ----------
    rig : Rig
        The connected rig.

    Returns
    -------
    callable
        ``release()``, returning the device tick from which the pendulum is free, or None on a rig without
        emulated hands (the operator lets go).
    """
    def release() -> int | None:
        return rig.fixture("RELEASE")  # None on a real rig: the operator lets go; the log starts before
    return release


# --------------------------------------------------------------------------
# static curves (figure 2)
# --------------------------------------------------------------------------
def _static_curve(rig: Rig, name: str, s: dict, compensated: bool, operator, progress, limits,
                  meta: dict) -> RigRun:
    amplitude = check_positive("amplitude", s["amplitude"])
    step_in = check_positive("step", s["step"])
    hold = check_finite("duration", s["duration"])
    if hold < 2 * STATIC_WINDOW:
        raise InputError(f"duration (hold time per point) must be >= {2 * STATIC_WINDOW:g} s, got {hold!r} s",
                         argument="duration")
    m = int(math.floor(amplitude / step_in + 1e-9))
    grid = step_in * np.arange(-m, m + 1)
    arrange(rig, True, operator)
    rig.mode("HOST")
    Ts = rig.info.params["period_us"] * 1e-6
    q4, done, loops = [], [], []
    interrupted, reason, error = False, "complete", None
    for value in grid:
        res = run_loop(rig, duration=hold, command=OpenLoop(lambda t, a=float(value): a), limits=limits,
                       progress=progress)
        loops.append(res)
        if res.interrupted:
            interrupted, reason, error = True, res.reason, res.error
            break
        t = (np.array([x.seq for x in res.samples]) - res.samples[0].seq) * Ts
        q2 = np.array([x.q2 for x in res.samples])
        win = t >= t[-1] - STATIC_WINDOW - 1e-9
        tw = t[win] - t[win].mean()
        q4.append(float(np.dot(tw, q2[win] - q2[win].mean()) / np.dot(tw, tw)) + 0.0)
        done.append(float(value))
        try:
            _wait_still(rig, Ts)
        except BaseException as exc:  # noqa: BLE001 (Ctrl-C while waiting: keep the points so far)
            interrupted, reason, error = True, "Ctrl-C" if isinstance(exc, KeyboardInterrupt) else str(exc), exc
            break
    log = None
    if len(done) >= 2:
        meta = dict(meta, pendulum="locked", hold=repr(hold), compensated="yes" if compensated else "no",
                    velocity=f"least-squares slope of q2 over the last {STATIC_WINDOW:g} s of each hold, "
                             "each point started from rest",
                    Ts=repr(Ts), counts_per_rev=f"{rig.info.params['counts1']:g}",
                    saturation=repr(rig.info.params["v_max"]), source=f"iwp rig on {rig.port}",
                    interrupted="true" if interrupted else "false", stop_reason=reason)
        if compensated:
            meta.update(v_dz_pos=repr(rig.info.params["v_dz_pos"]), v_dz_neg=repr(rig.info.params["v_dz_neg"]))
        log = StaticCurve(input_name="u" if compensated else "v", input=np.array(done), q4=np.array(q4),
                          metadata={k: str(v) for k, v in meta.items()}, source=f"{name} on {rig.port}")
    return RigRun(log, interrupted, reason, error, loops)


def _wait_still(rig: Rig, Ts: float) -> None:
    """Wait until the wheel's count has not changed for :data:`_STILL` seconds (heartbeats keep the link)."""
    need = max(2, int(round(_STILL / Ts)))
    same, last, waited = 0, None, 0
    while same < need:
        got = rig.samples(0.5)
        if not got:
            raise LinkLost(f"link lost: no telemetry from {rig.port}")
        for x in got:
            same = same + 1 if x.count2 == last else 0
            last = x.count2
            waited += 1
            rig.heartbeat(x.seq + 2)
        if waited * Ts > _STILL_MAX:
            raise DeviceError(f"the wheel did not stop within {_STILL_MAX:g} s")
