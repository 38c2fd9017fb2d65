"""The live view's server, in a process of its own: the page, the run's samples as Server-Sent Events, the stop.

``python -m iwp.live_server --fd FD`` (started by :class:`iwp.device.live.LiveView`):
the host's loop writes each sample it records into a ring of shared memory
(:class:`SampleRing`, the file ``FD`` the host passed) and reads one flag of
it (the stop button's); this process, a fresh interpreter that shares
nothing else with the host (it imports numpy and the standard library
only) and runs at the lowest priority, does everything else, so that
nothing it does holds up the host's real-time loop (a thread of the host
would compete with it for Python's interpreter lock). A pump
reads the ring every :data:`PUSH_PERIOD` seconds (what the loop wrote
since, the oldest overwritten if this process fell a whole ring behind),
decimates it for the plots (at most :data:`PLOT_RATE` points a second; the
log keeps every sample), compares every sample with the model's prediction
(:class:`_Reference`: how far the measurement is from it, in radians and in
half-widths of its 95 % band, and whether it has left the band), and each
open page receives it as Server-Sent Events, the whole run so far first,
then the run's end with the device's final state as the host knows it. The
standard library's threading HTTP server serves the page, BokehJS (from the
``bokeh`` package installed here), the run's description and the model's
prediction.
"""

from __future__ import annotations

import argparse
import collections
import json
import math
import mmap
import os
import signal
import sys
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path

import numpy as np

__all__ = ["SampleRing", "serve", "main", "PUSH_PERIOD", "PLOT_RATE", "RING_SAMPLES", "HISTORY_UPDATES", "FIELDS",
           "REFERENCE_ROWS", "LEAVE_SECONDS"]

#: How often the pages receive what the loop recorded [s] (20 updates a second).
PUSH_PERIOD = 0.05
#: The plots' points per second (the samples decimated; the log keeps them all).
PLOT_RATE = 20.0
#: The ring's length in samples (82 s at 5 ms): when the server falls this far behind, the oldest are dropped.
RING_SAMPLES = 16384
#: Most updates kept for a page opened late (the run so far; 30 min at 20 a second).
HISTORY_UPDATES = 36_000
#: One sample in the ring.
FIELDS = ("t", "q1", "q2", "q4", "u", "v", "saturated", "state", "fault", "overruns", "late")
#: The model's prediction as the host hands it over (a file in memory): these rows of float64, one column a time.
REFERENCE_ROWS = ("t", "q1", "q2", "q1_lo", "q1_hi", "q2_lo", "q2_hi")
#: The measurement has left the model's 95 % band when it stays outside it this long [s] (a sample outside now
#: and then is the band's 5 %; a stretch this long is the model's error).
LEAVE_SECONDS = 0.25
#: The header's slots: samples written, the stop flag, samples lost on the link.
_WRITTEN, _STOP, _LOST = 0, 1, 2
_HEADER = 8


class SampleRing:
    """A ring of samples in shared memory: one writer (the loop), one reader (the server), the oldest overwritten.

    Parameters
    ----------
    buffer : buffer
        Shared memory of :meth:`size` bytes (the host's and the server's mapping of one file in memory).
    n : int
        The ring's length in samples.
    """

    def __init__(self, buffer, n: int = RING_SAMPLES):
        self.n = int(n)
        self.header = np.frombuffer(buffer, dtype=np.int64, count=_HEADER)
        self.rows = np.frombuffer(buffer, dtype=np.float64, count=self.n * len(FIELDS),
                                  offset=8 * _HEADER).reshape(self.n, len(FIELDS))

    @staticmethod
    def size(n: int = RING_SAMPLES) -> int:
        """Bytes of a ring of ``n`` samples."""
        return 8 * (_HEADER + n * len(FIELDS))

    # ------------------------------------------------------------------ the loop's side: never waits
    def write(self, values: tuple) -> None:
        """Append one sample (:data:`FIELDS`), overwriting the oldest when the ring is full."""
        k = int(self.header[_WRITTEN])
        self.rows[k % self.n] = values
        self.header[_WRITTEN] = k + 1  # after the row: a reader that sees the count sees the row

    def set_lost(self, lost: int) -> None:
        self.header[_LOST] = lost

    @property
    def stop(self) -> bool:
        """The stop button was pressed."""
        return bool(self.header[_STOP])

    # ------------------------------------------------------------------ the server's side
    def request_stop(self) -> None:
        self.header[_STOP] = 1

    @property
    def written(self) -> int:
        return int(self.header[_WRITTEN])

    @property
    def lost(self) -> int:
        return int(self.header[_LOST])

    def read(self, cursor: int) -> tuple[np.ndarray, int, int]:
        """The samples from index ``cursor`` on (rows of :data:`FIELDS`), the next cursor, and how many were
        dropped (overwritten before they were read)."""
        end = self.written
        start = max(cursor, end - self.n)
        rows = self.rows[np.arange(start, end) % self.n].copy()
        after = self.written  # rows overwritten while they were copied are dropped too
        first = max(start, after - self.n + 1)
        return rows[first - start:], end, first - cursor


