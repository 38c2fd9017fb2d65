"""A live view of a run on a rig: a page on 127.0.0.1 that streams it, with the model's prediction and a stop button.

:class:`LiveFeed` is the loop's observer (:class:`~iwp.device.loop.LoopObserver`):
the loop hands it each sample it records, and it only appends the sample to
a bounded queue that drops its oldest entry when full (:data:`QUEUE_SAMPLES`),
so that nothing the page does can slow or block the loop. :class:`LiveView`
serves the page (the standard library's threading HTTP server) from
threads of its own: a pump takes the queue's samples every
:data:`PUSH_PERIOD` seconds (decimated to at most :data:`PLOT_RATE` points a
second for the plots; the log keeps every sample) and each open page
receives them as Server-Sent Events, the whole run so far first. The page
draws ``q1`` and ``q2`` with the model's prediction (:mod:`.prediction`)
and its 95 % band, the command applied with its saturated samples, the
device's state and fault, its overruns and late ticks and the samples lost
on the link. Plotly's JavaScript library is served from the ``plotly``
package installed here (``pip install 'iwp[live]'``), never from the
internet.

The stop button asks the loop to stop (:meth:`LiveFeed.request_stop`): it
ends the run as Ctrl-C does, the motor stopped and the log so far written,
marked interrupted (reason :data:`STOP_REASON`). Closing the page stops
nothing. The view shuts its server down on every way out of its ``with``
block.
"""

from __future__ import annotations

import collections
import importlib.util
import json
import math
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

from ..errors import InputError
from .connection import Sample
from .loop import LoopObserver

__all__ = ["LiveFeed", "LiveView", "STOP_REASON", "QUEUE_SAMPLES", "PUSH_PERIOD", "PLOT_RATE", "plotly_js"]

#: The loop's queue to the view holds this many samples; when full the oldest is dropped (50 s at 5 ms).
QUEUE_SAMPLES = 10_000
#: How often the pages receive what the loop recorded [s] (20 updates a second).
PUSH_PERIOD = 0.05
#: The plots' points per second (the samples decimated; the log keeps them all).
PLOT_RATE = 25.0
#: The stop reason of the stop button (the log's ``stop_reason``).
STOP_REASON = "stop button (live view)"
#: Most updates kept for a page opened late (the run so far; 30 min at 20 a second).
HISTORY_UPDATES = 36_000
#: The page.
_PAGE = Path(__file__).with_name("live.html")


def plotly_js() -> Path:
    """The file ``plotly.min.js`` of the installed ``plotly`` package (found without importing it).

    Returns
    -------
    Path
        The bundled JavaScript library.

    Raises
    ------
    InputError
        ``plotly`` is not installed (the extra ``live``).
    """
    spec = importlib.util.find_spec("plotly")
    paths = [] if spec is None or spec.submodule_search_locations is None else list(spec.submodule_search_locations)
    for p in paths:
        js = Path(p) / "package_data" / "plotly.min.js"
        if js.is_file():
            return js
    raise InputError("the live view needs the plotly package, which ships the plotting library it serves: "
                     "pip install 'iwp[live]'", argument="live")


