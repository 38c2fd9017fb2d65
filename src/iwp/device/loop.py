"""The fixed-rate loop on a rig: an open-loop input, a host controller or an on-device law, stopped on every path.

:func:`run_loop` is clocked by the device: every telemetry sample is
recorded and answered (the input ``lead`` ticks ahead, a host controller's
output for the next tick, or a heartbeat), until the duration is reached.
It stops the motor on every way out: the normal end (disarm), Ctrl-C and
SIGTERM (:func:`stop_signals`), a device fault or limit, the host's own
check of the limits, a lost link, an exception; and it always returns what
it recorded (:class:`LoopResult`, ``interrupted`` and ``reason`` say how it
ended), so that the caller writes the log up to the stop.

Timing (:meth:`LoopResult.timing`): the device's own period between
consecutive ticks (its time stamps) and its jitter ``|period - Ts|`` (p50,
p99, max; :func:`jitter_warning` when p99 exceeds a tenth of the period),
the machine's load average beside it, the period between the host's
receipts of consecutive samples and its jitter,
the device's overruns and late ticks during the run, samples lost on the
link. With the device's host clock (faster than real time) the periods are
not the device's and only the counters are reported.
"""

from __future__ import annotations

import contextlib
import gc
import math
import os
import signal
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..interruption import Terminated as InterruptTerminated
from .connection import Rig, Sample
from .errors import DeviceError, LinkLost
from .realtime import realtime_priority

__all__ = ["run_loop", "LoopResult", "HostLimits", "OpenLoop", "HostLaw", "DeviceLaw", "LoopCommand", "Terminated",
           "stop_signals", "DEFAULT_LEAD", "jitter_warning", "LoopObserver"]

#: How many ticks ahead an open-loop input is sent in real time (20 ms at 5 ms: a USB-serial adapter's latency).
DEFAULT_LEAD = 4


class Terminated(BaseException):
    """SIGTERM (or SIGHUP) arrived: stop as Ctrl-C does."""


class LoopObserver:
    """A ``progress`` of :func:`run_loop` that also sees every recorded sample and may ask the loop to stop.

    The loop calls :meth:`on_sample` with each sample it records and :meth:`stop_requested` after each batch of
    telemetry, both from its own thread and in its time budget: they must return at once (append to a bounded
    queue, read a flag), never wait. A stop requested ends the run as Ctrl-C does: the motor is stopped and the
    run so far returned, marked interrupted with the reason given. As a plain ``progress`` callable it is called
    about every 0.25 s with the progress dictionary (:meth:`__call__`, nothing by default).
    """

    def __call__(self, progress: dict) -> None:
        """The progress dictionary of :func:`run_loop` (about every 0.25 s)."""

    def on_sample(self, t: float, sample: Sample) -> None:
        """Sample ``sample`` recorded at time ``t`` [s] of the run."""

    def stop_requested(self) -> str | None:
        """Why the run should stop now (the loop's stop reason), or None to go on."""
        return None


@contextlib.contextmanager
def stop_signals():
    """Within the block, SIGTERM and SIGHUP raise :class:`Terminated` (main thread only)."""
    def handler(signum, frame):
        raise Terminated(signal.Signals(signum).name)

    old = {}
    try:
        for s in (signal.SIGTERM, signal.SIGHUP):
            old[s] = signal.signal(s, handler)
    except ValueError:  # not the main thread: nothing to install
        pass
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h)


@dataclass(frozen=True)
class HostLimits:
    """The host's own checks: the limits (the device checks them too) [rad, rad/s], and the link.

    Attributes
    ----------
    q1_max, q4_max : float
        The pendulum's angle [rad] and the wheel's speed [rad/s] past which the host stops the run.
    link_timeout : float
        No telemetry for this long [s] (at least 20 periods): the link is lost.
    """

    q1_max: float = math.inf
    q4_max: float = math.inf
    link_timeout: float = 1.0

    def violated(self, s: Sample) -> str | None:
        if abs(s.q1) > self.q1_max:
            return f"host limit: |q1| = {abs(s.q1):.3f} rad > {self.q1_max:g} rad"
        if abs(s.q4) > self.q4_max:
            return f"host limit: |q4| = {abs(s.q4):.1f} rad/s > {self.q4_max:g} rad/s"
        return None


