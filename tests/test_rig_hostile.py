"""Rig runs under hostile use (issue 51): settings refused before the motor moves, a device that goes silent,
an output that appears during a run."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from iwp.cli import main
from iwp.cli.rig import UNCONFIRMED_STOP, finish_port_run
from iwp.data import ExperimentData
from iwp.device.loop import LoopObserver
from iwp.device.runs import RigRun, run_on_rig
from iwp.device.twin import TwinRig


@pytest.mark.parametrize("argv, flags", [
    (["rig", "run", "chirp", "--tau", "1e-300"], ["--tau", "--w0", "--amplitude"]),
    (["rig", "run", "sine", "--amplitude", "1e39"], ["--amplitude"]),
    (["rig", "run", "steps", "--levels", "1e39,0"], ["--levels"]),
    (["control", "run", "hopf", "--k1", "1e39"], ["--k1"]),
    (["rig", "run", "sine", "--baud", "99999999999999999999"], ["--baud"]),
])
def test_a_setting_the_device_cannot_take_is_refused_before_the_motor_moves(tmp_path, capsys, argv, flags):
    out = tmp_path / "run.csv"
    status = main(argv + ["--port", "twin", "--fast", "--duration", "1", "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and len(err) == 1 and err[0].startswith("iwp: error: ")
    assert all(f in err[0] for f in flags), err
    assert "internal error" not in err[0] and not out.exists()


@pytest.mark.parametrize("port, words", [("/dev/null", "not a serial device"), (".", "is a folder")])
def test_a_port_that_is_no_serial_device_is_one_line_without_pyseriaL_tuples(tmp_path, capsys, port, words):
    status = main(["rig", "run", "sine", "--port", port, "--duration", "1", "--out", str(tmp_path / "x.csv")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and words in line and "(25," not in line and "Errno" not in line


class _Cut:
    """A pyserial-like wire that the host can no longer reach: writes vanish, reads bring nothing."""

    def __init__(self, inner):
        object.__setattr__(self, "inner", inner)

    def write(self, data):
        return len(data)

    def read(self, n=1):
        return b""

    @property
    def in_waiting(self):
        return 0

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def __setattr__(self, name, value):
        setattr(self.inner, name, value)


def test_a_device_that_goes_silent_is_not_said_to_have_stopped_its_motor(tmp_path, capsys):
    rig = TwinRig(fast=True)

    class Cutter(LoopObserver):
        def on_sample(self, t, sample):
            if t > 0.5 and not isinstance(rig.link.serial, _Cut):
                rig.link.serial = _Cut(rig.link.serial)

    try:
        run = run_on_rig(rig, "sine", fast=True, duration=5.0, progress=Cutter())
    finally:
        rig.link.serial = rig.link.serial.inner if isinstance(rig.link.serial, _Cut) else rig.link.serial
        rig.close()
    assert run.interrupted and "link lost" in run.reason
    assert run.stop_confirmed is False  # neither telemetry nor an ACK said the motor stopped
    assert run.log is not None and run.log.t[-1] >= 0.5  # what it recorded is kept
    args = argparse.Namespace(quiet=True, name="sine", port="twin", force=False)
    status = finish_port_run(run, tmp_path / "x.csv", args, lambda lg, out, force: None)
    err = capsys.readouterr().err
    assert status == UNCONFIRMED_STOP
    assert "the motor was stopped" not in err and "did not answer the stop, so nothing confirms it" in err
    assert "its watchdog stops the motor within" in err


def test_a_completed_run_says_the_motor_was_stopped_as_the_device_confirmed():
    with TwinRig(fast=True) as rig:
        run = run_on_rig(rig, "sine", fast=True, duration=0.5)
    assert not run.interrupted and run.stop_confirmed is True


def test_a_file_that_appears_at_out_during_a_run_is_not_overwritten(tmp_path, capsys):
    out = tmp_path / "run.csv"
    out.write_text("another program's data\n")  # appeared after the start's check
    log = ExperimentData(t=0.005 * np.arange(10), q1=np.zeros(10), q2=np.zeros(10))
    written = []
    args = argparse.Namespace(quiet=True, name="sine", port="twin", force=False)
    status = finish_port_run(RigRun(log, False, "complete", None, []), out, args,
                             lambda lg, path, force: written.append(path))
    err = capsys.readouterr().err
    assert status == 0 and written == [tmp_path / "run.1.csv"]
    assert out.read_text() == "another program's data\n"
    assert "appeared during the run" in err and "run.1.csv" in err


def test_a_sample_that_is_not_a_number_and_samples_the_link_lost_keep_the_run(tmp_path):
    """A lying device's NaN in one sample used to discard the whole run, and a 0.3 s gap made a log iwp could not
    read back: both are filled in on the tick grid, marked, kept out of every fit, and the log reads back."""
    import dataclasses

    from iwp.data import read_experiment, write_experiment
    from iwp.device.record import loop_log

    with TwinRig(fast=True) as rig:
        run = run_on_rig(rig, "sine", fast=True, duration=2.0)
        info, stats = rig.info, rig.link.stats
    res = run.loops[0]
    samples = list(res.samples)
    samples[100] = dataclasses.replace(samples[100], q4=float("nan"))
    del samples[200:260]  # 0.3 s of line noise behind a relay
    log = loop_log(dataclasses.replace(res, samples=samples), info, stats, input_name="u")
    assert log.n_samples == 401 and log.metadata["filled_samples"] == "61" and log.metadata["bad_samples"] == "1"
    assert json.loads(log.metadata["gaps"]) == [[0.5, 0.5, 1], [1.0, 1.295, 60]]
    assert int(log.glitch_mask("q1").sum()) == 61 and int(log.glitch_mask("q2").sum()) == 61
    write_experiment(log, tmp_path / "gap.csv")
    back = read_experiment(tmp_path / "gap.csv")
    assert back.n_samples == 401 and int(back.glitch_mask("q2").sum()) == 61
    assert float(back.extra["filled"].sum()) == 61.0
    assert np.all(np.isfinite(back.extra["q4_device"]))


def test_the_documented_defaults_are_the_devices_own_as_it_stores_them():
    """docs/protocol.md printed q1_max as 12.5664 while the firmware holds 4 pi: a client that restored the documented
    value was refused as 'changed: q1_max = 12.5664 (default 12.5664)'. Each default is now printed as the shortest
    decimal that reads back as the device's float32."""
    from pathlib import Path

    from iwp.device.protocol import PARAMS, float32_text

    doc = (Path(__file__).resolve().parents[1] / "docs" / "protocol.md").read_text()
    for p in PARAMS.values():
        text = float32_text(p.default)
        assert f"| `{p.name}` | {text} |" in doc
        assert np.float32(float(text)) == np.float32(p.default), p.name
    assert float32_text(PARAMS["q1_max"].default) == "12.566371"


