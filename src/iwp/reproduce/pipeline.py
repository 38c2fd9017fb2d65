"""Running the steps: :func:`reproduce`."""

from __future__ import annotations

import errno
import json
import os
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from numba.core import event

from ..errors import InputError, IwpError
from ..files import atomic_write, check_output_dir, staged_dir
from ..interruption import deliveries, raise_if_replaced
from ..models.parameters import table1
from ..rig import RigTruth, VirtualRig, default_truth
from .context import ProgressEvent, ReproduceResult, StepRecord
from .output import step_report
from .steps import (
    step_closed_loop,
    step_coulomb,
    step_dead_zone,
    step_free_pendulum,
    step_full_chirp,
    step_full_setup,
    step_motor_disk,
    step_paper_numbers,
    step_refine,
    step_sines,
    step_two_step,
)

__all__ = ["Step", "STEPS", "reproduce"]


@dataclass(frozen=True)
class Step:
    """One step of the reproduction: its name, what it runs, its title, where in the paper, the steps it needs."""

    name: str
    run: Callable[[ReproduceResult], str]
    title: str
    reference: str
    needs: tuple[str, ...] = ()


#: The steps, in the paper's order.
STEPS: list[Step] = [
    Step("dead-zone", step_dead_zone, "Static curves and the dead-zone thresholds", "section 5.1, figure 2"),
    Step("motor-disk", step_motor_disk, "Motor-disk chirp: p2(1+rho) and p3(1+rho)", "section 5.1"),
    Step("sines", step_sines, "Sinusoids A = 60, 40, 20: rigid and flexible-belt models", "section 5.1, figures 3, 4",
         ("motor-disk",)),
    Step("coulomb", step_coulomb, "The Coulomb-friction variant", "section 5.1, figures 6, 7"),
    Step("full-setup", step_full_setup, "The full 8-parameter set-up", "section 5.2, eq. (16)"),
    Step("free-pendulum", step_free_pendulum, "The free pendulum", "section 5.2, figure 8"),
    Step("two-step", step_two_step, "The two-step set-up and rho", "section 5.2, Table 1", ("free-pendulum",)),
    Step("full-chirp", step_full_chirp, "The full chirp, with and without the restart", "section 5.2, figure 9",
         ("two-step",)),
    Step("closed-loop", step_closed_loop, "Closed loop k1 = -10, k2 = 0.1", "section 5.3, figure 10", ("two-step",)),
    Step("paper-numbers", step_paper_numbers, "The paper's numbers, published against reproduced",
         "sections 5.1-5.3"),
    Step("refine", step_refine, "Refinement by simulation error", "beyond the paper", ("two-step",)),
    Step("report", step_report, "Statements, parameters.json, report.html", ""),
]


# --------------------------------------------------------------------------
# the runner
# --------------------------------------------------------------------------
def reproduce(
    out: str | os.PathLike,
    *,
    force: bool = False,
    quick: bool = False,
    seed: int = 0,
    truth=None,
    progress: Callable[[ProgressEvent], None] | None = None,
    keep_going: bool = True,
    keep_logs: bool = False,
) -> ReproduceResult:
    """Run the paper end to end on the virtual rig and write the report to ``out``.

    Parameters
    ----------
    out : path
        Output folder, created if needed inside a folder that exists. One that exists and is not
        empty is refused unless ``force`` (files are then overwritten).
    force : bool
    quick : bool
        Shorter experiments and a smaller refinement (for tests).
    seed : int
        Seed of the rig's measurement noise.
    truth : RigTruth, optional
        The rig's truth (default: :func:`iwp.rig.default_truth`).
    progress : callable, optional
        Called with a :class:`ProgressEvent` when a step starts and ends.
    keep_going : bool
        After a failed step, run the others that do not need it (default);
        ``False`` stops at the first failure (the report step still runs).
    keep_logs : bool
        Also write every experiment's log to ``out/data/NAME.csv`` (about 20 MB for a full run; the page names the
        command that writes each log again, bit for bit).

    Returns
    -------
    ReproduceResult
        ``.ok`` is false if a step failed; ``.failed_steps`` names them.

    Raises
    ------
    OutputExistsError
        ``out`` exists, is not empty, and ``force`` is false.
    InputError
        Bad ``seed`` or ``truth``.

    See Also
    --------
    iwp.reproduce.check_statements : The paper's statements checked with a run's numbers.

    Examples
    --------
    The quick run (shortened experiments, about 25 s): the report, its numbers and the statements' verdicts:

    >>> from iwp.reproduce import reproduce
    >>> res = reproduce("paper", quick=True)
    >>> res.ok, sorted(p.name for p in res.out.iterdir() if p.suffix in (".html", ".json"))
    (True, ['parameters.json', 'report.html', 'results.json'])
    >>> len(res.statements), {s.verdict for s in res.statements} <= {"pass", "fail"}
    (15, True)
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError(f"seed must be an integer >= 0, got {seed!r}")
    if truth is None:
        truth = default_truth()
    if not isinstance(truth, RigTruth):
        raise InputError(f"truth must be a RigTruth, got {type(truth).__name__}")
    final = check_output_dir(out, force=force)  # refuse before the work, not after
    # every file is written into a hidden sibling folder and moved into place whole at the end: an interrupt, a
    # kill or a full disk leaves the previous content (or nothing), never a half-written folder
    with staged_dir(final, force=force) as tmp:
        ctx = ReproduceResult(out=tmp, quick=bool(quick), seed=int(seed), truth=truth, keep_logs=bool(keep_logs))
        _run_steps(ctx, progress, keep_going)
        report = ctx.step("report")
        if report.status != "ok":  # no page: nothing of the run is kept
            err = ctx.extra.get("output-error")
            if isinstance(err, OSError):
                raise OSError(err.errno, f"{err.strerror or err}; nothing was written", str(final))
            raise RuntimeError(f"step 'report' {report.status}: {report.message}")
    _moved(ctx, final)
    return ctx


def _moved(ctx: ReproduceResult, final: Path) -> None:
    """Point the result's paths at the folder the staged one was moved to."""
    def move(p: Path) -> Path:
        return final / p.relative_to(ctx.out)

    ctx.files = [move(p) for p in ctx.files]
    for f in ctx.figures:
        f.files = [move(p) for p in f.files]
    ctx.out = final


