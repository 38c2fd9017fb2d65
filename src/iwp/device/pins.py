"""The pin-level twin: the board's firmware image under simavr, the twin at its pins, in closed loop.

:class:`SimavrRig` is a :class:`~iwp.device.connection.Rig` whose device is
iwp's AVR firmware (``firmware/avr/main.c`` and the core, built for the
ATmega328P) running in simavr (``firmware/sim/iwp_simavr.c --twin``), its
serial port on a pseudo-terminal. The harness puts the twin's encoder
angles on the encoder pins as quadrature edges (x4, the truth's
``counts_per_rev``: the firmware's interrupts decode them) and reads the
motor's input back from the PWM's compare register and the direction pins;
:class:`PinTwin` steps iwp's own twin (:class:`~iwp.rig.stepper.TwinStepper`)
in the simulated time, over the harness's stdin/stdout, so the physics is
written once. An input holds on the twin exactly from the cycle at which the
firmware set it; the emulated hands (FIXTURE) reach the twin the same way.

Compared with the emulator (:mod:`iwp.device.emulator`, the same core
compiled for this computer), this runs the board's image itself: its
encoder interrupts, its timer, its UART, its PWM, with the ATmega328P's
cycle costs (the control step applies its input when it ends, not at the
tick).

Its pace: as fast as simavr goes while the host keeps talking, at most half
a loop period (at least 1 ms) of device time beyond the end of the first
frame the host has not answered: a host that answers each tick's telemetry
with the next tick's command is on time at 200 Hz however slow the computer
(at 1 kHz such a command may be late). A host silent for a quarter of a
second of wall-clock time no longer holds it: it goes on in real time, and
the device's watchdog stops the motor as on a board. No ``host_clock`` (the
image has no HOST_CLOCK cap): run without ``fast``. The twin's encoders are
ideal (its ``noise_std`` is not applied).
"""

from __future__ import annotations

import math
import signal
import subprocess
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..rig.stepper import TwinStepper
from ..rig.truth import RigTruth
from .connection import Rig
from .errors import DeviceError
from .protocol import FIXTURE_ACTIONS

__all__ = ["SimavrRig", "PinTwin", "PinTick", "ConstantSpeed", "CountCheck", "compare_counts", "count_check",
           "CPU_HZ"]

#: The ATmega328P's clock [Hz] (the harness's cycles).
CPU_HZ = 16_000_000
_START_TIMEOUT = 20.0


class ConstantSpeed:
    """A plant whose angles turn at constant speeds, whatever the input (the encoders' capacity).

    Parameters
    ----------
    q3, q4 : float
        Pendulum and wheel speed [rad/s].
    counts_per_rev : float
        Encoder resolution [counts/rev].
    """

    def __init__(self, q3: float, q4: float, counts_per_rev: float = 2000.0):
        self.x = np.array([0.0, 0.0, float(q3), float(q4)])
        self.t = 0.0
        self.step = 2.0 * math.pi / float(counts_per_rev)

    def advance(self, v: float, dt: float) -> None:
        """Advance ``dt`` [s]; the input ``v`` has no effect."""
        self.x[:2] += self.x[2:] * dt
        self.t += dt

    def clamp(self) -> None:
        """Stop the pendulum at 0."""
        self.x[0] = self.x[2] = 0.0

    def hold(self, q1: float) -> None:
        """Hold the pendulum at ``q1`` [rad]."""
        self.x[0], self.x[2] = float(q1), 0.0

    def release(self) -> None:
        """Nothing to release."""


@dataclass(frozen=True)
class PinTick:
    """One control step of the firmware: the counts the harness had put on the pins when it read them.

    Attributes
    ----------
    tick : int
        The firmware's tick (the telemetry's ``seq``).
    t : float
        Device time of the step's start [s].
    n1, n2 : int
        Pendulum and wheel counts put on the pins since the first tick.
    seen1, seen2 : int
        The counts the pins showed when the encoder's interrupt last read them: what the firmware must have
        counted (an edge still pending behind the read makes them differ from ``n1``, ``n2``).
    """

    tick: int
    t: float
    n1: int
    n2: int
    seen1: int
    seen2: int

    @property
    def near(self) -> bool:
        """An edge was pending (not yet read by the firmware's interrupt) when the firmware read its counts."""
        return (self.seen1, self.seen2) != (self.n1, self.n2)


