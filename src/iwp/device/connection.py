"""One interface to every rig that speaks iwp's protocol: connect, identify, arm, stop, command, stream.

:class:`Rig` is the interface (after Quanser's rig API: the hardware and its
twin behind one set of calls) and its implementation over a link
(:class:`~iwp.device.link.DeviceLink`): a real board on a serial port, the
emulator's pseudo-terminal, simavr's, or the in-process twin
(:class:`iwp.device.twin.TwinRig`). Every request waits for the device's
``ACK`` and turns a refusal into a one-line :class:`DeviceError`.

Stopping the motor: :meth:`Rig.estop` is idempotent and never raises;
:meth:`Rig.close` (and leaving a ``with`` block, and garbage collection)
disarms after a normal end and calls it otherwise. The device's own watchdog stops the motor when the host is gone
(docs/protocol.md).
"""

from __future__ import annotations

import collections
import math
import random
import struct
import time
from dataclasses import dataclass, field
from typing import Any

from .errors import DeviceError
from .link import DEFAULT_BAUD, DeviceLink
from .protocol import (
    ACK_CODES,
    CAPS,
    DICTIONARY_HASH,
    FAULTS,
    FIXTURE_ACTIONS,
    MESSAGES,
    MODES,
    PARAMS,
    PROTOCOL_VERSION,
    STATES,
    Decoded,
    flag_names,
    name_of,
    param,
)

__all__ = ["Rig", "DeviceInfo", "Sample", "BOARDS", "connect", "params_hash"]

#: IDENT ``board``.
BOARDS = {0: "host (emulator or software in the loop)", 1: "ATmega328P", 2: "ATmega2560"}
#: How long a request waits for its ACK [s].
REQUEST_TIMEOUT = 1.0
#: How often, meanwhile, the request is sent again [s]. Every request the device answers with ACK is idempotent
#: (ARM when armed, DISARM when disarmed, a repeated SET_PARAM ... answer OK and change nothing more) and carries
#: a number its ACK echoes, so a frame lost to the wire's noise, either way, costs a repeat, not the experiment;
#: at most half the device's watchdog, so that an ARM whose ACK was lost is repeated (which feeds the watchdog)
#: before the watchdog stops the motor.
REQUEST_REPEAT = 0.05
#: How often HELLO is sent until the device answers IDENT, three times in all [s] (a board may be resetting).
HELLO_REPEAT = 0.5


@dataclass(frozen=True)
class DeviceInfo:
    """Who the device is: its firmware, board, capabilities, and parameters (read back)."""

    port: str
    protocol: int
    firmware: str
    board: str
    caps: tuple[str, ...]
    dict_hash: int
    params_hash: int
    base_us: int
    params: dict[str, float] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return {"port": self.port, "protocol": self.protocol, "firmware": self.firmware, "board": self.board,
                "caps": list(self.caps), "dict_hash": f"0x{self.dict_hash:08x}",
                "params_hash": f"0x{self.params_hash:08x}", "base_us": self.base_us, "params": dict(self.params)}


@dataclass(frozen=True)
class Sample:
    """One telemetry frame in SI units.

    Attributes
    ----------
    seq : int
        Device tick.
    t_device : float
        Device time [s] (wraps after 71 min).
    count1, count2 : int
        Encoder counts.
    q1, q2 : float
        Angles [rad] (counts times the encoder steps of the device's parameters).
    q4 : float
        Wheel speed of the device [rad/s].
    u, v : float
        Ideal input applied, driver command applied [input units].
    current : float
        Motor current [A] (NaN: not measured).
    state, fault : str
    flags : tuple of str
    overruns, late, rx_errors, dropped : int
        The device's counters (16 bits, wrapping): loop overruns, ticks without a command, frames refused,
        COMMANDs dropped by a full queue (protocol 3).
    t_host : float
        When the host received it (``time.monotonic``) [s].
    """

    seq: int
    t_device: float
    count1: int
    count2: int
    q1: float
    q2: float
    q4: float
    u: float
    v: float
    current: float
    state: str
    fault: str
    flags: tuple[str, ...]
    overruns: int
    late: int
    rx_errors: int
    dropped: int
    t_host: float


