"""The host's end of the link: a port (pyserial), frames, messages, and the count of what went wrong.

:class:`DeviceLink` opens a port with :func:`serial.serial_for_url` (a
device such as ``/dev/ttyACM0``, the pseudo-terminal of ``iwp rig emulate``
or of simavr, or a URL such as ``loop://``), sends messages of the
dictionary as frames and returns the device's messages in order. A frame
with a bad CRC or stuffing, a payload that is not a message of the
dictionary (unknown type, wrong length: "truncated"), and telemetry that
is not newer than the last one (out of order, repeated) are counted in
:class:`LinkStats` and skipped: never returned, never applied. Gaps in the
telemetry's sequence are counted as lost frames.
"""

from __future__ import annotations

import re
import time
from dataclasses import asdict, dataclass

import serial

from .errors import DeviceError
from .framing import FrameDecoder, encode_frame
from .protocol import Decoded, ProtocolError, decode, encode

__all__ = ["DeviceLink", "LinkStats", "DEFAULT_BAUD"]

#: Default baud rate (the AVR firmware's; a pseudo-terminal ignores it).
DEFAULT_BAUD = 500000


@dataclass
class LinkStats:
    """What the host saw on the link.

    Attributes
    ----------
    frames : int
        Frames with a good CRC.
    corrupt, truncated, oversize : int
        Frames refused by the framing (bad stuffing or CRC; too short; too long).
    refused : int
        Good frames that are no message of the dictionary (unknown type, wrong length).
    out_of_order : int
        Telemetry not newer than the last (skipped).
    stale : int
        Telemetry older than the device's tick when the host connected (an earlier session's, skipped).
    lost : int
        Telemetry samples missing from the sequence.
    sent : int
        Frames sent.
    """

    frames: int = 0
    corrupt: int = 0
    truncated: int = 0
    oversize: int = 0
    refused: int = 0
    out_of_order: int = 0
    stale: int = 0
    lost: int = 0
    sent: int = 0

    def to_dict(self) -> dict[str, int]:
        return asdict(self)


class DeviceLink:
    """Messages to and from a device over a port.

    Parameters
    ----------
    port : str
        A serial device, a pseudo-terminal, or a pyserial URL (``loop://``, ``socket://HOST:PORT``).
    baudrate : int
    transport : object, optional
        An open pyserial-like object to use instead of opening ``port`` (tests).

    Raises
    ------
    DeviceError
        The port does not exist or cannot be opened (one line naming it).
    """

    def __init__(self, port: str, *, baudrate: int = DEFAULT_BAUD, transport=None):
        self.port = str(port)
        if transport is None:
            try:
                transport = serial.serial_for_url(self.port, baudrate=baudrate, timeout=0, write_timeout=2.0)
            except (serial.SerialException, ValueError, OSError) as exc:
                raise DeviceError(f"port {self.port}: {_reason(exc)}", argument="port") from None
        self.serial = transport
        self._decoder = FrameDecoder()
        self.stats = LinkStats()
        self._last_seq: int | None = None
        #: telemetry before this device tick is stale (set from IDENT)
        self.min_seq = 0
        self.closed = False

    # ------------------------------------------------------------------
    def send(self, name: str, **fields) -> None:
        """Send one message."""
        try:
            self.serial.write(encode_frame(encode(name, **fields)))
        except (serial.SerialException, OSError) as exc:
            raise DeviceError(f"port {self.port}: {_reason(exc)}") from None
        self.stats.sent += 1

    def receive(self, timeout: float) -> list[Decoded]:
        """The device's messages that arrive within ``timeout`` [s] (returns as soon as some did)."""
        end = time.monotonic() + max(0.0, timeout)
        out: list[Decoded] = []
        while True:
            try:
                waiting = self.serial.in_waiting
                if waiting:
                    data = self.serial.read(waiting)
                else:
                    self.serial.timeout = max(0.0, min(end - time.monotonic(), 0.05))
                    data = self.serial.read(1)
            except (serial.SerialException, OSError) as exc:
                raise DeviceError(f"port {self.port}: {_reason(exc)}") from None
            if data:
                out.extend(self._messages(data))
            if out or time.monotonic() >= end:
                return out

    def _messages(self, data: bytes) -> list[Decoded]:
        out = []
        for payload in self._decoder.feed(data):
            try:
                msg = decode(payload)
            except ProtocolError:
                self.stats.refused += 1
                continue
            if msg.name == "TELEMETRY":
                seq = msg["seq"]
                if seq < self.min_seq:
                    self.stats.stale += 1
                    continue
                if self._last_seq is not None:
                    if seq <= self._last_seq:
                        self.stats.out_of_order += 1
                        continue
                    self.stats.lost += seq - self._last_seq - 1
                self._last_seq = seq
            out.append(msg)
        c = self._decoder.counts
        self.stats.frames, self.stats.corrupt = c.good, c.corrupt
        self.stats.truncated, self.stats.oversize = c.truncated, c.oversize
        return out

    def expect_gap(self) -> None:
        """The telemetry's sequence restarts or skips on purpose (a new stream rate): do not count a gap."""
        self._last_seq = None

    def discard_input(self) -> None:
        """Drop what arrived before (stale bytes of an earlier session)."""
        try:
            self.serial.reset_input_buffer()
        except (serial.SerialException, OSError, AttributeError):
            pass
        self._decoder = FrameDecoder()

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            try:
                self.serial.close()
            except (serial.SerialException, OSError):
                pass


def _reason(exc: BaseException) -> str:
    """The useful part of pyserial's message (``[Errno 2] could not open port X: [Errno 2] No such file ...``)."""
    text = str(exc)
    if "No such file or directory" in text:
        return "no such device"
    if "Permission denied" in text:
        return "permission denied (is your user in the dialout group?)"
    if "Device or resource busy" in text:
        return "busy (another program has it open)"
    if "Inappropriate ioctl" in text or "Could not configure port" in text:
        return "not a serial device (a regular file, or a device of another kind): give the rig's, e.g. /dev/ttyACM0"
    if "Is a directory" in text:
        return "is a folder, not a serial device"
    text = re.sub(r"\(\d+, '([^']*)'\)", r"\1", text)  # pyserial's (errno, 'message') tuple, as the message
    return text.split("] ")[-1] if "] " in text else text
