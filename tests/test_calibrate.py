"""The calibrated twin (issue 12): the paper's targets, the calibration by indirect inference, the belt fit.

* the calibration recovers a known truth from targets that a twin with that truth produced;
* the default rig reproduces the paper's published numbers within the issue's tolerances (full-length runs);
* the belt (15) is identified from the disk velocity alone, and reduces the error at A = 20 on the twin;
* the structure the calibration uses behaves as physics says (session resistance, sign-dependent gain).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

import iwp.cli
from iwp.calibration import (
    PaperTarget,
    calibrate,
    compare_targets,
    load_targets,
    paper_numbers,
    truth_with,
    twin_statistics,
)
from iwp.data import ExperimentData
from iwp.errors import InputError
from iwp.ident.belt_fit import refine_belt
from iwp.ident.identification import identify
from iwp.ident.problem import SolverOptions
from iwp.ident.validation import validate
from iwp.models import Plant
from iwp.models.encoder import quantize
from iwp.models.parameters import BeltParameters, table1
from iwp.rig import DEFAULT_TRUTH_FILE, RigTruth, VirtualRig, default_truth, truth_record
from iwp.sim import SimOptions, Tolerances, simulate
from iwp.sim.inputs import Sampled

# shortened experiments for the recovery test (targets and twin run with the same settings)
QUICK = {
    "static-curve": {"step": 4.0, "duration": 2.0},
    "static-curve-compensated": {"step": 4.0, "duration": 2.0},
    "motor-disk-chirp": {"duration": 40.0},
    "free-pendulum": {"duration": 15.0},
    "full-chirp": {"duration": 40.0},
    "closed-loop": {"duration": 20.0},
}


@pytest.fixture(scope="module")
def default_numbers():
    """The paper's procedures on the default rig's full-length experiments, as the CLI applies them."""
    return paper_numbers(default_truth())


# --------------------------------------------------------------------------
# the targets
# --------------------------------------------------------------------------
def test_targets_carry_the_issue_tolerances():
    targets = load_targets()
    graded = {t.key: t for t in targets if t.graded}
    assert len(graded) == 21
    tol = {k: t.tolerance for k, t in graded.items()}
    assert tol["v_dz_pos"] == tol["v_dz_neg"] == 0.10
    assert tol["b_sigma_c2_1rho"] == 0.20
    assert 0.25 <= tol["c_sigma_a1_v1"] <= 0.30 and 0.25 <= tol["c_sigma_b1"] <= 0.30
    assert tol["rho"] == tol["cl_amplitude_rig"] == tol["cl_model_over_rig"] == 0.02
    others = set(graded) - {"v_dz_pos", "v_dz_neg", "b_sigma_c2_1rho", "c_sigma_a1_v1", "c_sigma_b1", "rho",
                            "cl_amplitude_rig", "cl_model_over_rig"}
    assert all(tol[k] == 0.05 for k in others)
    # every entry says where the paper prints it
    assert all(t.reference.startswith("section") for t in targets)


def test_target_deviation_and_range():
    t = PaperTarget("x", "q", "section 1", "free.p1", 2.0, None, "2.0", 0.05, 0.05, True, True)
    assert t.deviation(2.1) == pytest.approx(0.05) and t.within(2.09) and not t.within(2.11)
    assert t.residual(1.9) == pytest.approx(-1.0)
    r = dataclasses.replace(t, published=None, published_range=(7.14, 7.28))
    assert r.deviation(7.2) == 0.0 and r.deviation(7.0) == pytest.approx(7.0 / 7.14 - 1)
    assert r.deviation(7.5) == pytest.approx(7.5 / 7.28 - 1)


@pytest.mark.parametrize("edit,match", [
    (lambda d: d["targets"][0].pop("tolerance"), "targets\\[0\\]: missing field 'tolerance'"),
    (lambda d: d["targets"][1].update(tolerance=-0.1), "targets\\[1\\]: field 'tolerance' must be > 0"),
    (lambda d: d["targets"][2].update(published_range=[1, 2]), "exactly one of 'published'"),
    (lambda d: d["targets"][3].update(bogus=1), "unknown field 'bogus'"),
    (lambda d: d["targets"].append(dict(d["targets"][0])), "appears more than once"),
    (lambda d: d.update(kind="other"), "not a targets file"),
])
def test_bad_targets_file(tmp_path, edit, match):
    doc = json.loads(load_targets.__globals__["TARGETS_FILE"].read_text())
    edit(doc)
    p = tmp_path / "t.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(InputError, match=match):
        load_targets(p)


# --------------------------------------------------------------------------
# the default rig against the paper
# --------------------------------------------------------------------------
def test_default_rig_reproduces_the_published_numbers(default_numbers):
    """Issue 12's target: at least 19 of the 21 within tolerance, every calibrated one among them."""
    targets = load_targets()
    rows = compare_targets(targets, default_numbers.values({t.statistic for t in targets}))
    graded = [r for r in rows if r.target.graded]
    missed = [(r.target.key, r.reproduced) for r in graded if not r.within]
    assert sum(r.within for r in graded) >= 19, missed
    # the misses are the documented ones, which the calibration does not fit
    assert all(not r.target.calibrate for r in graded if not r.within), missed