def test_the_emulator_refuses_a_rig_it_cannot_run_and_a_link_it_cannot_make(tmp_path, capsys):
    """A 50 ms rig was emulated at 5 ms 'as rig50.json describes'; --link in a missing folder named the pty; a
    dangling link was said to exist."""
    rig = tmp_path / "rig50.json"
    rig.write_text(json.dumps({
        "kind": "iwp-rig", "name": "r50", "sample_period": 0.05, "time": {"column": "t", "unit": "s"},
        "pendulum": {"column": "theta", "unit": "counts", "counts_per_rev": 20000},
        "wheel": {"column": "w", "quantity": "speed", "unit": "rad/s", "counts_per_rev": 4096},
        "input": {"column": "u", "kind": "duty", "limits": [-1, 1]}, "drive": {"kind": "direct"}}))
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    for argv, words in ((["--rig", str(rig)], "sample period 50 ms is beyond what the emulated board runs"),
                        (["--link", str(tmp_path / "nodir" / "link")], "its folder"),
                        (["--link", str(dangling)], "which does not exist (not an emulator's port)")):
        assert main(["rig", "emulate", *argv]) == 2
        (line,) = capsys.readouterr().err.strip().splitlines()
        assert words in line and line.startswith("iwp: error: --")


def test_sweep_threads_and_workers_are_capped_by_what_the_process_may_use():
    """--threads 100000 was reported as 100,000 threads and recorded as 100,000 cores; --workers 1000 started a
    cluster that gave no answer in 60 s."""
    from iwp.sweep.executors import DaskExecutor, LocalExecutor
    from iwp.threads import usable_cores

    ex = LocalExecutor(100000)
    assert ex.threads == ex.cores == usable_cores()
    assert ex.note.startswith("threads 100000: capped at") and "cgroup" in ex.note
    assert LocalExecutor(1).note == "" and LocalExecutor(1).threads == 1
    dask = DaskExecutor(workers=1000)  # nothing started yet
    assert dask.workers <= usable_cores() and dask.note.startswith("workers 1000: capped at")


