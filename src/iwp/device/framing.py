"""Frames on the wire: COBS with a CRC-16, between zero bytes.

A frame is ``0x00 COBS(payload + crc) 0x00``: the payload (a message of
:mod:`iwp.device.protocol`) followed by its CRC-16/CCITT-FALSE (polynomial
0x1021, initial value 0xFFFF, big-endian; :func:`binascii.crc_hqx`, and on
the AVR avr-libc's ``_crc_xmodem_update`` family), stuffed by Consistent
Overhead Byte Stuffing (the ``cobs`` package) so that the only zero bytes
on the wire are the delimiters. The leading delimiter makes every frame
independent of the one before: a corrupted byte, even a lost or forged
delimiter, spoils at most the frames it touches.

:class:`FrameDecoder` cuts a byte stream at the delimiters and returns the
payloads whose CRC is right; everything else is counted (``corrupt``:
bad stuffing or CRC; ``truncated``: fewer bytes than a CRC; ``oversize``:
longer than any frame) and skipped, never returned.
"""

from __future__ import annotations

import binascii
from dataclasses import dataclass

from cobs import cobs

from .protocol import MAX_PAYLOAD

__all__ = ["encode_frame", "FrameDecoder", "FrameCounts", "crc16", "CRC_INIT", "MAX_FRAME"]

#: Initial value of the CRC-16/CCITT-FALSE.
CRC_INIT = 0xFFFF
#: Longest stuffed frame between delimiters [bytes].
MAX_FRAME = MAX_PAYLOAD + 2 + MAX_PAYLOAD // 254 + 2


def crc16(data: bytes) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (poly 0x1021, init 0xFFFF, no reflection, no final xor).

    Parameters
    ----------
    data : bytes
        Bytes to check.

    Returns
    -------
    int
        The CRC, in ``[0, 0xFFFF]``.
    """
    return binascii.crc_hqx(data, CRC_INIT)


def encode_frame(payload: bytes) -> bytes:
    """``0x00 COBS(payload + crc16 big-endian) 0x00``.

    Parameters
    ----------
    payload : bytes
        The message payload.

    Returns
    -------
    bytes
        The frame, delimited by zero bytes.
    """
    body = bytes(payload) + crc16(payload).to_bytes(2, "big")
    return b"\x00" + cobs.encode(body) + b"\x00"


@dataclass
class FrameCounts:
    """What a :class:`FrameDecoder` saw: good frames and the refused ones by reason."""

    good: int = 0
    corrupt: int = 0
    truncated: int = 0
    oversize: int = 0
    bytes: int = 0

    @property
    def bad(self) -> int:
        """Frames refused."""
        return self.corrupt + self.truncated + self.oversize


class FrameDecoder:
    """Cut a byte stream into checked payloads.

    ``feed(data)`` returns the payloads completed by ``data`` (possibly
    none); partial frames wait for the next call. :attr:`counts` keeps
    the tallies.
    """

    def __init__(self) -> None:
        self._buf = bytearray()
        # the bytes before the first delimiter are the tail of a frame sent before this decoder listened (a port
        # opened while the device streams): skipped, not counted as a corrupt frame (every frame of encode()
        # starts with a delimiter, so none is lost)
        self._skipping = True
        self.counts = FrameCounts()

    def feed(self, data: bytes) -> list[bytes]:
        out: list[bytes] = []
        self.counts.bytes += len(data)
        start = 0
        while True:
            i = data.find(b"\x00", start)
            if i < 0:
                self._append(data[start:])
                return out
            self._append(data[start:i])
            payload = self._finish()
            if payload is not None:
                out.append(payload)
            start = i + 1

    def _append(self, chunk: bytes) -> None:
        if self._skipping or not chunk:
            return
        self._buf += chunk
        if len(self._buf) > MAX_FRAME:
            self.counts.oversize += 1
            self._buf.clear()
            self._skipping = True  # until the next delimiter

    def _finish(self) -> bytes | None:
        if self._skipping:
            self._skipping = False
            return None
        if not self._buf:  # back-to-back delimiters
            return None
        raw = bytes(self._buf)
        self._buf.clear()
        try:
            body = cobs.decode(raw)
        except cobs.DecodeError:
            self.counts.corrupt += 1
            return None
        if len(body) < 3:
            self.counts.truncated += 1
            return None
        payload, crc = body[:-2], int.from_bytes(body[-2:], "big")
        if crc16(payload) != crc:
            self.counts.corrupt += 1
            return None
        self.counts.good += 1
        return payload
