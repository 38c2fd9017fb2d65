"""Errors of the rig in the loop: a device that does not answer, speaks another protocol, or stopped."""

from __future__ import annotations

from ..errors import InputError

__all__ = ["DeviceError", "LinkLost"]


class DeviceError(InputError):
    """The device cannot be used.

    No such port, no answer, another protocol, a refused request (exit
    status 2 on the command line).
    """


class LinkLost(DeviceError):
    """The device stopped answering (no telemetry within the link timeout); a run ends with the motor stopped."""