def test_fits_and_designs_refuse_what_they_cannot_do_in_one_line(tmp_path, capsys):
    """iwp fit on logs with zero input ended in an internal error; an --out that is a dangling link named a hidden
    temporary folder; design hopf --k2 -1e308 printed a raw overflow warning and exited 1."""
    t = np.arange(0.0, 10.0, 0.005)
    log = tmp_path / "zero.csv"
    log.write_text("t,q1,q2,u\n" + "".join(f"{a:.3f},{0.3 * np.cos(5 * a):.6f},0,0\n" for a in t))
    link = tmp_path / "dl"
    link.symlink_to(tmp_path / "nowhere" / "dir")
    cases = [(["fit", str(log), "--out", str(tmp_path / "f")], "no training log drives the wheel"),
             (["fit", str(log), "--structure", "9", "--out", str(link)], "which does not exist; remove the link"),
             (["design", "hopf", "--orbit-amplitude", "1.5", "--k2", "-1e308"], "--k2 = -1e+308: the loop's cubic")]
    for argv, words in cases:
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and words in err[0] and "partial" not in err[0], err
    assert not (tmp_path / "f").exists()


def test_a_memory_error_names_the_argument_to_lower(monkeypatch, capsys):
    """'not enough memory for this run (shorten it or lengthen the sample time)' answered --draws 100000 without
    naming --draws."""
    import iwp.control as control

    def exhausted(*a, **kw):
        raise MemoryError

    monkeypatch.setattr(control, "design_hopf", exhausted)
    assert main(["design", "hopf", "--orbit-amplitude", "1.5"]) == 2
    assert capsys.readouterr().err.strip() == ("iwp: error: not enough memory for this run: lower --t-end 60.0 (or "
                                               "lengthen the sample time)")  # design hopf's check simulation
    from iwp.cli import _size_hint

    assert _size_hint(argparse.Namespace(draws=100000)) == "lower --draws 100000 (or lengthen the sample time)"
    assert "the points or draws of spec.json" in _size_hint(argparse.Namespace(spec="spec.json"))


