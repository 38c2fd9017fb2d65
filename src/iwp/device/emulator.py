"""The emulator: the firmware's core with the twin as its plant, behind a pseudo-terminal, in real time.

:class:`TwinDevice` is one emulated board: the firmware's portable core
(:class:`~iwp.device.core.DeviceCore`, the same C code the AVR runs) whose
encoders read the twin (:class:`~iwp.rig.stepper.TwinStepper`) and whose
motor command drives it, one loop period per :meth:`TwinDevice.tick`; the
device time is the ideal tick time (the board's crystal), the plant is
advanced by exactly one period.

:class:`Emulator` serves a :class:`TwinDevice` on a file descriptor (the
master side of a pseudo-terminal, :func:`open_pty`): bytes from the host go
to the core, the core's bytes go back, and a tick runs every period of the
wall clock. A reader thread takes the host's bytes as they arrive (a
board's UART receives them whatever its loop does) and stamps their wall
time; the core gets them between ticks.

The device's clock (telemetry ``t_us``, the watchdog's measure) is the wall
clock in real time, as a board's crystal: when the emulator falls behind
(a stall of the machine), its watchdog still stops the motor within
``watchdog_ms`` plus one period of the host's last bytes. By the host's
clock it is the ideal tick time (deterministic). The plant's time
(``TwinStepper.t``) is always the ideal tick time: one period per tick.

With the device's ``host_clock`` parameter set (caps ``HOST_CLOCK``,
``--fast``), a tick runs as soon as the host allows it (it has sent the
next tick's command or heartbeat). Armed, once the host clocks the ticks,
the device is lock-stepped: it waits for the host's command for each tick
(so a run gives the same log under any load), for up to :data:`HOST_WAIT`
of wall time; then it ticks in real time, and its watchdog stops the motor
of a host that is gone. Otherwise it ticks in real time. A tick that starts
more than one period late is an overrun (counted by the core, reported in
telemetry); the lateness of every real-time tick is kept
(:attr:`Emulator.lateness`).
"""

from __future__ import annotations

import collections
import errno
import math
import os
import select
import signal
import threading
import time
import tty

import numpy as np

from ..errors import InputError
from ..rig.stepper import TwinStepper
from .core import DeviceCore
from .framing import encode_frame
from .protocol import FAULTS, FIXTURE_ACTIONS, PARAMS, STATES, encode, name_of
from .realtime import realtime_priority

__all__ = ["TwinDevice", "Emulator", "open_pty", "run_emulator", "stop_device", "check_link"]

_NAN = float("nan")
#: Bytes kept for a host that does not read (beyond them the oldest are dropped, as a UART without flow control
#: drops them; the host sees the gap).
_TX_BACKLOG = 2048
#: The window [s] before a change of state over which the emulator's own longest tick interval is reported.
OWN_PAUSE_WINDOW = 0.25
#: By the host's clock, armed, the device waits this long [s] of wall time for the host's next command before it
#: ticks in real time again (a host gone: its watchdog stops the motor).
HOST_WAIT = 2.0


class TwinDevice:
    """One emulated board: the firmware's core reading and driving the twin.

    Parameters
    ----------
    stepper : TwinStepper, optional
        The plant (default: the calibrated twin, ``session="auto"``).
    core : DeviceCore, optional
    """

    def __init__(self, stepper: TwinStepper | None = None, core: DeviceCore | None = None):
        self.stepper = TwinStepper() if stepper is None else stepper
        self.core = DeviceCore() if core is None else core
        self.stepper.warm()

    @property
    def period(self) -> float:
        """The loop period [s]."""
        return self.core.period_us * 1e-6

    def rx(self, data: bytes) -> None:
        self.core.rx(data)

    def tx(self) -> bytes:
        return self.core.tx()

    def tick(self, t_us: int | None = None) -> float:
        """One loop period: the operator's pending action, the encoders, the core, the plant over one period.

        Parameters
        ----------
        t_us : int, optional
            The device's time [us] (default: the plant's simulated time).
        """
        fx = self.core.fixture()
        if fx is not None:
            action, q1 = fx
            if action == FIXTURE_ACTIONS["CLAMP"]:
                self.stepper.clamp()
            elif action == FIXTURE_ACTIONS["HOLD"]:
                self.stepper.hold(q1)
            else:
                self.stepper.release()
        c1, c2 = self.stepper.counts()
        period_us = self.core.period_us
        v = self.core.tick(c1, c2, _NAN, int(round(self.stepper.t * 1e6)) if t_us is None else t_us)
        self.stepper.advance(v, period_us * 1e-6)
        return v


