"""The rig in the loop (issue 19): timing, safety and fidelity of iwp's protocol path, on the emulator and simavr.

(a) The loop at 200 Hz for 60 s in real time: ``iwp rig emulate`` in one process, ``iwp rig run`` in
    another, through the pseudo-terminal: the host's period jitter ``|period - 5 ms|`` (p50, p99, max),
    missed periods and the device's overruns and late ticks (the log's ``timing`` metadata), and the
    lateness of the emulator's own ticks. Target: p99 below 1 ms.
(b) SIGKILL of the host mid-run: how long after the host's last bytes the device stopped the motor
    (the emulator's state event), five times. Bound: the watchdog's 100 ms plus one period of 5 ms.
(c) Byte errors injected into a telemetry stream: good frames lost, bad frames passed.
(d) The paper's experiments at full length through the emulator's port (``--fast``), then the paper's
    procedures, against the same on ``iwp rig run`` of the virtual rig: the graded targets within
    tolerance, and the parameters side by side; the Hopf amplitude through the port.
(e) The firmware: flash and RAM of the ATmega328P build, and the control step's cycles at 1 kHz under
    simavr (the Hopf law; telemetry every tick and at 200 Hz; encoder interrupts running).

Run: python benchmarks/bench_rig.py [--quick]
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from iwp.calibration import compare_targets, load_targets, paper_numbers
from iwp.calibration.statistics import PAPER_EXPERIMENTS
from iwp.data import read_experiment
from iwp.device.connection import Rig
from iwp.device.framing import FrameDecoder, encode_frame
from iwp.device.protocol import encode
from iwp.device.runs import run_on_rig
from iwp.device.twin import TwinRig
from iwp.ident.identification import identify
from iwp.rig import VirtualRig
from iwp.rig.experiments import experiment_spec
from iwp.rig.run_settings import open_loop_input
from iwp.sim.inputs import Sampled

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT / "src") + os.pathsep + os.environ.get("PYTHONPATH", "")}


class Emulator:
    """``iwp rig emulate`` in its own process."""

    def __init__(self, folder: Path):
        self.err = folder / "emulator.txt"
        self.p = subprocess.Popen([sys.executable, "-m", "iwp", "rig", "emulate"], stdout=subprocess.PIPE,
                                  stderr=open(self.err, "w"), text=True, env=ENV)
        self.port = self.p.stdout.readline().split()[1]

    def events(self) -> str:
        return self.err.read_text()

    def stop(self) -> str:
        self.p.send_signal(signal.SIGINT)
        self.p.wait(20)
        return self.events()


def iwp(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "iwp", *args], capture_output=True, text=True, env=ENV)


def sleeper_lateness(seconds: float = 10.0, period: float = 0.005) -> np.ndarray:
    """The machine's floor: how late a bare Python loop that sleeps to a 5 ms grid wakes [ms] (no I/O, no work)."""
    late = []
    nxt = time.perf_counter()
    for _ in range(int(seconds / period)):
        nxt += period
        d = nxt - time.perf_counter()
        if d > 0:
            time.sleep(d)
        late.append(time.perf_counter() - nxt)
    return np.asarray(late) * 1e3


def loop_timing(folder: Path, duration: float) -> None:
    floor = sleeper_lateness()
    emu = Emulator(folder)
    out = folder / "rt.csv"
    r = iwp("rig", "run", "sine-40", "--port", emu.port, "--duration", str(duration), "--out", str(out))
    tail = emu.stop().strip().splitlines()[-1]
    if r.returncode != 0:
        print(f"FAILED: {r.stderr}")
        return
    t = json.loads(read_experiment(out).metadata["timing"])
    m = re.search(r"p50 ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms \(([^)]*)\)", tail)
    print(f"## (a) The loop at 200 Hz for {duration:g} s, real time, emulator and host in two processes\n")
    print("| | p50 | p99 | max |\n|---|---:|---:|---:|")
    print(f"| host: period jitter \\|period - 5 ms\\| | {t['jitter_p50_ms']:.3f} ms | {t['jitter_p99_ms']:.3f} ms | "
          f"{t['jitter_max_ms']:.3f} ms |")
    if "device_jitter_p50_ms" in t:
        print(f"| device: its ticks' period jitter (the telemetry's own clock) | {t['device_jitter_p50_ms']:.3f} ms | "
              f"{t['device_jitter_p99_ms']:.3f} ms | {t['device_jitter_max_ms']:.3f} ms |")
    if m:
        print(f"| emulator: lateness of its ticks | {float(m.group(1)):.3f} ms | {float(m.group(2)):.3f} ms | "
              f"{float(m.group(3)):.3f} ms |")
    print("| baseline: a bare Python loop sleeping to a 5 ms grid (normal scheduling), 10 s just before (its "
          f"lateness) | "
          f"{np.percentile(floor, 50):.3f} ms | {np.percentile(floor, 99):.3f} ms | {floor.max():.3f} ms |")
    load = t.get("load_avg") or []
    print(f"\nScheduling: host {t['scheduling']}, emulator {m.group(4) if m else '?'}. "
          f"{t['samples']} samples in {t['wall_s']:.2f} s; host missed periods {t['host_overruns']}, device "
          f"overruns {t['device_overruns']}, late ticks {t['late_ticks']}, lost samples {t['lost_samples']}. "
          + (f"Load average (1, 5, 15 min) at the run's end: {', '.join(f'{x:.2f}' for x in load)} on "
             f"{os.cpu_count()} cores. " if load else "")
          + "Target: p99 below 1 ms.\n")


