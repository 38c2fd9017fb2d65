"""Helpers shared by several test files (not a test module: nothing here is collected)."""

from __future__ import annotations

from contextlib import contextmanager

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