class _Decimator:
    """Samples as one update of the page: every ``k``-th for the plots (at most :data:`PLOT_RATE` a second), the
    flags and counters of all of them."""

    def __init__(self, states: dict, faults: dict):
        self.states = {int(v): k for k, v in states.items()}
        self.faults = {int(v): k for k, v in faults.items()}
        self.next_t = -math.inf
        self.base = (0, 0)
        self.t_last = math.inf

    def update(self, rows: np.ndarray) -> dict:
        cols: dict[str, list] = {k: [] for k in ("t", "q1", "q2", "q4", "u", "v")}
        sat_t, sat_u = [], []
        for r in rows:
            t = float(r[0])
            if t < self.t_last:  # a new run (a static curve's next hold): time restarts
                self.next_t, self.base = -math.inf, (int(r[9]), int(r[10]))
            self.t_last = t
            if r[6]:
                sat_t.append(round(t, 4))
                sat_u.append(round(float(r[4]), 3))
            if t >= self.next_t:
                self.next_t = t + 1.0 / PLOT_RATE - 1e-9
                for i, k in enumerate(("t", "q1", "q2", "q4", "u", "v")):
                    cols[k].append(round(float(r[i]), 5) if math.isfinite(r[i]) else None)
        last = rows[-1]
        return dict(cols, sat_t=sat_t, sat_u=sat_u, now=round(float(last[0]), 4),
                    state=self.states.get(int(last[7]), str(int(last[7]))),
                    fault=self.faults.get(int(last[8]), str(int(last[8]))),
                    overruns=(int(last[9]) - self.base[0]) & 0xFFFF, late=(int(last[10]) - self.base[1]) & 0xFFFF,
                    q1_now=_rounded(last[1], 5), q2_now=_rounded(last[2], 4), u_now=_rounded(last[4], 3))


def _rounded(x, digits: int) -> float | None:
    """``x`` rounded for the page (None if not a number: JSON has none)."""
    x = float(x)
    return round(x, digits) if math.isfinite(x) else None


