"""Tests of iwp.lsq: exactness, numerical stability, rank deficiency, honest uncertainty."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.signal import fftconvolve

from iwp.errors import IdentificationError, InputError
from iwp.ident.covariance import correlation_messages, hac_bandwidth
from iwp.ident.fit_parameters import Parameter
from iwp.ident.lsq import (
    LeastSquaresOptions,
    LeastSquaresResult,
    solve_least_squares,
    stack_rows,
)

TS = 0.005
TRUE = dict(p1=26.76, sa1=0.12, sv1=0.76, sb1=0.058, p2=0.0054, p3=0.0284, p2r=2.606, p3r=7.139)


def _paper_signals(n: int = 1500):
    """Smooth, well exciting signals for the set-up (10)-(12)."""
    t = np.arange(n) * TS
    q1 = 1.2 * np.sin(2 * np.pi * 0.8 * t) + 0.4 * np.sin(2 * np.pi * 0.23 * t + 0.5)
    q3 = 1.2 * 2 * np.pi * 0.8 * np.cos(2 * np.pi * 0.8 * t) + 0.4 * 2 * np.pi * 0.23 * np.cos(
        2 * np.pi * 0.23 * t + 0.5
    )
    q4 = 30 * np.sin(2 * np.pi * 0.5 * t + 1.0) + 10 * np.sin(2 * np.pi * 1.7 * t)
    u = 60 * np.sin((3.0 + t / 100) * t)
    return q1, q3, q4, u


def _paper_blocks(q1, q3, q4, u):
    s1, c1 = np.sin(q1), np.abs(np.cos(q1))
    common = {"p1": -s1, "sa1": -c1 * q3, "sv1": -q3, "sb1": -(q3**3)}
    cols3 = {**common, "p2": q4, "p3": -u}
    cols4 = {**{k: -v for k, v in common.items()}, "p2r": -q4, "p3r": u}
    dq3 = sum(TRUE[k] * v for k, v in cols3.items())
    dq4 = sum(TRUE[k] * v for k, v in cols4.items())
    return cols3, dq3, cols4, dq4


# ---------------------------------------------------------------------------
# exactness and stability
# ---------------------------------------------------------------------------
def test_recovers_exact_parameters_from_noise_free_paper_setup() -> None:
    cols3, dq3, cols4, dq4 = _paper_blocks(*_paper_signals())
    system = stack_rows((cols3, dq3), (cols4, dq4), labels=("q3", "q4"))
    assert system.names == tuple(TRUE)
    assert system.Phi.shape == (3000, 8)
    # zeros of (11): p2, p3 only in q3 rows, p2r, p3r only in q4 rows
    assert np.all(system.Phi[1500:, 4] == 0) and np.all(system.Phi[:1500, 6] == 0)
    for cov in ("hac", "ols"):
        for weights in ("blocks", "none"):
            res = system.solve(options=LeastSquaresOptions(covariance=cov, weights=weights))
            assert res.success and res.rank == 8
            for name, value in TRUE.items():
                assert res.value(name) == pytest.approx(value, rel=1e-8)
                assert res[name].stderr < 1e-8 * max(1.0, abs(value))
            assert res.n_samples == 1500 and res.n_equations == 3000 and res.dof == 2992
            assert set(res.residual_rms) == {"q3", "q4"}
            assert max(res.residual_rms.values()) < 1e-9


def test_ill_conditioned_full_rank_is_solved_stably() -> None:
    rng = np.random.default_rng(5)
    n, p = 400, 5
    Q1, _ = np.linalg.qr(rng.standard_normal((n, p)))
    Q2, _ = np.linalg.qr(rng.standard_normal((p, p)))
    X = Q1 @ np.diag(np.logspace(0, -7, p)) @ Q2.T  # condition number 1e7
    theta = np.array([1.0, -2.0, 3.0, 0.5, -1.5])
    y = X @ theta
    res = solve_least_squares(X, y, ["a", "b", "c", "d", "e"], options=LeastSquaresOptions(covariance="ols", cond_warn=1e6))
    assert 1e6 < res.condition_number < 1e8
    assert res.success and res.rank == 5
    assert any("condition number" in w for w in res.warnings)
    err_svd = np.abs(res.values - theta).max()
    # the normal equations of (13) square the condition number (1e14): ~14 digits lost
    err_normal = np.abs(np.linalg.solve(X.T @ X, X.T @ y) - theta).max()
    assert err_svd < 1e-8
    assert err_normal > 1e-4
    # with the default threshold (1e8) no conditioning warning
    assert not any("condition number" in w for w in solve_least_squares(X, y, list("abcde")).warnings)


def test_column_scaling_handles_wildly_different_units() -> None:
    rng = np.random.default_rng(2)
    X = rng.standard_normal((300, 3)) * np.array([1e-6, 1.0, 1e6])
    theta = np.array([3e5, 2.0, -4e-7])
    res = solve_least_squares(X, X @ theta, ["a", "b", "c"])
    np.testing.assert_allclose(res.values, theta, rtol=1e-10)
    assert res.condition_number < 10
    assert not res.warnings


# ---------------------------------------------------------------------------
# rank deficiency and bad input
# ---------------------------------------------------------------------------
def test_rank_deficient_regressor_raises_naming_the_collinear_columns() -> None:
    q1, q3, q4, u = _paper_signals(600)
    X = np.column_stack([q4, -u, q3, 2.5 * q4])  # p2r column is a multiple of p2's
    y = X @ np.array([1.0, 2.0, 3.0, 4.0])
    names = ["p2", "p3", "sv1", "p2r"]
    with pytest.raises(IdentificationError) as info:
        solve_least_squares(X, y, names)
    msg = str(info.value)
    assert "rank" in msg and "p2," in msg and "p2r" in msg
    assert "p3" not in msg and "sv1" not in msg

    res = solve_least_squares(X, y, names, options=LeastSquaresOptions(allow_rank_deficient=True))
    assert not res.success and res.rank == 3
    assert np.isnan(res["p2"].stderr) and np.isnan(res["p2r"].stderr)
    assert np.isfinite(res["p3"].stderr) and np.isfinite(res["sv1"].stderr)
    assert res.value("p3") == pytest.approx(2.0, rel=1e-9)
    assert res.value("sv1") == pytest.approx(3.0, rel=1e-9)
    # the identifiable combination is still right: p2 + 2.5 p2r = 11
    assert res.value("p2") + 2.5 * res.value("p2r") == pytest.approx(11.0, rel=1e-9)
    assert any("collinear" in w for w in res.warnings)
    json.dumps(res.to_dict())  # NaN becomes null


def test_zero_column_and_three_way_collinearity_are_named() -> None:
    rng = np.random.default_rng(3)
    a, b, c = rng.standard_normal((3, 200))
    X = np.column_stack([a, b, a + b, c])
    with pytest.raises(IdentificationError) as info:
        solve_least_squares(X, X @ np.ones(4), ["x", "y", "z", "w"])
    named = str(info.value).split("columns ")[1].split(" are")[0]
    assert sorted(named.split(", ")) == ["x", "y", "z"]
    X0 = np.column_stack([a, np.zeros(200), c])
    with pytest.raises(IdentificationError, match="column zero_col is"):
        solve_least_squares(X0, a + c, ["a", "zero_col", "c"])


def test_nan_and_shape_errors_name_the_culprit() -> None:
    X = np.ones((50, 2))
    X[:, 1] = np.arange(50)
    y = X @ [1.0, 2.0]
    Xb = X.copy()
    Xb[17, 1] = np.inf
    Xb[30, 0] = np.nan
    with pytest.raises(InputError, match=r"column 'slope'.*row 17"):
        solve_least_squares(Xb, y, ["offset", "slope"])
    yb = y.copy()
    yb[9] = np.nan
    with pytest.raises(InputError, match=r"phi \(the target\).*row 9"):
        solve_least_squares(X, yb, ["offset", "slope"])
    with pytest.raises(InputError, match="names"):
        solve_least_squares(X, y, ["only_one"])
    with pytest.raises(InputError, match="unique"):
        solve_least_squares(X, y, ["a", "a"])
    with pytest.raises(InputError, match="phi"):
        solve_least_squares(X, y[:-1], ["a", "b"])
    with pytest.raises(InputError, match="covariance"):
        solve_least_squares(X, y, ["a", "b"], options=LeastSquaresOptions(covariance="white"))
    with pytest.raises(InputError, match="bandwidth"):
        solve_least_squares(X, y, ["a", "b"], options=LeastSquaresOptions(bandwidth=-3))
    with pytest.raises(InputError, match="weights"):
        solve_least_squares(X, y, ["a", "b"], options=LeastSquaresOptions(weights="equal"))
    with pytest.raises(InputError, match="more equations"):
        solve_least_squares(X[:2], y[:2], ["a", "b"])
    with pytest.raises(InputError, match="fixed"):
        solve_least_squares(X, y, ["a", "b"], fixed={"c": 1.0})


# ---------------------------------------------------------------------------
# honest uncertainty (Monte Carlo, vectorised noise generation)
# ---------------------------------------------------------------------------
def _regressor(n: int) -> np.ndarray:
    t = np.arange(n) * TS
    return np.column_stack([np.sin(2 * np.pi * 0.8 * t), np.cos(2 * np.pi * 1.3 * t) + 0.2, np.ones(n)])


THETA = np.array([2.0, -1.0, 0.5])
NAMES = ["a", "b", "c"]


def _monte_carlo(X: np.ndarray, E: np.ndarray, **kwargs) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    est, se, covered = [], [], []
    for e in E:
        res = solve_least_squares(X, X @ THETA + e, NAMES, options=LeastSquaresOptions(**kwargs))
        est.append(res.values)
        se.append(res.stderr)
        covered.append([res[n].ci95_low <= t <= res[n].ci95_high for n, t in zip(NAMES, THETA)])
    return np.array(est), np.array(se), np.array(covered)


def test_ols_stderr_and_coverage_with_white_noise() -> None:
    rng = np.random.default_rng(11)
    R, n = 300, 400
    X = _regressor(n)
    E = 0.3 * rng.standard_normal((R, n))
    est, se, covered = _monte_carlo(X, E, covariance="ols")
    ratio = se.mean(axis=0) / est.std(axis=0)
    assert np.all(np.abs(ratio - 1.0) < 0.15), ratio
    cov = covered.mean(axis=0)
    assert abs(covered.mean() - 0.95) <= 0.03, cov  # pooled over the 3 parameters
    assert np.all(np.abs(cov - 0.95) <= 0.04), cov
    assert np.abs(est.mean(axis=0) - THETA).max() < 4 * est.std(axis=0).max() / np.sqrt(R)


def test_hac_covers_with_moving_average_noise_where_ols_does_not() -> None:
    """White noise through a 21-sample moving average (the correlation length of
    the default Savitzky-Golay window): OLS intervals are ~4x too narrow."""
    rng = np.random.default_rng(12)
    R, n, m = 300, 3000, 21
    X = _regressor(n)
    E = fftconvolve(rng.standard_normal((R, n + m - 1)), np.ones((1, m)) / np.sqrt(m), mode="valid", axes=1)
    _, _, cov_ols = _monte_carlo(X, E, covariance="ols")
    _, _, cov_hac = _monte_carlo(X, E, covariance="hac")
    assert np.all(cov_ols.mean(axis=0) < 0.6), cov_ols.mean(axis=0)
    assert np.all(np.abs(cov_hac.mean(axis=0) - 0.95) <= 0.04), cov_hac.mean(axis=0)
    # pooled over the three parameters the coverage is close to nominal
    assert abs(cov_hac.mean() - 0.95) <= 0.025


def test_hac_treats_rows_of_one_sample_jointly() -> None:
    """Two blocks with the *same* noise carry the information of one: the HAC
    stderr (joint per sample) is sqrt(2) times the naive OLS one."""
    rng = np.random.default_rng(13)
    n = 4000
    X = _regressor(n)
    e = rng.standard_normal(n)
    system = stack_rows((X, X @ THETA + e), (X, X @ THETA + e), names=NAMES)
    hac = system.solve(options=LeastSquaresOptions(covariance="hac", weights="none", bandwidth=0))
    ols = system.solve(options=LeastSquaresOptions(covariance="ols", weights="none"))
    np.testing.assert_allclose(hac.stderr / ols.stderr, np.sqrt(2.0), rtol=0.03)
    assert hac.n_samples == n and hac.n_equations == 2 * n


def test_block_weighting_helps_when_noise_levels_differ_100x() -> None:
    rng = np.random.default_rng(14)
    R, n = 60, 800
    X = _regressor(n)
    X2 = X * np.array([1.0, -1.0, 0.5])  # second equation block sees the same parameters
    est_w, est_u, se_w, se_u, sig = [], [], [], [], []
    noise = rng.standard_normal((R, 2, n)) * np.array([0.01, 1.0])[None, :, None]
    for e in noise:
        system = stack_rows((X, X @ THETA + e[0]), (X2, X2 @ THETA + e[1]), labels=("q3", "q4"), names=NAMES)
        w = system.solve(options=LeastSquaresOptions(weights="blocks", covariance="ols"))
        u = system.solve(options=LeastSquaresOptions(weights="none", covariance="ols"))
        est_w.append(w.values)
        est_u.append(u.values)
        se_w.append(w.stderr)
        se_u.append(u.stderr)
        sig.append([w.block_sigma["q3"], w.block_sigma["q4"]])
    se_w, se_u = np.array(se_w).mean(axis=0), np.array(se_u).mean(axis=0)
    assert np.all(se_w < 0.2 * se_u), (se_w, se_u)
    assert np.all(np.std(est_w, axis=0) < 0.2 * np.std(est_u, axis=0))
    # the weighted stderr is honest
    np.testing.assert_allclose(se_w / np.std(est_w, axis=0), 1.0, atol=0.25)
    np.testing.assert_allclose(np.mean(sig, axis=0), [0.01, 1.0], rtol=0.05)


# ---------------------------------------------------------------------------
# result object, helpers
# ---------------------------------------------------------------------------
def test_result_access_export_and_summary() -> None:
    rng = np.random.default_rng(15)
    cols3, dq3, cols4, dq4 = _paper_blocks(*_paper_signals(1200))
    system = stack_rows(
        (cols3, dq3 + 0.05 * rng.standard_normal(1200)),
        (cols4, dq4 + 5.0 * rng.standard_normal(1200)),
        labels=("q3", "q4"),
    )
    res = system.solve()
    assert isinstance(res, LeastSquaresResult)
    p = res["p3r"]
    assert isinstance(p, Parameter) and p.name == "p3r" and not p.fixed
    assert p.ci95_low < p.value < p.ci95_high
    assert p.ci95_high - p.value == pytest.approx(res.critical_value * p.stderr)
    assert res.ci95("p3r") == (p.ci95_low, p.ci95_high)
    assert "p1" in res and "nope" not in res
    with pytest.raises(KeyError, match="nope"):
        res["nope"]
    assert res.covariance.shape == (8, 8) and res.correlation.shape == (8, 8)
    np.testing.assert_allclose(np.diag(res.correlation), 1.0)
    np.testing.assert_allclose(res.stderr, np.sqrt(np.diag(res.covariance)))
    assert res.block_sigma["q4"] > 30 * res.block_sigma["q3"]

    d = json.loads(json.dumps(res.to_dict()))
    assert set(d["parameters"]) == set(TRUE)
    assert set(d["parameters"]["p1"]) == {"value", "stderr", "ci95", "fixed"}
    assert d["samples"] == 1200 and d["equations"] == 2400
    assert set(d["residual_rms"]) == {"q3", "q4"}
    assert d["correlation"]["p1"]["p1"] == pytest.approx(1.0)
    assert d["covariance"] == "hac" and d["bandwidth"] >= 1

    text = res.summary()
    for name in TRUE:
        assert name in text
    assert "condition number" in text and "q4" in text


def test_strong_correlation_is_reported_by_name() -> None:
    rng = np.random.default_rng(16)
    a, b, c = rng.standard_normal((3, 2000))
    X = np.column_stack([a, a + 0.05 * b, c])  # columns 1 and 2 nearly equal
    res = solve_least_squares(X, X @ [1.0, 2.0, 3.0] + 0.1 * rng.standard_normal(2000), ["sv1", "sb1", "c"])
    assert res.correlation[0, 1] < -0.95
    assert abs(res.correlation[0, 2]) < 0.2
    (warning,) = [w for w in res.warnings if "correlated" in w]
    assert "sv1 & sb1 (r = -0.99" in warning
    assert "& c" not in warning and "c &" not in warning
    assert res.success  # a warning, not an error


def test_fixed_parameters_move_to_the_target() -> None:
    cols3, dq3, cols4, dq4 = _paper_blocks(*_paper_signals(800))
    system = stack_rows((cols3, dq3), (cols4, dq4))
    fixed = {k: TRUE[k] for k in ("p1", "sa1", "sv1", "sb1")}
    res = system.solve(fixed=fixed)
    for k in fixed:
        assert res[k].fixed and res[k].stderr == 0.0 and res.value(k) == TRUE[k]
    for k in ("p2", "p3", "p2r", "p3r"):
        assert res.value(k) == pytest.approx(TRUE[k], rel=1e-9)
    assert res.rank == 4


def test_stack_rows_layout() -> None:
    a = np.arange(4.0)
    system = stack_rows(
        ({"x": a, "c": 1.0}, a + 1),
        ({"y": 2 * a}, a, np.arange(10, 14)),
        labels=("first", "second"),
    )
    assert system.names == ("x", "c", "y")
    np.testing.assert_array_equal(system.Phi[:4], np.column_stack([a, np.ones(4), np.zeros(4)]))
    np.testing.assert_array_equal(system.Phi[4:], np.column_stack([np.zeros(4), np.zeros(4), 2 * a]))
    np.testing.assert_array_equal(system.phi, np.r_[a + 1, a])
    assert list(system.blocks) == ["first"] * 4 + ["second"] * 4
    np.testing.assert_array_equal(system.sample_index, np.r_[np.arange(4), np.arange(10, 14)])
    with pytest.raises(InputError, match="names"):
        stack_rows((np.ones((4, 2)), a)).solve()
    with pytest.raises(InputError, match="same form"):
        stack_rows(({"x": a}, a), (np.ones((4, 1)), a))
    with pytest.raises(InputError, match="column 'x'"):
        stack_rows(({"x": a[:3]}, a),)


def test_the_bandwidth_leaves_out_score_columns_that_overflow_or_are_not_finite():
    # the Andrews plug-in of the AR(1) fits overflows on scores of 1e200 (a near-diverged simulation's
    # sensitivities) and is undefined on a non-finite one: such a column is left out, never a NaN bandwidth
    rng = np.random.default_rng(0)
    H = rng.standard_normal((400, 3))
    H[:, 0] = np.convolve(rng.standard_normal(409), np.ones(10) / 10, "valid")  # autocorrelated: a longer lag
    alone = hac_bandwidth(H[:, [0, 2]])
    assert 0 < alone <= 100 and hac_bandwidth(H) != 0
    H[:, 1] *= 1e200
    assert hac_bandwidth(H) == alone
    H[:, 1] = 1.0
    H[5, 1] = np.inf
    assert hac_bandwidth(H) == alone
    H[:, [0, 2]] = np.nan
    assert hac_bandwidth(H) == 0  # nothing left to judge by


def _collinear_pair(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """Columns x and x + eps y: theta1 and theta2 alone are poorly determined, their sum is not."""
    rng = np.random.default_rng(5)
    x, y = rng.standard_normal((2, 1000))
    return np.column_stack([x, x + eps * y]), np.column_stack([x, eps * y])


def test_a_determined_sum_of_a_collinear_pair_is_given_with_its_standard_error() -> None:
    J, J_sum = _collinear_pair(1e-2)
    cov = np.linalg.inv(J.T @ J)
    msgs = correlation_messages(["a", "b"], np.array([2.0, 1.0]), cov, ["1/s", "1/s"], J)
    # the sum's standard error from the well-conditioned columns of (a + b, b)
    sd_sum = np.sqrt(np.linalg.inv(J_sum.T @ J_sum)[0, 0])
    assert len(msgs) == 1 and "a and b cannot be told apart" in msgs[0]
    assert f"a + b = 3 +- {sd_sum:.2g} is determined" in msgs[0], msgs


def test_a_sum_whose_variance_is_lost_in_rounding_is_not_called_determined() -> None:
    J, J_sum = _collinear_pair(1e-7)
    cov = np.linalg.inv(J.T @ J)  # entries near 1e11: the sum's variance (near 1e-3) is below their rounding
    msgs = correlation_messages(["a", "b"], np.array([2.0, 1.0]), cov, ["1/s", "1/s"], J)
    assert len(msgs) == 1 and "a and b cannot be told apart" in msgs[0]
    assert "determined" not in msgs[0] and "+-" not in msgs[0], msgs


def test_a_sum_known_no_better_than_its_value_is_not_called_determined() -> None:
    J, _ = _collinear_pair(1e-2)
    cov = np.linalg.inv(J.T @ J) * 1e4  # the sum's standard error near 3, its value 3
    msgs = correlation_messages(["a", "b"], np.array([2.0, 1.0]), cov, ["1/s", "1/s"], J)
    assert len(msgs) == 1 and "is determined" not in msgs[0], msgs