class PinTwin:
    """The plant's side of the harness's stepping protocol (``iwp_simavr --twin``; see its header).

    Parameters
    ----------
    plant : TwinStepper or ConstantSpeed
        Anything with ``x`` (the state, angles first), ``t``, ``step`` and ``advance(v, dt)``, ``clamp()``,
        ``hold(q1)``, ``release()``.
    frequency : float
        The simulated clock [Hz].

    Attributes
    ----------
    ticks : list of PinTick
    history : list of tuple
        ``(t, q1, q2)`` at every chunk's start [s, rad].
    error : BaseException or None
        What stopped :meth:`serve` (the plant failed), if anything.
    """

    def __init__(self, plant, frequency: float = CPU_HZ):
        self.plant = plant
        self.frequency = float(frequency)
        self.ticks: list[PinTick] = []
        self.history: list[tuple[float, float, float]] = []
        self.error: BaseException | None = None
        self.chunks = 0
        self._cycle = 0
        self._v = 0.0
        self._pred: tuple[int, np.ndarray] | None = None

    def _advance_to(self, cycle: int) -> None:
        p = self.plant
        if self._pred is not None and self._pred[0] == cycle:  # the chunk ran to its end: its prediction holds
            p.x[:] = self._pred[1]
        elif cycle > self._cycle:
            p.advance(self._v, (cycle - self._cycle) / self.frequency)
        p.t = cycle / self.frequency
        self._cycle = cycle

    def answer(self, line: str) -> str:
        """The answer to one ``T`` line: the angles and speeds now and predicted at the chunk's end [rad, rad/s]."""
        _, cycle, v, hand, q1, horizon = line.split()
        self._advance_to(int(cycle))
        p = self.plant
        hand = int(hand)
        if hand == FIXTURE_ACTIONS["CLAMP"] + 1:
            p.clamp()
        elif hand == FIXTURE_ACTIONS["HOLD"] + 1:
            p.hold(float(q1))
        elif hand == FIXTURE_ACTIONS["RELEASE"] + 1:
            p.release()
        self._v = float(v)
        now = [float(q) for q in p.x[[0, 2, 1, 3]]]  # q1, q3, q2, q4
        self.history.append((p.t, now[0], now[2]))
        x, t = p.x.copy(), p.t
        p.advance(self._v, (int(horizon) - self._cycle) / self.frequency)
        self._pred = (int(horizon), p.x.copy())
        ahead = [float(q) for q in p.x[[0, 2, 1, 3]]]
        p.x[:], p.t = x, t
        self.chunks += 1
        return " ".join(repr(q) for q in now + ahead) + "\n"

    def serve(self, lines, out) -> None:
        """Answer the harness until its output ends (``lines``: its stdout; ``out``: its stdin)."""
        try:
            for raw in lines:
                line = raw.decode() if isinstance(raw, bytes) else raw
                if line.startswith("T "):
                    out.write(self.answer(line).encode())
                    out.flush()
                elif line.startswith("M "):
                    _, tick, cycle, n1, n2, s1, s2 = line.split()
                    self.ticks.append(PinTick(int(tick), int(cycle) / self.frequency, int(n1), int(n2), int(s1),
                                              int(s2)))
        except BaseException as exc:  # noqa: BLE001 (kept for the owner; closing stdin ends the harness)
            self.error = exc
        finally:
            try:
                out.close()
            except OSError:
                pass


class SimavrRig(Rig):
    """The firmware image under simavr with the twin at its pins, as a rig (see the module's docstring).

    Parameters
    ----------
    elf : str or Path
        The firmware image (``make -C firmware avr``: ``build/iwp.elf``).
    harness : str or Path
        ``iwp_simavr`` (``make -C firmware simavr``).
    plant : TwinStepper or ConstantSpeed, optional
        Default: the twin of ``truth`` (:class:`~iwp.rig.stepper.TwinStepper`, ``session="auto"``).
    truth : RigTruth, optional
        Default: the calibrated twin.
    x0 : float or sequence of 4 floats, optional
        Initial state of the twin [rad, rad/s].
    chunk_us : float
        Longest stretch of device time over which the twin's angles are interpolated [us].
    stats : str or Path, optional
        Where the harness writes the control step's cycle counts (JSON).
    """

    def __init__(self, elf, harness, *, plant=None, truth: RigTruth | None = None, x0=None,
                 chunk_us: float = 1000.0, stats=None):
        for name, path in (("elf", elf), ("harness", harness)):
            if not Path(path).is_file():
                raise InputError(f"{name}: no such file {str(path)!r}", argument=name)
        if not (isinstance(chunk_us, (int, float)) and 1.0 <= chunk_us <= 1e5):
            raise InputError(f"chunk_us must be within 1 .. 100000 us, got {chunk_us!r}", argument="chunk_us")
        if plant is None:
            plant = TwinStepper(truth, x0=x0)
            plant.warm()
        self.twin = PinTwin(plant)
        counts = 2.0 * math.pi / plant.step
        cmd = [str(harness), str(elf), "--twin", f"{counts:.12g}", "--chunk-us", f"{chunk_us:g}"]
        if stats is not None:
            cmd += ["--stats", str(stats)]
        self._log = tempfile.TemporaryFile()
        self.process = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=self._log)
        self._thread = None
        try:
            port = self._port()
            self._thread = threading.Thread(target=self.twin.serve, args=(self.process.stdout, self.process.stdin),
                                            name="iwp-pin-twin", daemon=True)
            self._thread.start()
            super().__init__(port)
        except BaseException:
            self._shutdown()
            raise

    def _port(self) -> str:
        timer = threading.Timer(_START_TIMEOUT, self.process.kill)
        timer.start()
        try:
            for raw in self.process.stdout:
                line = raw.decode(errors="replace")
                if line.startswith("port: "):
                    return line.split()[1]
        finally:
            timer.cancel()
        raise DeviceError(f"{self.process.args[0]}: no port ({self.harness_log().strip()[-300:]})")

    def harness_log(self) -> str:
        """What the harness wrote to its stderr so far (all of it once closed)."""
        if self._log.closed:
            return self.log_text
        self._log.seek(0)
        return self._log.read().decode(errors="replace")

    def close(self) -> None:
        try:
            super().close()
        finally:
            self._shutdown()

    def _shutdown(self) -> None:
        p = self.process
        if p.poll() is None:
            p.send_signal(signal.SIGTERM)
            try:
                p.wait(5)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        for f in (p.stdin, p.stdout):
            try:
                f.close()
            except OSError:
                pass
        if not self._log.closed:
            self.log_text = self.harness_log()
            self._log.close()


