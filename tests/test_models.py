import dataclasses
import math

import numpy as np
import pytest
from numba import njit

from iwp.errors import InputError
from iwp.models import (
    SINCOS_MAX,
    BeltParameters,
    Plant,
    dead_zone,
    dead_zone_output,
    energy,
    feedforward,
    linearize,
    table1,
    to_statespace,
)
from iwp.models.equations import rhs_of
from iwp.models.layout import M_PLAIN
from iwp.models.mathfn import EXP_VEC_MAX, exp_vec, log_vec, sincos
from tests.helpers import physical


def rhs(model, params, x, w, **options):
    """The right-hand side of ``model`` through its :class:`Plant`."""
    return Plant(params, model=model, **options).rhs(x, w)


def test_el_model_equals_state_space_model_6():
    """(4) with (3) in physical units and (6) in lumped parameters are the same dynamics."""
    ph = physical()
    lp = ph.to_lumped()
    rng = np.random.default_rng(1)
    for _ in range(50):
        x = rng.normal(size=4) * [2.0, 5.0, 4.0, 80.0]
        v = rng.uniform(-80, 80)
        a = rhs("el", ph, x, v, coulomb_eps=0.0)
        b = rhs("raw", lp, x, v, coulomb_eps=0.0)
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-9)


def test_compensated_raw_equals_model_9_outside_dead_zone():
    p = table1().replace(v_dz_pos=33.0, v_dz_neg=29.0)
    rng = np.random.default_rng(2)
    for _ in range(50):
        x = rng.normal(size=4) * [1.0, 1.0, 3.0, 50.0]
        u = rng.uniform(-100, 100)
        v = float(feedforward(u, 33.0, 29.0))
        np.testing.assert_allclose(rhs("raw", p, x, v), rhs("compensated", p, x, u), rtol=1e-13, atol=1e-12)


def test_dead_zone_and_feedforward():
    v = np.array([-50.0, -29.0, -10.0, 0.0, 10.0, 33.0, 50.0])
    np.testing.assert_array_equal(dead_zone(v, 33.0, 29.0), [-29, -29, -10, 0, 10, 33, 33])
    np.testing.assert_array_equal(dead_zone_output(v, 33.0, 29.0), [-21, 0, 0, 0, 0, 0, 17])
    np.testing.assert_array_equal(feedforward([-5.0, 0.0, 5.0], 33.0, 29.0), [-34.0, 0.0, 38.0])
    # the feedforward cancels the dead zone exactly: (7)-(8) into (5)
    u = np.linspace(-100, 100, 2001)
    np.testing.assert_allclose(dead_zone_output(feedforward(u, 33.0, 29.0), 33.0, 29.0), u, atol=1e-12)


def test_model_14_is_model_9_row_with_pendulum_at_rest():
    p = table1().replace(sigma_c2=0.16)
    x = np.array([0.0, 0.3, 0.0, 40.0])
    md = rhs("motor-disk", p, x, 25.0, coulomb_eps=0.0)
    assert md[3] == pytest.approx((1 + p.rho) * (-p.p2 * 40.0 + p.p3 * 25.0 - p.sigma_c2))
    assert md[0] == md[2] == 0.0
    full = rhs("compensated", p, x, 25.0, coulomb_eps=0.0)
    assert md[3] == pytest.approx(full[3])


@pytest.mark.parametrize("eq,q1", [("down", 0.0), ("up", math.pi)])
def test_linearization_matches_finite_difference_jacobian(eq, q1):
    p = table1()
    A, B = linearize(p, eq)
    x0 = np.array([q1, 0.0, 0.0, 0.0])
    h = 1e-6
    J = np.zeros((4, 4))
    for i in range(4):
        e = np.zeros(4)
        e[i] = h
        J[:, i] = (rhs("compensated", p, x0 + e, 0.0) - rhs("compensated", p, x0 - e, 0.0)) / (2 * h)
    Bn = (rhs("compensated", p, x0, h) - rhs("compensated", p, x0, -h)) / (2 * h)
    np.testing.assert_allclose(A, J, rtol=1e-7, atol=1e-7)
    np.testing.assert_allclose(B[:, 0], Bn, rtol=1e-7, atol=1e-9)


