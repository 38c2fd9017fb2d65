"""A live view of a run on a rig: a page on 127.0.0.1 that streams it, with the model's prediction and a stop button.

:class:`LiveFeed` is the loop's observer (:class:`~iwp.device.loop.LoopObserver`):
the loop hands it each sample it records, and it only writes the sample into
a ring of shared memory whose oldest entry is overwritten when the reader
falls behind (:class:`~iwp.live_server.SampleRing`), and reads the stop
button's flag there: nothing the page does can slow or block the loop.
:class:`LiveView` serves the page from a process of its own, a fresh
interpreter (:mod:`iwp.live_server`) that shares only that memory with the
host, at the lowest priority: a thread of the host's process would compete
with its real-time loop for Python's interpreter lock (docs/live.md). The
page draws ``q1`` and ``q2`` with
the model's prediction (:mod:`.prediction`) and its 95 % band, the command
applied with its saturated samples, the device's state and fault, its
overruns and late ticks and the samples lost on the link. The plots are
BokehJS's (canvas: streaming a few points repaints cheaply, so that the page
keeps up at 20 updates a second on a busy machine), served from the
``bokeh`` package installed here (``pip install 'iwp[live]'``), never from
the internet.

The server compares every sample with the model's prediction (it has it at
every sample, handed over once before the run): the page shows how far
``q1`` and ``q2`` are from it and says when the measurement leaves the 95 %
band; the loop's process does nothing more per sample.

The stop button asks the loop to stop (:meth:`LiveFeed.request_stop`): it
ends the run as Ctrl-C does, the motor stopped and the log so far written,
marked interrupted (reason :data:`STOP_REASON`). When the run ends,
:meth:`LiveView.finish` tells the page so, with the device's final state as
the host knows it (:func:`final_state`: the motor disarmed, the emergency
stop, a fault, or a stop the device did not confirm), which the run's last
samples, recorded while it was armed, cannot show. Closing the page stops
nothing. The view shuts its server down on every way out of its ``with``
block.
"""

from __future__ import annotations

import importlib.util
import json
import mmap
import os
import select
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from ..errors import InputError
from ..live_server import PLOT_RATE, REFERENCE_ROWS, RING_SAMPLES, SampleRing
from .connection import Sample
from .loop import LoopObserver
from .protocol import FAULTS, STATES

__all__ = ["LiveFeed", "LiveView", "STOP_REASON", "bokeh_js", "BOKEH_FILES", "final_state"]

#: The stop reason of the stop button (the log's ``stop_reason``).
STOP_REASON = "stop button (live view)"
#: BokehJS's files the page loads (from the bokeh package).
BOKEH_FILES = ("bokeh.min.js", "bokeh-api.min.js")
#: How long the server process may take to start serving [s].
_START_TIMEOUT = 60.0
#: The page.
_PAGE = Path(__file__).with_name("live.html")
#: Most points of the prediction the server compares the measurement with (45 min at 5 ms; a longer one is
#: decimated); the page draws a few hundred.
_REFERENCE_POINTS = 1 << 19


def _shared_file(size: int) -> int:
    """A file of ``size`` bytes in memory, with no name (a descriptor the server process inherits)."""
    if hasattr(os, "memfd_create"):
        fd = os.memfd_create("iwp-live", 0)
    else:  # pragma: no cover (not Linux)
        with tempfile.TemporaryFile() as f:
            fd = os.dup(f.fileno())
    os.ftruncate(fd, size)
    return fd


def bokeh_js() -> dict[str, Path]:
    """BokehJS, as the installed ``bokeh`` package ships it (found without importing it): its files by name.

    Returns
    -------
    dict of str to Path
        ``bokeh.min.js`` (the library) and ``bokeh-api.min.js`` (its JavaScript plotting API).

    Raises
    ------
    InputError
        ``bokeh`` is not installed (the extra ``live``).
    """
    spec = importlib.util.find_spec("bokeh")
    paths = [] if spec is None or spec.submodule_search_locations is None else list(spec.submodule_search_locations)
    for p in paths:
        files = {n: Path(p) / "server" / "static" / "js" / n for n in BOKEH_FILES}
        if all(f.is_file() for f in files.values()):
            return files
    raise InputError("the live view needs the bokeh package, which ships the plotting library it serves: "
                     "pip install 'iwp[live]'", argument="live")


class LiveFeed(LoopObserver):
    """What the loop hands the live view: every sample, into the shared ring; and the stop button's request.

    Parameters
    ----------
    progress : callable, optional
        Called with the loop's progress dictionary as well (the terminal's progress line).
    n : int
        The ring's length in samples; the oldest are overwritten when the server falls this far behind.
    """

    def __init__(self, progress=None, n: int = RING_SAMPLES):
        self.n = int(n)
        self.fd = _shared_file(SampleRing.size(self.n))  # shared with the server's process
        self.buffer = mmap.mmap(self.fd, SampleRing.size(self.n))
        self.ring = SampleRing(self.buffer, self.n)
        self._progress = progress
        self._states, self._faults = dict(STATES), dict(FAULTS)

    def __call__(self, progress: dict) -> None:
        self.ring.set_lost(int(progress.get("lost", 0)))
        if self._progress is not None:
            self._progress(progress)

    def on_sample(self, t: float, sample: Sample) -> None:
        s = sample
        self.ring.write((t, s.q1, s.q2, s.q4, s.u, s.v, 1.0 if "SATURATED" in s.flags else 0.0,
                         self._states.get(s.state, -1), self._faults.get(s.fault, -1), s.overruns, s.late))

    def stop_requested(self) -> str | None:
        return STOP_REASON if self.ring.stop else None

    def request_stop(self) -> None:
        """Ask the loop to stop the run, as the stop button does (from any thread or process sharing the ring)."""
        self.ring.request_stop()


