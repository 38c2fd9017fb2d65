"""The live view without a browser: the loop's ring, the stop request through the loop, the server's lifetime, its
event stream, the prediction of a run and the command line's checks (the browser: tests/test_live_browser.py)."""

from __future__ import annotations

import http.client
import json
import math
import socket
import urllib.error
import urllib.request
from pathlib import Path

import numpy as np
import pytest

from iwp.cli import main
from iwp.device import TwinRig, run_on_rig
from iwp.device.connection import Sample
from iwp.device.control import ControlRun
from iwp.device.live import STOP_REASON, LiveFeed, LiveView, final_state
from iwp.device.prediction import RunPrediction, predict_control_run, predict_rig_run
from iwp.errors import InputError
from iwp.live_server import FIELDS, LEAVE_SECONDS, PLOT_RATE, SampleRing, _Reference
from iwp.models.parameters import load_params

pytest.importorskip("bokeh", reason="the live view serves BokehJS from the bokeh package: pip install 'iwp[live]'")


def _sample(k: int, **kw) -> Sample:
    values = dict(seq=k, t_device=k * 0.005, count1=0, count2=0, q1=math.sin(k * 0.005), q2=0.01 * k, q4=1.0,
                  u=float(k % 100), v=31.0 + k % 100, current=math.nan, state="ARMED", fault="NONE", flags=(),
                  overruns=0, late=0, rx_errors=0, dropped=0, t_host=0.0)
    values.update(kw)
    return Sample(**values)


def test_the_ring_keeps_the_newest_and_counts_what_it_dropped():
    ring = SampleRing(bytearray(SampleRing.size(10)), 10)
    for k in range(4):
        ring.write((k,) + (0.0,) * (len(FIELDS) - 1))
    rows, cursor, dropped = ring.read(0)
    assert rows[:, 0].tolist() == [0, 1, 2, 3] and cursor == 4 and dropped == 0
    for k in range(4, 29):  # 25 more: the reader falls more than a ring behind
        ring.write((k,) + (0.0,) * (len(FIELDS) - 1))
    rows, cursor, dropped = ring.read(cursor)
    # the oldest overwritten; the slot the writer would overwrite next is not trusted either
    assert rows[:, 0].tolist() == list(range(20, 29)) and cursor == 29 and dropped == 16
    assert ring.read(cursor)[0].shape == (0, len(FIELDS))


class _StopAt(LiveFeed):
    """The stop button pressed at t = 0.5 s."""

    def on_sample(self, t, sample):
        super().on_sample(t, sample)
        if t >= 0.5:
            self.request_stop()


def test_the_stop_request_ends_the_run_as_ctrl_c_does_and_stops_the_motor():
    feed = _StopAt()
    rig = TwinRig(fast=True)
    try:
        run = run_on_rig(rig, "chirp", fast=True, duration=5.0, progress=feed)
    finally:
        rig.close()
    assert run.interrupted and run.reason == STOP_REASON and run.error is None
    assert run.log.metadata["interrupted"] == "true" and run.log.metadata["stop_reason"] == STOP_REASON
    # stopped at the batch of telemetry that carried t = 0.5 s: a few samples at most
    assert 0.5 <= run.log.t[-1] < 0.6
    assert rig.device.core.status()[1] == 3 and rig.device.core.status()[3] == 0.0  # ESTOP, motor at 0
    rows, _, _ = feed.ring.read(0)  # every recorded sample went to the view
    assert rows.shape[0] == run.log.n_samples and np.allclose(rows[:, 1], run.log.q1)


def _events(url: str, seen: int | None) -> list[dict]:
    """The updates of the event stream until the one that has seen ``seen`` samples (None: until the run's end)."""
    host, port = url[len("http://"):].rstrip("/").split(":")
    conn = http.client.HTTPConnection(host, int(port), timeout=10)
    conn.request("GET", "/events")
    r = conn.getresponse()
    out = []
    while not out or ("end" not in out[-1] if seen is None else out[-1].get("seen", -1) < seen):
        line = r.fp.readline().decode()
        if line.startswith("data: "):
            out.append(json.loads(line[6:]))
    conn.close()
    return out


