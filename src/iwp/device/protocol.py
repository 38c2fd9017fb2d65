"""The wire protocol's one dictionary: messages, fields, parameters, states, faults, flags.

The host (this module) is the source of truth, as in Klipper: the firmware's
C header ``iwp_protocol.h`` is generated from these tables
(:func:`iwp.device.cheader.c_header`, ``python tools/gen_protocol_header.py``;
a test checks that the shipped header is current), and the message table of
``docs/protocol.md`` is checked against :func:`markdown_table`. The hash of
the dictionary (:data:`DICTIONARY_HASH`) travels in the device's ``IDENT``
reply: a host and a firmware built from different dictionaries refuse to
talk.

A message is one frame (:mod:`iwp.device.framing`): a type byte, then its
fields packed little-endian without padding (``struct`` codes ``B`` u8, ``H``
u16, ``I`` u32, ``i`` i32, ``f`` IEEE-754 float32). A payload whose length
is not its message's exact size is refused (:class:`ProtocolError`), never
applied.
"""

from __future__ import annotations

import binascii
import math
import struct
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from ..errors import IwpError

__all__ = [
    "PROTOCOL_VERSION",
    "Field",
    "Message",
    "Param",
    "MESSAGES",
    "MESSAGE_BY_ID",
    "PARAMS",
    "PARAM_BY_ID",
    "STATES",
    "FAULTS",
    "FLAGS",
    "CAPS",
    "MODES",
    "ACK_CODES",
    "FIXTURE_ACTIONS",
    "MAX_PAYLOAD",
    "FLOAT32_MAX",
    "DICTIONARY_HASH",
    "ProtocolError",
    "Decoded",
    "encode",
    "decode",
    "param",
    "markdown_table",
    "params_table",
    "dictionary_text",
]

#: Protocol version: a device with another version is refused.
PROTOCOL_VERSION = 3
#: Largest payload (type byte + fields) of a frame [bytes].
MAX_PAYLOAD = 64
#: The largest magnitude a float32 field of a frame carries.
FLOAT32_MAX = float(np.finfo(np.float32).max)


class ProtocolError(IwpError):
    """A frame that is not a message of the dictionary (unknown type, wrong length)."""


@dataclass(frozen=True)
class Field:
    """One field of a message: name, ``struct`` code, unit, meaning."""

    name: str
    code: str
    unit: str
    doc: str


@dataclass(frozen=True)
class Message:
    """One message of the protocol.

    Attributes
    ----------
    name : str
        Upper-case name (``TELEMETRY``).
    id : int
        Type byte: below 0x80 from the host, from 0x80 on from the device.
    fields : tuple of Field
    doc : str
    """

    name: str
    id: int
    fields: tuple[Field, ...]
    doc: str

    @property
    def direction(self) -> str:
        """``"host->device"`` or ``"device->host"``."""
        return "host->device" if self.id < 0x80 else "device->host"

    @property
    def struct(self) -> struct.Struct:
        """The layout: the type byte then the fields, little-endian, packed."""
        return struct.Struct("<B" + "".join(f.code for f in self.fields))

    @property
    def size(self) -> int:
        """Payload size [bytes] (type byte included)."""
        return self.struct.size

    def offsets(self) -> dict[str, int]:
        """Byte offset of each field in the payload."""
        out, pos = {}, 1
        for f in self.fields:
            out[f.name] = pos
            pos += struct.calcsize("<" + f.code)
        return out


def _f(name: str, code: str, unit: str, doc: str) -> Field:
    return Field(name, code, unit, doc)


#: The first field of every request the device answers with ACK: the host numbers its requests, repeats a
#: request whose ACK did not come with the same number (every such request is idempotent), and takes only the
#: ACK carrying that number, so a late or repeated ACK is never taken for the answer to another request.
_REQ = _f("req", "H", "-", "request number, echoed in ACK")