def final_state(*, interrupted: bool, stop_confirmed: bool | None, last_state: str | None = None,
                last_fault: str | None = None) -> dict:
    """The device's state after a run as its host knows it (the run's last samples were recorded before the stop).

    Parameters
    ----------
    interrupted : bool
        The run ended before its duration (the stop button, Ctrl-C, a fault, a limit): the host sent the emergency
        stop; else it disarmed the motor.
    stop_confirmed : bool or None
        The device acknowledged the stop; False: it did not answer; None: the motor was never armed.
    last_state, last_fault : str, optional
        The device's state and fault in the run's last sample.

    Returns
    -------
    dict
        ``state`` (``DISARMED``, ``ESTOP``, ``FAULT``, the last one seen when the motor was never armed, or
        ``UNKNOWN``), ``fault``, ``u`` (the command applied: 0 after a confirmed stop, None when not known),
        ``confirmed`` (``stop_confirmed``) and ``text`` (one line for the page).
    """
    if stop_confirmed is None:
        return {"state": last_state, "fault": last_fault, "u": None, "confirmed": None,
                "text": "the motor was not armed in this run"}
    if not stop_confirmed:
        return {"state": "UNKNOWN", "fault": None, "u": None, "confirmed": False,
                "text": "stop unconfirmed: the device did not answer the stop, so nothing confirms that the motor "
                        "stopped; its watchdog stops it if it still runs: check the rig"}
    if not interrupted:
        return {"state": "DISARMED", "fault": "NONE", "u": 0.0, "confirmed": True,
                "text": "the motor was disarmed at the end of the run (acknowledged by the device)"}
    if last_state == "FAULT":  # the device stopped the motor itself; its fault stays the one reported
        return {"state": "FAULT", "fault": last_fault, "u": 0.0, "confirmed": True,
                "text": f"the device stopped the motor ({last_fault}); the host's emergency stop acknowledged"}
    return {"state": "ESTOP", "fault": "ESTOP", "u": 0.0, "confirmed": True,
            "text": "the motor was stopped: emergency stop acknowledged by the device (latched until the next run)"}