def test_the_view_streams_the_samples_and_shuts_down_on_every_way_out():
    feed = LiveFeed()
    with pytest.raises(RuntimeError, match="on the way"):
        with LiveView(feed, title="test", duration=2.0) as view:
            url = view.url
            page = urllib.request.urlopen(url, timeout=10).read().decode()
            assert "/js/bokeh.min.js" in page and "STOP" in page
            assert len(urllib.request.urlopen(url + "js/bokeh.min.js", timeout=10).read()) > 500_000
            meta = json.loads(urllib.request.urlopen(url + "meta", timeout=10).read())
            assert meta["title"] == "test" and meta["duration"] == 2.0
            for k in range(401):  # 2 s at 5 ms, two saturated samples
                feed.on_sample(k * 0.005, _sample(k, flags=("SATURATED",) if k in (100, 101) else ()))
            updates = _events(url, 401)
            d = {k: sum((u[k] for u in updates), []) for k in ("t", "q1", "sat_t", "sat_u")}
            d.update({k: updates[-1][k] for k in ("seen", "dropped", "now", "state")})
            assert d["seen"] == 401 and d["dropped"] == 0 and d["now"] == 2.0 and d["state"] == "ARMED"
            assert d["sat_t"] == [0.5, 0.505] and d["sat_u"] == [0.0, 1.0]  # u = k % 100
            # decimated for the plots: PLOT_RATE points a second, the values as recorded
            assert len(d["t"]) == int(2.0 * PLOT_RATE) + 1
            assert np.allclose(d["q1"], np.sin(np.array(d["t"])), atol=1e-5)
            # the stop button's request reaches the loop's side
            assert feed.stop_requested() is None
            req = urllib.request.Request(url + "stop", method="POST")
            assert json.loads(urllib.request.urlopen(req, timeout=10).read()) == {"stopping": True}
            assert feed.stop_requested() == STOP_REASON
            raise RuntimeError("an error on the way out")
    with pytest.raises(urllib.error.URLError):
        urllib.request.urlopen(url, timeout=2)
    assert view._process.poll() is not None


def test_after_a_stop_the_page_gets_the_devices_final_state_not_the_last_armed_sample():
    feed = _StopAt()
    with LiveView(feed, title="test", duration=5.0) as view:
        rig = TwinRig(fast=True)
        try:
            run = run_on_rig(rig, "chirp", fast=True, duration=5.0, progress=feed)
        finally:
            rig.close()
        assert run.interrupted and run.stop_confirmed is True
        view.finish(run.reason, run=run)
        updates = _events(view.url, None)
        meta = json.loads(urllib.request.urlopen(view.url + "meta", timeout=10).read())
    # the last samples were recorded while the motor was armed, before the emergency stop
    samples = [u for u in updates if "end" not in u]
    assert samples[-1]["state"] == "ARMED" and samples[-1]["seen"] == run.log.n_samples
    # ... the run's end, after them, says what the device is now: the emergency stop, the motor at 0
    end = updates[-1]
    assert end["end"] == STOP_REASON
    assert end["final"]["state"] == "ESTOP" and end["final"]["u"] == 0.0 and end["final"]["confirmed"] is True
    assert "emergency stop acknowledged" in end["final"]["text"]
    assert meta["ended"] == STOP_REASON and meta["final"]["state"] == "ESTOP"