class _Reference:
    """The model's prediction, and how far the measurement is from it: at its latest sample, the distance
    ``|measured - predicted|`` [rad] and, with a band, in half-widths of the 95 % band there; when it has left the
    band (outside it for :data:`LEAVE_SECONDS` in a row), a warning from then on.

    Parameters
    ----------
    t : ndarray
        The prediction's times [s], increasing.
    nominal : dict of str to ndarray
        ``q1``, ``q2`` predicted [rad].
    lower, upper : dict of str to ndarray or None
        The 95 % band of each (None: no band).
    """

    SIGNALS = (("q1", 1), ("q2", 2))

    def __init__(self, t, nominal: dict, lower: dict | None = None, upper: dict | None = None):
        self.t = np.asarray(t, dtype=float)
        self.nominal = {s: np.asarray(nominal[s], dtype=float) for s, _ in self.SIGNALS}
        self.band = lower is not None and upper is not None
        self.lower = {s: np.asarray(lower[s], dtype=float) for s, _ in self.SIGNALS} if self.band else None
        self.upper = {s: np.asarray(upper[s], dtype=float) for s, _ in self.SIGNALS} if self.band else None
        self.t_last = -math.inf
        self.reset()

    def reset(self) -> None:
        self.since = {s: None for s, _ in self.SIGNALS}  # where the current stretch outside the band began
        self.left = {s: None for s, _ in self.SIGNALS}  # where the measurement left the band (the first time)
        self.now: dict = {}

    @classmethod
    def from_page(cls, p: dict) -> "_Reference | None":
        """From the prediction as the page gets it (:meth:`~iwp.device.prediction.RunPrediction.to_dict`)."""
        if p.get("none") or p.get("pending") or not p.get("t"):
            return None
        band = bool(p.get("band"))
        return cls(p["t"], p["nominal"], p.get("lower") if band else None, p.get("upper") if band else None)

    @classmethod
    def from_rows(cls, rows: np.ndarray, band: bool) -> "_Reference":
        """From the host's rows (:data:`REFERENCE_ROWS`, one a row)."""
        r = dict(zip(REFERENCE_ROWS, rows))
        return cls(r["t"], r, {"q1": r["q1_lo"], "q2": r["q2_lo"]} if band else None,
                   {"q1": r["q1_hi"], "q2": r["q2_hi"]} if band else None)

    def compare(self, rows: np.ndarray) -> dict | None:
        """Compare the samples ``rows`` (:data:`FIELDS`) with the prediction: for each signal compared, at the
        latest sample within the prediction's time, ``t``, ``dist`` [rad], ``hw`` (the band's half-width [rad],
        None without a band), ``rel`` (``dist`` in half-widths, None where the band has no width), ``out`` (outside
        the band now) and ``left`` (where it left the band, or None); None when nothing is compared yet."""
        t_all = rows[:, 0]
        if t_all.size and t_all[0] < self.t_last:  # a new run (a static curve's next hold): time restarts
            self.reset()
        if t_all.size:
            self.t_last = float(t_all[-1])
        tol = 1e-9 + 1e-9 * abs(float(self.t[-1]))
        for s, col in self.SIGNALS:
            m = rows[:, col]
            keep = (t_all >= self.t[0] - tol) & (t_all <= self.t[-1] + tol) & np.isfinite(m)
            if not keep.any():
                continue
            t, m = t_all[keep], m[keep]
            nom = np.interp(t, self.t, self.nominal[s])
            dist = np.abs(m - nom)
            now = {"t": round(float(t[-1]), 4), "dist": _num(dist[-1]), "hw": None, "rel": None, "out": False}
            if self.band:
                lo, hi = np.interp(t, self.t, self.lower[s]), np.interp(t, self.t, self.upper[s])
                out = (m < lo) | (m > hi)
                self._track(s, t, out)
                hw = 0.5 * float(hi[-1] - lo[-1])
                now.update(hw=_num(hw), rel=_num(dist[-1] / hw) if hw > 0 else None, out=bool(out[-1]))
            self.now[s] = now
        if not self.now:
            return None
        return {s: dict(v, left=self.left[s]) for s, v in self.now.items()}

    def _track(self, s: str, t: np.ndarray, out: np.ndarray) -> None:
        """Follow the stretches outside the band: the first that lasts :data:`LEAVE_SECONDS` is where it left."""
        if self.left[s] is not None:  # it left: only the distance matters from now on
            return
        if not out.any():
            self.since[s] = None
            return
        since = self.since[s]
        for ti, o in zip(t.tolist(), out.tolist()):
            if not o:
                since = None
                continue
            if since is None:
                since = ti
            if ti - since >= LEAVE_SECONDS - 1e-9:
                self.left[s] = round(since, 4)
                break
        self.since[s] = since

    def warning(self, model: dict | None) -> str:
        """One line for each signal that has left the band: where, and how far it is from the model now."""
        if not model:
            return ""
        out = []
        for s, m in model.items():
            if m["left"] is None:
                continue
            far = "no distance (the model gives no number)" if m["dist"] is None else \
                f"{_fmt(m['dist'])} rad from the model"
            if m["rel"] is not None:
                far += f", {_fmt(m['rel'])} half-widths"
            now = f"{far} (at t = {m['t']:.2f} s)" if m["out"] else f"inside it again at t = {m['t']:.2f} s ({far})"
            out.append(f"{s} has left the model's 95 % band at t = {m['left']:.2f} s: {now}")
        return "; ".join(out)


def _num(x) -> float | None:
    """A number for the page, to 4 significant digits (None if not finite)."""
    x = float(x)
    return float(f"{x:.4g}") if math.isfinite(x) else None


def _fmt(x: float) -> str:
    """As the page writes a distance: 3 significant digits, no exponent below a million."""
    return f"{x:.3g}" if abs(x) < 1000 else f"{x:.0f}"


class _Server(ThreadingHTTPServer):
    daemon_threads = True
    allow_reuse_address = False