@dataclass(frozen=True)
class CountCheck:
    """The firmware's counts against the counts put on its pins (:func:`compare_counts`).

    Attributes
    ----------
    compared : int
        Telemetry samples compared.
    wrong : int
        Samples whose pendulum or wheel count differs from what the pins showed the firmware's interrupts
        (an edge lost or invented).
    pending : int
        Samples taken while an edge waited for its interrupt (counted at the next tick).
    max_error : int
        Largest difference [counts].
    """

    compared: int
    wrong: int
    pending: int
    max_error: int


def compare_counts(samples, ticks) -> CountCheck:
    """Compare the telemetry's counts with the counts put on the pins at the same ticks.

    Parameters
    ----------
    samples : sequence of Sample
        Telemetry (its ``count1``, ``count2``, relative to the device's zero).
    ticks : sequence of PinTick
        :attr:`PinTwin.ticks` (relative to the first tick); the offset between the two is taken from the
        first sample.

    Returns
    -------
    CountCheck
    """
    by_tick = {k.tick: k for k in ticks}
    pairs = [(s, by_tick[s.seq]) for s in samples if s.seq in by_tick]
    if not pairs:
        return CountCheck(0, 0, 0, 0)
    off1, off2 = pairs[0][0].count1 - pairs[0][1].seen1, pairs[0][0].count2 - pairs[0][1].seen2
    wrong = pending = worst = 0
    for s, k in pairs:
        e = max(abs(s.count1 - off1 - k.seen1), abs(s.count2 - off2 - k.seen2))
        worst = max(worst, e)
        pending += k.near
        wrong += e > 0
    return CountCheck(len(pairs), wrong, pending, worst)


def count_check(rig: SimavrRig, seconds: float, *, period_us: float = 5000.0, every: int = 1) -> CountCheck:
    """Run the device's Hopf law for ``seconds`` of device time and compare its counts with the pins'.

    The limits are opened (``q1_max`` 1000 rad, ``q4_max`` 10000 rad/s, no stall check) so that a
    :class:`ConstantSpeed` plant can turn at any speed; disarmed at the end.

    Parameters
    ----------
    rig : SimavrRig
    seconds : float
        Device time compared [s].
    period_us : float
        The loop period [us].
    every : int
        Telemetry every ``every`` ticks.

    Returns
    -------
    CountCheck
    """
    rig.clear()
    rig.stream(int(every))  # first: telemetry every tick at 1 kHz would fill the line
    rig.set_params(q1_max=1000.0, q4_max=10000.0, sat_ms_max=0.0, period_us=float(period_us))
    rig.mode("HOPF")
    rig.arm()
    got = []
    try:
        while len(got) * every * period_us * 1e-6 < seconds:
            batch = rig.samples(2.0)
            if not batch:
                raise DeviceError(f"no telemetry from {rig.port}")
            for s in batch:
                rig.heartbeat(s.seq + 2 * every)
            got += [s for s in batch if s.state == "ARMED"]
    finally:
        rig.disarm()
    return compare_counts(got, rig.twin.ticks)
