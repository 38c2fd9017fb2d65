"""The virtual rig behind the rig interface: the emulator in this process, on a pseudo-terminal of its own.

:class:`TwinRig` is a :class:`~iwp.device.connection.Rig` whose device is the
emulator (:mod:`iwp.device.emulator`: the firmware's core with the twin as
its plant) served by a thread of this process on a private pseudo-terminal:
the host's code path is exactly that of a real rig, down to the bytes.
In real time by default; ``fast=True`` sets the device's host clock, so a
run goes as fast as the host keeps up.
"""

from __future__ import annotations

import os

from ..rig.stepper import TwinStepper
from ..rig.truth import RigTruth
from .connection import Rig
from .emulator import Emulator, TwinDevice, open_pty

__all__ = ["TwinRig", "open_rig", "TWIN_PORT"]


class TwinRig(Rig):
    """The twin as a rig (see the module's docstring).

    Parameters
    ----------
    truth : RigTruth, optional
        Default: the calibrated twin.
    session : {"auto", "5.1", "5.2"}
        See :class:`~iwp.rig.stepper.TwinStepper`.
    x0 : float or sequence of 4 floats, optional
        Initial state of the twin [rad, rad/s].
    seed : int
        Seed of the encoders' noise.
    fast : bool
        Run by the host's clock (the device's ``host_clock`` parameter).
    """

    def __init__(self, truth: RigTruth | None = None, *, session: str = "auto", x0=None, seed: int = 0,
                 fast: bool = False):
        self.device = TwinDevice(TwinStepper(truth, session=session, x0=x0, seed=seed))
        self._master, self._slave, path = open_pty()
        self.emulator = Emulator(self.device, self._master)
        self._thread = self.emulator.start()
        try:
            super().__init__(path)
            if fast:
                self.set_params(host_clock=1.0)
        except BaseException:
            self._shutdown()
            raise

    def close(self) -> None:
        super().close()
        self._shutdown()

    def _shutdown(self) -> None:
        if self._thread is None:
            return
        self.emulator.stop()
        self._thread.join(timeout=5.0)
        self._thread = None
        for fd in (self._master, self._slave):
            try:
                os.close(fd)
            except OSError:
                pass


#: The ``--port`` value that names the in-process twin.
TWIN_PORT = "twin"


def open_rig(port: str, *, baudrate: int | None = None, truth: RigTruth | None = None, fast: bool = False) -> Rig:
    """The rig on ``port``: :data:`TWIN_PORT` for the in-process twin, else a device.

    Parameters
    ----------
    port : str
        A serial device (``/dev/ttyACM0``), a pseudo-terminal of ``iwp rig
        emulate``, or :data:`TWIN_PORT` (``"twin"``).
    baudrate : int, optional
        Baud rate of a serial port (default: the protocol's).
    truth : RigTruth, optional
        The twin's truth plant (the twin only; default: the calibrated twin).
    fast : bool
        Run the twin by the host's clock, faster than real time.

    Returns
    -------
    Rig
        A :class:`TwinRig` or a :class:`~iwp.device.connection.Rig`, to be closed
        (a context manager).

    See Also
    --------
    iwp.device.run_on_rig : Run one of the paper's experiments on it.

    Examples
    --------
    The twin (no hardware: the firmware's core in this process, on a pseudo-terminal), faster than real time:

    >>> from iwp import open_rig
    >>> with open_rig("twin", fast=True) as rig:
    ...     print(type(rig).__name__, rig.info.board)
    ...     print(rig.info.params["period_us"], rig.info.params["v_dz_pos"])  # [us], [input units]
    TwinRig host (emulator or software in the loop)
    5000.0 31.0

    A board on a serial port is opened the same way (``open_rig("/dev/ttyACM0")``).
    """
    if port == TWIN_PORT:
        return TwinRig(truth, fast=fast)
    return Rig(port) if baudrate is None else Rig(port, baudrate=baudrate)
