"""The reference firmware: the core's unit tests (host C compiler), the AVR build, and the firmware under simavr.

* the portable core's unit tests in C (``firmware/tests/test_core.c``) pass;
* the ATmega328P build (Debian's gcc-avr, avr-libc) fits the board: flash and RAM used are reported;
* under simavr, behind a pseudo-terminal: HELLO, parameters, ARM, the telemetry stream at the loop's rate,
  and the watchdog stopping the motor when the host stops; the 1 kHz control step (the Hopf law, telemetry
  at 200 Hz, encoder interrupts running) within the AVR's cycle budget of 16,000 cycles (simavr's cycle count).

Tests that need gcc-avr, avr-libc, simavr or libsimavr-dev are skipped when they are absent, with the
reason, unless ``CI`` is set (``.ci/run`` installs them), where they fail.
"""

from __future__ import annotations

import json
import re
import signal
import subprocess
import time

import pytest

from iwp.device.connection import Rig
from tests.helpers import AVR_HEADERS, AVR_TOOLS, SIMAVR_HEADERS, make_firmware, need_tools

BUDGET_1KHZ = 16_000  # cycles of a 16 MHz ATmega328P in one millisecond


def test_core_unit_tests_pass_with_the_host_compiler(tmp_path):
    need_tools("make", "cc")
    r = make_firmware(tmp_path, "test")
    assert r.returncode == 0, r.stdout + r.stderr
    m = re.search(r"(\d+) passed, (\d+) failed", r.stdout)
    assert m and int(m.group(1)) >= 30 and m.group(2) == "0", r.stdout


@pytest.fixture(scope="module")
def avr_build(tmp_path_factory):
    need_tools(*AVR_TOOLS, headers=AVR_HEADERS)
    build = tmp_path_factory.mktemp("fw")
    r = make_firmware(build, "avr")
    assert r.returncode == 0, r.stdout + r.stderr
    return build, r.stdout


def test_avr_build_fits_the_atmega328p(avr_build):
    build, out = avr_build
    flash = int(re.search(r"Program:\s+(\d+) bytes", out).group(1))
    ram = int(re.search(r"Data:\s+(\d+) bytes", out).group(1))
    print(f"ATmega328P: flash {flash} bytes of 32768, RAM {ram} bytes of 2048 (static)")
    assert flash < 0.8 * 32768 and ram < 0.6 * 2048  # room for the bootloader and the stack
    assert (build / "iwp.hex").stat().st_size > 0


@pytest.fixture(scope="module")
def simavr(avr_build, tmp_path_factory):
    """The firmware under simavr; yields (port, stats path)."""
    need_tools("pkg-config", headers=SIMAVR_HEADERS)
    build, _ = avr_build
    r = make_firmware(build, "simavr")
    assert r.returncode == 0, r.stdout + r.stderr
    stats = tmp_path_factory.mktemp("sim") / "stats.json"
    p = subprocess.Popen([str(build / "iwp_simavr"), str(build / "iwp.elf"), "--stats", str(stats), "--spin", "400"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        port = None
        deadline = time.monotonic() + 20
        while port is None and time.monotonic() < deadline:
            line = p.stdout.readline()
            if line.startswith("port: "):
                port = line.split()[1]
        assert port, "simavr printed no port"
        yield port, stats
    finally:
        p.send_signal(signal.SIGTERM)
        try:
            p.wait(5)
        except subprocess.TimeoutExpired:
            p.kill()


def test_simavr_hello_arm_stream_and_watchdog_stop(simavr):
    port, _ = simavr
    with Rig(port) as rig:
        assert rig.info.board == "ATmega328P" and rig.info.firmware == "1.0.0" and rig.info.base_us == 1000
        assert rig.info.params["period_us"] == 5000.0 and "HOPF" in rig.info.caps
        rig.clear()
        rig.set_params(q1_max=1000.0, watchdog_ms=100.0)
        rig.arm()
        armed_at = rig.last_seq  # telemetry after this tick is armed
        t0 = time.monotonic()
        got = []
        # stream with commands: 100 ticks (1 s of device time; simavr runs slower than real time on a busy host)
        while len(got) <= 100 and time.monotonic() - t0 < 30.0:
            batch = [s for s in rig.samples(0.5) if s.seq > armed_at]
            for s in batch:
                rig.command(20.0, s.seq + 4)
            got += batch
        assert len(got) > 100 and all(s.state == "ARMED" for s in got)
        seqs = [s.seq for s in got]
        assert seqs == list(range(seqs[0], seqs[0] + len(seqs)))  # every tick, in order
        assert got[-1].v == pytest.approx(51.0) and got[-1].u == pytest.approx(20.0)
        dt = (got[-1].t_device - got[0].t_device) / (len(got) - 1)
        assert dt == pytest.approx(0.005, rel=1e-3)  # the board's clock
        fed = got[-1]
        later = []
        while time.monotonic() - t0 < 2.0:  # the host stops sending
            later += rig.samples(0.5)
        stop = next(s for s in later if s.state != "ARMED")
        assert stop.state == "FAULT" and stop.fault == "WATCHDOG" and stop.v == 0.0
        # the last command fed it when the host sent it, at fed (+ one period of the link); queued commands ran out
        assert stop.t_device - fed.t_device <= 0.100 + 0.005 + 0.005
        assert all(s.v == 0.0 for s in later if s.seq >= stop.seq)


def test_simavr_1khz_control_step_fits_the_cycle_budget(simavr):
    port, stats = simavr
    with Rig(port) as rig:
        rig.clear()
        rig.set_params(period_us=1000.0, q1_max=1000.0, q4_max=10000.0)
        rig.stream(5)  # telemetry at the paper's 200 Hz
        rig.mode("HOPF")
        rig.arm()
        t0 = time.monotonic()
        n = 0
        while time.monotonic() - t0 < 1.5:
            for s in rig.samples(0.5):
                n += 1
                rig.heartbeat(s.seq + 2)
        rig.disarm()
        rig.set_params(period_us=5000.0)
        rig.stream(1)
        rig.mode("HOST")
    assert n > 200  # telemetry every fifth tick
    time.sleep(1.2)  # the harness writes its stats every simulated second
    st = json.loads(stats.read_text())
    print(f"simavr: {st['steps']} control steps, {st['cycles_mean']:.0f} cycles mean, {st['cycles_max']} max "
          f"(budget {BUDGET_1KHZ} at 1 kHz)")
    assert st["steps"] > 1000 and st["cycles_max"] < BUDGET_1KHZ