def watchdog(folder: Path, repeats: int) -> None:
    emu = Emulator(folder)
    stops = []
    for i in range(repeats):
        before = len(emu.events())
        p = subprocess.Popen([sys.executable, "-m", "iwp", "rig", "run", "sine-60", "--port", emu.port,
                              "--duration", "30", "--out", str(folder / f"k{i}.csv")], env=ENV,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while "device ARMED" not in emu.events()[before:]:
            time.sleep(0.02)
        time.sleep(0.3 + 0.137 * i)
        p.kill()
        p.wait()
        time.sleep(0.4)
        m = re.search(r"FAULT \(WATCHDOG\).*?([\d.]+) ms after the host's last bytes", emu.events()[before:])
        stops.append(float(m.group(1)) if m else float("nan"))
    emu.stop()
    print("## (b) SIGKILL of the host mid-run\n")
    print("| run | " + " | ".join(str(i + 1) for i in range(repeats)) + " |")
    print("|---|" + "---:|" * repeats)
    print("| motor stopped after the host's last bytes [ms] | " + " | ".join(f"{s:.1f}" for s in stops) + " |")
    print(f"\nWatchdog 100 ms + one period 5 ms = 105 ms; largest {max(stops):.1f} ms.\n")


def byte_errors() -> None:
    rng = np.random.default_rng(3)
    payloads = [encode("TELEMETRY", seq=k, t_us=5000 * k, count1=k, count2=3 * k, q4=0.5, u=1.0, v=32.0,
                       current=float("nan"), state=1, fault=0, flags=0, overruns=0, late=0, rx_errors=0)
                for k in range(1, 100_001)]
    frames = [encode_frame(p) for p in payloads]
    a = np.frombuffer(b"".join(frames), dtype=np.uint8).copy()
    hit = rng.random(a.size) < 1e-3
    a[hit] ^= rng.integers(1, 256, size=int(hit.sum()), dtype=np.uint8)
    bounds = np.cumsum([0] + [len(f) for f in frames])
    touched = np.add.reduceat(hit, bounds[:-1]) > 0
    got = set(FrameDecoder().feed(a.tobytes()))
    lost = sum(1 for k in np.flatnonzero(~touched) if payloads[k] not in got)
    passed_bad = len(got - set(payloads))
    print("## (c) Byte errors in a telemetry stream\n")
    print(f"100,000 frames, one byte in 1,000 replaced at random: {int(touched.sum())} frames hit; good frames lost "
          f"**{lost}**, bad frames passed **{passed_bad}** (the end-to-end test, `tests/test_device.py`, checks "
          "the same through the emulator in both directions, and the core's unit test every single-bit error of "
          "a command).\n")


def paper(folder: Path) -> None:
    t0 = time.perf_counter()
    virtual = paper_numbers()
    t_v = time.perf_counter() - t0
    rig = TwinRig(fast=True)
    logs, walls = {}, {}
    try:
        for name in PAPER_EXPERIMENTS:
            t1 = time.perf_counter()
            run = run_on_rig(rig, name, fast=True)
            walls[name] = time.perf_counter() - t1
            logs[name] = run.log
    finally:
        rig.close()
    port = paper_numbers(logs=logs)
    targets = [t for t in load_targets() if t.graded]
    stats = {t.statistic for t in targets}
    rv = compare_targets(targets, virtual.values(stats))
    rp = compare_targets(targets, port.values(stats))
    print("## (d) The paper's experiments through the emulator's port\n")
    print("Full length (`iwp rig run NAME --port PORT --fast` of every experiment the paper's numbers come from), "
          "then the paper's procedures as `iwp identify` applies them, against `iwp rig run NAME` on the virtual "
          f"rig. Wall time through the port: {sum(walls.values()):.1f} s for "
          f"{sum(logs[n].n_samples if hasattr(logs[n], 'n_samples') else 0 for n in logs)} samples of time series "
          f"and two static curves (virtual rig and procedures: {t_v:.1f} s).\n")
    print(f"Graded targets within tolerance: virtual rig **{sum(r.within for r in rv)} of {len(rv)}**, through the "
          f"port **{sum(r.within for r in rp)} of {len(rp)}**.\n")
    print("| target | published | virtual rig | through the port | tolerance |\n|---|---:|---:|---:|---:|")
    for a, b in zip(rv, rp):
        pub = a.target.published if a.target.published is not None else float("nan")
        print(f"| {a.target.key} | {pub:.5g} | {a.reproduced:.5g}{'' if a.within else ' (out)'} | "
              f"{b.reproduced:.5g}{'' if b.within else ' (out)'} | {a.target.tolerance:.0%} |")
    # the virtual rig evaluates an open-loop input continuously; a rig holds it over each period
    spec = experiment_spec("motor-disk-chirp")
    inp = open_loop_input("motor-disk-chirp", spec.settings)
    tt = 0.005 * np.arange(60001)
    held = VirtualRig().record(Sampled(np.array([inp.evaluate(x) for x in tt]), 0.005, 0.0), duration=300.0,
                               locked=True, metadata={"pendulum": "locked", "input": "the chirp held per period"})
    ha, hb = identify(held, "motor-disk"), identify(held, "motor-disk-coulomb")
    pa, pb = identify(logs["motor-disk-chirp"], "motor-disk"), identify(logs["motor-disk-chirp"], "motor-disk-coulomb")
    print(f"\nThe two targets out through the port come from the motor-disk chirp. `iwp rig run` evaluates an "
          "open-loop input continuously, a rig (and the emulator) holds it over each 5 ms period. The virtual rig "
          f"with the chirp held per period gives p2(1+rho) = {ha.value('p2_1rho'):.5g}, sigma~c2(1+rho) = "
          f"{hb.value('sigma_c2_1rho'):.5g}; through the port {pa.value('p2_1rho'):.5g}, "
          f"{pb.value('sigma_c2_1rho'):.5g}: the emulator's path adds nothing; the held input (half a period of "
          "delay at up to 7 rad/s) is what moves them.")
    cl = logs["closed-loop"]
    amp = np.max(np.abs(cl.q1[cl.t >= cl.t[-1] - 20]))
    print(f"\nHopf closed loop k1 = -10, k2 = 0.1 on the device, through the port: amplitude **{amp:.4f} rad** "
          f"({(amp / 2.58 - 1) * 100:+.2f} % of the paper's 2.58).\n")


def firmware(folder: Path) -> None:
    print("## (e) The firmware on an ATmega328P\n")
    if not (shutil.which("avr-gcc") and Path("/usr/include/simavr/sim_avr.h").exists()):
        print("gcc-avr or simavr not installed: skipped.\n")
        return
    build = folder / "fw"
    r = subprocess.run(["make", "-s", "-C", str(ROOT / "firmware"), f"BUILD={build}", "avr", "simavr"],
                       capture_output=True, text=True)
    flash = re.search(r"Program:\s+(\d+) bytes \(([\d.]+)% Full\)", r.stdout)
    ram = re.search(r"Data:\s+(\d+) bytes \(([\d.]+)% Full\)", r.stdout)
    print(f"avr-gcc -Os: flash **{flash.group(1)} bytes** ({flash.group(2)} % of 32 KB), static RAM "
          f"**{ram.group(1)} bytes** ({ram.group(2)} % of 2 KB).\n")
    print("| 1 kHz loop, Hopf law on the device | steps | cycles mean | cycles max | of the 16,000 budget |")
    print("|---|---:|---:|---:|---:|")
    for every, what in ((5, "telemetry at 200 Hz"), (1, "telemetry every tick (500000 baud full)")):
        stats = folder / f"stats{every}.json"
        p = subprocess.Popen([str(build / "iwp_simavr"), str(build / "iwp.elf"), "--stats", str(stats), "--spin",
                              "400"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        port = next(line.split()[1] for line in p.stdout if line.startswith("port: "))
        with Rig(port) as rig:
            rig.set_params(period_us=1000.0, q1_max=1000.0, q4_max=10000.0, watchdog_ms=2000.0)
            rig.stream(every)
            rig.mode("HOPF")
            rig.arm()
            t0 = time.monotonic()
            while time.monotonic() - t0 < 2.5:
                rig.heartbeat()
                rig.samples(0.02)
        time.sleep(1.1)
        st = json.loads(stats.read_text())
        p.send_signal(signal.SIGTERM)
        p.wait(5)
        print(f"| {what} | {st['steps']} | {st['cycles_mean']:.0f} | {st['cycles_max']} | "
              f"{st['cycles_max'] / 16000:.0%} |")
    print("\nCycles between the step marker's edges (D13), simavr's count at 16 MHz, with the encoder interrupts "
          "of a turning pendulum and wheel (`--spin 400`) and the serial interrupt running.\n")


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="a 10 s loop, two kills, no full-length paper")
    a = ap.parse_args()
    print(f"Machine: {os.cpu_count()} cores. Emulator and host are separate processes on one pseudo-terminal "
          "unless said.\n")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        loop_timing(folder, 10.0 if a.quick else 60.0)
        watchdog(folder, 2 if a.quick else 5)
        byte_errors()
        if not a.quick:
            paper(folder)
        firmware(folder)


if __name__ == "__main__":
    main()