def open_pty() -> tuple[int, int, str]:
    """A raw pseudo-terminal: ``(master_fd, slave_fd, slave_path)``; the master is non-blocking."""
    master, slave = os.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    return master, slave, os.ttyname(slave)


class Emulator:
    """Serve a :class:`TwinDevice` on a file descriptor in real time (or faster, by the host's clock).

    Parameters
    ----------
    device : TwinDevice
    fd : int
        A non-blocking descriptor to read the host's bytes from and write the device's to
        (the master side of :func:`open_pty`).
    """

    def __init__(self, device: TwinDevice, fd: int):
        self.device = device
        self.fd = fd
        self._stop = threading.Event()
        self._out = bytearray()
        self.lateness: list[float] = []
        #: (wall time, wall time since the tick before) of the latest ticks: the emulator's own pauses [s]
        self._intervals: collections.deque[tuple[float, float]] = collections.deque(maxlen=256)
        self.ticks = 0
        self.dropped = 0
        self.error: BaseException | None = None
        #: wall time (time.monotonic) of the last bytes from the host [s]
        self.last_rx = math.nan
        #: called with a dict when the device's state changes (see :meth:`serve`)
        self.on_event = None
        self._state = None
        self._rx: list[bytes] = []
        self._rx_lock = threading.Lock()
        self._rx_event = threading.Event()
        self._clocked = False
        #: the device's clock [us] (its telemetry's ``t_us``)
        self.clock_us = 0
        self.scheduling = "normal"

    def stop(self) -> None:
        """Ask :meth:`serve` to return (from another thread or a signal handler)."""
        self._stop.set()

    def _reader(self) -> None:
        """Read the host's bytes as they arrive (a board's UART receives them whatever its loop does), stamping
        the wall time of the last ones; :meth:`_take` hands them to the core between ticks."""
        while not self._stop.is_set():
            try:
                r, _, _ = select.select([self.fd], [], [], 0.05)
                if not r:
                    continue
                data = os.read(self.fd, 65536)
            except BlockingIOError:
                continue
            except (OSError, ValueError) as exc:  # EIO: nobody holds the other side; EBADF: closed
                if isinstance(exc, OSError) and exc.errno == errno.EIO:
                    time.sleep(0.01)
                    continue
                return
            if data:
                with self._rx_lock:
                    self._rx.append(data)
                    self.last_rx = time.monotonic()
                self._rx_event.set()

    def _take(self) -> None:
        """The bytes received since the last call, to the core."""
        with self._rx_lock:
            chunks, self._rx = self._rx, []
            self._rx_event.clear()
        for data in chunks:
            self.device.rx(data)

    def _flush(self) -> None:
        self._out += self.device.tx()
        if len(self._out) > _TX_BACKLOG:
            self.dropped += len(self._out) - _TX_BACKLOG
            del self._out[: len(self._out) - _TX_BACKLOG]
        while self._out:
            try:
                n = os.write(self.fd, self._out)
            except BlockingIOError:
                return
            except OSError as exc:
                if exc.errno != errno.EIO:
                    raise
                self._out.clear()
                return
            del self._out[:n]

    def serve(self, *, max_ticks: int | None = None) -> None:
        """Run until :meth:`stop` (or ``max_ticks`` ticks), with real-time priority where allowed."""
        with realtime_priority() as self.scheduling:
            self._serve(max_ticks)

    def _serve(self, max_ticks: int | None) -> None:
        dev = self.device
        reader = threading.Thread(target=self._reader, name="iwp-emulator-rx", daemon=True)
        reader.start()
        last_tick = time.monotonic()
        deadline = last_tick + dev.period
        try:
            while not self._stop.is_set() and (max_ticks is None or self.ticks < max_ticks):
                self._take()
                now = time.monotonic()
                fast = dev.core.param("host_clock") != 0.0
                lockstep = fast and self._lockstep() and now - last_tick < HOST_WAIT
                if dev.core.ready():
                    deadline = now  # the host allows the next tick: run it now, and a period from now at the latest
                    late = 0.0
                elif lockstep or now < deadline:
                    wait = HOST_WAIT - (now - last_tick) if lockstep else deadline - now
                    self._rx_event.wait(min(wait, 0.002) if self._out else wait)
                    self._flush()
                    continue
                else:
                    late = now - deadline
                    self.lateness.append(late)
                if late > dev.period:
                    dev.core.overrun()
                    deadline = now  # the lost periods are not caught up
                # the device's clock: the wall clock as a board's crystal (its watchdog counts real time, also when
                # the emulator fell behind), the ideal period by the host's clock (deterministic)
                self.clock_us += dev.core.period_us if fast else int(round((now - last_tick) * 1e6))
                self._intervals.append((now, now - last_tick))
                last_tick = now
                dev.tick(self.clock_us)
                self.ticks += 1
                if self.on_event is not None:
                    self._report()
                self._flush()
                deadline += dev.period
        except BaseException as exc:  # noqa: BLE001 (kept for the thread's owner)
            self.error = exc
            raise
        finally:
            self._stop.set()
            reader.join()

    def _lockstep(self) -> bool:
        """By the host's clock, armed, with the host clocking the ticks since the arming: wait for it."""
        _, state, _, _ = self.device.core.status()
        if state != STATES["ARMED"]:
            self._clocked = False
        elif self.device.core.ready():
            self._clocked = True
        return self._clocked

    def _report(self) -> None:
        """Tell :attr:`on_event` when the state changed: device time, wall time, how long after the host's
        last bytes (the watchdog's measure), and the longest wall time between two of the emulator's own ticks
        in the last :data:`OWN_PAUSE_WINDOW` (``own_pause``: a board ticks every period whatever the machine does;
        an emulator paused by its machine sends no telemetry meanwhile, so a host that answers each sample falls
        silent with it)."""
        tick, state, fault, v = self.device.core.status()
        if state == self._state:
            return
        self._state = state
        now = time.monotonic()
        recent = [dt for w, dt in self._intervals if w >= now - OWN_PAUSE_WINDOW]
        self.on_event({"state": name_of(STATES, state), "fault": name_of(FAULTS, fault), "tick": tick,
                       "t_device": self.device.stepper.t, "wall": now, "v": v,
                       "after_host": now - self.last_rx if math.isfinite(self.last_rx) else math.nan,
                       "own_pause": max(recent, default=0.0)})

    def start(self) -> threading.Thread:
        """Serve in a daemon thread (the in-process twin, tests)."""
        th = threading.Thread(target=self._serve_quietly, name="iwp-emulator", daemon=True)
        th.start()
        return th

    def _serve_quietly(self) -> None:
        try:
            self.serve()
        except BaseException:  # noqa: BLE001 (recorded in self.error)
            pass

    def timing(self) -> dict[str, float]:
        """Lateness of the real-time ticks after their deadline [s]: p50, p99, max, and the count."""
        lat = np.asarray(self.lateness, dtype=float)
        if lat.size == 0:
            return {"ticks": self.ticks, "p50": math.nan, "p99": math.nan, "max": math.nan,
                    "scheduling": self.scheduling}
        return {"ticks": self.ticks, "p50": float(np.percentile(lat, 50)), "p99": float(np.percentile(lat, 99)),
                "max": float(lat.max()), "scheduling": self.scheduling}


