"""The firmware's portable core, compiled for this computer and driven through ctypes.

The emulator (:mod:`iwp.device.emulator`) and the in-process twin run the
very C core that the AVR firmware runs (``src/iwp/device/csrc/``, also
``firmware/core/``): the protocol, the state machine, the watchdog, the
limits and the control laws. :func:`core_library` compiles it once with the
host's C compiler (``cc``, or ``$CC``) into a cache folder keyed by the
sources' hash (``$IWP_DEVICE_CACHE``, default ``~/.cache/iwp/device-core``)
and loads it; :class:`DeviceCore` is one device.
"""

from __future__ import annotations

import ctypes
import functools
import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path

from .errors import DeviceError
from .protocol import CAPS, PARAMS

__all__ = ["DeviceCore", "core_library", "CORE_SOURCES", "CSRC", "EMULATOR_CAPS", "EMULATOR_BASE_US"]

#: The portable core's folder.
CSRC = Path(__file__).with_name("csrc")
#: Its C sources (the header ``iwp_protocol.h`` is generated from :mod:`iwp.device.protocol`).
CORE_SOURCES = ("iwp_core.c", "iwp_frame.c")
_HEADERS = ("iwp_core.h", "iwp_frame.h", "iwp_protocol.h")
#: What the emulated board offers: host clock, the Hopf law, state feedback, the operator's hands.
EMULATOR_CAPS = CAPS["HOST_CLOCK"] | CAPS["HOPF"] | CAPS["STATE_FEEDBACK"] | CAPS["FIXTURE"]
#: The emulated board's tick granularity [us].
EMULATOR_BASE_US = 100
_CFLAGS = ("-std=c99", "-O2", "-fPIC", "-shared", "-Wall")


def _cache_dir() -> Path:
    env = os.environ.get("IWP_DEVICE_CACHE")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "iwp" / "device-core"


def _compiler() -> list[str]:
    cc = shlex.split(os.environ.get("CC", "")) or ["cc"]
    if shutil.which(cc[0]) is None:
        raise DeviceError(f"the device core is C and needs a C compiler, but {cc[0]!r} is not installed "
                          "(apt-get install gcc, or set CC)")
    return cc


@functools.lru_cache(maxsize=1)
def core_library() -> ctypes.CDLL:
    """The core compiled as a shared library (compiled on first use, then cached on disk)."""
    h = hashlib.sha256()
    for name in CORE_SOURCES + _HEADERS:
        h.update(name.encode() + b"\0" + (CSRC / name).read_bytes())
    h.update(" ".join(_CFLAGS).encode())
    cc = _compiler()
    h.update(" ".join(cc).encode())
    folder = _cache_dir() / h.hexdigest()[:16]
    lib = folder / "libiwpcore.so"
    if not lib.exists():
        folder.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=".libiwpcore.", suffix=".so", dir=folder)
        os.close(fd)
        cmd = [*cc, *_CFLAGS, "-o", tmp, *(str(CSRC / s) for s in CORE_SOURCES), "-lm"]
        try:
            done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
            if done.returncode != 0:
                first = (done.stderr.strip().splitlines() or ["no message"])[0]
                raise DeviceError(f"compiling the device core failed: {first}")
            os.replace(tmp, lib)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    so = ctypes.CDLL(str(lib))
    P = ctypes.c_void_p
    so.iwp_core_init.argtypes = [P, ctypes.c_uint8, ctypes.c_uint16, ctypes.c_uint32]
    so.iwp_core_rx.argtypes = [P, ctypes.c_char_p, ctypes.c_uint16]
    so.iwp_core_tick.argtypes = [P, ctypes.c_int32, ctypes.c_int32, ctypes.c_float, ctypes.c_uint32]
    so.iwp_core_tick.restype = ctypes.c_float
    so.iwp_core_overrun.argtypes = [P]
    so.iwp_core_ready.argtypes = [P]
    so.iwp_core_ready.restype = ctypes.c_int
    so.iwp_core_param.argtypes = [P, ctypes.c_uint8]
    so.iwp_core_param.restype = ctypes.c_float
    so.iwp_core_period_us.argtypes = [P]
    so.iwp_core_period_us.restype = ctypes.c_uint32
    so.iwp_core_tx_take.argtypes = [P, ctypes.c_char_p, ctypes.c_uint16]
    so.iwp_core_tx_take.restype = ctypes.c_uint16
    so.iwp_core_tx_pending.argtypes = [P]
    so.iwp_core_tx_pending.restype = ctypes.c_uint16
    so.iwp_core_params_hash.argtypes = [P]
    so.iwp_core_params_hash.restype = ctypes.c_uint32
    so.iwp_core_status.argtypes = [P, ctypes.POINTER(ctypes.c_uint32), ctypes.POINTER(ctypes.c_uint8),
                                   ctypes.POINTER(ctypes.c_uint8), ctypes.POINTER(ctypes.c_float)]
    so.iwp_core_fixture.argtypes = [P, ctypes.POINTER(ctypes.c_uint8), ctypes.POINTER(ctypes.c_float)]
    so.iwp_core_fixture.restype = ctypes.c_int
    so.iwp_core_size.restype = ctypes.c_uint32
    return so