#: The messages, by name.
MESSAGES: dict[str, Message] = {m.name: m for m in [
    # ---------------------------------------------------------------- host -> device
    Message("HELLO", 0x01, (_f("nonce", "H", "-", "echoed in IDENT"),),
            "start a session (the sequence numbers of COMMAND and HEARTBEAT start again) and ask the device who it "
            "is; it answers IDENT"),
    Message("GET_PARAM", 0x02, (_REQ, _f("param", "B", "-", "parameter id"),),
            "read a parameter; ACK carries its value"),
    Message("SET_PARAM", 0x03, (_REQ, _f("param", "B", "-", "parameter id"), _f("value", "f", "param", "new value")),
            "set a parameter (refused while armed, or outside its range); ACK carries the value kept"),
    Message("ARM", 0x04, (_REQ,), "enable the motor (refused in FAULT or ESTOP, or with a limit already "
            "exceeded); when armed already: OK, and the watchdog is fed"),
    Message("DISARM", 0x05, (_REQ,), "motor off, back to DISARMED; a fault is kept"),
    Message("ESTOP", 0x06, (_REQ,), "emergency stop: motor off, latched until CLEAR; idempotent"),
    Message("CLEAR", 0x07, (_REQ,), "clear a fault or an emergency stop, back to DISARMED"),
    Message("ZERO", 0x08, (_REQ, _f("mask", "B", "-", "bit 0: pendulum encoder, bit 1: wheel encoder"),),
            "set encoder counts to 0 (refused while armed)"),
    Message("COMMAND", 0x09, (_f("seq", "I", "-", "increasing; an older or repeated one is skipped"),
                              _f("tick", "I", "-", "device tick from which it applies; 0: the next tick"),
                              _f("u", "f", "input units", "ideal input u (before feedforward (7)-(8))")),
            "the open-loop input, queued by tick; also feeds the watchdog"),
    Message("HEARTBEAT", 0x0A, (_f("seq", "I", "-", "increasing; an older or repeated one is skipped"),
                                _f("tick", "I", "-", "the host may be this far (host clock: the device may run "
                                                     "up to this tick)")),
            "feeds the watchdog (on-device controllers, idle links)"),
    Message("MODE", 0x0B, (_REQ, _f("mode", "B", "-", "see MODES"),),
            "the device's control law: the host's commands, Hopf or state feedback (refused while armed)"),
    Message("FIXTURE", 0x0D, (_REQ, _f("action", "B", "-", "see FIXTURE_ACTIONS"),
                              _f("q1", "f", "rad", "HOLD: the angle the pendulum is held at")),
            "the operator's hands on an emulated rig (CAPS FIXTURE): clamp, hold, release; a real board refuses it "
            "and the host asks the operator instead"),
    Message("STREAM", 0x0C, (_REQ, _f("every", "B", "ticks", "one telemetry frame every N ticks; 0: none"),),
            "telemetry rate"),
    # ---------------------------------------------------------------- device -> host
    Message("IDENT", 0x81, (_f("nonce", "H", "-", "HELLO's nonce"),
                            _f("protocol", "B", "-", "PROTOCOL_VERSION of the firmware"),
                            _f("fw_major", "B", "-", "firmware version"),
                            _f("fw_minor", "B", "-", ""),
                            _f("fw_patch", "B", "-", ""),
                            _f("board", "B", "-", "0 host (emulator/SIL), 1 ATmega328P, 2 ATmega2560"),
                            _f("caps", "H", "-", "see CAPS"),
                            _f("dict_hash", "I", "-", "CRC-32 of the protocol dictionary"),
                            _f("params_hash", "I", "-", "FNV-1a of the parameter values"),
                            _f("base_us", "I", "us", "the device's tick granularity (period is a multiple)"),
                            _f("tick", "I", "ticks", "the device's tick now (older telemetry is stale)")),
            "who the device is"),
    Message("ACK", 0x82, (_f("req", "H", "-", "the request's ``req``"),
                          _f("msg", "B", "-", "type of the message answered"),
                          _f("code", "B", "-", "see ACK_CODES"),
                          _f("param", "B", "-", "parameter id (GET_PARAM/SET_PARAM), else 0"),
                          _f("value", "f", "param", "the parameter's value (GET_PARAM/SET_PARAM), else 0")),
            "answer to every host message but COMMAND, HEARTBEAT and HELLO"),
    Message("TELEMETRY", 0x83, (_f("seq", "I", "ticks", "the device tick of this sample (increasing)"),
                                _f("t_us", "I", "us", "device time of the sample (wraps after 71 min)"),
                                _f("count1", "i", "counts", "pendulum encoder"),
                                _f("count2", "i", "counts", "wheel encoder (relative to the arm)"),
                                _f("q4", "f", "rad/s", "wheel speed: counts over the last period"),
                                _f("u", "f", "input units", "ideal input applied from this sample on"),
                                _f("v", "f", "input units", "driver command applied (feedforward, saturation)"),
                                _f("current", "f", "A", "motor current; NaN where not measured"),
                                _f("state", "B", "-", "see STATES"),
                                _f("fault", "B", "-", "see FAULTS"),
                                _f("flags", "H", "-", "see FLAGS"),
                                _f("overruns", "H", "-", "loop overruns since boot (wraps)"),
                                _f("late", "H", "-", "ticks without a command for them while armed (wraps)"),
                                _f("rx_errors", "H", "-", "frames refused by the device since boot (wraps)"),
                                _f("dropped", "H", "-", "COMMANDs dropped by a full queue since boot (wraps)")),
            "one sample of the loop"),
]}