@dataclass
class LoopResult:
    """What :func:`run_loop` recorded and how it ended.

    Attributes
    ----------
    samples : list of Sample
        From the first sample of the run (its ``seq`` is time 0) to the stop.
    Ts : float
        Loop period [s].
    interrupted : bool
        Ended before the duration.
    reason : str
        ``"complete"``, ``"Ctrl-C"``, ``"SIGTERM"``, ``"device FAULT (WATCHDOG)"``, a host limit, ``"link lost"``, or
        the error.
    error : BaseException or None
        The exception that ended it, for the caller to re-raise after writing the log.
    host_clock : bool
        Ran by the host's clock (faster than real time).
    counters0 : tuple of int
        The device's ``(overruns, late, rx_errors, dropped)`` before the run.
    stop_confirmed : bool or None
        The device acknowledged the stop (DISARM or ESTOP); False: it did not answer (its watchdog stops the
        motor); None: the motor was not armed.
    """

    samples: list[Sample] = field(default_factory=list)
    Ts: float = 0.005
    interrupted: bool = False
    reason: str = "complete"
    error: BaseException | None = None
    host_clock: bool = False
    counters0: tuple[int, int, int, int] = (0, 0, 0, 0)
    wall: float = 0.0
    scheduling: str = "normal"
    #: whether the device answered the stop (its DISARM or ESTOP acknowledged); None: the motor was never armed
    stop_confirmed: bool | None = None

    @property
    def seq0(self) -> int | None:
        return self.samples[0].seq if self.samples else None

    def timing(self) -> dict:
        """Loop timing and counters (see the module's docstring); periods in milliseconds."""
        out: dict = {"Ts_ms": self.Ts * 1e3, "samples": len(self.samples), "wall_s": self.wall,
                     "clock": "host (faster than real time)" if self.host_clock else "device (real time)",
                     "scheduling": self.scheduling}
        if self.samples:
            last = self.samples[-1]
            o0, l0, r0, d0 = self.counters0
            out["device_overruns"] = (last.overruns - o0) & 0xFFFF
            out["late_ticks"] = (last.late - l0) & 0xFFFF
            out["device_rx_errors"] = (last.rx_errors - r0) & 0xFFFF
            out["dropped_commands"] = (last.dropped - d0) & 0xFFFF
            seqs = np.array([s.seq for s in self.samples])
            out["lost_samples"] = int(seqs[-1] - seqs[0] + 1 - seqs.size)
        out["load_avg"] = list(_load_avg())
        if not self.host_clock and len(self.samples) > 2:
            out.update(_device_jitter(self.samples, self.Ts))
            th = np.array([s.t_host for s in self.samples])
            d = np.diff(th)
            jit = np.abs(d - self.Ts)
            out.update(period_p50_ms=float(np.percentile(d, 50) * 1e3),
                       jitter_p50_ms=float(np.percentile(jit, 50) * 1e3),
                       jitter_p99_ms=float(np.percentile(jit, 99) * 1e3),
                       jitter_max_ms=float(jit.max() * 1e3),
                       host_overruns=int(np.sum(d > 2.0 * self.Ts)))
        return out


@dataclass(frozen=True)
class OpenLoop:
    """The host sends an open-loop input.

    Attributes
    ----------
    input : callable
        The ideal input ``u(t)`` [input units], ``t`` from the run's start [s].
    lead : int, optional
        Sent this many ticks ahead (default :data:`DEFAULT_LEAD`).
    """

    input: Callable[[float], float]
    lead: int | None = None


