"""Exceptions raised by iwp.

Every error that a user can cause by bad input derives from :class:`IwpError`;
the command-line interface turns these into a one-line message and exit
status 2, without a traceback.
"""

from __future__ import annotations

__all__ = ["IwpError", "InputError", "DataFormatError", "SimulationError", "IdentificationError", "OutputExistsError",
           "GoalNotReached"]


class IwpError(Exception):
    """Base class of every error iwp raises on purpose."""


class InputError(IwpError, ValueError):
    """An argument or parameter has a wrong value, type or shape.

    The message names the argument and, where it helps, the fix.

    Parameters
    ----------
    message : str
        One line.
    argument : str or tuple of str, optional
        The API name(s) of the argument(s) at fault (``"t_end"``). The command
        line replaces them in the message by the flags the user typed
        (``--t-end``); when it is not given, the message's first word is tried.
    """

    def __init__(self, message: str = "", *, argument: str | tuple[str, ...] | None = None):
        super().__init__(message)
        self.argument = (argument,) if isinstance(argument, str) else tuple(argument or ())


class DataFormatError(InputError):
    """A data file cannot be read as an iwp log.

    The message names the file and, where known, the line and the column.
    """


class SimulationError(IwpError, RuntimeError):
    """A simulation did not reach its end (divergence, step-size underflow)."""


class IdentificationError(IwpError, RuntimeError):
    """An identification cannot give trustworthy numbers (e.g. rank deficiency)."""


class GoalNotReached(IwpError, RuntimeError):
    """A computation ran on valid input but did not reach its goal.

    An orbit continuation that does not converge on these parameters, draws of
    a fit's uncertainty of which too few are physical: the message says why
    and what to change. The command line prints it on one line and exits with
    status 1 (ran but did not reach its goal), not 2 (bad input).
    """


class OutputExistsError(IwpError, FileExistsError):
    """An output file or folder exists and ``--force`` (``force=True`` in Python) was not given."""