class _View:
    """The server's state: the ring's reader, the updates so far, what the pages ask for."""

    def __init__(self, ring: SampleRing, config: dict):
        self.ring, self.meta = ring, config["meta"]
        self.page, self.js = Path(config["page"]), {n: Path(p) for n, p in config["js"].items()}
        self.prediction: dict = {"pending": True, "text": "computing the model's prediction"}
        self.reference: _Reference | None = None
        self.reference_fd = config.get("reference_fd")
        self.cond = threading.Condition()
        self.history: collections.deque = collections.deque(maxlen=HISTORY_UPDATES)
        self.first = 0
        self.ended: str | None = None
        self.final: dict | None = None
        self.quit = threading.Event()  # the host is done: end the pages, then close
        self.closing = threading.Event()  # the pages' streams end
        self.cursor = 0
        self.dropped = 0
        self.flushing = threading.Lock()
        self.decimate = _Decimator(config["states"], config["faults"])

    def flush(self) -> None:
        """Publish what the loop wrote since the last flush (from the pump, and from the host's end)."""
        with self.flushing:
            self._flush()

    def _flush(self) -> None:
        rows, self.cursor, dropped = self.ring.read(self.cursor)
        self.dropped += dropped
        if rows.shape[0] == 0:
            return
        update = self.decimate.update(rows)
        update.update(seen=self.cursor, dropped=self.dropped, lost=self.ring.lost, stopping=self.ring.stop)
        ref = self.reference
        if ref is not None:
            try:
                model = ref.compare(rows)
                if model is not None:
                    update.update(model=model, warning=ref.warning(model))
            except Exception:  # noqa: BLE001 (the samples matter more than the comparison: it stops, they go on)
                self.reference = None
        with self.cond:
            self.publish(update)

    def publish(self, update: dict) -> None:
        """Append ``update`` to the history and wake the pages (``self.cond`` held)."""
        if len(self.history) == self.history.maxlen:
            self.first += 1
        self.history.append(json.dumps(update, separators=(",", ":"), allow_nan=False))
        self.cond.notify_all()

    def set_prediction(self, value: dict) -> None:
        """The model's prediction: the page's (``value``, without ``reference``) and the one the measurement is
        compared with (the host's rows of :data:`REFERENCE_ROWS` in the file ``reference_fd``, every sample, when
        ``value["reference"]`` says how many; else the page's)."""
        value = dict(value)
        info = value.pop("reference", None)
        ref = None
        try:
            if info and self.reference_fd is not None:
                size = 8 * len(REFERENCE_ROWS) * int(info["n"])
                data = os.pread(self.reference_fd, size, 0)
                if len(data) == size:
                    rows = np.frombuffer(data, dtype=np.float64).reshape(len(REFERENCE_ROWS), -1)
                    ref = _Reference.from_rows(rows, bool(info.get("band")))
            if ref is None:
                ref = _Reference.from_page(value)
        except (OSError, KeyError, TypeError, ValueError):  # no comparison; the page still draws it
            ref = None
        self.reference = ref
        self.prediction = value

    def end(self, value) -> None:
        """The run ended: ``value`` its reason, or ``{"reason": ..., "final": {...}}`` with the device's final state
        as the host knows it (``state``, ``fault``, ``u``, ``confirmed``, ``text``); the pages receive
        ``{"end": reason, "final": final}`` after the run's last samples."""
        if isinstance(value, dict):
            reason, final = str(value.get("reason", "")), value.get("final")
        else:
            reason, final = str(value), None
        self.flush()
        with self.cond:
            if self.ended is None:
                self.ended, self.final = reason, final
                self.publish({"end": reason, "final": final})

    def updates_from(self, cursor: int, wait: float) -> tuple[list[str], int, bool]:
        """The updates from index ``cursor`` on (waiting up to ``wait`` s for one), the next cursor, and whether
        they were the last (the run ended, or the server closes)."""
        with self.cond:
            if cursor - self.first >= len(self.history) and not self.closing.is_set():
                self.cond.wait(wait)
            cursor = max(cursor, self.first)
            out = list(self.history)[cursor - self.first:]
            last = self.ended is not None and cursor + len(out) == self.first + len(self.history)
            return out, cursor + len(out), last or self.closing.is_set()

    def page_data(self, path: str) -> tuple[bytes, str] | None:
        if path in ("/", "/index.html"):
            return self.page.read_bytes(), "text/html; charset=utf-8"
        if path.startswith("/js/") and path[4:] in self.js:
            return self.js[path[4:]].read_bytes(), "application/javascript"
        if path == "/meta":
            return json.dumps(dict(self.meta, ended=self.ended, final=self.final)).encode(), "application/json"
        if path == "/prediction":
            return json.dumps(self.prediction, allow_nan=False).encode(), "application/json"
        return None


