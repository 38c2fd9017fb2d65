"""Hopf amplitude design (section 5.3), continuation, LQR and swing-up (iwp.control)."""

import json
import math

import numpy as np
import pytest

from iwp.cli import main
from iwp.control import (
    LQRBalance,
    RigConditions,
    closed_loop_matrix,
    continue_hopf,
    design_hopf,
    find_orbit,
    hopf_point,
    lqr_balance,
    pendulum_energy,
    simulated_amplitude,
    swing_up,
)
from iwp.errors import InputError
from iwp.models import Plant, linearize, table1
from iwp.plotting import plot_branch_details, savefig
from iwp.sim import CallableController, Feedforward, HopfController, SimOptions, simulate

P = table1()


@pytest.fixture(scope="module")
def branch():
    return continue_hopf(P, 0.1)


# --------------------------------------------------------------------------
# Hopf point and first Lyapunov coefficient
# --------------------------------------------------------------------------
def _max_real_full(k1):
    """Largest real part of the full 4-state closed loop, without the q2 zero eigenvalue."""
    A, B = linearize(P, "down")
    K = np.array([[0.0, 0.0, k1, 0.0]])
    ev = np.linalg.eigvals(A + B @ K)
    ev = ev[np.abs(ev) > 1e-9]
    return ev[np.argmax(ev.real)]


def test_hopf_point_against_eigenvalues():
    hp = hopf_point(P, 0.1)
    # independent bisection on the eigenvalues of the full linearisation
    lo, hi = -5.0, 0.0
    assert _max_real_full(lo).real > 0 > _max_real_full(hi).real
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        if _max_real_full(mid).real > 0:
            lo = mid
        else:
            hi = mid
    assert hp.k1 == pytest.approx(0.5 * (lo + hi), abs=1e-9)
    assert hp.k1 == pytest.approx(-0.94466, abs=1e-5)
    lam = _max_real_full(hp.k1)
    assert abs(lam.real) < 1e-9
    assert hp.omega == pytest.approx(abs(lam.imag), rel=1e-9)
    assert hp.period == pytest.approx(2 * math.pi / hp.omega)
    # crossing: stable above k1*, unstable below; transversality has the sign of it
    assert hp.dmu_dk1 < 0
    for d in (1e-3, 1e-1):
        assert _max_real_full(hp.k1 + d).real < 0 < _max_real_full(hp.k1 - d).real
    ev = np.linalg.eigvals(closed_loop_matrix(P, hp.k1))
    assert np.min(np.abs(ev - 1j * hp.omega)) < 1e-9


def test_first_lyapunov_coefficient_sign_set_by_k2():
    h1, h0, hm = hopf_point(P, 0.1), hopf_point(P, 0.0), hopf_point(P, -0.1)
    assert h1.l1 < 0 and h1.criticality == "supercritical" and h1.orbit_side == -1
    assert hm.l1 > 0 and hm.criticality == "subcritical" and hm.orbit_side == +1
    # l1 is affine in k2 and vanishes at k2_critical
    assert h1.l1 - h0.l1 == pytest.approx(0.1 * h1.l1_slope, rel=1e-6)
    assert h1.k2_critical == pytest.approx(-0.02199, abs=2e-5)
    hc = hopf_point(P, h1.k2_critical)
    assert abs(hc.l1) < 1e-9 * abs(h1.l1_slope) * 1e3
    # k1* does not depend on k2
    assert h1.k1 == pytest.approx(hm.k1, abs=1e-12)


def test_small_amplitude_prediction_matches_continuation(branch):
    hp = branch.hopf
    # near the Hopf point the normal form predicts k1(A) to second order
    for a in (0.05, 0.1):
        k1 = np.interp(a, branch.amplitude, branch.k1)
        assert (k1 - hp.k1) == pytest.approx(hp.predicted_k1(a) - hp.k1, rel=0.03)
        assert hp.predicted_amplitude(k1) == pytest.approx(a, rel=0.02)
    assert np.isnan(hp.predicted_amplitude(hp.k1 + 0.5))  # no orbit on the stable side