@pytest.mark.parametrize("extra, words", [
    ({"controller_Ts": 1e-9}, "controller_Ts = 1e-09 s: the law would be sampled 3e+11 times"),
    ({"rtol": 1e-300, "atol": 1e-300}, "rtol = 1e-300: below 1e-14"),
])
def test_a_sweep_with_runaway_settings_is_refused_by_its_key(tmp_path, capsys, extra, words):
    """rtol = atol = 1e-300 or controller_Ts = 1e-9 ran a compiled kernel that ignored SIGTERM for over 15 s."""
    spec = {"law": "hopf", "params": "table1", "k1": -10, "k2": 0.1, "x0": [0.1, 0, 0, 0], "t_end": 300,
            "sample_time": 0.05, "window": 20, "vary": {"k1": {"linspace": [-12, -6, 4]}}, "chunk_size": 4, **extra}
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    assert main(["sweep", str(path), "--out", str(tmp_path / "st")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert words in line and not (tmp_path / "st").exists()


def test_report_on_a_sweeps_folder_says_what_it_is(tmp_path, capsys):
    """iwp report on a sweep's folder said 'study: no such file'."""
    study = tmp_path / "study"
    (study / "chunks").mkdir(parents=True)
    (study / "manifest.json").write_text("{}")
    assert main(["report", str(study), "--out", str(tmp_path / "r")]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "a sweep's folder (iwp sweep)" in line and not (tmp_path / "r").exists()


def test_a_chunk_whose_numbers_were_edited_is_computed_again(tmp_path, capsys):
    """A chunk file whose numbers were edited was taken as done: each chunk's SHA-256 is kept in the manifest."""
    spec = {"law": "hopf", "params": "table1", "k1": -10, "k2": 0.1, "x0": [0.1, 0, 0, 0], "t_end": 20,
            "sample_time": 0.05, "window": 5, "vary": {"k1": {"linspace": [-12, -6, 4]}}, "chunk_size": 4}
    path = tmp_path / "spec.json"
    path.write_text(json.dumps(spec))
    out = tmp_path / "st"
    assert main(["sweep", str(path), "--out", str(out), "--quiet"]) == 0
    chunk = out / "chunks" / "chunk-000000.csv"
    first = chunk.read_text()
    rows = first.split("\n")
    cells = rows[1].split(",")
    cells[8] = "9.999"  # the first lane's amplitude
    chunk.write_text("\n".join([rows[0], ",".join(cells), *rows[2:]]))
    capsys.readouterr()
    assert main(["sweep", str(path), "--out", str(out), "--quiet"]) == 0
    assert "its numbers differ from those this sweep wrote" in capsys.readouterr().err
    assert chunk.read_text() == first  # computed again, the same numbers
    assert (out / "chunks" / "chunk-000000.csv.damaged").is_file()


def _truth_file(tmp_path, capsys, **fields):
    assert main(["rig", "truth", "--out", str(tmp_path / "t.json")]) == 0
    capsys.readouterr()
    doc = json.loads((tmp_path / "t.json").read_text())
    doc.update(fields)
    return doc


@pytest.mark.parametrize("field, value, words", [
    ("coulomb_eps", 0, ["field 'coulomb_eps'", "at least 0.0001"]),
    ("noise_std", 1e300, ["field 'noise_std'", "beyond 1 rad"]),
    ("counts_per_rev", "9" * 401, ["key 'counts_per_rev'", "401 digits"]),
])
def test_a_truth_files_bad_field_is_named_by_its_key_before_anything_runs(tmp_path, capsys, field, value, words):
    doc = _truth_file(tmp_path, capsys)
    text = json.dumps({**doc, field: "@"}).replace('"@"', str(value))
    (tmp_path / "bad.json").write_text(text)
    status = main(["rig", "run", "free-pendulum", "--truth", str(tmp_path / "bad.json"), "--duration", "1",
                   "--out", str(tmp_path / "x.csv")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and "bad.json" in line and all(w in line for w in words), line
    assert "--noise" not in line and "limit was reached" not in line


def test_a_calibration_target_with_an_unknown_statistic_is_refused_at_reading(tmp_path, capsys):
    from iwp.calibration.targets import TARGETS_FILE
    doc = json.loads(TARGETS_FILE.read_text())
    doc["targets"][3]["statistic"] = "motor-disk.nothing"
    (tmp_path / "targets.json").write_text(json.dumps(doc))
    status = main(["rig", "calibrate", "--targets", str(tmp_path / "targets.json"), "--out", str(tmp_path / "c.json")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and "targets[3]: field 'statistic'" in line and "'nothing'" in line, line
    assert not (tmp_path / "c.json").exists()


def test_a_long_hopf_sweep_is_not_refused_for_the_lqr_laws_sampling():
    """A Hopf sweep over 1e5 s was refused for lqr_Ts, a setting of the other law, at its default."""
    from iwp.models import table1
    from iwp.sweep.spec import Grid, SweepSpec

    spec = SweepSpec(params=table1(), t_end=1e5, window=5000.0, sample_time=10.0, vary=(Grid("k1", (-10.0,)),))
    assert spec.lqr_Ts == 0.005 and spec.t_end / spec.lqr_Ts > 1e7
    with pytest.raises(Exception, match="lqr_Ts"):
        SweepSpec(params=table1(), law="lqr", t_end=1e5, window=5000.0, sample_time=10.0, vary=(Grid("x0.q1", (3.1,)),))


def test_a_latched_stop_is_seen_also_when_the_live_view_turned_telemetry_off():
    """The live view's prediction turns telemetry off; the latched ESTOP was then not seen, --clear-fault was
    ignored and the device refused ARM (exit 1) where the documented refusal is exit 2."""
    from iwp.device.errors import DeviceError
    from iwp.device.runs import Clearing, prepare

    rig = TwinRig(fast=True)
    try:
        rig.estop()
        rig.stream(0)  # as LiveView.attach leaves it
        with pytest.raises(DeviceError, match="ESTOP.*clear_fault"):
            prepare(rig, True)
        rig.stream(0)
        prepare(rig, True, Clearing(clear_fault=True))
        assert rig.device.core.status()[1] == 0  # cleared, disarmed
    finally:
        rig.close()


def test_a_runs_own_watchdog_is_set_for_the_run_recorded_and_put_back_on_close():
    """--watchdog-ms: a host without real-time scheduling was held off 148 ms by a browser starting (the device's
    100 ms watchdog ended the run); the run's own watchdog is the device's for the run, in its log, and put back
    when the rig is closed, so that the next run does not find a changed limit."""
    from iwp.device.runs import Clearing

    rig = TwinRig(fast=True)
    try:
        run = run_on_rig(rig, "sine", fast=True, duration=0.5, clearing=Clearing(watchdog_ms=500))
        assert rig.device.core.param("watchdog_ms") == 500.0
    finally:
        rig.close()
    assert not run.interrupted and json.loads(run.log.metadata["device"])["params"]["watchdog_ms"] == 500.0
    assert rig.device.core.param("watchdog_ms") == 100.0
    with pytest.raises(Exception, match="watchdog_ms must be from 10 to 2000 ms"):
        Clearing(watchdog_ms=5)


def test_the_live_view_says_when_a_starting_program_can_stop_the_run(monkeypatch):
    from iwp.device import realtime

    monkeypatch.setattr(realtime, "realtime_allowed", lambda: False)
    note = realtime.starving_note("/dev/ttyACM0", None)
    assert "--watchdog-ms 500" in note and "148 ms" in note
    assert realtime.starving_note("/dev/ttyACM0", 500.0) == "" and realtime.starving_note("twin", None) == ""
    monkeypatch.setattr(realtime, "realtime_allowed", lambda: True)
    assert realtime.starving_note("/dev/ttyACM0", None) == ""


def test_a_port_opened_in_the_middle_of_a_frame_counts_no_corrupt_frame():
    """Every run with --clear-fault said the link 'refused 1 corrupt frames': the tail of the frame the device was
    sending when the port opened. It is skipped, not counted; a frame damaged later still is."""
    from iwp.device.framing import FrameDecoder, encode_frame
    from iwp.device.protocol import encode

    stream = b"".join(encode_frame(encode("ARM", req=k)) for k in range(1, 11))
    dec = FrameDecoder()
    got = dec.feed(stream[5:])  # opened 5 bytes into the first frame
    assert len(got) == 9 and dec.counts.bad == 0
    damaged = bytearray(stream)
    damaged[-4] ^= 0x55
    got = dec.feed(bytes(damaged))
    assert len(got) == 9 and dec.counts.corrupt == 1


@pytest.mark.parametrize("name, value", [("counts1", 0.0), ("period_us", float("nan"))])
def test_a_device_reporting_what_no_device_holds_is_refused_at_connect(monkeypatch, tmp_path, capsys, name, value):
    """counts1 = 0 ended in a ZeroDivisionError, period_us = NaN in a ValueError (internal errors, exit 3)."""
    from iwp.device.connection import Rig

    real = Rig.get_param
    monkeypatch.setattr(Rig, "get_param", lambda self, n: value if n == name else real(self, n))
    status = main(["rig", "run", "sine", "--port", "twin", "--fast", "--duration", "1", "--out", str(tmp_path / "x.csv")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status == 2 and f"reports {name} = {value!r}" in line and "internal error" not in line, line
    assert not (tmp_path / "x.csv").exists()


def test_a_design_that_fails_on_a_parameter_file_names_the_file(monkeypatch, tmp_path, capsys):
    """A fit's parameters.json whose orbit diverged (x0 of 3.9e7 rad/s) failed the design without naming it."""
    import iwp.control
    from iwp.errors import SimulationError
    from iwp.models import save_params, table1

    save_params(table1(), tmp_path / "fit.json")

    def diverges(*a, **k):
        raise SimulationError("the simulation diverged at t = 0.2 s (x0 = [0, 0, 0, 3.9e7])")

    monkeypatch.setattr(iwp.control, "design_hopf", diverges)
    status = main(["design", "hopf", "--orbit-amplitude", "2.58", "--params", str(tmp_path / "fit.json")])
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert status != 0 and f"--params {tmp_path / 'fit.json'}" in line and "3.9e7" in line, line
