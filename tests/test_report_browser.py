"""The reproduction report and the fit page: their figures legible, and the pages opened in headless Chromium.

Every figure of both pages is checked for legends on the data: each
legend's box (``legend.get_window_extent()``) against the plotted data in
display coordinates (the points and segments of every line drawn in data
coordinates, the polygons of every filled envelope): not one may reach
into it. In the browser, every image must load (the page marks each
``<img>`` with ``data-loaded`` once loaded, and the body with
``data-images-loaded="N/M"``), and a screenshot must not be blank.
Chromium comes from the system packages (``apt-get install -y chromium``,
done by ``.ci/run``); without it the browser tests are skipped, except
under CI (``CI`` set in the environment), where they fail.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from matplotlib.path import Path as MplPath
from matplotlib.transforms import Bbox

from tests.helpers import EXPECTED_FIGURES, keeping_figures

_CANDIDATES = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def _chromium() -> str | None:
    for name in _CANDIDATES:
        path = shutil.which(name)
        if path:
            return path
    return "/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None


@pytest.fixture(scope="module")
def chromium():
    path = _chromium()
    if path is None:
        if os.environ.get("CI"):
            pytest.fail("Chromium is not installed; CI must install it (apt-get install -y chromium)")
        pytest.skip("Chromium is not installed (apt-get install -y chromium); set CI=1 to make this a failure")
    return path


def _run(chromium: str, profile: Path, *args: str, timeout: float = 90.0) -> subprocess.CompletedProcess:
    cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           "--disable-default-apps", "--disable-extensions", "--no-first-run", "--no-default-browser-check",
           "--hide-scrollbars", "--mute-audio", f"--user-data-dir={profile}", *args]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


def test_every_image_loads(chromium, quick_run, tmp_path):
    page = (quick_run["out"] / "report.html").resolve()
    r = _run(chromium, tmp_path / "profile", "--virtual-time-budget=10000", "--dump-dom", page.as_uri())
    assert r.returncode == 0, r.stderr[-2000:]
    dom = r.stdout
    m = re.search(r'data-images-loaded="(\d+)/(\d+)"', dom)
    assert m, "the page's load script did not run: " + dom[:500]
    loaded, total = int(m.group(1)), int(m.group(2))
    assert total == len(EXPECTED_FIGURES)
    assert loaded == total
    assert 'data-loaded="0"' not in dom
    assert dom.count('data-loaded="1"') == total


def test_screenshot_not_blank(chromium, quick_run, tmp_path):
    from PIL import Image

    page = (quick_run["out"] / "report.html").resolve()
    shot = tmp_path / "shot.png"
    r = _run(chromium, tmp_path / "profile", "--window-size=1280,2400", "--virtual-time-budget=10000",
             f"--screenshot={shot}", page.as_uri())
    assert r.returncode == 0, r.stderr[-2000:]
    assert shot.is_file() and shot.stat().st_size > 10_000
    img = Image.open(shot).convert("RGB")
    assert img.size == (1280, 2400)
    small = img.resize((320, 600))
    colours = small.getcolors(maxcolors=320 * 600)
    assert colours is not None and len(colours) > 50  # text, tables, plots: many distinct colours
    white = sum(n for n, c in colours if min(c) >= 250)
    assert white < 0.97 * 320 * 600  # not an empty white page
    # the pass/fail cells are coloured: some green and some red or green pixels exist
    assert any(g > r_ + 20 and g > b + 20 for n, (r_, g, b) in colours)


# --------------------------------------------------------------------------
# legends off the data, in every figure of both pages
# --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def fit_run(tmp_path_factory):
    """``iwp fit``'s page for two 20 s chirps, a 20 s PRBS and a 120 s chirp held out; its figures' artists kept."""
    import warnings

    import iwp.report.fit_page as fit_page
    from iwp.ident.logfit import fit_logs
    from iwp.rig.described import DescribedRig, write_rig_csv
    from iwp.sim.inputs import Chirp
    from tests.test_rig_fit import TRUTH, rig_of, write_logs

    tmp = tmp_path_factory.mktemp("fit")
    rig = rig_of()
    files, held = write_logs(tmp, rig, duration=20.0)
    long = write_rig_csv(DescribedRig(rig, TRUTH).run(Chirp(0.25, 2.0, 15.0), duration=120.0), tmp / "long.csv")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = fit_logs(files, rig=rig, validate=[held, long], warn=False)
    with keeping_figures(fit_page) as figures:
        written = fit_page.write_fit_report(res, tmp / "out")
    return {"out": written["folder"], "figures": figures}


def _data_under(box: Bbox, ax) -> int:
    """Data points, segments and filled areas of ``ax`` inside the display box ``box`` (guides and grids left out)."""
    hits = 0
    grid = np.array([[x, y] for x in np.linspace(box.x0, box.x1, 12) for y in np.linspace(box.y0, box.y1, 6)])
    for ln in ax.get_lines():
        if ln.get_transform() is not ax.transData or not ln.get_visible():
            continue  # axhline, axvline: guides in axes coordinates
        xy = ax.transData.transform(np.asarray(ln.get_xydata(), dtype=float))
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        hits += int(box.count_contains(xy))  # the samples
        if ln.get_linestyle() not in ("None", "", " ") and len(xy) > 1 and \
                MplPath(xy).intersects_bbox(box, filled=False):
            hits += 1  # a segment through the box between two samples outside it
    for coll in ax.collections:
        for path in coll.get_paths():
            poly = coll.get_transform().transform_path(path)
            hits += int(box.count_contains(poly.vertices)) + int(poly.contains_points(grid).sum())
    return hits


def _legend_report(fig) -> list[str]:
    """Every legend of ``fig`` that covers data, overlaps another axes or leaves the figure, said in words."""
    fig.canvas.draw()
    bad = []
    legends = [(ax, ax.get_legend()) for ax in fig.axes if ax.get_legend() is not None]
    legends += [(None, leg) for leg in fig.legends]
    for owner, leg in legends:
        box = leg.get_window_extent()
        for ax in fig.axes:
            n = _data_under(box, ax)
            if n:
                bad.append(f"legend {leg.get_texts()[0].get_text()!r} covers {n} data of axes {ax.get_ylabel()!r}")
            if ax is not owner and box.overlaps(ax.bbox):
                bad.append(f"legend {leg.get_texts()[0].get_text()!r} lies on the axes {ax.get_ylabel()!r}")
        if not fig.bbox.contains(box.x0 + 1, box.y0 + 1) or not fig.bbox.contains(box.x1 - 1, box.y1 - 1):
            bad.append(f"legend {leg.get_texts()[0].get_text()!r} leaves the figure")
    return bad


def test_the_overlap_check_sees_a_legend_on_the_data():
    """The check itself: a legend forced onto a dense record is caught; put back in a free corner it is not."""
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3))
    t = np.linspace(0, 10, 2001)
    ax.plot(t, np.sin(20 * t), label="dense")
    ax.plot([0, 10], [-3, -3], label="a straight line through the box's corner")
    leg = ax.legend(loc="center")
    assert any("covers" in b for b in _legend_report(fig))
    ax.set_ylim(-4, 6)
    leg.set_loc("upper right")
    assert _legend_report(fig) == []
    plt.close(fig)


@pytest.mark.parametrize("name", sorted(EXPECTED_FIGURES))
def test_no_legend_on_the_data_of_the_reproduction(quick_run, name):
    fig = quick_run["figures"][name]
    assert _legend_report(fig) == []
    assert any(ax.get_legend() is not None for ax in fig.axes)  # every figure of the report has a legend


def test_no_legend_on_the_data_of_the_fit_page(fit_run):
    figs = fit_run["figures"]
    logs = [n for n in figs if n != "correlation"]
    assert len(logs) == 4  # two training logs, two held out
    long = next(n for n in logs if n.endswith("long"))
    assert any(ax.get_title().startswith("zoom:") for ax in figs[long].axes)  # 120 s: a zoom beside it
    for name, fig in figs.items():
        assert _legend_report(fig) == [], name


def test_the_fit_page_loads_its_figures(chromium, fit_run, tmp_path):
    page = (fit_run["out"] / "report.html").resolve()
    r = _run(chromium, tmp_path / "profile", "--virtual-time-budget=10000", "--dump-dom", page.as_uri())
    assert r.returncode == 0, r.stderr[-2000:]
    m = re.search(r'data-images-loaded="(\d+)/(\d+)"', r.stdout)
    assert m and m.group(1) == m.group(2) == str(len(fit_run["figures"]))


def _signal_bands(shot: Path) -> int:
    """Bands of rows (apart by more than 60 px) in which the measured signal's blue (matplotlib's C0) is drawn."""
    from PIL import Image

    img = np.asarray(Image.open(shot).convert("RGB")).astype(int)
    blue = (np.abs(img - np.array([31, 119, 180])).sum(axis=2) < 40).sum(axis=1) >= 3
    rows = np.flatnonzero(blue)
    return 0 if rows.size == 0 else 1 + int(np.sum(np.diff(rows) > 60))


@pytest.mark.parametrize("page", ["reproduction", "fit"])
def test_the_figures_are_drawn_on_the_screen(chromium, quick_run, fit_run, tmp_path, page):
    """A screenshot of the whole page: each figure's measured signal shows as its own band of blue pixels."""
    out, expected = ((quick_run["out"], len(EXPECTED_FIGURES) - 1) if page == "reproduction"  # fig_refine: errors
                     else (fit_run["out"], len(fit_run["figures"]) - 1))  # the correlation matrix: no signal
    shot = tmp_path / "page.png"
    r = _run(chromium, tmp_path / "profile", "--window-size=1280,24000", "--virtual-time-budget=10000",
             f"--screenshot={shot}", (out / "report.html").resolve().as_uri())
    assert r.returncode == 0, r.stderr[-2000:]
    assert _signal_bands(shot) >= expected