class LiveView:
    """The page of a run (see the module's docstring); a context manager that serves it until its block ends.

    Parameters
    ----------
    feed : LiveFeed
        The loop's observer (give it as the run's ``progress``).
    port : int
        Port on 127.0.0.1 (0: a free one; :attr:`url` says which).
    title : str
        What runs, for the page's heading.
    duration : float, optional
        Length of the run [s] (the plots' time axis).

    Raises
    ------
    InputError
        The port is taken or not allowed (argument ``live_port``), or bokeh is missing.
    """

    def __init__(self, feed: LiveFeed, *, port: int = 0, title: str = "", duration: float | None = None):
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise InputError(f"live_port must be a port number from 0 to 65535, got {port!r}", argument="live_port")
        js = {n: str(p) for n, p in bokeh_js().items()}
        # the model's prediction at every sample goes to the server through a file in memory, not the pipe: the
        # host never waits for the server (at the lowest priority) to read a megabyte
        self._reference_fd = _shared_file(0)
        config = {"meta": {"title": title, "duration": duration, "limits": {}, "plot_rate": PLOT_RATE},
                  "page": str(_PAGE), "js": js, "states": STATES, "faults": FAULTS, "n": feed.n,
                  "reference_fd": self._reference_fd}
        self.feed = feed
        self._closed = False
        self._process = subprocess.Popen(
            [sys.executable, "-m", "iwp.live_server", "--fd", str(feed.fd), "--port", str(port)],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            pass_fds=(feed.fd, self._reference_fd), text=True, env=_child_env())
        self._send("config", config)
        ready, _, _ = select.select([self._process.stdout], [], [], _START_TIMEOUT)
        line = self._process.stdout.readline().strip() if ready else "error it did not start"
        what, _, value = line.partition(" ")
        if what != "port":
            self.close()
            raise InputError(f"live_port {port}: cannot serve there ({value or 'the server ended'})",
                             argument="live_port")
        self.port = int(value)
        self.url = f"http://127.0.0.1:{self.port}/"

    def _send(self, what: str, value) -> None:
        if self._closed:
            return
        try:
            line = json.dumps(_message(what, value), allow_nan=False)
            self._process.stdin.write(line + "\n")
            self._process.stdin.flush()
        except (BrokenPipeError, OSError, ValueError):  # the server is gone: the run goes on without its page
            pass

    def set_prediction(self, prediction) -> None:
        """The model's prediction to draw (a :class:`~iwp.device.prediction.RunPrediction`), None for none, or a
        string saying why there is none."""
        if prediction is None or isinstance(prediction, str):
            self._send("prediction", {"none": True, "text": prediction or "no prediction for this run"})
            return
        page = prediction.to_dict()
        try:
            rows = _reference_rows(prediction)
            os.ftruncate(self._reference_fd, rows.nbytes)
            if os.pwrite(self._reference_fd, rows.tobytes(), 0) != rows.nbytes:
                raise OSError("the prediction was not written whole")
            page["reference"] = {"n": int(rows.shape[1]), "band": prediction.lower is not None}
        except (OSError, ValueError, KeyError):  # the server compares with the page's points instead
            pass
        self._send("prediction", page)

    def set_limits(self, **limits) -> None:
        """The rig's limits (``q1_max`` [rad], ``v_max`` [input units]) shown on the page."""
        self._send("limits", {k: float(v) for k, v in limits.items()})

    def attach(self, rig, predict=None) -> None:
        """Show ``rig``'s limits and the model's prediction of the run about to start on it.

        Parameters
        ----------
        rig : Rig
            Connected, not armed. Its telemetry is switched off while the model runs (the run switches it on),
            so that nothing queues on the link meanwhile.
        predict : callable, optional
            ``predict(Ts)``, the prediction at the rig's loop period ``Ts`` [s]
            (:func:`~iwp.device.prediction.predict_rig_run`, :func:`~iwp.device.prediction.predict_control_run`),
            or None for none. A prediction that fails is said on the page; the run goes on.
        """
        p = rig.info.params
        self.set_limits(q1_max=p["q1_max"], v_max=p["v_max"])
        if predict is None:
            self.set_prediction(None)
            return
        rig.stream(0)
        try:
            self.set_prediction(predict(p["period_us"] * 1e-6))
        except Exception as exc:  # noqa: BLE001 (the page says so; the run matters more than its prediction)
            self.set_prediction(f"the model's prediction failed: {exc}")

    def finish(self, reason: str, *, run=None) -> None:
        """The run ended: the pages are told, after its last samples, with the device's final state.

        Parameters
        ----------
        reason : str
            ``"complete"`` or the run's stop reason.
        run : RigRun, optional
            The run (:func:`~iwp.device.runs.run_on_rig`, :func:`~iwp.device.control.run_control`): whether it was
            interrupted and its stop confirmed, whence the final state (:func:`final_state`); None: the reason
            alone.
        """
        final = None if run is None else final_state(interrupted=bool(run.interrupted),
                                                     stop_confirmed=run.stop_confirmed, **self._last_state())
        self._send("end", {"reason": str(reason), "final": final})

    def _last_state(self) -> dict:
        """The device's state and fault in the last sample the loop wrote (once, after the run)."""
        ring = self.feed.ring
        if ring.written == 0:
            return {}
        row = ring.rows[(ring.written - 1) % ring.n]
        names = {v: k for k, v in STATES.items()}, {v: k for k, v in FAULTS.items()}
        return {"last_state": names[0].get(int(row[7])), "last_fault": names[1].get(int(row[8]))}

    def close(self) -> None:
        """Tell the pages the run ended (if not yet), stop serving and end the server's process. Idempotent."""
        if self._closed:
            return
        self._send("close", None)
        self._closed = True
        for stream in (self._process.stdin, self._process.stdout):
            try:
                stream.close()
            except OSError:
                pass
        try:
            self._process.wait(5.0)
        except subprocess.TimeoutExpired:
            self._process.kill()
            self._process.wait(5.0)
        try:
            os.close(self._reference_fd)
        except OSError:
            pass

    def __enter__(self) -> "LiveView":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _reference_rows(prediction) -> np.ndarray:
    """The prediction as the server compares with it: :data:`~iwp.live_server.REFERENCE_ROWS` (the band NaN without
    one), every sample (every ``k``-th and the last beyond :data:`_REFERENCE_POINTS`)."""
    t = np.asarray(prediction.t, dtype=float)
    k = max(1, -(-t.size // _REFERENCE_POINTS))
    keep = np.unique(np.r_[np.arange(0, t.size, k), t.size - 1])
    nan = np.full(t.size, np.nan)
    band = prediction.lower is not None and prediction.upper is not None
    cols = {"t": t, "q1": prediction.nominal["q1"], "q2": prediction.nominal["q2"],
            "q1_lo": prediction.lower["q1"] if band else nan, "q1_hi": prediction.upper["q1"] if band else nan,
            "q2_lo": prediction.lower["q2"] if band else nan, "q2_hi": prediction.upper["q2"] if band else nan}
    return np.ascontiguousarray(np.array([np.asarray(cols[r], dtype=float)[keep] for r in REFERENCE_ROWS]))


def _message(what: str, value):
    """A message to the server: the configuration as it is (the first line), the others as ``[what, value]``."""
    return value if what == "config" else [what, value]


def _child_env() -> dict:
    """The server's environment: this process's, with the folder iwp is imported from first on the path."""
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    return env