# --------------------------------------------------------------------------
# Continuation against long simulations
# --------------------------------------------------------------------------
def test_branch_shape_and_stability(branch):
    assert branch.k1[0] == branch.hopf.k1 and branch.amplitude[0] == 0
    assert np.all(np.diff(branch.k1) < 0) and np.all(np.diff(branch.amplitude) > 0)
    assert np.all(np.diff(branch.period) > 0)
    assert branch.period[0] == pytest.approx(branch.hopf.period)
    # trivial multiplier 1 along the branch
    triv = np.array([np.min(np.abs(m - 1)) for m in branch.floquet[1:]])
    assert np.max(triv) < 1e-3
    # stable up to a symmetry-breaking / fold (multiplier +1) near the upright
    assert branch.stable[1:20].all() and not branch.stable[-1]
    assert len(branch.bifurcations) == 1 and branch.bifurcations[0]["kind"] == "multiplier +1"
    assert 3.0 < branch.bifurcations[0]["amplitude"] < 3.1
    assert 3.0 < branch.stable_amplitude_range[1] < branch.bifurcations[0]["amplitude"]


@pytest.mark.parametrize("k1", [-2.0, -5.0, -10.0, -12.0])
def test_continuation_amplitude_against_long_simulation(branch, k1):
    orbit = find_orbit(P, k1, 0.1)
    assert orbit.stable
    a_branch = np.interp(-k1, -branch.k1, branch.amplitude)
    assert orbit.amplitude == pytest.approx(a_branch, rel=2e-3)
    sim = simulated_amplitude(P, k1, 0.1, t_end=600.0)  # from just off the bottom: slow growth near k1*
    assert not sim.rotating
    assert sim.amplitude == pytest.approx(orbit.amplitude, rel=0.01)
    assert sim.amplitude_min == pytest.approx(orbit.amplitude, rel=0.01)  # symmetric orbit
    assert sim.period == pytest.approx(orbit.period, rel=0.01)
    # much tighter in fact
    assert sim.amplitude == pytest.approx(orbit.amplitude, rel=1e-4)


def test_paper_gains_give_the_measured_amplitude():
    # section 5.3: k1 = -10, k2 = 0.1 -> the rig oscillates with max q1 ~ 2.58 rad
    orbit = find_orbit(P, -10.0, 0.1)
    assert orbit.amplitude == pytest.approx(2.58, abs=0.02)
    assert orbit.u_max < 100


def test_unstable_orbit_beyond_the_bifurcation_departs(branch):
    b = branch.bifurcations[0]
    orbit = find_orbit(P, b["k1"] - 0.15, 0.1)
    assert not orbit.stable and np.max(np.abs(orbit.floquet)) > 1.2
    # Past the multiplier +1 crossing the symmetric orbit is unstable along an antisymmetric mode (symmetry
    # breaking). Started 1e-4 beyond its positive turning point, the positive swings grow, the negative ones
    # shrink, and the pendulum goes over the top forwards (q1 = +pi), within 40 s (growth x2.06 per period).
    x0 = orbit.x0 * (1 + 1e-4)
    r = simulate(P, x0=x0, t_end=60.0, input=HopfController(orbit.k1, 0.1))
    over = np.flatnonzero(np.abs(r.q1) > math.pi)
    assert over.size > 0 and r.t[over[0]] < 40
    assert r.q1[over[0]] > math.pi
    q1, q3 = r.q1[: over[0]], r.q3[: over[0]]
    tops = q1[np.flatnonzero((q3[:-1] > 0) & (q3[1:] <= 0))]  # positive turning points
    bottoms = q1[np.flatnonzero((q3[:-1] < 0) & (q3[1:] >= 0))]  # negative turning points
    assert tops[-1] > orbit.amplitude + 0.02 and bottoms[-1] > -orbit.amplitude + 0.02