@dataclass(frozen=True)
class HostLaw:
    """A controller on the host: ``controller(t, y) -> u`` with the measured ``y = [q1, q2]`` [rad]; its output
    applies from the next tick (one period of delay, as on any host-side loop)."""

    controller: Callable[[float, np.ndarray], float]


@dataclass(frozen=True)
class DeviceLaw:
    """The device's own law runs (MODE HOPF or STATE_FEEDBACK); the host sends heartbeats."""


#: what drives the motor in :func:`run_loop` (None: nothing but heartbeats, e.g. a free swing)
LoopCommand = OpenLoop | HostLaw | DeviceLaw | None


def run_loop(
    rig: Rig,
    *,
    duration: float,
    command: LoopCommand = None,
    arm: bool = True,
    limits: HostLimits = HostLimits(),
    progress: Callable[[dict], None] | None = None,
    on_start: Callable[[], int | None] | None = None,
) -> LoopResult:
    """Run the loop for ``duration`` seconds and return what it recorded.

    Parameters
    ----------
    rig : Rig
        Connected; parameters and mode already set; not armed.
    duration : float
        Length of the record [s] (``floor(duration / Ts) + 1`` samples).
    command : OpenLoop, HostLaw, DeviceLaw or None
        What drives the motor: an open-loop input sent ahead, a controller on the host, the device's own law, or
        nothing but heartbeats.
    arm : bool
        Arm the motor (False: the motor stays off, e.g. a free swing).
    limits : HostLimits
        The host's limits and the link's timeout.
    progress : callable or LoopObserver, optional
        Called about every 0.25 s with ``{"t", "duration", "q1", "u", "overruns", "late", "lost"}``; a
        :class:`LoopObserver` also sees every sample and can stop the run (its reason is the stop's).
    on_start : callable, optional
        Called once the motor is armed (e.g. to release the pendulum); returns the device tick of the run's
        first sample (None: as without it). Not with an open-loop input.

    Returns
    -------
    LoopResult
        The samples recorded, and how the run ended.

    Examples
    --------
    One second of a constant input ``u = 40`` on the twin (the device adds its feedforward of 31):

    >>> from iwp import open_rig
    >>> from iwp.device import run_loop
    >>> from iwp.device.loop import OpenLoop
    >>> with open_rig("twin", fast=True) as rig:
    ...     rig.mode("HOST")
    ...     res = run_loop(rig, duration=1.0, command=OpenLoop(lambda t: 40.0))
    >>> res.reason, len(res.samples)
    ('complete', 201)
    >>> last = res.samples[-1]
    >>> last.u, last.v, round(last.q4, 1)  # [input units], [input units], [rad/s]
    (40.0, 71.0, 108.7)
    """
    if command is not None and not isinstance(command, (OpenLoop, HostLaw, DeviceLaw)):
        raise DeviceError(f"command must be OpenLoop, HostLaw, DeviceLaw or None, got {type(command).__name__}")
    input = command.input if isinstance(command, OpenLoop) else None
    controller = command.controller if isinstance(command, HostLaw) else None
    lead = command.lead if isinstance(command, OpenLoop) else None
    observer = progress if isinstance(progress, LoopObserver) else None
    link_timeout = limits.link_timeout
    Ts = rig.info.params["period_us"] * 1e-6
    n = int(math.floor(duration / Ts + 1e-9)) + 1
    lead = (1 if controller is not None else DEFAULT_LEAD) if lead is None else max(1, int(lead))
    res = LoopResult(Ts=Ts, host_clock=rig.info.params.get("host_clock", 0.0) != 0.0)
    armed = False
    start = None
    wall0 = time.monotonic()
    next_progress = wall0
    link_timeout = max(link_timeout, 20 * Ts)
    # a full collection of a process holding numpy, scipy and numba takes tens of milliseconds (0.12 s in a
    # test session): the device's watchdog would see a silent host. The objects so far are frozen out of it,
    # and the loop runs without it (what it allocates has no cycles and is freed by reference counting). Only
    # the young generations are collected first (a millisecond): a full collection before every run cost a
    # static curve's 40 steps seconds, and what is frozen is handed back to the collector after the run.
    gc.collect(1)
    gc.freeze()
    gc.disable()
    priority = realtime_priority()
    res.scheduling = priority.__enter__()
    try:
        if input is not None:
            input(0.0)  # load what it needs (compiled code) now, not while the watchdog counts
        got = _first_sample(rig, link_timeout)
        res.counters0 = (got.overruns, got.late, got.rx_errors, got.dropped)
        if arm:
            rig.arm()
            armed = True
            got = _first_sample(rig, link_timeout)
        first = on_start() if on_start is not None else None
        if first is not None:
            start = first  # time 0: the first sample after the operator's action
        else:
            start = got.seq + lead  # time 0 of the run
            for k in range(got.seq + 1, start + 1):  # prime the queue up to time 0
                if input is not None:
                    rig.command(float(input((k - start) * Ts)) if k >= start else 0.0, k)
                elif controller is not None:
                    rig.command(0.0, k)
                else:
                    rig.heartbeat(k)
        while True:
            batch = rig.samples(link_timeout)
            if not batch:
                raise LinkLost(f"link lost: no telemetry from {rig.port} for {link_timeout:g} s")
            for s in batch:
                if s.seq < start:  # before time 0: keep the queue ahead
                    if controller is not None:
                        rig.command(0.0, s.seq + 1)
                    else:
                        _answer(rig, s, s.seq + lead, start, Ts, input, None)
                    continue
                if not res.samples:  # the device's counters at time 0
                    res.counters0 = (s.overruns, (s.late - ("LATE" in s.flags)) & 0xFFFF, s.rx_errors, s.dropped)
                res.samples.append(s)
                if observer is not None:
                    observer.on_sample((s.seq - start) * Ts, s)
                if armed and s.state != "ARMED":
                    raise _Stop(f"device {s.state}" + (f" ({s.fault})" if s.fault != "NONE" else ""))
                bad = limits.violated(s)
                if bad:
                    raise _Stop(bad)
                if len(res.samples) >= n:
                    raise _Done()
                _answer(rig, s, s.seq + lead, start, Ts, input, controller)
            if observer is not None:
                why = observer.stop_requested()
                if why:
                    raise _Stop(why)
            now = time.monotonic()
            if progress is not None and now >= next_progress:
                s = res.samples[-1] if res.samples else batch[-1]
                progress({"t": (s.seq - start) * Ts if res.samples else 0.0, "duration": duration, "q1": s.q1,
                          "u": s.u, "overruns": (s.overruns - res.counters0[0]) & 0xFFFF,
                          "late": (s.late - res.counters0[1]) & 0xFFFF, "lost": rig.link.stats.lost})
                next_progress = now + 0.25
    except _Done:
        pass
    except _Stop as stop:
        res.interrupted, res.reason = True, str(stop)
    except KeyboardInterrupt as exc:  # Ctrl-C, or the CLI's SIGTERM (iwp.interruption.Terminated)
        res.interrupted, res.reason = True, "SIGTERM" if isinstance(exc, InterruptTerminated) else "Ctrl-C"
        res.error = exc
    except Terminated as exc:
        res.interrupted, res.reason = True, str(exc)
        res.error = exc
    except BaseException as exc:  # noqa: BLE001 (the motor is stopped below, the caller re-raises)
        res.interrupted, res.reason = True, f"{type(exc).__name__}: {exc}" if not isinstance(
            exc, DeviceError) else str(exc)
        res.error = exc
    finally:
        res.wall = time.monotonic() - wall0
        if armed:
            _stop_despite_interrupts(rig, res)
        priority.__exit__(None, None, None)
        gc.enable()
        gc.unfreeze()
    return res