#: The messages, by type byte.
MESSAGE_BY_ID: dict[int, Message] = {m.id: m for m in MESSAGES.values()}

#: Device states (TELEMETRY ``state``).
STATES = {"DISARMED": 0, "ARMED": 1, "FAULT": 2, "ESTOP": 3}
#: Why the device stopped the motor (TELEMETRY ``fault``).
FAULTS = {"NONE": 0, "WATCHDOG": 1, "Q1_LIMIT": 2, "Q4_LIMIT": 3, "DUTY_LIMIT": 4, "ESTOP": 5, "HOST": 6}
#: Bits of TELEMETRY ``flags``.
FLAGS = {"SATURATED": 1 << 0, "LATE": 1 << 1, "QUEUE_FULL": 1 << 2, "CURRENT_VALID": 1 << 3, "HOST_CLOCK": 1 << 4}
#: Bits of IDENT ``caps``.
CAPS = {"HOST_CLOCK": 1 << 0, "CURRENT": 1 << 1, "HOPF": 1 << 2, "STATE_FEEDBACK": 1 << 3, "FIXTURE": 1 << 4}
#: FIXTURE ``action``: let the pendulum go; clamp it at rest (section 5.1); hold it at ``q1`` with the wheel
#: at rest (a release from there, as figure 8).
FIXTURE_ACTIONS = {"RELEASE": 0, "CLAMP": 1, "HOLD": 2}
#: Control laws of the device (MODE ``mode``).
MODES = {"HOST": 0, "HOPF": 1, "STATE_FEEDBACK": 2}
#: ACK ``code``.
ACK_CODES = {"OK": 0, "BAD_PARAM": 1, "OUT_OF_RANGE": 2, "ARMED": 3, "FAULT": 4, "LIMIT": 5, "BAD_MODE": 6}


@dataclass(frozen=True)
class Param:
    """One device parameter: float32 on the wire, checked against ``[lo, hi]`` by the device."""

    name: str
    id: int
    default: float
    lo: float
    hi: float
    unit: str
    doc: str


