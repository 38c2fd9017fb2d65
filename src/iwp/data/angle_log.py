"""Third-party angle logs: two header lines, then one angle a line (read only)."""

from __future__ import annotations

import math
import os

import numpy as np

from ..checks import check_positive
from ..errors import InputError
from .experiment import ExperimentData
from .plausibility import check_log_values
from .tables import check_read_options, fail, read_text_lines, warn_if_degrees


# --------------------------------------------------------------------------
# third-party angle log
# --------------------------------------------------------------------------
def read_angle_log(
    path: str | os.PathLike,
    angle_unit: str = "deg",
    sample_rate: float | None = None,
    zero: str = "down",
    *,
    min_samples: int = 10,
) -> ExperimentData:
    """Read a free-swing angle log: a header line, a values line, one angle a line.

    Format (as written by some rotary-pendulum rigs)::

        trigger_start_deg, sample_rate, duration_sec
        90, 1000, 5
        -90.36
        -90.64
        ...

    Line 1 names the header values, line 2 gives them (both comma-separated);
    every further non-blank line holds one pendulum angle, sampled at
    ``sample_rate`` [Hz]. The header pairs become the metadata (plus
    ``source_format: angle-log``).

    Parameters
    ----------
    path : str or path-like
    angle_unit : {'deg', 'rad'}, optional
        Unit of the angles in the file (default degrees).
    sample_rate : float, optional
        Sampling rate [Hz]; default: the header value ``sample_rate``.
    zero : {'down', 'up'}, optional
        Where the file's zero angle is: ``'down'`` (pendulum hanging down, as
        iwp) or ``'up'`` (upright; pi is added so that iwp's zero is down).
    min_samples : int, optional
        Fewest samples accepted (default 10).

    Returns
    -------
    ExperimentData
        ``t = k / sample_rate`` [s] from 0, ``q1`` [rad], ``q2`` zeros (no
        wheel), no velocities, no input (free pendulum).

    Raises
    ------
    DataFormatError
        Naming the file, line and column (empty/binary file, bad header, no
        sample rate, text or NaN where an angle belongs, too few samples).

    Examples
    --------
    A swing of a pendulum without wheel released at 80 degrees, logged at 200 Hz:

    >>> import numpy as np
    >>> from iwp import Plant, simulate, table1
    >>> from iwp.data import read_angle_log
    >>> swing = simulate(Plant(table1(), model="free-nowheel"), x0=[np.radians(80), 0, 0, 0], t_end=5.0)
    >>> lines = ["trigger_start_deg, sample_rate, duration_sec", "80, 200, 5"]
    >>> lines += [f"{a:.2f}" for a in np.degrees(swing.q1)]  # one angle [deg] a line
    >>> with open("swing.txt", "w") as f:
    ...     for line in lines:
    ...         print(line, file=f)
    >>> log = read_angle_log("swing.txt")
    >>> log.n_samples, round(log.Ts, 3), round(float(log.q1[0]), 4)  # [s], [rad]
    (1001, 0.005, 1.3963)
    >>> log.metadata["source_format"], log.input_name
    ('angle-log', None)
    """
    if angle_unit not in ("deg", "rad"):
        raise InputError(f"angle_unit must be 'deg' or 'rad', got {angle_unit!r}")
    if zero not in ("down", "up"):
        raise InputError(f"zero must be 'down' or 'up', got {zero!r}")
    min_samples, _ = check_read_options(min_samples, 0.01)
    src, lines = read_text_lines(path)
    numbered = [(k, ln.strip()) for k, ln in enumerate(lines, start=1) if ln.strip()]
    if len(numbered) < 2:
        raise fail(f"{src}: expected a header line and a values line, found {len(numbered)} line(s)")
    (l1, names_line), (l2, values_line) = numbered[0], numbered[1]
    names = [s.strip() for s in names_line.split(",")]
    values = [s.strip() for s in values_line.split(",")]
    for name in names:
        try:
            float(name)
        except ValueError:
            continue
        raise fail(
            f"{src}, line {l1}: expected a header of names (e.g. trigger_start_deg, sample_rate, "
            f"duration_sec), found the number {name!r}"
        )
    if any(not n for n in names):
        raise fail(f"{src}, line {l1}: empty name in the header")
    if len(values) != len(names):
        raise fail(f"{src}, line {l2}: {len(values)} value(s) but line {l1} names {len(names)}")
    header: dict[str, str] = {}
    for name, value in zip(names, values):
        try:
            float(value)
        except ValueError:
            raise fail(f"{src}, line {l2}, column {name!r}: {value!r} is not a number") from None
        header[name.replace(":", "_")] = value
    if sample_rate is None:
        if "sample_rate" not in header:
            raise fail(
                f"{src}, line {l1}: no 'sample_rate' in the header; pass sample_rate= "
                "(--sample-rate) [Hz]"
            )
        try:
            rate = check_positive("sample_rate", header["sample_rate"])
        except InputError as exc:
            raise fail(f"{src}, line {l2}, column 'sample_rate': {exc}") from None
    else:
        rate = check_positive("sample_rate", sample_rate)
    data_lines = numbered[2:]
    angles = np.empty(len(data_lines))
    for i, (lineno, text) in enumerate(data_lines):
        try:
            angles[i] = float(text)
        except ValueError:
            what = "more than one value; expected one angle a line" if "," in text else f"{text!r} is not a number"
            raise fail(f"{src}, line {lineno}, column 'angle': {what}") from None
        if not math.isfinite(angles[i]):
            raise fail(f"{src}, line {lineno}, column 'angle': {text!r} is not a finite number (NaN or inf)")
    if angles.size < min_samples:
        raise fail(f"{src}: {angles.size} sample(s), at least {min_samples} are needed (min_samples)")
    q1 = np.deg2rad(angles) if angle_unit == "deg" else angles
    if angle_unit == "rad":
        warn_if_degrees(q1, src, "angle", hint="iwp convert --angle-unit deg (angle_unit='deg' in Python)")
    if zero == "up":
        q1 = q1 + math.pi
    metadata = dict(header)
    metadata["source_format"] = "angle-log"
    t = np.arange(angles.size) / rate
    check_log_values({"t": t, "q1": q1}, source=src, locate=lambda i, name: f"{src}, line {data_lines[i][0]}, "
                     f"column {name!r}", names={"t": "sample_rate", "q1": "angle"})
    return ExperimentData(
        t=t,
        q1=q1,
        q2=np.zeros(angles.size),
        metadata=metadata,
        source=src,
    )