def _load_avg() -> tuple[float, float, float]:
    """The machine's load over 1, 5 and 15 minutes (NaN where the system has none)."""
    try:
        return os.getloadavg()
    except OSError:
        return (math.nan, math.nan, math.nan)


def _device_jitter(samples: list[Sample], Ts: float) -> dict:
    """The device's own tick timing from its time stamps: the period between consecutive ticks and its jitter
    ``|period - Ts|`` (p50, p99, max) [ms], and the ticks that came more than a period late."""
    seq = np.array([s.seq for s in samples], dtype=np.int64)
    t_us = np.array([round(s.t_device * 1e6) for s in samples], dtype=np.int64)
    one = np.diff(seq) == 1  # consecutive ticks only (a lost sample is no late tick)
    d = (np.diff(t_us) % (1 << 32))[one] * 1e-6  # t_us wraps after 71 min
    if d.size == 0:
        return {}
    jit = np.abs(d - Ts)
    return {"device_period_p50_ms": float(np.percentile(d, 50) * 1e3),
            "device_jitter_p50_ms": float(np.percentile(jit, 50) * 1e3),
            "device_jitter_p99_ms": float(np.percentile(jit, 99) * 1e3),
            "device_jitter_max_ms": float(jit.max() * 1e3),
            "device_late_ticks": int(np.sum(d > 2.0 * Ts))}