def test_shipped_residual_table_is_what_the_default_rig_gives(default_numbers):
    """The record in default_truth.json is reproducible: the same twin gives the same numbers."""
    rec = truth_record()["calibration"]
    for row in rec["residuals"]:
        got = default_numbers.value(row["statistic"])
        assert got == pytest.approx(row["reproduced"], rel=1e-6, abs=1e-9), row["key"]


def test_default_truth_file_records_where_values_came_from():
    doc = json.loads(DEFAULT_TRUTH_FILE.read_text())
    prov = doc["provenance"]
    assert prov["counts_per_rev"].startswith("paper") and prov["belt.N"].startswith("paper")
    for name in doc["calibration"]["free"]:
        key = "belt.b2_over_I2" if name == "belt.b2_share" else name
        assert prov[key].startswith("calibration"), name
    assert RigTruth.from_json(DEFAULT_TRUTH_FILE) == default_truth()


def test_paper_estimator_moves_the_full_setups_pendulum_terms(default_numbers):
    """Eq. (16)'s far-off friction terms come from the unweighted (13): the same log, both estimators."""
    weighted = default_numbers.value("full.friction_ratio")
    plain = default_numbers.value("full-13.friction_ratio")
    assert weighted < 3.0
    assert plain > 20.0 * weighted


# --------------------------------------------------------------------------
# the calibration
# --------------------------------------------------------------------------
def test_calibration_recovers_a_known_truth():
    """Targets made by a twin with a known truth; from a perturbed start the calibration finds that truth."""
    base = default_truth()
    known = {"lumped.p1": base.lumped.p1 * 1.01, "lumped.p3": base.lumped.p3 * 1.05,
             "lumped.v_dz_pos": base.lumped.v_dz_pos + 2.0, "lumped.sigma_c2": base.lumped.sigma_c2 * 0.85}
    truth = truth_with(base, known)
    keys = ("c_p1", "a_p3_1rho", "v_dz_pos", "v_dz_neg", "b_sigma_c2_1rho", "b_p2_1rho", "d_p3")
    paper = {t.key: t for t in load_targets()}
    stats = twin_statistics(truth, [paper[k] for k in keys], overrides=QUICK)
    targets = [dataclasses.replace(paper[k], published=stats[paper[k].statistic], published_range=None,
                                   tolerance=0.01, calibrate=True) for k in keys]
    res = calibrate(targets, start=base, free=tuple(known), overrides=QUICK,
                    options=SolverOptions(tol=1e-3, max_nfev=15), warn=False)
    assert res.success
    for name, want in known.items():
        assert res.values[name] == pytest.approx(want, rel=0.01), (name, res.values[name], want)
    assert all(r.within for r in res.rows)
    assert res.cost < 1e-2 * res.cost_start
    # the sensitivity names what determines what: v+ moves the static curve's positive threshold most
    s = res.sensitivity["v_dz_pos"]
    assert abs(s["lumped.v_dz_pos"]) == max(abs(v) for v in s.values())


def test_calibrate_rejects_bad_arguments():
    with pytest.raises(InputError, match="unknown parameter 'lumped.nope'"):
        calibrate(free=("lumped.nope",))
    with pytest.raises(InputError, match="free is empty"):
        calibrate(free=())
    with pytest.raises(InputError, match="needs the belt"):
        calibrate(start=default_truth().replace(belt=None), free=("lumped.p1",))