class DeviceCore:
    """One device: the firmware's core in this process.

    Parameters
    ----------
    board : int
        IDENT ``board`` (0: host).
    caps : int
        IDENT ``caps`` (default :data:`EMULATOR_CAPS`).
    base_us : int
        Tick granularity [us]; the loop period is a multiple of it.
    """

    def __init__(self, *, board: int = 0, caps: int = EMULATOR_CAPS, base_us: int = EMULATOR_BASE_US):
        self._so = core_library()
        self._mem = ctypes.create_string_buffer(int(self._so.iwp_core_size()))
        self._ptr = ctypes.cast(self._mem, ctypes.c_void_p)
        self._so.iwp_core_init(self._ptr, board, caps, base_us)
        self._out = ctypes.create_string_buffer(4096)

    def rx(self, data: bytes) -> None:
        """Bytes from the host."""
        for i in range(0, len(data), 60000):
            chunk = bytes(data[i:i + 60000])
            self._so.iwp_core_rx(self._ptr, chunk, len(chunk))

    def tick(self, count1: int, count2: int, current: float, t_us: int) -> float:
        """One loop period; returns the driver command to apply [input units]."""
        return float(self._so.iwp_core_tick(self._ptr, int(count1), int(count2), float(current),
                                            int(t_us) & 0xFFFFFFFF))

    def overrun(self) -> None:
        """Count a missed period."""
        self._so.iwp_core_overrun(self._ptr)

    def ready(self) -> bool:
        """Host clock: the host allows the next tick now."""
        return bool(self._so.iwp_core_ready(self._ptr))

    def param(self, name: str) -> float:
        """The value of device parameter ``name`` (:data:`~iwp.device.protocol.PARAMS`) [its unit]."""
        return float(self._so.iwp_core_param(self._ptr, PARAMS[name].id))

    @property
    def period_us(self) -> int:
        """The loop period [us]."""
        return int(self._so.iwp_core_period_us(self._ptr))

    def tx(self) -> bytes:
        """The bytes to send (emptied)."""
        out = bytearray()
        while True:
            n = self._so.iwp_core_tx_take(self._ptr, self._out, len(self._out))
            out += self._out.raw[:n]
            if n < len(self._out):
                return bytes(out)

    def status(self) -> tuple[int, int, int, float]:
        """``(tick, state, fault, v)``: see :data:`iwp.device.protocol.STATES` and ``FAULTS``."""
        tick, state, fault, v = ctypes.c_uint32(), ctypes.c_uint8(), ctypes.c_uint8(), ctypes.c_float()
        self._so.iwp_core_status(self._ptr, ctypes.byref(tick), ctypes.byref(state), ctypes.byref(fault),
                                 ctypes.byref(v))
        return int(tick.value), int(state.value), int(fault.value), float(v.value)

    def fixture(self) -> tuple[int, float] | None:
        """A pending FIXTURE request ``(action, q1)`` (see :data:`~iwp.device.protocol.FIXTURE_ACTIONS`), or None."""
        action, q1 = ctypes.c_uint8(), ctypes.c_float()
        if self._so.iwp_core_fixture(self._ptr, ctypes.byref(action), ctypes.byref(q1)):
            return int(action.value), float(q1.value)
        return None

    @property
    def params_hash(self) -> int:
        return int(self._so.iwp_core_params_hash(self._ptr))
