"""Helpers shared by several test files (not a test module: nothing here is collected)."""

from __future__ import annotations

import os
import shutil
import subprocess
from contextlib import contextmanager
from pathlib import Path

import pytest

from iwp.models import PhysicalParameters


@contextmanager
def keeping_figures(module):
    """Within the block, ``module.save_figure`` also keeps each figure: yields the dict name -> Figure it fills."""
    figures = {}
    orig = module.save_figure

    def keep(fig, out_dir, name, **kw):
        figures[name] = fig
        return orig(fig, out_dir, name, **kw)

    mp = pytest.MonkeyPatch()
    mp.setattr(module, "save_figure", keep)
    try:
        yield figures
    finally:
        mp.undo()


#: the reference firmware's folder
FIRMWARE = Path(__file__).resolve().parents[1] / "firmware"

#: the figures a reduced run of ``iwp reproduce`` writes (names without extension)
EXPECTED_FIGURES = {
    "fig02_dead_zone", "fig03_sines", "fig04_sine20", "fig06_coulomb", "fig07_coulomb20", "fig_full_setup",
    "fig08_free_pendulum", "fig09_full_chirp", "fig10_closed_loop", "fig_refine",
}


def physical() -> PhysicalParameters:
    """A physical parameter set of a plausible rig (SI units), for the mappings of section 4."""
    return PhysicalParameters(m1=0.2, m2=0.3, I1=2e-3, I2=4e-5, l=0.25, c=0.12, g=9.81, kT=0.02, kF=0.02, R=5.0,
                              N=13.5, beta=0.12, sigma_v1=1e-4, sigma_r=0.01, r=0.004, sigma_v2=1e-6,
                              sigma_c2=2e-4, V_dz_pos=3.7, V_dz_neg=3.5)


def need_tools(*tools: str, headers: tuple[str, ...] = ()) -> None:
    """Skip (or, with ``CI`` set, fail) a test whose tools or headers are absent (the firmware's toolchain)."""
    missing = [t for t in tools if shutil.which(t) is None]
    missing += [h for h in headers if not Path(h).exists()]
    if missing:
        msg = f"needs {', '.join(missing)} (apt-get install -y gcc-avr avr-libc simavr libsimavr-dev libelf-dev)"
        if os.environ.get("CI"):
            pytest.fail(msg + "; CI must install them")
        pytest.skip(msg + "; set CI=1 to make this a failure")


def make_firmware(build: Path, *targets: str) -> subprocess.CompletedProcess:
    """``make -s -C firmware BUILD=build targets``."""
    return subprocess.run(["make", "-s", "-C", str(FIRMWARE), f"BUILD={build}", *targets], capture_output=True,
                          text=True, timeout=300)


#: what the AVR build and the simavr harness need
AVR_TOOLS = ("make", "avr-gcc", "avr-size", "avr-objcopy")
AVR_HEADERS = ("/usr/lib/avr/include/avr/io.h",)
SIMAVR_HEADERS = ("/usr/include/simavr/sim_avr.h", "/usr/include/simavr/parts/uart_pty.h")
