"""The iwp CSV format (``.csv`` / ``.txt``): ``# key: value`` metadata lines, one header row, one row per sample.

Also the static curves (one row per steady state of the disk, section 5,
figure 2). See ``docs/data-format.md`` for the contract.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

import numpy as np

from ..errors import InputError
from ..files import atomic_write, prepare_output_file
from .experiment import ExperimentData, StaticCurve
from .tables import (
    Table,
    check_leftover_name,
    check_mapping,
    check_read_options,
    fail,
    finish_log,
    resolve_columns,
)


# --------------------------------------------------------------------------
# CSV
# --------------------------------------------------------------------------
def read_csv(
    path: str | os.PathLike,
    *,
    mapping: Mapping[str, str] | None = None,
    degrees: bool = False,
    resample: bool = False,
    min_samples: int = 10,
    sampling_tol: float = 0.01,
) -> ExperimentData:
    """Read an iwp time-series CSV.

    Format: ``# key: value`` lines (anywhere; other comment lines and blank
    lines are ignored) hold the metadata; the first other line is the header
    (comma-separated; tab, semicolon or blanks are accepted if the header has
    no comma); then one row per sample. Required columns ``t`` [s], ``q1``,
    ``q2`` [rad]; optional ``q3``, ``q4`` [rad/s]; at most one input column,
    ``u`` or ``v`` (none: zero input); any other column goes to
    :attr:`ExperimentData.extra`.

    Parameters
    ----------
    path : str or path-like
        The file.
    mapping : dict, optional
        The iwp name -> column name in the file, for files with other names,
        e.g. ``{"t": "time", "q1": "theta"}``. Unmapped iwp names are looked
        up under their own name.
    degrees : bool, optional
        Angles ``q1``, ``q2`` are in [deg] and velocities ``q3``, ``q4`` in
        [deg/s]; convert them to [rad] and [rad/s].
    resample : bool, optional
        Accept irregular sampling and interpolate every column linearly onto a
        uniform grid with the median step (see :meth:`ExperimentData.resample`).
    min_samples : int, optional
        Fewest samples accepted (default 10).
    sampling_tol : float, optional
        Largest accepted relative deviation of a time step from the median
        step (default 0.01, i.e. 1%) when ``resample`` is False.

    Returns
    -------
    ExperimentData

    Raises
    ------
    DataFormatError
        One line naming the file, the line (1-based) and the column: empty or
        binary file, no header, duplicated or missing columns, both ``u`` and
        ``v``, a row of the wrong length, text where a number belongs, NaN or
        inf, time not strictly increasing, irregular sampling, too few samples.

    Warns
    -----
    UserWarning
        If ``q1`` looks like degrees (peak ``|q1| > 3*pi``) and ``degrees`` is
        False.

    See Also
    --------
    write_csv : Write a log as this format.
    iwp.data.read_experiment : Read a log of any format.

    Examples
    --------
    Another rig's CSV, its columns named otherwise and its angles in degrees:

    >>> import numpy as np
    >>> from iwp.data import read_csv
    >>> t = np.arange(400) * 0.005
    >>> columns = np.column_stack([t, 30 * np.cos(5.1 * t), 0 * t])
    >>> np.savetxt("swing.csv", columns, fmt="%.4f", delimiter=",", header="time,theta_deg,wheel_deg", comments="")
    >>> log = read_csv("swing.csv", mapping={"t": "time", "q1": "theta_deg", "q2": "wheel_deg"}, degrees=True)
    >>> log.n_samples, round(log.Ts, 3), log.input_name  # no input column: the free pendulum
    (400, 0.005, None)
    >>> round(float(log.q1.max()), 4)  # 30 deg [rad]
    0.5236
    """
    min_samples, sampling_tol = check_read_options(min_samples, sampling_tol)
    mapping = check_mapping(mapping)
    table = Table(path)
    src = table.source
    used, leftovers = resolve_columns(table.header, mapping, table.where())
    for name in leftovers:
        check_leftover_name(name, used, table.where(), "column")
    if not table.lines:
        raise fail(f"{src}: no data rows after the header (line {table.header_line})")
    values = table.numbers()
    cols = {name: values[:, j].copy() for j, name in enumerate(table.header)}
    lines = table.lines

    def locate(i: int, name: str) -> str:
        return f"{src}, line {lines[i]}, column {name!r}"

    return finish_log(
        cols, used, leftovers, source=src, locate=locate, metadata=table.metadata,
        degrees=degrees, resample=resample, min_samples=min_samples, sampling_tol=sampling_tol,
    )


def _csv_text(metadata: Mapping[str, str], cols: Mapping[str, np.ndarray]) -> str:
    out = [f"# {k}: {v}".rstrip() + "\n" for k, v in metadata.items()]
    out.append(",".join(cols) + "\n")
    rows = np.column_stack(list(cols.values())).tolist()
    # repr(float) is the shortest string that reads back to the same double.
    out.extend(",".join(map(repr, row)) + "\n" for row in rows)
    return "".join(out)


def write_csv(data: ExperimentData, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a log as an iwp CSV (bit-exact round trip with :func:`read_csv`).

    Metadata first as ``# key: value`` lines, then the header (canonical
    columns in the order ``t,q1,q2,q3,q4,u|v``, then the extra columns), then
    one row per sample with every float written as its shortest exact
    representation (``repr``).

    Parameters
    ----------
    data : ExperimentData
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    OutputExistsError
        If ``path`` exists and ``force`` is False.

    See Also
    --------
    read_csv : Read it back.

    Examples
    --------
    >>> import numpy as np
    >>> from iwp.data import read_csv, write_csv
    >>> from iwp.rig import run_experiment
    >>> log = run_experiment("sine-60", duration=1.0)
    >>> write_csv(log, "sine60.csv").name
    'sine60.csv'
    >>> open("sine60.csv").readline().strip()  # the metadata first
    '# experiment: sine-60'
    >>> back = read_csv("sine60.csv")
    >>> back.metadata["reference"], np.array_equal(back.q2, log.q2)  # bit-exact
    ('section 5.1, figure 3(a)', True)
    """
    if not isinstance(data, ExperimentData):
        raise InputError(f"data must be an ExperimentData, got {type(data).__name__}")
    p = prepare_output_file(path, force)
    text = _csv_text(data.metadata, data.as_columns())
    return atomic_write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"), force=force)


