"""A run on a rig as an iwp log: the samples, and what is known of the device, the link and the timing.

:func:`loop_log` turns a :class:`~iwp.device.loop.LoopResult` into an
:class:`~iwp.data.ExperimentData` that every iwp reader and ``iwp fit``
read: ``t = (seq - seq0) Ts`` (the device's ticks: regular by construction,
so the readers' sampling check holds; the device's own time stamps and the
host's receipt times are the extra columns ``t_device``, ``t_host``),
``q1, q2`` from the encoder counts, the input ``u`` (compensated) or ``v``
(raw) as the device applied it, the driver command after the feedforward
and saturation ``v_command``, the device's wheel speed ``q4_device``, the
motor current where measured, and the status ``flags``. The metadata say
how the run ended (``interrupted``, ``stop_reason``), who the device is
(``device``), what the link saw (``link``), the loop's timing (``timing``),
and a rig description of the log's columns (``rig``,
docs/rig-description.md).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass

import numpy as np

from ..data import ExperimentData
from ..data.glitches import Glitch
from ..files import jsonable
from .connection import DeviceInfo
from .link import LinkStats
from .loop import LoopResult
from .protocol import FLAGS

__all__ = ["loop_log", "rig_description"]


def rig_description(info: DeviceInfo, Ts: float, input_name: str | None) -> dict:
    """A rig description (docs/rig-description.md) of the logs that :func:`loop_log` writes.

    Parameters
    ----------
    info : DeviceInfo
        What the device reported (port, board, firmware, parameters).
    Ts : float
        Sample period of the logs [s].
    input_name : str or None
        Logged input column, ``"u"`` (compensated) or ``"v"``; None: no input column.

    Returns
    -------
    dict
        The rig description, ready to write as JSON.
    """
    p = info.params
    return {"kind": "iwp-rig", "name": f"iwp rig on {info.port} ({info.board}, firmware {info.firmware})",
            "sample_period": Ts, "time": {"column": "t", "unit": "s"},
            "pendulum": {"column": "q1", "unit": "rad", "zero": "down", "offset": 0.0},
            "wheel": {"column": "q2", "quantity": "angle", "unit": "rad", "counts_per_rev": p.get("counts2")},
            "input": ({"column": None} if input_name is None else
                      {"column": input_name, "kind": "units", "limits": [-p.get("v_max", 100.0), p.get("v_max", 100.0)],
                       "compensated": input_name == "u"})}


def loop_log(res: LoopResult, info: DeviceInfo, link: LinkStats, *, input_name: str | None,
             metadata: dict | None = None, source: str | None = None) -> ExperimentData | None:
    """The log of a run (see the module's docstring); None when fewer than 2 samples were recorded.

    Parameters
    ----------
    res : LoopResult
    info : DeviceInfo
    link : LinkStats
    input_name : {"u", "v", None}
        ``u``: the device compensated the dead zone (its ``v_dz`` > 0); ``v``: raw; None: the motor was off.
    metadata : dict, optional
        More ``key: value`` entries (experiment, settings).
    """
    S = res.samples
    if len(S) < 2:
        return None
    grid = _on_grid(S)
    if grid is None:
        return None
    t = (grid.seq - grid.seq[0]) * res.Ts
    q1, q2, u, v = grid.values["q1"], grid.values["q2"], grid.values["u"], grid.values["v"]
    extra = {"v_command": v, "q4_device": grid.values["q4"],
             "t_device": grid.values["t_device"] - grid.values["t_device"][0],
             "t_host": grid.values["t_host"] - grid.values["t_host"][0],
             "flags": grid.values["flags"]}
    if grid.filled.any():
        extra["filled"] = grid.filled.astype(float)
    cur = grid.values["current"]
    if grid.current_measured:
        extra["current"] = cur
    inputs = {} if input_name is None else {input_name: u if input_name == "u" else v}
    p = info.params
    meta = {k: str(val) for k, val in (metadata or {}).items()}
    meta.update({
        "source": f"iwp rig on {info.port}",
        "interrupted": "true" if res.interrupted else "false",
        "stop_reason": res.reason,
        "Ts": repr(res.Ts),
        "counts_per_rev": f"{p.get('counts1', math.nan):g}",
        "compensated": "yes" if input_name == "u" else ("no" if input_name == "v" else "no (motor off, v = 0)"),
        "saturation": repr(p.get("v_max")),
        "columns": "q1, q2: encoder counts times 2 pi / counts_per_rev [rad]; u or v: the input the device applied; "
                   "v_command: driver command after feedforward and saturation; q4_device: the device's wheel speed "
                   "[rad/s]; t_device: the device's time stamps, t_host: the host's receipt times [s]; flags: "
                   "telemetry flags (" + ", ".join(f"{k}={v}" for k, v in FLAGS.items()) + ")",
        "device": json.dumps(jsonable(info.to_dict()), separators=(",", ":")),
        "link": json.dumps(link.to_dict(), separators=(",", ":")),
        "timing": json.dumps(jsonable(res.timing()), separators=(",", ":")),
        "rig": json.dumps(rig_description(info, res.Ts, input_name), separators=(",", ":")),
    })
    if input_name == "u":
        meta.update(v_dz_pos=repr(p.get("v_dz_pos")), v_dz_neg=repr(p.get("v_dz_neg")))
    glitches = ()
    if grid.filled.any():
        meta["gaps"] = json.dumps(grid.gaps(res.Ts))
        meta["filled_samples"] = str(int(grid.filled.sum()))
        meta["bad_samples"] = str(grid.bad)
        meta["columns"] += ("; filled: 1 where the sample was lost on the link or carried a value that is not a "
                            "number, its values interpolated between its neighbours (left out of every fit)")
        glitches = tuple(Glitch(c, int(k), float(t[k]), "dropout", math.nan, float(grid.values[c][k]))
                         for c in ("q1", "q2") for k in np.flatnonzero(grid.filled))
    return ExperimentData(t=t, q1=q1, q2=q2, extra=extra, metadata=meta, source=source or f"rig {info.port}",
                          glitches=glitches, **inputs)


@dataclass(frozen=True, eq=False)
class _Grid:
    """A run's samples on the device's tick grid: the ticks, each field's values, which ticks were filled in."""

    seq: np.ndarray
    values: dict[str, np.ndarray]
    filled: np.ndarray
    bad: int
    current_measured: bool

    def gaps(self, Ts: float) -> list[list[float]]:
        """``[t_first, t_last, samples]`` of each run of filled ticks [s]."""
        edges = np.diff(np.concatenate([[0], self.filled.astype(np.int8), [0]]))
        first, last = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
        t = (self.seq - self.seq[0]) * Ts
        return [[float(t[a]), float(t[b]), int(b - a + 1)] for a, b in zip(first, last)]


_FIELDS = ("q1", "q2", "u", "v", "q4", "t_device", "t_host", "current")


def _on_grid(S: list) -> _Grid | None:
    """The samples on every tick from the first to the last: a tick the link lost, or a sample carrying a value
    that is not a number (a lying device), filled in by interpolating its neighbours and marked, so that nothing
    recorded is lost and the log stays regular (readable by every iwp reader). None with fewer than two good
    samples."""
    raw = {f: np.array([getattr(s, f) for s in S], dtype=float) for f in _FIELDS}
    flags = np.array([sum(FLAGS[f] for f in s.flags) for s in S], dtype=float)
    current_measured = bool(np.all(np.isfinite(raw["current"])))
    checked = [f for f in _FIELDS if f != "current" or current_measured]
    good = np.all([np.isfinite(raw[f]) for f in checked], axis=0)
    seq_all = np.array([s.seq for s in S], dtype=np.int64)
    good &= np.concatenate([[True], np.diff(seq_all) > 0])  # a tick seen twice, or out of order, counts once
    if good.sum() < 2:
        return None
    seq = seq_all[good]
    ticks = np.arange(seq[0], seq[-1] + 1)
    filled = ~np.isin(ticks, seq)
    values = {f: np.interp(ticks, seq, raw[f][good]) for f in _FIELDS if f != "current" or current_measured}
    if not current_measured:
        values["current"] = np.full(ticks.size, np.nan)
    values["flags"] = np.where(filled, 0.0, np.interp(ticks, seq, flags[good]))
    return _Grid(ticks.astype(float), values, filled, int((~good).sum()), current_measured)
