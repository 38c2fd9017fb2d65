"""Errors of the rig in the loop: a device that does not answer, speaks another protocol, or stopped."""

from __future__ import annotations

from ..errors import InputError

__all__ = ["DeviceError", "LinkLost", "DeviceStopped"]


class DeviceError(InputError):
    """The device cannot be used: no such port, no answer, another protocol, a refused request (exit status 2
    on the command line)."""


class LinkLost(DeviceError):
    """The device stopped answering during a run (no telemetry within the link timeout)."""


class DeviceStopped(DeviceError):
    """The device stopped the motor by itself during a run (a limit, its watchdog) or the host's check did."""