# --------------------------------------------------------------------------
# Inverse design
# --------------------------------------------------------------------------
@pytest.mark.parametrize("amplitude", [0.5, 1.0, 2.0, 2.58, 3.0])
def test_design_k1_gives_the_amplitude_in_simulation(amplitude):
    d = design_hopf(P, amplitude, k2=0.1)
    assert d.solved_for == "k1" and d.k2 == 0.1 and d.stable
    assert d.orbit.amplitude == pytest.approx(amplitude, abs=1e-9)
    # start off the orbit (5 % larger): the transient near the Hopf point is slow
    x0 = d.orbit.x0 * 1.05 if amplitude < 1 else None
    sim = simulated_amplitude(P, d.k1, d.k2, x0=x0, t_end=300.0)
    assert sim.amplitude == pytest.approx(amplitude, rel=0.02)
    assert sim.period == pytest.approx(d.period, rel=0.02)


def test_design_k2_for_given_k1():
    d = design_hopf(P, 2.58, k1=-10.0)
    assert d.solved_for == "k2" and d.k1 == -10.0
    assert d.k2 == pytest.approx(0.0993, abs=5e-4)
    sim = simulated_amplitude(P, d.k1, d.k2)
    assert sim.amplitude == pytest.approx(2.58, rel=0.02)


def test_design_with_sampled_controller_on_the_raw_model():
    # the rig's setting: raw model, dead zone compensated exactly, controller every 5 ms
    d = design_hopf(P, 2.0)
    sim = simulated_amplitude(Plant(P, model="raw"), d.k1, d.k2, controller_Ts=0.005, t_end=200.0,
                              options=SimOptions(feedforward=Feedforward.of_plant(P)))
    assert sim.amplitude == pytest.approx(2.0, rel=0.02)


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"amplitude": 3.139}, r"beyond the reach .* reachable 0 < amplitude <= 3\.1"),
        ({"amplitude": 3.09}, r"unstable .* stable up to an amplitude between 3\.05\d* and 3\.0\d* rad"),
        ({"amplitude": 1.0, "k2": -0.1}, "subcritical"),
        ({"amplitude": 3.5}, "below pi"),
        ({"amplitude": -1.0}, "amplitude must be > 0"),
        ({"amplitude": 1.0, "k1": -5.0, "k2": 0.1}, "not both"),
        ({"amplitude": 1.0, "k1": 0.0}, "below the Hopf point"),
    ],
)
def test_design_errors_name_the_argument(kwargs, match):
    with pytest.raises(InputError, match=match):
        design_hopf(P, **kwargs)


def test_design_subcritical_allowed_when_asked():
    d = design_hopf(P, 0.3, k2=-0.1, require_stable=False)
    assert not d.stable and d.k1 > hopf_point(P, -0.1).k1


def test_find_orbit_outside_the_branch():
    with pytest.raises(InputError, match="lies on the side"):
        find_orbit(P, 0.0, 0.1)