class LiveFeed(LoopObserver):
    """What the loop hands the live view: every sample, to a bounded queue; and the stop button's request.

    Parameters
    ----------
    progress : callable, optional
        Called with the loop's progress dictionary as well (the terminal's progress line).
    maxlen : int
        The queue's length in samples; when full the oldest is dropped (and counted in :attr:`dropped`).
    """

    def __init__(self, progress=None, maxlen: int = QUEUE_SAMPLES):
        self._queue: collections.deque = collections.deque(maxlen=int(maxlen))
        self._progress = progress
        self._stop = threading.Event()
        self._reason = STOP_REASON
        #: samples handed over by the loop
        self.seen = 0
        #: samples taken from the queue by the view
        self.taken = 0
        #: the loop's latest progress dictionary
        self.status: dict = {}

    @property
    def dropped(self) -> int:
        """Samples the queue dropped (the view did not take them in time)."""
        return self.seen - self.taken - len(self._queue)

    def __call__(self, progress: dict) -> None:
        self.status = progress
        if self._progress is not None:
            self._progress(progress)

    def on_sample(self, t: float, sample: Sample) -> None:
        self._queue.append((t, sample))  # atomic; a full deque drops its oldest
        self.seen += 1

    def stop_requested(self) -> str | None:
        return self._reason if self._stop.is_set() else None

    def request_stop(self, reason: str = STOP_REASON) -> None:
        """Ask the loop to stop the run (from any thread); it stops at its next batch of telemetry."""
        self._reason = reason
        self._stop.set()

    @property
    def stopping(self) -> bool:
        return self._stop.is_set()

    def take(self) -> list:
        """Everything queued, oldest first: ``(t, Sample)`` pairs (the view's thread)."""
        out = []
        q = self._queue
        while True:
            try:
                out.append(q.popleft())
            except IndexError:
                break
        self.taken += len(out)
        return out


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = False


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
    limits : dict, optional
        ``q1_max`` [rad] and ``v_max`` [input units], shown with the flags.

    Raises
    ------
    InputError
        The port is taken or not allowed (argument ``live_port``), or plotly is missing.
    """

    def __init__(self, feed: LiveFeed, *, port: int = 0, title: str = "", duration: float | None = None,
                 limits: dict | None = None):
        if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
            raise InputError(f"live_port must be a port number from 0 to 65535, got {port!r}", argument="live_port")
        self.feed = feed
        self._js = plotly_js()
        self._meta = {"title": title, "duration": duration, "limits": dict(limits or {}), "plot_rate": PLOT_RATE}
        self._prediction: dict = {"pending": True, "text": "computing the model's prediction"}
        self._cond = threading.Condition()
        self._history: collections.deque = collections.deque(maxlen=HISTORY_UPDATES)
        self._first = 0  # index of the history's first update
        self._ended: str | None = None
        self._closing = threading.Event()
        self._decimate = _Decimator()
        try:
            self._server = _Server(("127.0.0.1", port), _handler(self))
        except OSError as exc:
            raise InputError(f"live_port {port}: cannot serve there ({exc.strerror or exc})",
                             argument="live_port") from None
        self.port = self._server.server_address[1]
        self.url = f"http://127.0.0.1:{self.port}/"
        self._threads = [threading.Thread(target=self._server.serve_forever, kwargs={"poll_interval": 0.1},
                                          name="iwp-live-server", daemon=True),
                         threading.Thread(target=self._pump, name="iwp-live-pump", daemon=True)]
        for th in self._threads:
            th.start()

    # ------------------------------------------------------------------ the run's side
    def set_prediction(self, prediction) -> None:
        """The model's prediction to draw (a :class:`~iwp.device.prediction.RunPrediction`), None for none, or a
        string saying why there is none."""
        if prediction is None or isinstance(prediction, str):
            self._prediction = {"none": True, "text": prediction or "no prediction for this run"}
        else:
            self._prediction = prediction.to_dict()

    def set_limits(self, **limits) -> None:
        """The rig's limits (``q1_max`` [rad], ``v_max`` [input units]) shown on the page."""
        self._meta["limits"].update({k: float(v) for k, v in limits.items()})

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

    def finish(self, reason: str) -> None:
        """The run ended (``reason``: ``"complete"`` or its stop reason): the pages are told, after its last
        samples."""
        self._flush()
        with self._cond:
            if self._ended is None:
                self._ended = str(reason)
                self._publish({"end": self._ended})

    def close(self) -> None:
        """Tell the pages the run ended (if not yet), stop serving and join the view's threads. Idempotent."""
        if self._closing.is_set():
            return
        self.finish("the live view closed")
        time.sleep(min(0.3, 2 * PUSH_PERIOD))  # let the pages receive the end
        self._closing.set()
        with self._cond:
            self._cond.notify_all()
        self._server.shutdown()
        self._server.server_close()
        for th in self._threads:
            th.join(5.0)

    def __enter__(self) -> "LiveView":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # ------------------------------------------------------------------ the view's threads
    def _pump(self) -> None:
        while not self._closing.wait(PUSH_PERIOD):
            self._flush()

    def _flush(self) -> None:
        got = self.feed.take()
        if not got:
            return
        update = self._decimate.update(got)
        st = self.feed.status
        update.update(seen=self.feed.seen, dropped=self.feed.dropped, lost=st.get("lost", 0),
                      stopping=self.feed.stopping)
        with self._cond:
            self._publish(update)

    def _publish(self, update: dict) -> None:
        """Append ``update`` to the history and wake the pages (``self._cond`` held)."""
        if len(self._history) == self._history.maxlen:
            self._first += 1
        self._history.append(json.dumps(update, separators=(",", ":"), allow_nan=False))
        self._cond.notify_all()

    def _updates_from(self, cursor: int, wait: float) -> tuple[list[str], int, bool]:
        """The updates from index ``cursor`` on (waiting up to ``wait`` s for one), the next cursor, and whether
        the run has ended and they were the last."""
        with self._cond:
            if cursor - self._first >= len(self._history) and not self._closing.is_set():
                self._cond.wait(wait)
            cursor = max(cursor, self._first)
            out = list(self._history)[cursor - self._first:]
            last = self._ended is not None and cursor + len(out) == self._first + len(self._history)
            return out, cursor + len(out), last or self._closing.is_set()

    def _page_data(self, path: str) -> tuple[bytes, str] | None:
        if path in ("/", "/index.html"):
            return _PAGE.read_bytes(), "text/html; charset=utf-8"
        if path == "/plotly.min.js":
            return self._js.read_bytes(), "application/javascript"
        if path == "/meta":
            return json.dumps(dict(self._meta, ended=self._ended)).encode(), "application/json"
        if path == "/prediction":
            return json.dumps(self._prediction, allow_nan=False).encode(), "application/json"
        return None