def run_emulator(device: TwinDevice, *, on_port, link: str | None = None, setup: dict | None = None,
                 on_event=None) -> dict:
    """Serve ``device`` on a new pseudo-terminal until SIGINT or SIGTERM; stop its motor; return the timing.

    Parameters
    ----------
    device : TwinDevice
    on_port : callable
        Called with the port's path once it is ready (the CLI prints it).
    link : str, optional
        Also reachable as this path (a symbolic link to the port, removed at the end).
    setup : dict, optional
        Device parameters to set before serving (``period_us``, ``counts1``, ...), as a host would.
    on_event : callable, optional
        Called with a dict at each change of the device's state (state, fault, tick, device and wall
        time, ``after_host``: seconds since the host's last bytes, ``own_pause``: the emulator's longest interval
        between two of its ticks in the last :data:`OWN_PAUSE_WINDOW` seconds).

    Returns
    -------
    dict
        :meth:`Emulator.timing` and :func:`stop_device`'s states before and after the final stop.
    """
    for name, value in (setup or {}).items():
        device.rx(encode_frame(encode("SET_PARAM", req=0, param=PARAMS[name].id, value=float(value))))
    device.tx()  # the answers to ourselves
    master, slave, path = open_pty()
    emu = Emulator(device, master)
    emu.on_event = on_event
    made_link = False
    old = {}

    def handler(signum, frame):
        emu.stop()

    try:
        for s in (signal.SIGINT, signal.SIGTERM):
            old[s] = signal.signal(s, handler)
        if link is not None:
            os.symlink(path, link)
            made_link = True
        on_port(path)
        emu.serve()
    finally:
        for s, h in old.items():
            signal.signal(s, h)
        if made_link:
            try:
                os.unlink(link)
            except OSError:
                pass
        os.close(master)
        os.close(slave)
        stopped = stop_device(device)  # on every path out, as the board's power going off
    out = emu.timing()
    out.update(stopped)
    return out