def params_hash(values: dict[str, float]) -> int:
    """FNV-1a of the parameters as float32 in id order: the device's ``params_hash``.

    Parameters
    ----------
    values : dict of str to float
        Value of every device parameter (:data:`PARAMS`), by name, in its unit.

    Returns
    -------
    int
        The 32-bit hash.
    """
    h = 2166136261
    for p in sorted(PARAMS.values(), key=lambda p: p.id):
        for b in struct.pack("<f", values[p.name]):
            h = ((h ^ b) * 16777619) & 0xFFFFFFFF
    return h


class Rig:
    """A rig that speaks iwp's protocol.

    Parameters
    ----------
    port : str
        Serial device, pseudo-terminal or pyserial URL.
    baudrate : int
    transport : object, optional
        An open pyserial-like object (tests).

    Examples
    --------
    >>> with Rig("/dev/ttyACM0") as rig:          # doctest: +SKIP
    ...     print(rig.info.firmware, rig.info.board)
    ...     rig.set_params(v_dz_pos=31, v_dz_neg=31)
    ...     rig.arm()
    ...     rig.command(20.0)
    ...     samples = rig.samples(0.1)
    """

    def __init__(self, port: str, *, baudrate: int = DEFAULT_BAUD, transport=None):
        self._stopped = True
        self.link = DeviceLink(port, baudrate=baudrate, transport=transport)
        self._pending: collections.deque[Decoded] = collections.deque()  # put back, in order
        self._telemetry: collections.deque[Decoded] = collections.deque()  # seen while waiting for an answer
        #: The newest device tick seen (in the order of the stream).
        self.last_seq = -1
        self._cmd_seq = 0
        self._hb_seq = 0
        self._req = 0
        self.info: DeviceInfo | None = None
        self.params_found: dict[str, float] = {}
        #: parameters set for this connection only (:meth:`set_params_until_close`), with the values to put back
        self._restore: dict[str, float] = {}
        try:
            self.link.discard_input()
            self.info = self.identify()
        except BaseException:
            self.link.close()
            raise

    # ------------------------------------------------------------------ requests
    @property
    def port(self) -> str:
        return self.link.port

    def _request(self, name: str, what: str, **fields) -> Decoded:
        """Send request ``name`` and wait for its ACK (the one echoing its ``req``), sending it again every
        :data:`REQUEST_REPEAT` s for up to :data:`REQUEST_TIMEOUT` s; a refusal raises :class:`DeviceError`."""
        self._req = self._req % 0xFFFF + 1
        req, want = self._req, MESSAGES[name].id  # the ACK's ``req`` and ``msg`` (the request's type)
        ack = self._exchange(name, dict(fields, req=req),
                             lambda m: m.name == "ACK" and m["req"] == req and m["msg"] == want,
                             self._repeat(), REQUEST_TIMEOUT, what)
        if ack["code"] != ACK_CODES["OK"]:
            raise DeviceError(f"{self.port}: the device refused {what}: {name_of(ACK_CODES, ack['code']).lower()}"
                              + (f" (state {self.state_text()})" if ack["code"] in (3, 4, 5) else ""))
        return ack

    def _repeat(self) -> float:
        """How long one attempt of a request waits [s]: :data:`REQUEST_REPEAT`, or half the device's watchdog."""
        if self.info is None:
            return REQUEST_REPEAT
        return min(REQUEST_REPEAT, self.info.params["watchdog_ms"] / 2000.0)

    def _next_messages(self, timeout: float) -> list[Decoded]:
        """The device's messages in the order they came: those put back first, then new ones."""
        if self._pending:
            out = list(self._pending)
            self._pending.clear()
            return out
        return self.link.receive(timeout)

    def _poll(self, match, timeout: float) -> Decoded | None:
        """The first message that ``match``es within ``timeout`` s, or None; telemetry before it is kept for
        :meth:`samples`, later messages are put back."""
        end = _now() + timeout
        while True:
            left = end - _now()
            if left <= 0:
                return None
            batch = self._next_messages(left)
            for i, m in enumerate(batch):
                if m.name == "TELEMETRY":
                    self._telemetry.append(m)
                    self.last_seq = m["seq"]
                elif match(m):
                    self._pending.extendleft(reversed(batch[i + 1:]))
                    return m

    def _exchange(self, name: str, fields: dict, match, repeat: float, timeout: float, what: str) -> Decoded:
        """Send ``name`` with ``fields`` every ``repeat`` s until a message ``match``es, for up to ``timeout`` s.

        Raises
        ------
        DeviceError
            Nothing matched within ``timeout`` s (the message says how many times it was sent).
        """
        attempts = 0
        end = _now() + timeout
        while True:
            left = end - _now()
            if left <= 0:
                raise DeviceError(f"port {self.port}: no answer to {what} within {timeout:g} s (sent "
                                  f"{attempts} times; is an iwp firmware on it, at the right baud rate?)")
            self.link.send(name, **fields)
            attempts += 1
            m = self._poll(match, min(repeat, left))
            if m is not None:
                return m

    def identify(self) -> DeviceInfo:
        """Ask the device who it is (HELLO), check its protocol, read its parameters."""
        nonce = random.randrange(1, 65536)
        ident = self._exchange("HELLO", {"nonce": nonce}, lambda m: m.name == "IDENT" and m["nonce"] == nonce,
                               HELLO_REPEAT, 3 * HELLO_REPEAT, "HELLO")
        if ident["protocol"] != PROTOCOL_VERSION or ident["dict_hash"] != DICTIONARY_HASH:
            raise DeviceError(
                f"{self.port}: the device speaks protocol {ident['protocol']} (dictionary 0x{ident['dict_hash']:08x}), "
                f"this iwp protocol {PROTOCOL_VERSION} (0x{DICTIONARY_HASH:08x}); flash the firmware of this iwp "
                "(firmware/README.md)")
        self.link.min_seq = ident["tick"]  # what came before is an earlier session's
        self.link.expect_gap()
        self._telemetry = collections.deque(m for m in self._telemetry if m["seq"] >= ident["tick"])
        values = {p.name: self.get_param(p.name) for p in PARAMS.values()}
        for p in PARAMS.values():  # a device that reports what no device holds (counts1 = 0, period_us = NaN)
            v = values[p.name]
            if not (math.isfinite(v) and p.lo <= v <= p.hi):
                raise DeviceError(f"{self.port}: the device reports {p.name} = {v!r}, outside the range every iwp "
                                  f"firmware holds ({p.lo:g} .. {p.hi:g} {p.unit}): its firmware or the link is "
                                  "faulty; flash the firmware of this iwp (firmware/README.md)")
        caps = tuple(k for k, v in CAPS.items() if ident["caps"] & v)
        info = DeviceInfo(port=self.port, protocol=ident["protocol"],
                          firmware=f"{ident['fw_major']}.{ident['fw_minor']}.{ident['fw_patch']}",
                          board=BOARDS.get(ident["board"], f"board {ident['board']}"), caps=caps,
                          dict_hash=ident["dict_hash"], params_hash=ident["params_hash"], base_us=ident["base_us"],
                          params=values)
        if params_hash(values) != info.params_hash:
            raise DeviceError(f"{self.port}: the parameters read back do not match the device's hash")
        self.info = info
        #: the parameters as this connection found them (what an earlier run or another client left)
        self.params_found = dict(values)
        return info

    def get_param(self, name: str) -> float:
        """One parameter of the device."""
        p = param(name)
        return float(self._request("GET_PARAM", f"GET_PARAM {name}", param=p.id)["value"])

    def set_params(self, **values: float) -> None:
        """Set parameters (see :data:`~iwp.device.protocol.PARAMS`); refused while armed or out of range."""
        for name, value in values.items():
            p = param(name)
            ack = self._request("SET_PARAM", f"{name} = {value!r} (range {p.lo:g} .. {p.hi:g} {p.unit})",
                                param=p.id, value=float(value))
            if self.info is not None:
                self.info.params[name] = float(ack["value"])

    # ------------------------------------------------------------------ state
    def arm(self) -> None:
        """Enable the motor."""
        self._request("ARM", "ARM")
        self._stopped = False

    def disarm(self) -> None:
        """Motor off (a fault stays)."""
        self._request("DISARM", "DISARM")
        self._stopped = True

    def estop(self) -> bool:
        """Emergency stop: motor off, latched until :meth:`clear`. Idempotent; never raises.

        Returns
        -------
        bool
            Whether the device acknowledged it (False: the link is gone; its watchdog stops the motor).
        """
        if self.link.closed:
            return False
        try:
            self._request("ESTOP", "ESTOP")
            self._stopped = True
            return True
        except Exception:  # noqa: BLE001 (a stop must not raise: the watchdog is the last line)
            return False

    def clear(self) -> None:
        """Clear a fault or an emergency stop."""
        self._request("CLEAR", "CLEAR")

    def zero(self, pendulum: bool = True, wheel: bool = True) -> None:
        """Set the encoder counts to 0 (the pendulum hanging at rest)."""
        self._request("ZERO", "ZERO", mask=(1 if pendulum else 0) | (2 if wheel else 0))

    def mode(self, name: str) -> None:
        """The device's control law: ``"HOST"``, ``"HOPF"`` or ``"STATE_FEEDBACK"``."""
        if name not in MODES:
            raise DeviceError(f"unknown mode {name!r}; known: {', '.join(MODES)}")
        self._request("MODE", f"MODE {name}", mode=MODES[name])

    def stream(self, every: int = 1) -> None:
        """One telemetry frame every ``every`` ticks (0: none)."""
        self._request("STREAM", "STREAM", every=int(every))
        self.link.expect_gap()

    def has(self, cap: str) -> bool:
        return self.info is not None and cap in self.info.caps

    def fixture(self, action: str, q1: float = 0.0) -> int | None:
        """The operator's hands on an emulated rig (``CLAMP``, ``HOLD`` at ``q1``, ``RELEASE``).

        Returns
        -------
        int or None
            The device tick whose sample is the first after the action (the action applies from that tick
            on), or None when the device has no such hands (a real rig: the operator acts).
        """
        if not self.has("FIXTURE"):
            return None
        self._request("FIXTURE", f"FIXTURE {action}", action=FIXTURE_ACTIONS[action], q1=float(q1))
        return self.last_seq + 1

    # ------------------------------------------------------------------ streaming
    def command(self, u: float, tick: int = 0) -> None:
        """The ideal input ``u`` [input units] from device tick ``tick`` on (0: the next tick)."""
        if not math.isfinite(u):
            raise DeviceError(f"command u must be finite, got {u!r}")
        self._cmd_seq += 1
        self.link.send("COMMAND", seq=self._cmd_seq, tick=int(tick), u=float(u))

    def heartbeat(self, tick: int = 0) -> None:
        """Feed the watchdog; with the host clock, allow the device to run up to ``tick``."""
        self._hb_seq += 1
        self.link.send("HEARTBEAT", seq=self._hb_seq, tick=int(tick))

    def samples(self, timeout: float) -> list[Sample]:
        """The telemetry that arrives within ``timeout`` [s] (returns as soon as some did), oldest first.

        Other messages that come meanwhile (an acknowledgement, a refusal) are passed over: empty means no
        telemetry for ``timeout``, not that something else came first.
        """
        end = _now() + timeout
        msgs = list(self._telemetry)
        self._telemetry.clear()
        read = False
        while not any(m.name == "TELEMETRY" for m in msgs):
            left = end - _now()
            if read and left <= 0:
                return []
            msgs = self._next_messages(max(left, 0.0))
            read = True
        now = _now()
        s1 = 2 * math.pi / self.info.params["counts1"]
        s2 = 2 * math.pi / self.info.params["counts2"]
        out = []
        for m in msgs:
            if m.name != "TELEMETRY":
                continue
            v = m.values
            self.last_seq = max(self.last_seq, v["seq"])
            out.append(Sample(seq=v["seq"], t_device=v["t_us"] * 1e-6, count1=v["count1"], count2=v["count2"],
                              q1=v["count1"] * s1, q2=v["count2"] * s2, q4=v["q4"], u=v["u"], v=v["v"],
                              current=v["current"], state=name_of(STATES, v["state"]),
                              fault=name_of(FAULTS, v["fault"]), flags=tuple(flag_names(v["flags"])),
                              overruns=v["overruns"], late=v["late"], rx_errors=v["rx_errors"],
                              dropped=v["dropped"], t_host=now))
        return out

    def set_params_until_close(self, **values: float) -> None:
        """Set parameters for this connection only: :meth:`close` puts back the values they had before, after the
        motor is stopped (if that fails, e.g. the link is gone, the next connection finds them changed and says
        so: :func:`iwp.device.runs.latched`)."""
        for name in values:
            if name not in self._restore:
                self._restore[name] = self.info.params[name] if self.info is not None and name in \
                    self.info.params else self.get_param(name)
        self.set_params(**values)

    def state_text(self) -> str:
        """The device's state from its latest telemetry (``ARMED``, ``FAULT (WATCHDOG)``, ...)."""
        got = self.samples(0.2)
        if not got:
            return "unknown"
        s = got[-1]
        return s.state + (f" ({s.fault})" if s.fault != "NONE" else "")

    # ------------------------------------------------------------------ closing
    def close(self) -> None:
        """Stop the motor, then close the port. Idempotent.

        After a normal end (the host disarmed, or never armed) a disarm, so that the next run finds the device
        as this one left it, not in a latched emergency stop; otherwise (armed, or the disarm fails) an
        emergency stop, latched until :meth:`clear`.
        """
        if self.link.closed:
            return
        stopped = False
        if self._stopped:
            try:
                self.disarm()
                stopped = True
            except Exception:  # noqa: BLE001 (fall back to the emergency stop; the watchdog is the last line)
                pass
        if not stopped:
            self.estop()
        for name, value in self._restore.items():
            try:
                self.set_params(**{name: value})
            except Exception:  # noqa: BLE001 (the next connection sees the change: latched())
                break
        self._restore = {}
        self.link.close()

    def __enter__(self) -> "Rig":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def __del__(self) -> None:
        try:
            self.close()
        except Exception:  # noqa: BLE001 (garbage collection: the watchdog is the last line)
            pass