def jitter_warning(timing: dict) -> str | None:
    """A warning when a real-time run's device jitter p99 exceeds a tenth of the period, else None.

    Parameters
    ----------
    timing : dict
        :meth:`LoopResult.timing` (a log's ``timing`` metadata).

    Returns
    -------
    str or None
        One line naming the jitter, the period and the machine's load.
    """
    p99, Ts = timing.get("device_jitter_p99_ms"), timing.get("Ts_ms")
    if p99 is None or Ts is None or not p99 > 0.1 * Ts:
        return None
    load = timing.get("load_avg") or [math.nan]
    return (f"the device's tick jitter p99 {p99:.3g} ms exceeds a tenth of the period ({Ts:g} ms; load average "
            f"{load[0]:.2f}): the samples are not evenly spaced; see the log's 'timing' metadata")


class _Done(Exception):
    pass


class _Stop(Exception):
    pass


def _first_sample(rig: Rig, timeout: float) -> Sample:
    got = rig.samples(timeout)
    if not got:
        raise LinkLost(f"link lost: no telemetry from {rig.port} for {timeout:g} s")
    return got[-1]


def _answer(rig: Rig, s: Sample, k: int, start: int, Ts: float, input, controller) -> None:
    """What the host sends after sample ``s``: the input for tick ``k``, the controller's output for the next
    tick, or a heartbeat allowing tick ``k``."""
    if controller is not None:
        rig.command(float(controller((s.seq - start) * Ts, np.array([s.q1, s.q2]))), s.seq + 1)
    elif input is not None:
        rig.command(float(input((k - start) * Ts)), k)
    else:
        rig.heartbeat(k)


def _stop_despite_interrupts(rig: Rig, res: "LoopResult") -> None:
    """Stop the motor (:func:`_stop_motor`); an interrupt that arrives meanwhile (a second Ctrl-C, ``timeout``'s
    signal to the process group after the one to the process) is noted and the emergency stop sent again, up to
    three times, so that the run so far is returned, not lost (the device's watchdog is the last line)."""
    res.stop_confirmed = False
    for _ in range(3):
        try:
            res.stop_confirmed = _stop_motor(rig, res.interrupted)
            return
        except (KeyboardInterrupt, Terminated) as exc:
            if not res.interrupted:
                res.interrupted, res.error = True, exc
                res.reason = "SIGTERM" if isinstance(exc, (InterruptTerminated, Terminated)) else "Ctrl-C"


def _stop_motor(rig: Rig, abnormal: bool) -> bool:
    """Disarm at the normal end; emergency stop otherwise (and if the disarm fails). Whether the device
    acknowledged it."""
    if not abnormal:
        try:
            rig.disarm()
            return True
        except BaseException:  # noqa: BLE001 (fall through to the emergency stop)
            pass
    return bool(rig.estop())
