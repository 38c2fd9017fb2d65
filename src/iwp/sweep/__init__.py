"""Sweeps and Monte Carlo studies of closed loops, on one machine or a Dask cluster (issue 20, part 4).

=====================  ==============================================================
module                 what
=====================  ==============================================================
:mod:`.spec`           :class:`SweepSpec`: plant parameters, gains, initial states (grids
                       and distributions, a fit's covariance); lanes and seeds of a chunk
:mod:`.metrics`        what is recorded of every closed loop
:mod:`.chunk`          one chunk through the batch engine (:func:`iwp.sim.simulate_batch`)
:mod:`.store`          the output folder: chunk files, manifest, results table; resuming
:mod:`.executors`      local (all cores) or Dask distributed
:mod:`.run`            :func:`run_sweep`
=====================  ==============================================================

Example::

    from iwp.sweep import Grid, Normal, SweepSpec, run_sweep
    from iwp import table1

    spec = SweepSpec(params=table1(), vary=(Grid("k1", (-12.0, -10.0, -8.0)), Normal("x0.q1", 0.1, 0.05)),
                     samples=100, t_end=300.0)
    res = run_sweep(spec, "sweep-out")               # all local cores
    res = run_sweep(spec, "sweep-out", workers=2)    # the same numbers on a 2-worker Dask LocalCluster
    print(res.summary())
"""

from __future__ import annotations

from .chunk import ChunkResult, run_chunk
from .executors import DaskExecutor, LocalExecutor, make_executor
from .metrics import METRICS, closed_loop_metrics
from .run import SweepProgress, SweepResult, run_sweep
from .spec import (
    GAIN_NAMES,
    LAWS,
    STATE_NAMES,
    Grid,
    LaneSet,
    Normal,
    SweepSpec,
    Uniform,
    lanes_of_chunk,
    load_spec,
    spec_from_dict,
)
from .store import RESULT_FORMATS, SweepStore, read_table

__all__ = [
    "SweepSpec",
    "Grid",
    "Normal",
    "Uniform",
    "LaneSet",
    "lanes_of_chunk",
    "load_spec",
    "spec_from_dict",
    "LAWS",
    "GAIN_NAMES",
    "STATE_NAMES",
    "METRICS",
    "closed_loop_metrics",
    "ChunkResult",
    "run_chunk",
    "LocalExecutor",
    "DaskExecutor",
    "make_executor",
    "SweepStore",
    "read_table",
    "RESULT_FORMATS",
    "SweepProgress",
    "SweepResult",
    "run_sweep",
]