def test_the_final_state_is_what_the_host_knows_and_an_unconfirmed_stop_is_said():
    done = final_state(interrupted=False, stop_confirmed=True, last_state="ARMED", last_fault="NONE")
    assert done["state"] == "DISARMED" and done["u"] == 0.0
    fault = final_state(interrupted=True, stop_confirmed=True, last_state="FAULT", last_fault="WATCHDOG")
    assert fault["state"] == "FAULT" and fault["fault"] == "WATCHDOG" and fault["u"] == 0.0
    lost = final_state(interrupted=True, stop_confirmed=False, last_state="ARMED", last_fault="NONE")
    assert lost["state"] == "UNKNOWN" and lost["u"] is None and lost["confirmed"] is False
    assert "stop unconfirmed" in lost["text"] and "stopped" not in lost["text"].split(":")[0]
    motor_off = final_state(interrupted=False, stop_confirmed=None, last_state="DISARMED", last_fault="NONE")
    assert motor_off["state"] == "DISARMED"
    # through the server: a stop the device did not answer is not shown as a stopped motor
    feed = LiveFeed()
    with LiveView(feed) as view:
        for k in range(20):
            feed.on_sample(k * 0.005, _sample(k))
        view.finish("link lost", run=type("Run", (), {"interrupted": True, "stop_confirmed": False})())
        end = _events(view.url, None)[-1]
    assert end["final"]["state"] == "UNKNOWN" and end["final"]["u"] is None and "unconfirmed" in end["final"]["text"]


def _prediction(n: int, band: float | None) -> RunPrediction:
    t = np.arange(n) * 0.005
    nominal = {"q1": np.sin(t), "q2": 0.01 * np.arange(n) + 0.5 * (np.arange(n) % 2)}  # q2 zigzags each sample
    if band is None:
        return RunPrediction(t, nominal, text="test")
    return RunPrediction(t, nominal, {s: v - band for s, v in nominal.items()},
                         {s: v + band for s, v in nominal.items()}, text="test")


def test_the_server_says_how_far_the_measurement_is_from_the_model_and_when_it_leaves_its_band():
    feed = LiveFeed()
    pred = _prediction(1001, 0.01)  # 5 s; the page gets every 2nd point of it, the server every sample
    with LiveView(feed, duration=5.0) as view:
        view.set_prediction(pred)
        for k in range(500):  # q1 as predicted, q2 5 rad from it from t = 1 s on, q1 out of its band for 0.1 s
            q2 = pred.nominal["q2"][k] + (5.0 if k >= 200 else 0.0)
            q1 = pred.nominal["q1"][k] + (0.05 if 60 <= k < 80 else 0.0)
            feed.on_sample(k * 0.005, _sample(k, q1=q1, q2=q2))
        last = _events(view.url, 500)[-1]
    m = last["model"]
    assert m["q1"]["t"] == pytest.approx(2.495) and m["q1"]["dist"] < 1e-6 and m["q1"]["rel"] < 1e-4
    assert m["q1"]["hw"] == pytest.approx(0.01) and not m["q1"]["out"] and m["q1"]["left"] is None  # 0.1 s out
    # compared at every sample (the odd sample 499 is not among the page's points, where q2 zigzags)
    assert m["q2"]["dist"] == pytest.approx(5.0) and m["q2"]["rel"] == pytest.approx(500.0) and m["q2"]["out"]
    assert m["q2"]["left"] == 1.0
    assert last["warning"] == "q2 has left the model's 95 % band at t = 1.00 s: 5 rad from the model, " \
                              "500 half-widths (at t = 2.50 s)"
    # without a band: the distance only, no warning
    feed = LiveFeed()
    with LiveView(feed) as view:
        view.set_prediction(_prediction(1001, None))
        for k in range(11):
            feed.on_sample(k * 0.005, _sample(k, q1=math.sin(k * 0.005) + 3.0))
        last = _events(view.url, 11)[-1]
    assert last["model"]["q1"]["dist"] == pytest.approx(3.0) and last["model"]["q1"]["rel"] is None
    assert last["warning"] == ""