def connect(port: str, *, baudrate: int = DEFAULT_BAUD) -> Rig:
    """Open the rig on ``port`` (see :class:`Rig`).

    Parameters
    ----------
    port : str
        Serial device, pseudo-terminal or pyserial URL.
    baudrate : int, default DEFAULT_BAUD
        Baud rate of the serial link.

    Returns
    -------
    Rig
        The open rig.

    See Also
    --------
    iwp.device.open_rig : The same, or the in-process twin for ``"twin"``.

    Examples
    --------
    The emulator (as ``iwp rig emulate`` serves it) on a pseudo-terminal of this process stands in for a board:

    >>> import os
    >>> from iwp.device import connect
    >>> from iwp.device.emulator import Emulator, TwinDevice, open_pty
    >>> master, slave, port = open_pty()
    >>> emulator = Emulator(TwinDevice(), master)
    >>> thread = emulator.start()
    >>> with connect(port) as rig:
    ...     print(rig.info.firmware, rig.info.caps)
    ...     print(rig.get_param("v_dz_pos"), rig.get_param("watchdog_ms"))  # [input units], [ms]
    1.0.0 ('HOST_CLOCK', 'HOPF', 'STATE_FEEDBACK', 'FIXTURE')
    31.0 100.0
    >>> emulator.stop(); thread.join(); os.close(master); os.close(slave)

    A board is ``connect("/dev/ttyACM0")`` (or ``"COM3"``).
    """
    return Rig(port, baudrate=baudrate)


def _now() -> float:
    return time.monotonic()