#: The device's parameters, by name (ids are their order).
PARAMS: dict[str, Param] = {p.name: p for p in [
    Param("period_us", 0, 5000.0, 1000.0, 20000.0, "us", "loop period (a multiple of IDENT base_us)"),
    Param("watchdog_ms", 1, 100.0, 10.0, 2000.0, "ms", "motor off when no valid COMMAND/HEARTBEAT for this long"),
    Param("v_max", 2, 100.0, 0.0, 100.0, "input units", "driver saturation |v| <= v_max (100: full duty)"),
    Param("v_dz_pos", 3, 31.0, 0.0, 100.0, "input units", "feedforward (7)-(8) threshold for u > 0 (0: none)"),
    Param("v_dz_neg", 4, 31.0, 0.0, 100.0, "input units", "feedforward (7)-(8) threshold for u < 0 (0: none)"),
    Param("q1_max", 5, 12.566370614359172, 0.1, 1000.0, "rad", "fault when |q1| exceeds it"),
    Param("q4_max", 6, 300.0, 1.0, 10000.0, "rad/s",
          "fault when |q4| exceeds it (300: within what the AVR firmware counts exactly at 200 Hz)"),
    Param("sat_ms_max", 7, 3000.0, 0.0, 60000.0, "ms",
          "stall: fault when the command stays saturated with |q4| < q4_max/10 this long (0: off)"),
    Param("counts1", 8, 2000.0, 1.0, 1e6, "counts/rev", "pendulum encoder resolution"),
    Param("counts2", 9, 2000.0, 1.0, 1e6, "counts/rev", "wheel encoder resolution"),
    Param("k1", 10, -10.0, -1e4, 1e4, "input units s/rad", "Hopf law u = k1 q3 + k2 q3^3 (section 5.3)"),
    Param("k2", 11, 0.1, -1e4, 1e4, "input units s^3/rad^3", "Hopf law cubic gain"),
    Param("filter_tau", 12, 0.01, 0.0, 1.0, "s", "first-order filter of the q3 estimate (0: none)"),
    Param("K_q1", 13, 0.0, -1e6, 1e6, "input units/rad",
          "state feedback u = -(K_q1 e + K_q3 q3 + K_q4 q4), e = q1 - q1_ref wrapped to [-pi, pi)"),
    Param("K_q3", 14, 0.0, -1e6, 1e6, "input units s/rad", "state feedback gain on q3"),
    Param("K_q4", 15, 0.0, -1e6, 1e6, "input units s/rad", "state feedback gain on q4"),
    Param("q1_ref", 16, math.pi, -10.0, 10.0, "rad", "state feedback set point (pi: upright)"),
    Param("u_max", 17, 100.0, 0.0, 100.0, "input units", "on-device laws: |u| <= u_max before the feedforward"),
    Param("host_clock", 18, 0.0, 0.0, 1.0, "-", "1: tick as soon as the next tick's command is queued "
                                                "(emulator only, CAPS HOST_CLOCK); never slower than real time"),
]}
PARAM_BY_ID: dict[int, Param] = {p.id: p for p in PARAMS.values()}


def param(name: str) -> Param:
    """The parameter ``name``; :class:`ProtocolError` listing the names for an unknown one.

    Parameters
    ----------
    name : str
        Device parameter name, a key of :data:`PARAMS`.

    Returns
    -------
    Param
        Its id, unit and limits.

    Raises
    ------
    ProtocolError
        Unknown name.
    """
    if name not in PARAMS:
        raise ProtocolError(f"unknown device parameter {name!r}; known: {', '.join(PARAMS)}")
    return PARAMS[name]


@dataclass(frozen=True)
class Decoded:
    """A decoded message: its dictionary entry and its field values."""

    message: Message
    values: dict[str, Any]

    @property
    def name(self) -> str:
        return self.message.name

    def __getitem__(self, key: str):
        return self.values[key]


def encode(name: str, **values: Any) -> bytes:
    """The payload of message ``name`` with ``values`` (every field, nothing else).

    Parameters
    ----------
    name : str
        Message name, a key of :data:`MESSAGES`.
    **values
        Every field of the message, by name, and no other.

    Returns
    -------
    bytes
        The payload: the message's type byte, then its fields (little-endian, the message's struct).

    Raises
    ------
    ProtocolError
        Unknown message, missing or extra fields, or a value its field cannot hold.
    """
    m = MESSAGES.get(name)
    if m is None:
        raise ProtocolError(f"unknown message {name!r}")
    names = [f.name for f in m.fields]
    if set(values) != set(names):
        raise ProtocolError(f"message {name} takes the fields {names}, got {sorted(values)}")
    try:
        return m.struct.pack(m.id, *(values[n] for n in names))
    except (struct.error, OverflowError) as exc:
        big = [f"{f.name} = {values[f.name]!r}" for f in m.fields if f.code in ("f", "d")
               and isinstance(values[f.name], (int, float)) and abs(float(values[f.name])) > FLOAT32_MAX]
        raise ProtocolError(f"message {name}: {', '.join(big) or exc} does not fit its field") from None


