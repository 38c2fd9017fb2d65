"""Tests of iwp.differentiate: exactness, convergence, noise bounds, consistency, errors."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy import signal

from iwp.errors import InputError
from iwp.ident.differentiate import (
    DEFAULT_DIFFERENTIATOR,
    METHODS,
    Differentiator,
    central_first,
    central_second,
)

TS = 0.005  # s, the paper's sample time
DELTA = 2 * np.pi / 2000  # rad, encoder quantisation step (2000 counts/rev)


def _time(n: int = 400, Ts: float = TS) -> np.ndarray:
    return np.arange(n) * Ts


# ---------------------------------------------------------------------------
# exactness on polynomials
# ---------------------------------------------------------------------------
def test_central_exact_for_quadratic_everywhere() -> None:
    t = _time(50) - 0.1
    q = 3.0 + 2.0 * t - 5.0 * t**2
    q_f, dq, ddq = Differentiator("central").derivatives(TS, q)
    np.testing.assert_array_equal(q_f, q)
    np.testing.assert_allclose(dq, 2.0 - 10.0 * t, rtol=0, atol=1e-9)  # ends included
    np.testing.assert_allclose(ddq, np.full_like(t, -10.0), rtol=0, atol=1e-6)


def test_central_second_exact_for_cubic_inside() -> None:
    t = _time(40)
    q = 0.5 * t**3 - t**2
    ddq = central_second(q, TS)
    np.testing.assert_allclose(ddq[1:-1], 3.0 * t[1:-1] - 2.0, rtol=0, atol=1e-6)
    # the first derivative of a cubic has the O(Ts^2) error q'''/6 Ts^2 = 0.5 * Ts^2
    dq = central_first(q, TS)
    np.testing.assert_allclose(dq[1:-1] - (1.5 * t[1:-1] ** 2 - 2 * t[1:-1]), 0.5 * TS**2, rtol=1e-6)


def test_savgol_direct_exact_for_cubic() -> None:
    t = _time(200)
    q = 1.0 - 0.3 * t + 0.7 * t**2 - 0.4 * t**3
    q_f, dq, ddq = Differentiator("savgol_direct", window=21, polyorder=3).derivatives(TS, q)
    np.testing.assert_allclose(q_f, q, atol=1e-10)
    np.testing.assert_allclose(dq, -0.3 + 1.4 * t - 1.2 * t**2, atol=1e-8)
    np.testing.assert_allclose(ddq, 1.4 - 2.4 * t, atol=1e-6)


def test_savgol_exactness_in_the_interior() -> None:
    """Consistent savgol: acceleration exact for cubics, velocity for quadratics."""
    d = Differentiator("savgol", window=21, polyorder=3)
    k = d.edge_samples
    t = _time(200)
    cubic = 1.0 - 0.3 * t + 0.7 * t**2 - 0.4 * t**3
    _, _, ddq = d.derivatives(TS, cubic)
    np.testing.assert_allclose(ddq[k:-k], (1.4 - 2.4 * t)[k:-k], atol=1e-6)
    quad = 2.0 + 0.5 * t - 3.0 * t**2
    q_f, dq, ddq = d.derivatives(TS, quad)
    np.testing.assert_allclose(dq[k:-k], (0.5 - 6.0 * t)[k:-k], atol=1e-8)
    np.testing.assert_allclose(ddq[k:-k], -6.0, atol=1e-6)
    # the common filter K has unit DC gain and keeps straight lines
    line = 0.2 + 4.0 * t
    np.testing.assert_allclose(d.smooth(TS, line)[k:-k], line[k:-k], atol=1e-10)


def test_savgol_kernel_factorises_the_second_derivative_filter() -> None:
    for window, polyorder in [(5, 2), (21, 3), (41, 3), (21, 5)]:
        K = Differentiator("savgol", window=window, polyorder=polyorder).smoothing_kernel()
        assert K.shape == (window - 2,)
        assert K.sum() == pytest.approx(1.0, abs=1e-12)
        S2 = signal.savgol_coeffs(window, polyorder, deriv=2, use="conv")
        np.testing.assert_allclose(np.convolve([1.0, -2.0, 1.0], K), S2, atol=1e-12)


# ---------------------------------------------------------------------------
# convergence and noise
# ---------------------------------------------------------------------------
def test_central_differences_converge_with_order_two() -> None:
    errs1, errs2 = [], []
    for Ts in (0.01, 0.005):
        t = np.arange(0.0, 2.0 + Ts / 2, Ts)
        w = 2 * np.pi
        _, dq, ddq = Differentiator("central").derivatives(Ts, np.sin(w * t))
        errs1.append(np.abs(dq - w * np.cos(w * t)).max())
        errs2.append(np.abs(ddq + w**2 * np.sin(w * t)).max())
    assert errs1[0] / errs1[1] == pytest.approx(4.0, rel=0.06)
    assert errs2[0] / errs2[1] == pytest.approx(4.0, rel=0.06)


# stated bounds: 1 rad sine at 1 Hz, Ts = 5 ms, quantised to 2*pi/2000, edges
# dropped; max abs error of velocity [rad/s] and acceleration [rad/s^2].
# (measured: central 0.31 / 228, savgol 0.067 / 1.6, savgol_direct 0.048 / 1.6,
# butter 0.021 / 1.0)
BOUNDS = {
    "central": (0.4, 300.0),
    "savgol": (0.1, 2.5),
    "savgol_direct": (0.1, 2.5),
    "butter": (0.05, 2.0),
}


@pytest.mark.parametrize("method", METHODS)
def test_quantised_sine_error_below_bound(method: str) -> None:
    t = np.arange(0.0, 10.0, TS)
    w = 2 * np.pi * 1.0
    q = np.sin(w * t + 0.3)
    qq = np.round(q / DELTA) * DELTA
    d = Differentiator(method)
    k = d.edge_samples_at(TS)
    _, dq, ddq = d.derivatives(TS, qq)
    ev = np.abs(dq - w * np.cos(w * t + 0.3))[k:-k].max()
    ea = np.abs(ddq + w**2 * np.sin(w * t + 0.3))[k:-k].max()
    vmax, amax = BOUNDS[method]
    assert ev < vmax
    assert ea < amax
    if method != "central":
        # filtering gains a factor of > 50 on the acceleration
        assert ea < BOUNDS["central"][1] / 50 * 2


# ---------------------------------------------------------------------------
# one filter for positions, velocities, accelerations and other signals
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("method", METHODS)
def test_smooth_equals_filtered_position(method: str) -> None:
    rng = np.random.default_rng(0)
    x = rng.standard_normal((300, 2)).cumsum(axis=0)
    d = Differentiator(method)
    pos = d.derivatives(TS, x).position
    np.testing.assert_allclose(d.smooth(TS, x), pos, rtol=0, atol=1e-12)
    # columns are filtered independently, like 1-D signals
    np.testing.assert_allclose(d.smooth(TS, x[:, 1]), pos[:, 1], rtol=0, atol=1e-12)


@pytest.mark.parametrize("method", ["savgol", "butter", "central"])
def test_derivatives_are_differences_of_the_filtered_position(method: str) -> None:
    rng = np.random.default_rng(1)
    x = rng.standard_normal(400).cumsum()
    d = Differentiator(method)
    k = d.edge_samples_at(TS)
    pos, vel, acc = d.derivatives(TS, x)
    np.testing.assert_allclose(vel[k:-k], central_first(pos, TS)[k:-k], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(acc[k:-k], central_second(pos, TS)[k:-k], rtol=1e-7, atol=1e-6)


def test_savgol_consistent_but_savgol_direct_not() -> None:
    """Ratio of acceleration to velocity amplitude of a 2 Hz sine must be w."""
    t = np.arange(0.0, 4.0, TS)
    w = 2 * np.pi * 2.0
    q = np.sin(w * t)
    sl = slice(100, -100)

    def ratio(method: str) -> float:
        _, dq, ddq = Differentiator(method).derivatives(TS, q)
        return float(np.sqrt(np.mean(ddq[sl] ** 2) / np.mean(dq[sl] ** 2)) / w)

    assert abs(ratio("savgol") - 1.0) < 1e-3  # only the O(Ts^2) difference error
    assert abs(ratio("butter") - 1.0) < 1e-3
    assert abs(ratio("savgol_direct") - 1.0) > 5e-3  # deriv=1 and deriv=2 filters differ


# ---------------------------------------------------------------------------
# edges
# ---------------------------------------------------------------------------
def test_edge_samples() -> None:
    assert Differentiator("central").edge_samples == 1
    assert Differentiator("savgol", window=21).edge_samples == 10
    assert Differentiator("savgol_direct", window=31).edge_samples == 15
    b = Differentiator("butter", cutoff=10.0, order=4)
    assert b.edge_samples == b.edge_samples_at(0.005)
    assert b.edge_samples_at(0.001) > 3 * b.edge_samples_at(0.005)

    t = np.arange(0.0, 8.0, TS)
    w = 2 * np.pi * 1.5
    q = np.sin(w * t + 1.0) + 0.3 * t
    for d in (b, Differentiator("savgol")):
        k = d.edge_samples
        _, _, ddq = d.derivatives(TS, q)
        err = np.abs(ddq + w**2 * np.sin(w * t + 1.0))
        middle = err[len(t) // 4 : -len(t) // 4].max()
        assert err[k:-k].max() < 2.0 * middle + 1e-3  # past the edge: as good as the middle
        assert max(err[0], err[-1]) > 5.0 * middle  # the edges are really worse


# ---------------------------------------------------------------------------
# settings and errors
# ---------------------------------------------------------------------------
def test_defaults() -> None:
    assert DEFAULT_DIFFERENTIATOR.method == "savgol"
    assert (DEFAULT_DIFFERENTIATOR.window, DEFAULT_DIFFERENTIATOR.polyorder) == (21, 3)
    b = Differentiator("butter")
    assert (b.cutoff, b.order) == (10.0, 4)
    assert Differentiator("central").settings() == {"method": "central"}
    with pytest.raises(dataclasses.FrozenInstanceError):
        DEFAULT_DIFFERENTIATOR.window = 5  # type: ignore[misc]


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(method="spline"), "method"),
        (dict(method="savgol", window=20), "window"),
        (dict(method="savgol", window=2.5), "window"),
        (dict(method="savgol", window=5, polyorder=5), "polyorder"),
        (dict(method="savgol", polyorder=1), "polyorder"),
        (dict(method="savgol", window=101, polyorder=13), "polyorder must be at most 12"),
        (dict(method="butter", cutoff=-1.0), "cutoff"),
        (dict(method="butter", order=0), "order"),
        (dict(method="butter", window=21), "window"),
        (dict(method="central", cutoff=5.0), "cutoff"),
    ],
)
def test_bad_settings_name_the_field(kwargs: dict, word: str) -> None:
    with pytest.raises(InputError, match=word):
        Differentiator(**kwargs)


def test_bad_call_arguments() -> None:
    q = np.sin(_time(100))
    with pytest.raises(InputError, match="Ts"):
        DEFAULT_DIFFERENTIATOR.derivatives(0.0, q)
    with pytest.raises(InputError, match="Ts"):
        DEFAULT_DIFFERENTIATOR.smooth(-0.005, q)
    bad = q.copy()
    bad[37] = np.nan
    with pytest.raises(InputError, match=r"q contains NaN.*sample 37"):
        DEFAULT_DIFFERENTIATOR.derivatives(TS, bad)
    with pytest.raises(InputError, match=r"x contains NaN"):
        DEFAULT_DIFFERENTIATOR.smooth(TS, bad)
    with pytest.raises(InputError, match="too few.*at least 21"):
        DEFAULT_DIFFERENTIATOR.derivatives(TS, q[:20])
    with pytest.raises(InputError, match="at least 4"):
        Differentiator("central").derivatives(TS, q[:3])
    with pytest.raises(InputError, match="samples"):
        Differentiator("butter").derivatives(TS, q[:10])
    with pytest.raises(InputError, match="cutoff.*Nyquist"):
        Differentiator("butter", cutoff=120.0).derivatives(TS, q)
    with pytest.raises(InputError, match="scalar"):
        DEFAULT_DIFFERENTIATOR.derivatives(TS, 1.0)
