"""How a log's input acted between its samples, read from the log itself when the file does not say.

A rig's digital controller holds each command until the next sample (a
zero-order hold, ``"zoh"``); a continuous simulation (scipy, Simulink) or an
analog drive applies an input that moves between the samples, of which the
log keeps the values at the samples (``"continuous"``). The regression of
section 5 and the replay of a simulation-error fit must know which: read the
wrong way, an input lags or leads half a sample, and a chirp's ``p2 (1 + rho)``
comes out 1.8-2.5 % off, tens of standard errors (issue 50, on logs iwp did
not make).

A log whose metadata ``input_hold`` says it is taken at its word. Otherwise
:func:`read_input_hold` fits both readings to the one equation of model (9)
that holds whatever the pendulum does, the sum of its two rows (the wheel's
absolute acceleration),

    q3' + q4' = -rho p2 q4 + rho p3 u  (+ a Coulomb column sgn q4),

(with the pendulum clamped it is the wheel's row (14)), on the log's
Savitzky-Golay-filtered signals as :mod:`iwp.ident.signals` forms them, and
takes the reading whose residuals are the smaller; it is *decided* when the
other reading's are at least :data:`HOLD_CLEAR` times larger, else the log is
read as held (a rig's controller) and said undecided. The residuals are also
compared with what the encoders' noise explains, and that ratio is reported.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Mapping, Sequence

import numpy as np

from ..data import ExperimentData
from .differentiate import Differentiator, central_first
from .signals import (
    EDGE_MIN,
    acceleration_noise_gain,
    apply_K,
    apply_KS,
    fast_derivatives,
    held_input,
    point_velocity,
    position_noise,
)

__all__ = ["InputHoldReading", "read_input_hold", "with_input_hold", "describe_readings", "HOLD_CLEAR",
           "INPUT_HOLDS"]

#: how a log's input acted between its samples (``"auto"``: as its metadata says, else read from the data)
INPUT_HOLDS = ("auto", "zoh", "continuous")
#: the wrong reading leaves residuals at least this many times the right one's: measured 1.3-170 on chirps,
#: multisines and steps of three rigs unlike Table 1 with white and AR(1) noise (tests/test_input_hold.py); below
#: it the input moves too little within a sample for the hold to matter or to be read
HOLD_CLEAR = 1.1
#: the span of the filters of the reading [s] (identify's default)
_SPAN = 0.5


@dataclass(frozen=True)
class InputHoldReading:
    """How one log's input acted between its samples, and why iwp reads it so.

    Attributes
    ----------
    hold : {"zoh", "continuous"}
        The reading taken.
    how : {"metadata", "data", "default", "given"}
        ``"metadata"``: the log says so (``input_hold``); ``"data"``: the residuals decided
        (:func:`read_input_hold`); ``"default"``: no input, or the data could not tell (held, as a rig's
        controller applies it); ``"given"``: the caller forced it.
    residual : dict of str to float
        Per reading, the RMS residual of the row sum of (9) [rad/s^2] (empty unless read from the data).
    noise : float
        What the encoders' noise explains of that RMS [rad/s^2] (NaN unless read from the data).
    """

    hold: str
    how: str
    residual: dict[str, float]
    noise: float = math.nan

    @property
    def ratio(self) -> float:
        """The other reading's residual over the one taken (1 when not read from the data)."""
        if len(self.residual) < 2:
            return 1.0
        other = "continuous" if self.hold == "zoh" else "zoh"
        return self.residual[other] / self.residual[self.hold] if self.residual[self.hold] > 0 else math.inf

    def describe(self) -> str:
        """One clause: the reading and why."""
        name = {"zoh": "held between samples", "continuous": "continuous"}[self.hold]
        if self.how == "metadata":
            return f"input {name} (the log's metadata input_hold)"
        if self.how == "given":
            return f"input {name} (as given)"
        if not self.residual:
            return f"input {name} (no input to read)"
        other = "continuous" if self.hold == "zoh" else "zoh"
        noise = (f", {self.residual[self.hold] / self.noise:.3g} times what the encoder noise explains"
                 if self.noise > 0 else "")
        if self.how == "data":
            return (f"input read as {name} from the data (the file does not say): the wheel's row leaves "
                    f"{self.ratio:.3g} times larger residuals read as {other}{noise}")
        return (f"input {name} (the file does not say, and the data cannot tell: the two readings' residuals are "
                f"within a factor {HOLD_CLEAR:g}, {self.ratio:.3g}{noise}; the rig default)")

    def to_dict(self) -> dict[str, Any]:
        return {"hold": self.hold, "how": self.how, "residual": dict(self.residual),
                "noise": None if not math.isfinite(self.noise) else self.noise}


def _said(data: ExperimentData) -> str | None:
    said = str(data.metadata.get("input_hold", "")).strip().lower()
    return said if said in ("zoh", "continuous") else None