def _run_steps(ctx: ReproduceResult, progress, keep_going: bool) -> None:
    """Run every step into ``ctx.out``; a failed step is recorded (an interrupt or a full disk is raised)."""
    ctx._rig = VirtualRig(ctx.truth, seed=ctx.seed)
    ctx._progress = progress
    ctx.extra["t_start"] = time.perf_counter()
    ctx.params["truth"] = ctx.truth.lumped
    ctx.params["table1"] = table1()
    ctx.steps = [StepRecord(s.name, s.title, s.reference) for s in STEPS]
    total = len(STEPS)
    stop = False
    for i, step in enumerate(STEPS, 1):
        name, title, needs = step.name, step.title, step.needs
        rec = ctx.step(name)
        ctx._current = name
        blocked = [n for n in needs if ctx.step(n).status != "ok"]
        if (stop and name != "report") or blocked:
            rec.status = "skipped"
            rec.message = (f"needs step '{blocked[0]}', which {ctx.step(blocked[0]).status}" if blocked
                           else "stopped after a failed step")
            _emit(progress, ProgressEvent("skipped", name, i, total, title, rec.message))
            continue
        _emit(progress, ProgressEvent("start", name, i, total, title))
        t0 = time.perf_counter()
        signals = deliveries()
        compiling = event.TimingListener()  # numba compiling a kernel on its first use: shown apart
        try:
            with event.install_listener("numba:compile", compiling):
                msg = step.run(ctx)
            rec.status = "ok"
            rec.message = msg or ""
        except KeyboardInterrupt:
            raise
        except OSError as exc:
            if exc.errno in _OUTPUT_ERRNOS:  # a full disk or a folder that became read-only: nothing is kept
                raise
            raise_if_replaced(signals, exc)
            ctx.extra["output-error"] = exc
            _failed(rec, exc, keep_going)
            stop = stop or not keep_going
        except Exception as exc:  # noqa: BLE001 - every failure is recorded with the step's name
            raise_if_replaced(signals, exc)  # an interrupt that compiled code turned into its own error
            _failed(rec, exc, keep_going)
            stop = stop or not keep_going
        rec.compile_seconds = compiling.duration if compiling.done else 0.0
        rec.seconds = time.perf_counter() - t0 - rec.compile_seconds
        _emit(progress, ProgressEvent("done" if rec.status == "ok" else "failed", name, i, total, title,
                                      rec.message, rec.seconds + rec.compile_seconds))  # the wall time waited
    ctx.elapsed = time.perf_counter() - ctx.extra["t_start"]
    if ctx.step("report").status == "ok":
        write_results(ctx, progress)  # the elapsed time in results.json includes the report


#: errno values that say the output cannot be written (the run stops; nothing of it is kept).
_OUTPUT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EROFS, errno.EACCES, errno.EIO, errno.EFBIG}


def _failed(rec: StepRecord, exc: BaseException, keep_going: bool) -> None:
    rec.status = "failed"
    rec.message = f"{type(exc).__name__}: {exc}" if not isinstance(exc, IwpError) else str(exc)
    rec.detail = traceback.format_exc()


def write_results(ctx: ReproduceResult, progress: Callable[[ProgressEvent], None] | None = None) -> bool:
    """Write ``DIR/results.json`` (atomically); a failure marks the step ``report`` failed and says why.

    Returns True when written. On an :class:`OSError` (no space, no permission, a folder in the way) the
    report step's record becomes ``failed`` with the file and the reason, a ``failed`` progress event is
    emitted and the run is not ``ok`` (``iwp reproduce`` then exits 1 naming it).
    """
    path = ctx.out / "results.json"
    text = json.dumps(ctx.to_dict(), indent=2) + "\n"
    try:
        atomic_write(path, lambda tmp: tmp.write_text(text))
    except OSError as exc:
        ctx.extra["output-error"] = exc
        rec = ctx.step("report")
        rec.status = "failed"
        rec.message = f"could not write {path}: {exc.strerror or exc}"
        idx = next(i for i, s in enumerate(ctx.steps, 1) if s.name == "report")
        _emit(progress, ProgressEvent("failed", "report", idx, len(ctx.steps), rec.title, rec.message))
        return False
    return True


def _emit(progress, event: ProgressEvent) -> None:
    if progress is not None:
        progress(event)