def _handler(view: _View):
    class Handler(BaseHTTPRequestHandler):
        server_version = "iwp-live"

        def log_message(self, format, *args):  # no request log on the terminal
            pass

        def _send(self, status: int, body: bytes, ctype: str) -> None:
            self.send_response(status)
            self.send_header("Content-Type", ctype)
            self.send_header("Content-Length", str(len(body)))
            # BokehJS is kept by the browser: a page opened again during the run does not load and parse it again
            self.send_header("Cache-Control", "max-age=86400" if ctype == "application/javascript" else "no-store")
            self.end_headers()
            self.wfile.write(body)

        def do_GET(self):
            path = self.path.split("?", 1)[0]
            try:
                if path == "/events":
                    self._events()
                    return
                got = view.page_data(path)
                if got is None:
                    self._send(HTTPStatus.NOT_FOUND, b"not found", "text/plain")
                else:
                    self._send(HTTPStatus.OK, *got)
            except (BrokenPipeError, ConnectionResetError):  # the page went away: nothing to do
                pass

        def do_POST(self):
            try:
                if self.path.split("?", 1)[0] != "/stop":
                    self._send(HTTPStatus.NOT_FOUND, b"not found", "text/plain")
                    return
                view.ring.request_stop()
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
                out, cursor, last = view.updates_from(cursor, 1.0)
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


def _control(view: _View, lines) -> None:
    """The host's messages, one JSON line each: ``prediction``, ``limits``, ``end``, ``close``; the end of the
    stream (the host closed it, or is gone) closes the view."""
    for line in lines:
        try:
            what, value = json.loads(line)
        except ValueError:
            continue
        if what == "close":
            break
        if what == "prediction":
            view.set_prediction(value)
        elif what == "limits":
            view.meta["limits"].update(value)
        elif what == "end":
            view.end(value)
    view.quit.set()


def serve(buffer, port: int, config: dict, lines, out) -> None:
    """Serve the view until the host closes it or is gone.

    Parameters
    ----------
    buffer : mmap
        The shared ring (:class:`SampleRing`, ``config["n"]`` samples).
    port : int
        Port on 127.0.0.1 (0: a free one).
    config : dict
        ``meta`` (the page's title, duration, limits), ``page`` (the HTML file), ``js`` (BokehJS's files by
        name), ``states`` and ``faults`` (the device's codes by name), ``n``, and ``reference_fd`` (optional: the
        file in memory where the host puts the model's prediction at every sample, :data:`REFERENCE_ROWS`).
    lines : iterable of str
        The host's messages (see :func:`_control`).
    out : file
        Where ``port N`` (serving) or ``error MESSAGE`` is written, one line.
    """
    view = _View(SampleRing(buffer, config["n"]), config)
    try:
        server = _Server(("127.0.0.1", port), _handler(view))
    except OSError as exc:
        print(f"error {exc.strerror or exc}", file=out, flush=True)
        return
    print(f"port {server.server_address[1]}", file=out, flush=True)
    threading.Thread(target=server.serve_forever, kwargs={"poll_interval": 0.1}, daemon=True).start()
    threading.Thread(target=_control, args=(view, lines), daemon=True).start()
    try:
        while not view.quit.wait(PUSH_PERIOD):
            view.flush()
    finally:
        view.end("the live view closed")
        time.sleep(2 * PUSH_PERIOD)  # let the pages receive the end
        view.closing.set()
        with view.cond:
            view.cond.notify_all()
        server.shutdown()
        server.server_close()


def _lowest_priority() -> None:
    """This process and the threads it starts run only when nothing else wants the processor (``SCHED_IDLE``
    where the system has it, else the lowest ``nice``): a page served must never take time from the rig's loop."""
    try:
        os.sched_setscheduler(0, os.SCHED_IDLE, os.sched_param(0))
    except (AttributeError, OSError):  # not Linux
        try:
            os.nice(19)
        except OSError:
            pass


def main(argv=None) -> int:
    """``python -m iwp.live_server --fd FD --port N``; the configuration is the first line of stdin (JSON)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the host's: it closes the view on its way out
    _lowest_priority()
    p = argparse.ArgumentParser(prog="python -m iwp.live_server")
    p.add_argument("--fd", type=int, required=True)
    p.add_argument("--port", type=int, default=0)
    args = p.parse_args(argv)
    config = json.loads(sys.stdin.readline())
    buffer = mmap.mmap(args.fd, SampleRing.size(config["n"]))
    serve(buffer, args.port, config, sys.stdin, sys.stdout)
    return 0


if __name__ == "__main__":
    sys.exit(main())
