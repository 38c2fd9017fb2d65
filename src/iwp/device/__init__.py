"""The rig in the loop: iwp's wire protocol, a rig interface over any port, the emulator, and the safe loop.

The paper's experiments (section 5) and iwp's controllers run on a real rig
(a board with iwp's firmware, ``firmware/``), on the emulator (the
firmware's core with the twin as its plant, behind a pseudo-terminal), or
on the twin inside the process, through one interface and the same bytes
(docs/protocol.md).

=====================  ==============================================================
module                 what
=====================  ==============================================================
:mod:`.protocol`       the one dictionary: messages, fields, parameters, states, faults, flags
:mod:`.cheader`        the firmware's C header generated from the dictionary
:mod:`.framing`        frames on the wire: COBS with a CRC-16, between zero bytes
:mod:`.link`           the host's end: a pyserial port, messages, the count of what went wrong
:mod:`.rig`            :class:`Rig`: connect, identify, arm, stop, command, stream
:mod:`.core`           the firmware's portable core (C, ``csrc/``) compiled here, through ctypes
:mod:`.emulator`       :class:`TwinDevice` (the core driving the twin), :class:`Emulator` (behind a pty)
:mod:`.twin`           :class:`TwinRig`: the emulator in this process; :func:`open_rig`
:mod:`.pins`           :class:`SimavrRig`: the board's image under simavr, the twin at its pins
:mod:`.loop`           :func:`run_loop`: the fixed-rate loop that stops the motor on every way out
:mod:`.realtime`       real-time scheduling of a loop's thread where allowed
:mod:`.record`         a run as an iwp log, with the device, the link and the timing in its metadata
:mod:`.experiments`    :func:`run_on_rig`: the paper's experiments and user inputs on a rig
:mod:`.control`        :func:`run_control`: the Hopf law, the upright LQR, swing-up on a rig
:mod:`.prediction`     the model's prediction of a run (and its 95 % band), for the live view
:mod:`.live`           the live view of a run: a page on 127.0.0.1 with a stop button (docs/live.md)
:mod:`.errors`         :class:`DeviceError`, :class:`LinkLost`
=====================  ==============================================================
"""

from __future__ import annotations

from .connection import DeviceInfo, Rig, Sample, connect
from .control import CONTROLLERS, ControlRun, run_control
from .errors import DeviceError, LinkLost
from .loop import HostLimits, LoopResult, run_loop
from .protocol import DICTIONARY_HASH, PROTOCOL_VERSION
from .runs import RUN_NAMES, USER_INPUTS, RigRun, run_on_rig
from .twin import TWIN_PORT, TwinRig, open_rig

__all__ = [
    "Rig",
    "DeviceInfo",
    "Sample",
    "connect",
    "TwinRig",
    "open_rig",
    "TWIN_PORT",
    "run_loop",
    "LoopResult",
    "HostLimits",
    "run_on_rig",
    "RigRun",
    "RUN_NAMES",
    "USER_INPUTS",
    "run_control",
    "ControlRun",
    "CONTROLLERS",
    "DeviceError",
    "LinkLost",
    "PROTOCOL_VERSION",
    "DICTIONARY_HASH",
]
