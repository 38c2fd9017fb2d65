"""The pin-level twin: the board's firmware image under simavr with iwp's twin at its pins, in closed loop.

* the encoders: quadrature edges on D2-D5 decoded by the firmware's interrupts; its counts equal the counts
  the pins showed its interrupts, at every tick, with the wheel at the device's default ``q4_max`` and at
  the capacity measured by bench_pins (BENCHMARKS.md); beyond it the interrupts leave the device no time to
  answer, which the host reports (never counts silently wrong); the check itself finds a lost edge;
* the Hopf law k1 = -10, k2 = 0.1 on the device (as ``iwp control run hopf`` runs it) oscillates at the
  paper's 2.58 rad within 2 %, its counts those of the twin's angles;
* the motor-disk set-up (section 5.1) on a chirp run through the pins recovers p2(1+rho), p3(1+rho) as the
  same run through the emulator does.

Skipped without gcc-avr, avr-libc, simavr, libsimavr-dev (failed with ``CI`` set, as in test_firmware.py).
Short runs: the harness and the twin cost about one second of CPU per simulated second.
"""

from __future__ import annotations

import math
from types import SimpleNamespace

import numpy as np
import pytest

from iwp.device.control import ControlRun, run_control
from iwp.device.errors import DeviceError
from iwp.device.pins import ConstantSpeed, CountCheck, PinTick, SimavrRig, compare_counts, count_check
from iwp.device.protocol import PARAMS
from iwp.device.runs import run_on_rig
from iwp.device.twin import TwinRig
from iwp.ident.identification import identify
from iwp.models.parameters import table1
from tests.helpers import AVR_HEADERS, AVR_TOOLS, SIMAVR_HEADERS, make_firmware, need_tools

STEP = 2 * math.pi / 2000  # the twin's encoders: 2000 counts/rev (section 5)
#: the wheel at the device's default limit q4_max [edges/s]; the capacity bench_pins measures at 200 Hz with the
#: pendulum at 5000 edges/s (BENCHMARKS.md: counted exactly, the control step inside its period, in 3 runs of
#: each rate); far beyond it, where the interrupts starve the device
DEFAULT, CAPACITY, STARVED = PARAMS["q4_max"].default / STEP, 140_000.0, 250_000.0


@pytest.fixture(scope="module")
def build(tmp_path_factory):
    need_tools(*AVR_TOOLS, "pkg-config", headers=AVR_HEADERS + SIMAVR_HEADERS)
    b = tmp_path_factory.mktemp("fw")
    r = make_firmware(b, "avr", "simavr")
    assert r.returncode == 0, r.stdout + r.stderr
    return b / "iwp.elf", b / "iwp_simavr"


def _rig(build, **kw) -> SimavrRig:
    elf, harness = build
    return SimavrRig(elf, harness, **kw)


def test_the_firmware_counts_every_edge_at_the_default_speed_limit(build):
    with _rig(build, plant=ConstantSpeed(5000 * STEP, DEFAULT * STEP)) as rig:
        assert rig.info.board == "ATmega328P" and "FIXTURE" in rig.info.caps  # the harness's hands
        c = count_check(rig, 0.5)
    print(f"wheel {DEFAULT:.0f} edges/s, pendulum 5000: {c}")
    assert DEFAULT < CAPACITY  # the default limit is inside the capacity (at 68 % of it)
    assert c.compared >= 90
    assert c.wrong == 0 and c.max_error == 0


def test_beyond_the_capacity_the_device_stops_answering_instead_of_miscounting(build):
    with pytest.raises(DeviceError, match="no answer"):
        with _rig(build, plant=ConstantSpeed(5000 * STEP, STARVED * STEP)) as rig:
            count_check(rig, 0.5)


def test_the_count_check_finds_a_lost_edge():
    ticks = [PinTick(k, 0.005 * k, 10 * k, 100 * k, 10 * k, 100 * k) for k in range(1, 6)]
    good = [_sample(k, 7 + 10 * k, -3 + 100 * k) for k in range(1, 6)]
    assert compare_counts(good, ticks) == CountCheck(5, 0, 0, 0)
    lost = good[:3] + [_sample(k, 7 + 10 * k, -5 + 100 * k) for k in (4, 5)]  # two edges of the wheel lost
    assert compare_counts(lost, ticks) == CountCheck(5, 2, 0, 2)


def _sample(seq, count1, count2):
    return SimpleNamespace(seq=seq, count1=count1, count2=count2)


def test_hopf_on_the_device_through_the_pins_oscillates_at_2_58(build):
    with _rig(build) as rig:
        run = run_control(rig, ControlRun("hopf", duration=10.0, x0=2.5), params=table1())
        ticks, history = list(rig.twin.ticks), np.array(rig.twin.history)
    assert not run.interrupted, run.reason
    log = run.log
    amp = np.max(np.abs(log.q1[log.t >= log.t[-1] - 5.0]))
    print(f"Hopf through the pins: amplitude {amp:.4f} rad")
    assert abs(amp - 2.58) < 0.02 * 2.58
    assert log.metadata["controller"] == "device" and np.max(np.abs(log.u)) > 30.0  # the law drove the motor
    samples = run.loops[0].samples
    c = compare_counts(samples, ticks)
    assert c.compared == len(samples) and c.wrong == 0
    # ... and the counts are the twin's angles, rounded, at the instants the firmware read them (count 0 at the
    # first tick)
    n0 = round(float(np.interp(ticks[0].t, history[:, 0], history[:, 1])) / STEP)
    seqs = {s.seq for s in samples}
    run_ticks = [k for k in ticks if k.tick in seqs]
    q1 = np.interp([k.t for k in run_ticks], history[:, 0], history[:, 1])
    err = np.array([k.n1 for k in run_ticks]) * STEP - (q1 - n0 * STEP)
    assert len(run_ticks) == len(samples) and np.max(np.abs(err)) <= 0.55 * STEP


def _identified(rig, experiment: str, setup: str, **kw):
    run = run_on_rig(rig, experiment, duration=12.0, **kw)
    assert not run.interrupted, run.reason
    return identify(run.log, setup)


@pytest.mark.parametrize("experiment, setup, names", [
    ("motor-disk-chirp", "motor-disk", ("p2_1rho", "p3_1rho")),
    ("full-chirp", "full", ("p1", "p2", "p3")),
], ids=["motor-disk", "full"])
def test_identification_through_the_pins_matches_the_emulator(build, experiment, setup, names):
    """Section 5.1's motor-disk set-up and section 5.2's full set-up on 12 s chirps through the board's image give
    the emulator's parameters (the same core compiled for this computer, whose runs give the virtual rig's
    numbers: test_device) within 2 %."""
    with _rig(build) as rig:
        pins = _identified(rig, experiment, setup)
    with TwinRig(fast=True) as twin:
        emulated = _identified(twin, experiment, setup, fast=True)
    for name in names:
        a, b = pins.parameters[name].value, emulated.parameters[name].value
        print(f"{name}: through the pins {a:.5g}, through the emulator {b:.5g}")
        assert abs(a - b) <= 0.02 * abs(b)