# --------------------------------------------------------------------------
# CLI
# --------------------------------------------------------------------------
def test_cli_design_hopf_json_checked_by_simulation(capsys):
    assert main(["design", "hopf", "--amplitude", "1.5", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["solved_for"] == "k1" and out["k2"] == 0.1 and out["stable"]
    sim = simulated_amplitude(P, out["k1"], out["k2"])
    assert sim.amplitude == pytest.approx(1.5, rel=0.02)
    assert sim.period == pytest.approx(out["period"], rel=0.02)


def test_cli_design_hopf_text_check_and_plot(tmp_path, capsys):
    fig = tmp_path / "bif.png"
    assert main(["design", "hopf", "--amplitude", "2.58", "--check", "--plot", str(fig)]) == 0
    text = capsys.readouterr().out
    assert "k1 = -10.04" in text and "check (300 s simulation)" in text
    assert fig.stat().st_size > 10_000
    # refuses to overwrite
    assert main(["design", "hopf", "--amplitude", "2.58", "--plot", str(fig)]) == 2


def test_cli_design_errors_are_one_line(capsys):
    assert main(["design", "hopf", "--amplitude", "3.139"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error: --amplitude = 3.139 rad is beyond the reach") and "\n" not in err


def test_cli_design_branch_csv(tmp_path, capsys):
    out = tmp_path / "branch.csv"
    assert main(["design", "branch", "--out", str(out), "--simulate", "2"]) == 0
    text = capsys.readouterr().out
    assert "stability change" in text and "simulation k1" in text
    data = np.loadtxt(out, delimiter=",", comments="#", skiprows=7)
    assert data.shape[1] == 9 and data[0, 1] == 0.0 and data[-1, 1] > 3.0


def test_bifurcation_figure(branch, tmp_path):
    h = branch.plot(simulations=([-5.0], [1.42]), design=design_hopf(P, 2.0))
    assert set(h) == {"figure", "axes", "lines", "markers"}
    assert len(h["markers"]) >= 3
    savefig(h["figure"], tmp_path / "b.png")
    h2 = plot_branch_details(branch)
    savefig(h2["figure"], tmp_path / "d.png")
    assert (tmp_path / "b.png").exists() and (tmp_path / "d.png").exists()


# --------------------------------------------------------------------------
# Balance: LQR
# --------------------------------------------------------------------------
def test_lqr_backends_agree_and_stabilise():
    for Ts in (None, 0.005):
        a = lqr_balance(P, Ts=Ts, backend="python-control")
        b = lqr_balance(P, Ts=Ts, backend="scipy")
        np.testing.assert_allclose(a.K, b.K, rtol=1e-6)
        if Ts is None:
            assert np.all(a.poles.real < 0)
        else:
            assert np.all(np.abs(a.poles) < 1)
    L = lqr_balance(P, Ts=0.005)
    assert L.unstable_eigenvalue == pytest.approx(math.sqrt(P.p1), rel=0.01)
    # capture bound: |w . B| u_max / lambda_u with w the left eigenvector of the reduced linearisation
    A, B = linearize(P, "up")
    r = [0, 2, 3]
    ev, W = np.linalg.eig(A[np.ix_(r, r)].T)
    i = np.argmax(ev.real)
    w = W[:, i].real / W[0, i].real
    assert L.capture_bound == pytest.approx(abs(w @ B[r, 0]) * 100 / ev[i].real, rel=1e-9)
    # the back-emf coupling makes it smaller than the rigid-pendulum estimate p3 u_max / p1
    assert L.capture_bound < P.p3 * 100 / P.p1
    assert L([math.pi, 0, 0, 0]) == 0.0
    assert abs(L([math.pi + 0.5, 0, 0, 0])) == L.u_max
    np.testing.assert_allclose(LQRBalance.error_state([3 * math.pi + 0.1, 0, 1, 2]), [0.1, 1, 2], atol=1e-12)
    with pytest.raises(InputError, match="Q must be"):
        lqr_balance(P, Q=(1, 2))


def test_lqr_balances_from_near_the_top_with_saturation():
    L = lqr_balance(P, Ts=0.005)
    r = simulate(P, x0=[math.pi + 0.03, 0, 0, 0], t_end=5.0, input=CallableController(lambda t, x: L(x), 0.005))
    assert abs(r.q1[-1] - math.pi) < 1e-3 and np.max(np.abs(r.u)) <= 100


def test_pendulum_energy():
    assert pendulum_energy(P, [math.pi, 0, 0, 50.0]) == pytest.approx(2 * P.p1)
    assert pendulum_energy(P, [0, 0, 2.0, -7.0]) == pytest.approx(2.0)


# --------------------------------------------------------------------------
# Swing-up and balance
# --------------------------------------------------------------------------
X0S = [[0, 0, 0, 0], [0.5, 0, 0, 0], [-1.0, 0, 2.0, 0], [0, 0, 0, 50.0], [2.0, 0, 0, -100.0]]


@pytest.mark.parametrize("x0", X0S)
def test_swingup_and_balance_ideal(x0):
    r = swing_up(P, x0=x0, t_end=20.0, rig=None)
    assert r.success and r.conditions == "ideal"
    assert r.t_catch < 15 and r.u_max <= 100 + 1e-9
    assert abs(r.theta[-1]) < 1e-3


@pytest.mark.parametrize("x0", X0S)
def test_swingup_and_balance_on_rig_conditions(x0):
    r = swing_up(P, x0=x0, t_end=20.0)  # dead zone 33/29 compensated by 31, 2000 counts, 5 ms, |u| <= 100
    res = r.result
    assert r.success and r.conditions == "rig", r.summary()
    assert r.t_catch < 15 and np.all(np.abs(res.u) <= 100 + 1e-9)
    assert np.max(np.abs(r.theta[res.t > 17])) < 0.02
    # the command is the feedforward of u with the single threshold 31
    nz = res.u != 0
    np.testing.assert_allclose(res.command[nz], res.u[nz] + 31 * np.sign(res.u[nz]))
    # the disk velocity stays bounded
    assert r.q4_max < 300


def test_swingup_with_less_authority_and_model_error():
    # |v| <= 100 on the driver means |u| <= 69 after the feedforward; plant 5 % off the model
    rig = RigConditions(u_max=69.0)
    r = swing_up(P, t_end=25.0, rig=rig, plant_params=P.replace(p1=P.p1 * 1.04, p3=P.p3 * 0.96))
    assert r.success and r.u_max <= 69 + 1e-9


def test_swingup_reports_failure():
    r = swing_up(P, t_end=3.0)
    assert not r.success and math.isnan(r.t_catch)


def test_swingup_cli_writes_csv_figure_gif(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["control", "swingup", "--out", str(out), "--t-end", "14", "--frames", "12"]) == 0
    assert "balanced" in capsys.readouterr().out
    for name in ("swingup.csv", "swingup.png", "swingup.gif", "swingup.json"):
        assert (out / name).stat().st_size > 0
    summary = json.loads((out / "swingup.json").read_text())
    assert summary["success"] and summary["conditions"] == "rig"
    from PIL import Image

    with Image.open(out / "swingup.gif") as im:
        assert im.n_frames == 12
    # existing files are refused without --force
    assert main(["control", "swingup", "--out", str(out), "--t-end", "1", "--no-animation"]) == 2
    assert main(["control", "swingup", "--out", str(out), "--t-end", "14", "--no-animation", "--force",
                 "--ideal"]) == 0


def test_cli_control_lqr(capsys):
    assert main(["control", "lqr", "--json"]) == 0
    d = json.loads(capsys.readouterr().out)
    assert len(d["K"]) == 3 and d["Ts"] == 0.005


def test_cli_swingup_bad_x0_is_refused_before_writing(tmp_path, capsys):
    out = tmp_path / "never"
    with pytest.raises(SystemExit) as e:  # refused while parsing, as in every command (one --x0 vocabulary)
        main(["control", "swingup", "--out", str(out), "--x0", "1,2"])
    err = capsys.readouterr().err
    assert e.value.code == 2 and "argument --x0: expected Q1 or Q1,Q2,Q3,Q4, got 2 numbers" in err and not out.exists()


def test_json_output_is_strict_json_without_nan(tmp_path, capsys):
    # a value that is not defined is null: NaN is not JSON (jq and browsers refuse it)
    def strict(text):
        return json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in the JSON output"))

    assert main(["design", "hopf", "--amplitude", "2", "--k1", "-20", "--json"]) == 0
    assert strict(capsys.readouterr().out)["k1_normal_form"] is None
    assert main(["control", "swingup", "--no-animation", "--out", str(tmp_path / "su"), "--t-end", "2", "--json"]) == 1
    doc = strict(capsys.readouterr().out)
    assert doc["t_catch"] is None and doc["t_balanced"] is None
    assert strict((tmp_path / "su" / "swingup.json").read_text())["t_catch"] is None