def test_the_band_is_left_after_a_stretch_outside_it_across_updates():
    ref = _Reference([0.0, 10.0], {"q1": [0.0, 0.0], "q2": [0.0, 0.0]}, {"q1": [-0.1, -0.1], "q2": [-1, -1]},
                     {"q1": [0.1, 0.1], "q2": [1, 1]})

    def rows(t0, n, q1):
        t = t0 + 0.005 * np.arange(n)
        r = np.zeros((n, len(FIELDS)))
        r[:, 0], r[:, 1] = t, q1
        return r

    assert ref.compare(rows(0.0, 100, 0.05))["q1"]["left"] is None  # inside
    for k in range(int(LEAVE_SECONDS / 0.05) - 1):  # outside, 10 samples an update: not long enough yet
        m = ref.compare(rows(0.5 + 0.05 * k, 10, -0.3))
        assert m["q1"]["out"] and m["q1"]["left"] is None and m["q1"]["rel"] == pytest.approx(3.0)
        assert ref.warning(m) == ""
    m = ref.compare(rows(0.5 + LEAVE_SECONDS - 0.05, 11, -0.3))  # to t = 0.5 + LEAVE_SECONDS
    assert m["q1"]["left"] == 0.5
    m = ref.compare(rows(1.0, 10, 0.0))  # back inside: the warning stays, saying so
    assert not m["q1"]["out"] and ref.warning(m) == ("q1 has left the model's 95 % band at t = 0.50 s: inside it again "
                                                     "at t = 1.04 s (0 rad from the model, 0 half-widths)")


def test_the_page_has_the_readouts_and_legends_outside_the_plots():
    page = (Path(__file__).parents[1] / "src" / "iwp" / "device" / "live.html").read_text()
    for element in ('id="q1dist"', 'id="q2dist"', 'id="warning"', 'id="final"', 'id="q2"'):
        assert element in page
    assert 'f.add_layout(lg, "above")' in page and "BAND_MIN_PX" in page
    assert "data: {t: [NaN], u: [NaN]}" in page  # the saturated samples' legend entry drawn before any


def test_a_taken_port_is_refused_naming_the_flag():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        s.listen()
        port = s.getsockname()[1]
        with pytest.raises(InputError, match=f"live_port {port}: cannot serve there"):
            LiveView(LiveFeed(), port=port)
    with pytest.raises(InputError, match="live_port must be a port number"):
        LiveView(LiveFeed(), port=70000)


def test_the_prediction_of_a_release_is_the_free_pendulum_decaying_from_x0():
    p = load_params("table1")
    pred = predict_rig_run("release", p, duration=20.0)
    q1 = pred.nominal["q1"]
    assert q1[0] == pytest.approx(-1.0) and pred.lower is None
    # the pendulum's period (wheel held to the arm: q3' = -p1 sin(q1) rho/(1 + rho)) between the small-angle one
    # and the one at the release's amplitude of 1 rad (T0 (1 + 1/16 + 11/3072), the series of the exact period)
    crossings = np.flatnonzero(np.diff(np.sign(q1)) != 0)
    period = 2 * np.mean(np.diff(pred.t[crossings]))
    t0 = 2 * math.pi / math.sqrt(p.p1 * p.rho / (1 + p.rho))
    assert t0 < period < t0 * (1 + 1 / 16 + 11 / 3072)
    # ... and it loses energy
    assert np.max(np.abs(q1[pred.t > 15])) < 0.9


def test_the_prediction_of_the_hopf_law_reaches_its_limit_cycle():
    pred = predict_control_run(ControlRun("hopf", 60.0), load_params("table1"), q1_start=0.3)
    amp = np.max(np.abs(pred.nominal["q1"][pred.t > 40]))
    assert amp == pytest.approx(2.58, rel=0.05)  # section 5.3's oscillation
    d = pred.to_dict(max_points=500)
    assert len(d["t"]) <= 501 and d["t"][-1] == 60.0 and not d["band"]


@pytest.mark.parametrize("argv, message", [
    (["rig", "run", "chirp", "--port", "twin", "--live-port", "8000"], "--live-port needs --live"),
    (["rig", "run", "full-chirp", "--live"], "--live needs --port"),
    (["rig", "run", "chirp", "--port", "twin", "--params", "table1"], "--params is the model of the live view"),
    (["rig", "run", "chirp", "--port", "twin", "--live", "--live-port", "70000"], "--live-port must be a port"),
])
def test_the_command_line_refuses_live_flags_without_what_they_need(argv, message, tmp_path, capsys):
    out = tmp_path / "x.csv"
    assert main([*argv, "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert message in err and err.count("\n") == 1 and not out.exists()