def check_link(link: str | os.PathLike) -> bool:
    """Check that ``link`` is free for :func:`run_emulator`'s port link; remove a stale one.

    A link left by an emulator killed without its clean-up (``kill -9``)
    points to a pseudo-terminal that no longer exists: it is removed.

    Parameters
    ----------
    link : str or path-like
        The path asked for (``iwp rig emulate --link``).

    Returns
    -------
    bool
        Whether a stale link was removed.

    Raises
    ------
    InputError
        ``link`` exists (a file, or a link to a port that exists: another emulator may serve it).
    """
    p = os.fspath(link)
    folder = os.path.dirname(os.path.abspath(p))
    if not os.path.isdir(folder):
        raise InputError(f"--link {p}: its folder {os.path.dirname(p) or '.'} does not exist", argument="--link")
    if os.path.islink(p) and not os.path.exists(p):
        target = os.readlink(p)
        if target.startswith("/dev/pts/"):
            os.unlink(p)
            return True
        raise InputError(f"--link {p}: a link to {target}, which does not exist (not an emulator's port); remove it "
                         "or pick another path", argument="--link")
    if os.path.lexists(p):
        what = (f"a link to {os.readlink(p)}, which exists: another emulator may serve it" if os.path.islink(p)
                else "exists")
        raise InputError(f"--link {p}: {what}; pick another path", argument="--link")
    return False


def stop_device(device: TwinDevice) -> dict:
    """Stop an emulated board's motor as it ends, as a board's power going off does: an emergency stop sent to
    its core in a frame, as a host sends one.

    Parameters
    ----------
    device : TwinDevice

    Returns
    -------
    dict
        ``state_before``/``fault_before``: the device's state when the emulator ended (``"ARMED"`` while a
        host still drove it); ``state``/``fault``: after the stop; ``v``: the motor's command after it.
    """
    _, before, fault_before, _ = device.core.status()
    if before == STATES["ARMED"]:
        device.rx(encode_frame(encode("ESTOP", req=0)))
        device.tx()  # its answer goes nowhere: the port is closed
    _, state, fault, v = device.core.status()
    return {"state_before": name_of(STATES, before), "fault_before": name_of(FAULTS, fault_before),
            "state": name_of(STATES, state), "fault": name_of(FAULTS, fault), "v": float(v)}