def test_linearization_eigenvalues():
    p = table1().replace(p2=0.0, sigma_a1=0.0, sigma_v1=0.0, sigma_b1=0.0)
    ev = np.linalg.eigvals(linearize(p, "down")[0])
    assert np.max(np.abs(ev.imag)) == pytest.approx(math.sqrt(p.p1), rel=1e-12)
    ev_up = np.linalg.eigvals(linearize(p, "up")[0])
    assert np.max(ev_up.real) == pytest.approx(math.sqrt(p.p1), rel=1e-12)  # the upright is a saddle


def test_statespace_conversion():
    ss = to_statespace(table1(), "up")
    A, B = linearize(table1(), "up")
    np.testing.assert_array_equal(ss.A, A)
    np.testing.assert_array_equal(ss.B, B)


def test_energy_lumped_and_physical_agree():
    ph = physical()
    lp = ph.to_lumped()
    x = np.array([0.7, 0.0, 1.3, -20.0])
    e_ph = energy(ph, x)
    e_lp = energy(lp, x)
    assert e_ph["total"] / ph.I1_hat == pytest.approx(float(e_lp["total"]), rel=1e-12)


def test_rhs_rejects_bad_arguments():
    with pytest.raises(InputError, match="unknown model 'foo'"):
        rhs("foo", table1(), np.zeros(4), 0.0)
    with pytest.raises(InputError, match="shape"):
        rhs("compensated", table1(), np.zeros(3), 0.0)
    with pytest.raises(InputError, match="belt=BeltParameters"):
        rhs("belt", table1(), np.zeros(6), 0.0)
    with pytest.raises(InputError, match="PhysicalParameters"):
        rhs("el", table1(), np.zeros(4), 0.0)
    rhs("belt", table1(), np.zeros(6), 0.0, belt=BeltParameters())


@njit(cache=False)
def _sincos_many(x):
    S = np.empty_like(x)
    C = np.empty_like(x)
    for i in range(x.size):
        S[i], C[i] = sincos(x[i])
    return S, C


def test_sincos_matches_libm_to_two_ulp():
    """The polynomial sin/cos of the right-hand sides (fdlibm's kernels) against numpy's."""
    rng = np.random.default_rng(3)
    x = np.concatenate([np.linspace(-60.0, 60.0, 400_001), rng.uniform(-1e4, 1e4, 100_000),
                        rng.uniform(-SINCOS_MAX, SINCOS_MAX, 100_000), np.arange(-40, 41) * (math.pi / 2),
                        [0.0, 1e-300, -1e-300, 5e-324]])
    S, C = _sincos_many(x)
    # one ulp of 1: a reassociated reduction or a wrong coefficient is off by far more
    assert np.max(np.abs(S - np.sin(x))) <= 2.3e-16
    assert np.max(np.abs(C - np.cos(x))) <= 2.3e-16
    where = np.abs(np.sin(x)) > 1e-3
    assert np.max(np.abs(S - np.sin(x))[where] / np.spacing(np.abs(np.sin(x)))[where]) <= 2.0
    S, C = _sincos_many(np.array([np.inf, -np.inf, np.nan, 2 * SINCOS_MAX]))
    assert np.all(np.isnan(S)) and np.all(np.isnan(C))


@njit(cache=False)
def _log_exp_many(x, y):
    L = np.empty_like(x)
    E = np.empty_like(y)
    for i in range(x.size):
        L[i] = log_vec(x[i])
    for i in range(y.size):
        E[i] = exp_vec(y[i])
    return L, E


