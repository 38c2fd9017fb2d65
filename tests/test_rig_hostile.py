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