def decode(payload: bytes) -> Decoded:
    """The message in ``payload``; :class:`ProtocolError` for an unknown type or a wrong length.

    Parameters
    ----------
    payload : bytes
        Payload of one frame (type byte first).

    Returns
    -------
    Decoded
        The message and its field values by name.

    Raises
    ------
    ProtocolError
        Empty payload, unknown message type or a length other than the message's.
    """
    if not payload:
        raise ProtocolError("empty payload")
    m = MESSAGE_BY_ID.get(payload[0])
    if m is None:
        raise ProtocolError(f"unknown message type 0x{payload[0]:02x}")
    if len(payload) != m.size:
        raise ProtocolError(f"{m.name}: {len(payload)} bytes, expected {m.size}")
    vals = m.struct.unpack(payload)[1:]
    return Decoded(m, dict(zip((f.name for f in m.fields), vals)))


# --------------------------------------------------------------------------
# the dictionary as text: its hash, the docs' tables
# --------------------------------------------------------------------------
def dictionary_text() -> str:
    """A canonical text of the whole dictionary (its CRC-32 is :data:`DICTIONARY_HASH`)."""
    lines = [f"protocol {PROTOCOL_VERSION}"]
    for m in MESSAGES.values():
        lines.append(f"msg {m.id} {m.name} " + " ".join(f"{f.name}:{f.code}" for f in m.fields))
    for title, table in (("state", STATES), ("fault", FAULTS), ("flag", FLAGS), ("cap", CAPS), ("mode", MODES),
                         ("ack", ACK_CODES), ("fixture", FIXTURE_ACTIONS)):
        lines.extend(f"{title} {k} {v}" for k, v in table.items())
    for p in PARAMS.values():
        lines.append(f"param {p.id} {p.name} {p.default!r} {p.lo!r} {p.hi!r}")
    return "\n".join(lines) + "\n"


#: CRC-32 of :func:`dictionary_text`; the firmware reports its own in IDENT.
DICTIONARY_HASH = binascii.crc32(dictionary_text().encode("ascii"))

_TYPE_NAMES = {"B": "u8", "H": "u16", "I": "u32", "i": "i32", "f": "f32"}


def markdown_table() -> str:
    """The message table of ``docs/protocol.md`` (Markdown), generated from the dictionary."""
    out = ["| type | message | direction | size [bytes] | fields (type, unit) | what |",
           "|---|---|---|---|---|---|"]
    for m in MESSAGES.values():
        fields = ", ".join(f"`{f.name}` ({_TYPE_NAMES[f.code]}, {f.unit})" for f in m.fields) or "-"
        out.append(f"| 0x{m.id:02x} | `{m.name}` | {m.direction} | {m.size} | {fields} | {m.doc} |")
    return "\n".join(out) + "\n"


def float32_text(value: float) -> str:
    """The shortest decimal that reads back as ``value``'s float32 (what the device stores): ``4 pi`` is
    ``12.566371``."""
    return np.format_float_positional(np.float32(value), unique=True, trim="-")


def params_table() -> str:
    """The parameter table of ``docs/protocol.md`` (Markdown)."""
    out = ["| id | parameter | default (as the device stores it, float32) | range | unit | what |",
           "|---|---|---|---|---|---|"]
    for p in PARAMS.values():
        # the shortest decimal that reads back as the device's float32: a client that restores it restores the
        # default exactly (printed as 12.5664, 4 pi was refused as changed)
        out.append(f"| {p.id} | `{p.name}` | {float32_text(p.default)} | {p.lo:g} .. {p.hi:g} | {p.unit} | {p.doc} |")
    return "\n".join(out) + "\n"


def flag_names(flags: int, table: Mapping[str, int] = FLAGS) -> list[str]:
    """The names of the bits set in ``flags``.

    Parameters
    ----------
    flags : int
        Bit field.
    table : mapping of str to int, default FLAGS
        Bit of each name.

    Returns
    -------
    list of str
        Names whose bits are set, in the table's order.
    """
    return [k for k, v in table.items() if flags & v]


def name_of(table: Mapping[str, int], value: int) -> str:
    """The name of ``value`` in one of the tables (``STATES``, ``FAULTS``, ...), or its number.

    Parameters
    ----------
    table : mapping of str to int
        Value of each name.
    value : int
        Value to name.

    Returns
    -------
    str
        The first name with that value, else ``str(value)``.
    """
    for k, v in table.items():
        if v == value:
            return k
    return str(value)


__all__ += ["flag_names", "name_of"]