def read_input_hold(data: ExperimentData, input_hold: str = "auto") -> InputHoldReading:
    """How ``data``'s input acted between its samples (see the module docstring).

    Parameters
    ----------
    data : ExperimentData
        A time-series log.
    input_hold : {"auto", "zoh", "continuous"}
        ``"zoh"`` or ``"continuous"`` force the reading; ``"auto"`` (default): the log's metadata
        ``input_hold``, else the data's reading.

    Returns
    -------
    InputHoldReading

    Examples
    --------
    A motor-disk chirp whose input was continuous, logged at 5 ms with a 2000-count encoder:

    >>> import numpy as np
    >>> from iwp import Chirp, Plant, simulate, table1
    >>> from iwp.ident.input_hold import read_input_hold
    >>> log = simulate(Plant(table1(), locked=True), input=Chirp(50, 3, 100), t_end=20).to_experiment()
    >>> r = read_input_hold(log)
    >>> r.hold, r.how, r.ratio > 10
    ('continuous', 'data', True)
    """
    if input_hold not in INPUT_HOLDS:
        raise ValueError(f"input_hold must be one of {INPUT_HOLDS}, got {input_hold!r}")
    if input_hold != "auto":
        return InputHoldReading(input_hold, "given", {})
    said = _said(data)
    if said is not None:
        return InputHoldReading(said, "metadata", {})
    residual, noise = _residuals(data)
    if not residual:
        return InputHoldReading("zoh", "default", {})
    hold = min(residual, key=residual.get)
    reading = InputHoldReading(hold, "data", residual, noise)
    if reading.ratio < HOLD_CLEAR:
        return InputHoldReading("zoh", "default", residual, noise)
    return reading


def with_input_hold(datas: Sequence[ExperimentData], input_hold: str = "auto"
                    ) -> tuple[list[ExperimentData], list[InputHoldReading]]:
    """The logs with their reading in the metadata (``input_hold`` and ``input_hold_read``), and the readings.

    Every later step (the regression, a fit's replay of the input) then reads the metadata.
    """
    out, readings = [], []
    for d in datas:
        r = read_input_hold(d, input_hold)
        readings.append(r)
        if r.how == "metadata":
            out.append(d)
            continue
        meta = {**d.metadata, "input_hold": r.hold, "input_hold_read": r.how}
        out.append(replace(d, metadata=meta))
    return out, readings


def _residuals(data: ExperimentData) -> tuple[dict[str, float], float]:
    """Per reading, the RMS residual of the row sum of (9) fitted by least squares, and the encoder noise's share
    of it; empty where the log has no input that moves, no wheel angle, or too few samples."""
    if data.input_name is None or data.q2 is None or data.n_samples < 50:
        return {}, math.nan
    u = np.asarray(data.input, dtype=float)
    if not np.all(np.isfinite(u)) or np.ptp(u) == 0:
        return {}, math.nan
    Ts = float(data.Ts)
    dt = np.diff(data.t)
    if float(np.max(np.abs(dt - Ts))) > 0.01 * Ts:
        return {}, math.nan
    d = Differentiator.savgol_spanning(_SPAN, Ts, min_window=7)
    kk = max(d.edge_samples_at(Ts), EDGE_MIN)
    if data.n_samples < 4 * kk + 10:
        return {}, math.nan
    q1 = np.zeros(data.n_samples) if data.q1 is None else np.asarray(data.q1, dtype=float)
    q = np.column_stack([q1, np.asarray(data.q2, dtype=float)])
    _pos, _vel, acc = fast_derivatives(d, Ts, q)
    target = (acc[:, 0] + acc[:, 1])[kk:-kk]
    q4 = point_velocity(central_first(q[:, 1:], Ts))[:, 0]
    common = apply_KS(d, Ts, np.column_stack([q4, np.sign(q4), u]))
    readings = {"continuous": common[:, 2], "zoh": apply_K(d, Ts, held_input(u)[:, None])[:, 0]}
    out = {}
    for name, col in readings.items():
        X = np.column_stack([common[:, 0], common[:, 1], col])[kk:-kk]
        coef, *_ = np.linalg.lstsq(X, target, rcond=None)
        r = target - X @ coef
        out[name] = float(math.sqrt(float(r @ r) / max(r.size - 3, 1)))
    noise_sd = position_noise(q)
    noise = float(math.sqrt(float(noise_sd @ noise_sd) * acceleration_noise_gain(d, Ts)))
    return out, noise


def describe_readings(readings: Mapping[str, InputHoldReading]) -> str:
    """One line for a fit's summary: how the logs' inputs were read, grouped (``readings`` by source)."""
    groups: dict[tuple[str, str], list[str]] = {}
    for src, r in readings.items():
        groups.setdefault((r.hold, r.how), []).append(src)
    why = {"metadata": "as the logs say", "given": "as given", "data": "read from the data, the files not saying",
           "default": "the files not saying and the data not telling (a rig's controller holds)"}
    parts = []
    for (hold, how), srcs in groups.items():
        name = "held between samples" if hold == "zoh" else "continuous"
        if how == "default" and all(not readings[s].residual for s in srcs):
            reason = "no input to read"
        else:
            reason = why[how]
        ratios = [readings[s].ratio for s in srcs if readings[s].how == "data"]
        extra = (f"; the other reading leaves {min(ratios):.3g}-{max(ratios):.3g} times larger residuals"
                 if ratios else "")
        parts.append(f"{name} in {len(srcs)} log{'s' if len(srcs) > 1 else ''} ({reason}{extra})")
    return "inputs: " + "; ".join(parts)