def test_vectorisable_log_and_exp_match_libm():
    """The step-size controller's logarithm and exponential (exponent from the bits, a series on the rest)."""
    rng = np.random.default_rng(5)
    x = np.concatenate([np.exp(rng.uniform(-700.0, 700.0, 100_000)), rng.uniform(1e-13, 1.0, 100_000),
                        [1.0, 2.0, 0.5, math.sqrt(2.0), np.nextafter(math.sqrt(2.0), 2.0), 2.2250738585072014e-308,
                         1.7976931348623157e308]])
    y = np.concatenate([rng.uniform(-EXP_VEC_MAX, EXP_VEC_MAX, 100_000), rng.uniform(-5.0, 5.0, 100_000),
                        [0.0, -EXP_VEC_MAX, EXP_VEC_MAX]])
    L, E = _log_exp_many(x, y)
    # a few units in the last place: of ln x (absolute near ln 1 = 0), of exp y relative (the docstrings' claims)
    assert np.max(np.abs(L - np.log(x)) / np.maximum(np.abs(np.log(x)), 1.0)) <= 1e-15
    assert np.max(np.abs(E - np.exp(y)) / np.exp(y)) <= 4e-16
    assert L[x.size - 7] == 0.0 and E[y.size - 3] == 1.0
    # beyond its range the exponential saturates at exp(+-EXP_VEC_MAX)
    _, E = _log_exp_many(np.ones(1), np.array([-1e4, 1e4]))
    assert E[0] == pytest.approx(math.exp(-EXP_VEC_MAX), rel=1e-15) and E[1] == pytest.approx(math.exp(EXP_VEC_MAX),
                                                                                               rel=1e-15)


@njit(cache=False)
def _rhs_plain(x, w, P, dx):
    rhs_of(M_PLAIN, x, w, P, dx)


def test_plain_rhs_is_model_9():
    """M_PLAIN (model (9) compiled without its optional terms) gives model (9)'s derivatives."""
    p = table1()
    P = Plant(p).packed()
    rng = np.random.default_rng(4)
    for _ in range(50):
        x = rng.normal(size=4) * [2.0, 5.0, 4.0, 80.0]
        u = rng.uniform(-80, 80)
        dx = np.empty(4)
        _rhs_plain(x, u, P, dx)
        np.testing.assert_allclose(dx, rhs("compensated", p, x, u), rtol=1e-14, atol=1e-12)


def test_free_pendulum_models_are_model_9_with_the_wheel_held_or_absent():
    """Section 5.2: q3' = -xi rho/(1 + rho) with the wheel held to the arm (q2'' = 0 in (4)), -xi without it."""
    p = table1()
    rng = np.random.default_rng(5)
    for _ in range(20):
        q1, q3 = rng.uniform(-3, 3), rng.uniform(-8, 8)
        x = np.array([q1, 0.4, q3, 0.0])
        full = rhs("compensated", p, x, 0.0)  # q4 = 0 and u = 0: q3' = -xi, q4' = xi
        xi = -full[2]
        held = rhs("free", p, x, 0.0)
        # (4a) with q2'' = 0: q3' = q3'(9) + q4'(9)/(1 + rho) at q4 = 0
        assert held[2] == pytest.approx(full[2] + full[3] / (1 + p.rho), rel=1e-13, abs=1e-12)
        assert held[2] == pytest.approx(-xi * p.rho / (1 + p.rho), rel=1e-13, abs=1e-12)
        nowheel = rhs("free-nowheel", p, x, 0.0)
        assert nowheel[2] == pytest.approx(-xi, rel=1e-13, abs=1e-12)
        assert held[1] == held[3] == nowheel[1] == nowheel[3] == 0.0
        assert held[0] == nowheel[0] == q3


def test_plant_checks_its_options():
    with pytest.raises(InputError, match="locked=True applies"):
        Plant(table1(), model="free", locked=True)
    with pytest.raises(InputError, match="coulomb_eps"):
        Plant(table1(), coulomb_eps=-1.0)
    plant = Plant(physical(), model="compensated")  # physical parameters map to lumped ones (section 4)
    assert plant.params == physical().to_lumped()
    assert Plant(table1(), model="raw").dead_zone_active and not Plant(table1()).dead_zone_active
    assert not Plant(table1()).packed().flags.writeable