def test_cli_calibrate_bad_input(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(iwp.cli, "_COMMANDS", ["rig"])
    bad = tmp_path / "t.json"
    bad.write_text("{\"kind\": \"paper-targets\", \"targets\": []}")
    assert iwp.cli.main(["rig", "calibrate", "--targets", str(bad), "--out", str(tmp_path / "o.json")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("iwp: error:") and "t.json" in err and "\n" not in err
    out = tmp_path / "exists.json"
    out.write_text("{}")
    assert iwp.cli.main(["rig", "calibrate", "--out", str(out)]) == 2
    assert "--force" in capsys.readouterr().err
    assert out.read_text() == "{}"


# --------------------------------------------------------------------------
# the structure: sessions and the sign of the voltage
# --------------------------------------------------------------------------
def test_warmer_winding_lowers_gain_and_back_emf_together():
    t = default_truth().replace(resistance_ratio=1.25)
    t = truth_with(t, {})
    warm = t.for_session("5.2")
    L, W = t.lumped, warm.lumped
    assert W.p3 == pytest.approx(L.p3 / 1.25)
    b2 = t.belt.b2_over_I2 / L.rho
    assert W.p2 - b2 == pytest.approx((L.p2 - b2) / 1.25)  # the back-emf part only
    # the warm belt's rigid limit is the warm lumped model
    assert warm.belt.rigid_p2rho == pytest.approx(W.p2 * W.rho)
    assert warm.belt.rigid_p3rho == pytest.approx(W.p3 * W.rho)
    assert warm.for_session("5.2") == warm and t.for_session("5.1") is t
    log = VirtualRig(t).run("full-chirp", duration=1.0)
    assert log.metadata["session"] == "5.2"
    assert json.loads(log.metadata["truth"])["lumped"]["p3"] == pytest.approx(W.p3)


def test_motor_gain_by_sign_sets_the_static_slopes():
    """Section 3.2's sign-dependent gain: the steady speed per input unit differs by the gain ratio."""
    t = truth_with(default_truth(), {"belt.gain_neg": 0.8})
    res = identify(VirtualRig(t).run("static-curve"), "dead-zone")
    slope = res.details
    ratio = abs(slope["neg"]["slope"]) / abs(slope["pos"]["slope"])
    assert ratio == pytest.approx(0.8, rel=0.02)


# --------------------------------------------------------------------------
# the belt (15), identified from the disk velocity
# --------------------------------------------------------------------------
def _belt_logs(belt: BeltParameters, lumped, amplitudes=(60.0, 20.0), duration=12.0):
    """Logs of the belt model driven as a digital rig drives it: u = A sin 5t sampled every 5 ms and held."""
    logs = []
    plant = Plant(lumped, model="belt", belt=belt)
    t = 0.005 * np.arange(int(round(duration / 0.005)) + 1)
    for A in amplitudes:
        inp = Sampled(A * np.sin(5.0 * t), 0.005, 0.0)
        r = simulate(plant, t_end=duration, Ts=0.005, input=inp,
                     options=SimOptions(tolerances=Tolerances(rtol=1e-9, atol=1e-9)))
        q2 = quantize(r.x[:, 1], 2 * math.pi / 2000)
        logs.append(ExperimentData(t=r.t, q1=np.zeros_like(r.t), q2=q2, u=r.u, source=f"belt A={A:g}"))
    return logs


def test_belt_fit_recovers_a_known_belt_from_the_disk_velocity():
    lumped = table1()
    true = BeltParameters.from_rigid(2.6, 7.5, k_over_I2=150.0, d=0.4, N=13.5, b2_over_I2=0.6)
    logs = _belt_logs(true, lumped)
    start = BeltParameters.from_rigid(2.3, 7.0, k_over_I2=80.0, d=1.0, N=13.5, b2_over_I2=1.0)
    res = refine_belt(logs, Plant(lumped, model="belt", belt=start), warn=False)
    assert res.success and res.belt is not None
    # each log's initial wheel speed estimated (a log driven from rest is measured ~1 rad/s off by a one-sided
    # fit) and the model's wheel speed differentiated as the log's is: every parameter within 0.4 % on these
    # quantised logs (1-5 %, b2/I2 8 %, with either alone)
    for name in ("k_over_I2", "d", "b2_over_I2", "k_over_gamma", "kTbeta_over_Rgamma"):
        assert getattr(res.belt, name) == pytest.approx(getattr(true, name), rel=0.01), name
    assert all(f["q4"] > 99.0 for f in res.fit)
    assert res.cost < 1e-3 * res.cost_start


def test_belt_model_reduces_the_error_at_a20_on_the_twin():
    """What the paper found on its rig (figure 4): the identified belt fits A = 20 better than the rigid model."""
    rig = VirtualRig()
    md = identify(rig.run("motor-disk-chirp"), "motor-disk")
    params = md.to_params(base=table1())
    sines = [rig.run(f"sine-{A}", duration=8.0) for A in (60, 40, 20)]
    start = BeltParameters.from_rigid(md.value("p2_1rho"), md.value("p3_1rho"), k_over_I2=60.0, d=2.0, N=13.5,
                                      b2_over_I2=0.5)
    res = refine_belt(sines, Plant(params, model="belt", belt=start), warn=False,
                      options=SolverOptions(max_nfev=20, rtol=1e-6, atol=1e-6))
    rigid20 = validate(sines[2], params, model="compensated", signals=("q4",)).fit["q4"]
    assert res.fit[2]["q4"] > rigid20 + 1.0
    assert res.cost < res.cost_start


def test_refine_belt_bad_input():
    lumped = table1()
    with pytest.raises(InputError, match="model='belt', belt="):
        refine_belt([], Plant(lumped))
    logs = _belt_logs(BeltParameters.from_rigid(2.6, 7.5, k_over_I2=150.0, d=0.4), lumped, amplitudes=(20.0,),
                      duration=1.0)
    with pytest.raises(InputError, match="unknown belt parameter 'p1'"):
        refine_belt(logs, Plant(lumped, model="belt", belt=BeltParameters()), free=("p1",))
    moving = dataclasses.replace(logs[0], q1=np.linspace(0, 1, logs[0].n_samples))
    with pytest.raises(InputError, match="the pendulum moves"):
        refine_belt([moving], Plant(lumped, model="belt", belt=BeltParameters()))