# --------------------------------------------------------------------------
# static curves
# --------------------------------------------------------------------------
def read_static_curve(path: str | os.PathLike, *, min_points: int = 2) -> StaticCurve:
    """Read a static input / steady-state disk-velocity curve.

    CSV with ``# key: value`` metadata lines, a header ``v,q4`` (raw input) or
    ``u,q4`` (compensated input), one row per steady state: the constant
    input [input units] and the disk velocity reached [rad/s]. Rows need not
    be sorted; repeated inputs are allowed.

    Parameters
    ----------
    path : str or path-like
    min_points : int, optional
        Fewest rows accepted (default 2).

    Returns
    -------
    StaticCurve

    Raises
    ------
    DataFormatError
        One line naming the file, line and column (missing or unexpected
        column, both ``u`` and ``v``, text, NaN/inf, too few rows, ...).

    Examples
    --------
    A static curve of the motor-disk subsystem (input, steady disk velocity):

    >>> import numpy as np
    >>> from iwp import StaticCurve, read_static_curve
    >>> from iwp.data import write_static_curve
    >>> curve = StaticCurve("v", np.array([40.0, 60.0, 80.0]), np.array([24.0, 76.0, 128.0]))
    >>> path = write_static_curve(curve, "static.csv")
    >>> back = read_static_curve("static.csv")
    >>> back.input_name, back.q4.tolist()
    ('v', [24.0, 76.0, 128.0])
    """
    if isinstance(min_points, bool) or not isinstance(min_points, (int, np.integer)) or min_points < 1:
        raise InputError(f"min_points must be an integer >= 1, got {min_points!r}")
    table = Table(path)
    src, where = table.source, table.where()
    found = table.header
    listing = ", ".join(found)
    inputs = [c for c in ("v", "u") if c in found]
    if "q4" not in found or not inputs:
        missing = [c for c in ("v or u", "q4") if not (inputs if c != "q4" else "q4" in found)]
        raise fail(
            f"{where}: missing required column(s) {', '.join(missing)}; found: {listing} "
            "(a static curve has columns v,q4 or u,q4)"
        )
    if len(inputs) == 2:
        raise fail(f"{where}: both input columns u and v present; a static curve has one")
    for name in found:
        if name not in ("q4", inputs[0]):
            raise fail(
                f"{where}: unexpected column {name!r}; a static curve has columns v,q4 or u,q4"
                + (" (this looks like a time series: use read_experiment)" if name == "t" else "")
            )
    if not table.lines:
        raise fail(f"{src}: no data rows after the header (line {table.header_line})")
    values = table.numbers()
    for j, name in enumerate(found):
        bad = np.flatnonzero(~np.isfinite(values[:, j]))
        if bad.size:
            i = int(bad[0])
            raise fail(
                f"{src}, line {table.lines[i]}, column {name!r}: {float(values[i, j])!r} is not a "
                "finite number (NaN or inf)"
            )
    if len(table.lines) < min_points:
        raise fail(f"{src}: {len(table.lines)} point(s), at least {min_points} are needed (min_points)")
    return StaticCurve(
        input_name=inputs[0],
        input=values[:, found.index(inputs[0])],
        q4=values[:, found.index("q4")],
        metadata=table.metadata,
        source=src,
    )


def write_static_curve(curve: StaticCurve, path: str | os.PathLike, force: bool = False) -> Path:
    """Write a :class:`StaticCurve` as CSV (bit-exact round trip).

    Parameters
    ----------
    curve : StaticCurve
    path : str or path-like
    force : bool, optional
        Overwrite an existing file.

    Returns
    -------
    pathlib.Path

    See Also
    --------
    iwp.data.read_static_curve : Read it back.

    Examples
    --------
    Figure 2(a) on the virtual rig, every 20 input units:

    >>> from iwp.data import read_static_curve, write_static_curve
    >>> from iwp.rig import run_experiment
    >>> curve = run_experiment("static-curve", step=20.0, duration=2.0)
    >>> write_static_curve(curve, "curve.csv").name
    'curve.csv'
    >>> [line.strip() for line in open("curve.csv") if not line.startswith("#")][:3]
    ['v,q4', '-100.0,-201.54033584872298', '-80.0,-143.1390782778901']
    >>> read_static_curve("curve.csv").input_name
    'v'
    """
    if not isinstance(curve, StaticCurve):
        raise InputError(f"curve must be a StaticCurve, got {type(curve).__name__}")
    p = prepare_output_file(path, force)
    text = _csv_text(curve.metadata, {curve.input_name: curve.input, "q4": curve.q4})
    return atomic_write(p, lambda tmp: tmp.write_text(text, encoding="utf-8"), force=force)