class _Decimator:
    """The samples as one update of the page: every ``k``-th for the plots (at most :data:`PLOT_RATE` a
    second), the flags and counters of all of them."""

    def __init__(self):
        self.next_t = -math.inf
        self.base: tuple[int, int] | None = None
        self.t_last = math.inf

    def update(self, got: list) -> dict:
        cols: dict[str, list] = {"t": [], "q1": [], "q2": [], "q4": [], "u": [], "v": []}
        sat_t, sat_u = [], []
        for t, s in got:
            if t < self.t_last:  # a new run (a static curve's next hold): time restarts
                self.next_t, self.base = -math.inf, (s.overruns, s.late)
            self.t_last = t
            if "SATURATED" in s.flags:
                sat_t.append(round(t, 4))
                sat_u.append(round(s.u, 3))
            if t >= self.next_t:
                self.next_t = t + 1.0 / PLOT_RATE - 1e-9
                for k, val in (("t", t), ("q1", s.q1), ("q2", s.q2), ("q4", s.q4), ("u", s.u), ("v", s.v)):
                    cols[k].append(round(float(val), 5) if math.isfinite(val) else None)
        last_t, last = got[-1]
        o0, l0 = self.base
        return dict(cols, sat_t=sat_t, sat_u=sat_u, now=round(last_t, 4), state=last.state, fault=last.fault,
                    flags=list(last.flags), overruns=(last.overruns - o0) & 0xFFFF, late=(last.late - l0) & 0xFFFF,
                    q1_now=round(last.q1, 5), u_now=round(last.u, 3))


def _handler(view: LiveView):
    class Handler(BaseHTTPRequestHandler):
        server_version = "iwp-live"

        def log_message(self, format, *args):  # no request log on the terminal
            pass

        def _send(self, status: int, body: bytes, ctype: str) -> None:
            self.send_response(status)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self):
            path = self.path.split("?", 1)[0]
            try:
                if path == "/events":
                    self._events()
                    return
                got = view._page_data(path)
                if got is None:
                    self._send(HTTPStatus.NOT_FOUND, b"not found", "text/plain")
                else:
                    self._send(HTTPStatus.OK, *got)
            except (BrokenPipeError, ConnectionResetError):  # the page went away: nothing to do
                pass

        def do_POST(self):
            if self.path.split("?", 1)[0] != "/stop":
                self._send(HTTPStatus.NOT_FOUND, b"not found", "text/plain")
                return
            view.feed.request_stop()
            try:
                self._send(HTTPStatus.OK, b'{"stopping":true}', "application/json")
            except (BrokenPipeError, ConnectionResetError):
                pass

        def _events(self):
            self.send_response(HTTPStatus.OK)
            self.send_header("Content-Type", "text/event-stream")
            self.send_header("Cache-Control", "no-store")
            self.end_headers()
            self.wfile.write(b"retry: 1000\n\n")
            cursor, quiet = 0, time.monotonic()
            while True:
                out, cursor, last = view._updates_from(cursor, 1.0)
                if out:
                    self.wfile.write("".join(f"data: {u}\n\n" for u in out).encode())
                    quiet = time.monotonic()
                elif time.monotonic() - quiet > 1.0:  # a comment: finds a closed page
                    self.wfile.write(b": alive\n\n")
                    quiet = time.monotonic()
                self.wfile.flush()
                if last:
                    return

    return Handler