def test_the_compiled_dispatch_knows_every_model_of_the_registry_and_nothing_else():
    """The compiled dispatch (equations.rhs) is kept in step with MODELS by hand: every model's code has its
    branch (finite derivatives at a generic state), a code that no model has gives NaN, not model (9)'s law."""
    from iwp.models import MODELS, BeltParameters
    from iwp.models.equations import rhs as compiled
    from iwp.models.layout import BELT_CODES, N_PACK

    x6 = np.array([0.3, 0.1, -0.2, 1.5, 0.01, 0.2])
    lp = table1()
    for name, info in MODELS.items():
        params = physical() if info.physical else lp
        belt = BeltParameters.from_rigid(lp.p2 * lp.rho, lp.p3 * lp.rho, k_over_I2=250.0, d=2.0, N=13.5,
                                         b2_over_I2=0.5) if info.drive == "belt" else None
        plant = Plant(params, model=name, belt=belt)
        dx = plant.rhs(x6[:info.n_states], 20.0)
        assert np.all(np.isfinite(dx)) and np.any(dx != 0.0), name
        moving = set(info.moving)
        assert all(dx[i] == 0.0 for i in range(info.n_states) if i not in moving), name
    # the compiled code's belt models (the play's guards, the belt's parameters packed) are those declaring the belt
    assert set(BELT_CODES) == {info.code for info in MODELS.values() if info.drive == "belt"}
    assert all(info.n_states == (6 if info.drive == "belt" else 4) for info in MODELS.values())
    unknown = max(m.code for m in MODELS.values()) + 100
    dx = np.zeros(4)
    compiled(unknown, x6[:4].copy(), 20.0, np.zeros(N_PACK), dx)
    assert np.all(np.isnan(dx))


def test_the_compiled_switching_surfaces_are_those_each_model_declares():
    """Each model declares its switching surfaces by family (ModelInfo.surfaces, guards.SURFACES); the compiled
    guards the engine calls find exactly those (the kinks where sigma_a1 is not 0, the play where its width d is
    not 0), the surfaces' codes are distinct, and the engine reads the rate exactly for those declared to."""
    from iwp.models import MODELS, BeltParameters
    from iwp.models.guards import SURFACES, guard_needs_rate, has_branches, has_kink

    lp = table1()
    belt = BeltParameters.from_rigid(lp.p2 * lp.rho, lp.p3 * lp.rho, k_over_I2=250.0, d=0.1, N=13.5, b2_over_I2=0.5)
    codes = [s.which for family in SURFACES.values() for s in family.surfaces.values()]
    assert len(set(codes)) == len(codes)
    assert {family.kind for family in SURFACES.values()} == {"predicted", "held mode"}
    for name, info in MODELS.items():
        for active in (True, False):
            if info.physical:
                params = physical() if active else dataclasses.replace(physical(), sigma_r=0.0)
            else:
                params = lp if active else lp.replace(sigma_a1=0.0)
            b = None if info.drive is None else (belt if active else BeltParameters(**{**belt.to_dict(), "d": 0.0}))
            P = tuple(Plant(params, model=name, belt=b).packed())
            assert bool(has_kink(info.code, P)) == (active and "kinks" in info.surfaces), (name, active)
            assert bool(has_branches(info.code, P)) == (active and "play" in info.surfaces), (name, active)
        for family in info.surfaces:
            for surface in SURFACES[family].surfaces.values():
                assert bool(guard_needs_rate(info.code, surface.which)) == surface.reads_rate, (name, surface)
    with pytest.raises(InputError, match="unknown switching surfaces"):
        dataclasses.replace(MODELS["compensated"], surfaces=("stiction",))
